r"""Robot specs: published facts about a base and its sensors, read from ``robots/specs/*.yaml``.

A spec file lists the rigid bodies (base link, wheels, casters, sensor masses), the speed caps,
the default :class:`~robots.params.DriveParams`, the lidar and depth camera, what the odometry
reports, and the sources of every number (comments in the YAML cite them).

Mass model
----------
The generated pybullet model (:mod:`robots._urdf`) and the reduced model must describe the same
rigid bodies, so the effective :class:`~robots.params.BaseGeometry` is computed here from them:

.. math::

    m_{eff} = m_{base} + \sum m_{point} + \sum m_{caster} + 2 m_w + 2 J_w / r^2

    I_{eff} = I_{zz,base} + \sum m_i (x_i^2 + y_i^2) + 2\,(I_{w,\perp} + m_w L^2/4)
              + 2 J_w L^2 / (4 r^2)

where :math:`J_w` is the spin inertia of one wheel (it adds :math:`J_w/r^2` of apparent mass per
wheel). The base centre of mass is placed on the wheel-axle midpoint: the reduced model assumes
it, and an offset ``d`` would add a force :math:`m d \omega^2` that it does not have.

Priors
------
The optional ``priors`` section gives every drive parameter a prior in its coordinate of
:data:`robots.params.SCHEMA` (``field: {sd: .., session_sd: .., nominal: ..}``, nominal
defaulting to the ``drive`` value), each with its justification in a comment. Friction fields
are fitted per unit of the total mass or yaw inertia (``per_total_*`` coordinates), but their
spreads are written in the value's own unit (N, N m, N s/m, N m s/rad) at the spec's mass and
inertia, the figures a datasheet or a pull test gives; they are divided by the spec mass or
yaw inertia when read. Fields it does not
list -- and every field of a spec without the section, as ``sim2real robots new`` writes them --
get the schema's generic wide prior (:func:`robots.params.generic_priors`). ``sysid`` fits MAP
estimates against these priors; :mod:`robots.randomization` samples them.

Examples
--------
>>> from robots.spec import load_spec
>>> spec = load_spec("turtlebot3_burger")
>>> spec.geometry.wheel_radius_m
0.033
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from robots._spec_parse import Section
from robots.errors import RobotsValueError, SpecError, UnknownRobotError
from robots.params import SCHEMA, SPECS_DIR, BaseGeometry, DriveParams, Prior, generic_priors

__all__ = [
    "SPECS_DIR",
    "BodySpec",
    "CameraSpec",
    "CasterSpec",
    "LidarSpec",
    "OdometrySpec",
    "PointMass",
    "RobotSpec",
    "WheelSpec",
    "list_robots",
    "load_spec",
]


Vec3 = tuple[float, float, float]


@dataclass(frozen=True, kw_only=True)
class BodySpec:
    """Collision shape of the base link (box or upright cylinder), in the base_link frame.

    Attributes
    ----------
    shape : str
        ``"box"`` or ``"cylinder"``.
    xyz_m : tuple
        Centre of the shape, m.
    size_m : tuple
        Box extents (x, y, z), m; for a cylinder (2 radius, 2 radius, height).
    """

    shape: str
    xyz_m: Vec3
    size_m: Vec3


@dataclass(frozen=True, kw_only=True)
class WheelSpec:
    """The two drive wheels (on the y axis of base_link at +-separation/2).

    Attributes
    ----------
    radius_m, width_m, separation_m : float
        Wheel radius, tyre width and track (contact-to-contact distance), m.
    mass_kg : float
        Mass of one wheel, kg.
    spin_inertia_kgm2, cross_inertia_kgm2 : float
        Inertia of one wheel about its axle and about a diameter, kg m^2.
    """

    radius_m: float
    width_m: float
    separation_m: float
    mass_kg: float
    spin_inertia_kgm2: float
    cross_inertia_kgm2: float


@dataclass(frozen=True, kw_only=True)
class CasterSpec:
    """A caster or skid, modelled as a frictionless sphere fixed to the base.

    Attributes
    ----------
    xyz_m : tuple
        Sphere centre in base_link, m (z puts the sphere on flat ground).
    radius_m : float
        Sphere radius, m.
    mass_kg : float
        Mass (lumped into the base link), kg.
    """

    xyz_m: Vec3
    radius_m: float
    mass_kg: float


@dataclass(frozen=True, kw_only=True)
class PointMass:
    """A sensor or part whose mass is lumped into the base link (e.g. the LDS-01)."""

    name: str
    mass_kg: float
    xyz_m: Vec3


@dataclass(frozen=True, kw_only=True)
class LidarSpec:
    """A 2-D scanning lidar (ROS ``LaserScan`` conventions, angles counter-clockwise).

    Attributes
    ----------
    beams : int
        Samples per scan.
    angle_min_rad, angle_max_rad : float
        Angle of the first and of the last beam in the lidar frame, rad.
    range_min_m, range_max_m : float
        Valid range interval, m. Readings outside it are reported as ``range_max_m``.
    xyz_m : tuple
        Mount position in base_link, m (the lidar frame is parallel to base_link).
    rate_hz : float
        Scan rate, Hz.
    """

    beams: int
    angle_min_rad: float
    angle_max_rad: float
    range_min_m: float
    range_max_m: float
    xyz_m: Vec3
    rate_hz: float

    @property
    def angle_increment_rad(self) -> float:
        """Angle between consecutive beams, rad."""
        if self.beams == 1:
            return 0.0
        return (self.angle_max_rad - self.angle_min_rad) / (self.beams - 1)


@dataclass(frozen=True, kw_only=True)
class CameraSpec:
    """A depth camera.

    Attributes
    ----------
    width, height : int
        Image size, pixels.
    hfov_deg : float
        Horizontal field of view, degrees.
    near_m, far_m : float
        Clip distances, m; depth beyond ``far_m`` is invalid (NaN).
    xyz_m, rpy_rad : tuple
        Mount pose in base_link: position (m) and roll-pitch-yaw (rad) of the camera *body*
        frame (x along the optical axis, y left, z up; REP-103), not of the optical frame.
    rate_hz : float
        Frame rate, Hz.
    """

    width: int
    height: int
    hfov_deg: float
    near_m: float
    far_m: float
    xyz_m: Vec3
    rpy_rad: Vec3
    rate_hz: float


@dataclass(frozen=True, kw_only=True)
class OdometrySpec:
    """What the base reports as odometry velocity.

    Attributes
    ----------
    v_source : str
        ``"wheels"``: forward speed from the wheel encoders.
    w_source : str
        ``"imu"`` (yaw rate from the gyro, i.e. the true body rate) or ``"wheels"``.
    rate_hz : float
        Odometry publishing rate, Hz.
    """

    v_source: str
    w_source: str
    rate_hz: float

    @property
    def v_window_s(self) -> float:
        """Window over which the reported v averages the true speed, s.

        Encoder odometry (``v_source: wheels``) differences wheel ticks over one odometry
        period, so it reports the mean speed over ``1 / rate_hz``; the default of
        ``sysid fit`` and ``sim2real agree`` (``--odom-v-window auto``).

        Examples
        --------
        >>> round(OdometrySpec(v_source="wheels", w_source="imu", rate_hz=30.0).v_window_s, 4)
        0.0333
        """
        return 1.0 / self.rate_hz if self.v_source == "wheels" else 0.0


@dataclass(frozen=True, kw_only=True)
class RobotSpec:
    """Everything known about one robot model (see the module docstring for the mass model).

    Attributes
    ----------
    name, description : str
        Robot name (file stem) and a one-line description.
    geometry : BaseGeometry
        Effective mass and yaw inertia (including the wheels' spin inertia), wheel radius and
        separation: what the reduced model and the pybullet model share.
    drive : DriveParams
        Default drive parameters (published numbers where they exist, nominal otherwise).
    priors : dict
        ``{field: Prior}`` for every DriveParams field: the spec's ``priors`` section where it
        gives one (nominal, sd and between-session sd in the field's coordinate, see
        :data:`robots.params.SCHEMA`), the schema's generic wide prior otherwise.
    max_v_mps, max_w_radps : float
        Top forward speed and yaw rate the base reaches, m/s and rad/s.
    base_mass_kg : float
        Mass of the base link alone, kg.
    base_inertia_diag_kgm2 : tuple
        (ixx, iyy, izz) of the base link about its centre of mass, kg m^2.
    base_link_height_m : float
        Height of the base_link origin above the ground, m.
    body : BodySpec
        Collision shape of the base.
    wheels : WheelSpec
        Drive wheels.
    casters : tuple of CasterSpec
        Casters and skids (frictionless spheres).
    point_masses : tuple of PointMass
        Parts lumped into the base link.
    lidar : LidarSpec
        The 2-D lidar.
    depth_camera : CameraSpec or None
        The depth camera, if any.
    odometry : OdometrySpec
        What the odometry reports.
    sources : tuple of str
        Citations of the numbers.
    path : Path
        The spec file.
    """

    name: str
    description: str
    geometry: BaseGeometry
    drive: DriveParams
    max_v_mps: float
    max_w_radps: float
    base_mass_kg: float
    base_inertia_diag_kgm2: Vec3
    base_link_height_m: float
    body: BodySpec
    wheels: WheelSpec
    casters: tuple[CasterSpec, ...]
    point_masses: tuple[PointMass, ...]
    lidar: LidarSpec
    depth_camera: CameraSpec | None
    odometry: OdometrySpec
    sources: tuple[str, ...]
    path: Path
    priors: dict[str, Prior] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.priors:  # a spec built in code: generic priors around its drive values
            object.__setattr__(self, "priors", generic_priors(self.drive, self.geometry))

    @property
    def wheel_positions_m(self) -> tuple[Vec3, Vec3]:
        """Centres of the (left, right) wheels in base_link, m."""
        half = 0.5 * self.wheels.separation_m
        z = self.wheels.radius_m - self.base_link_height_m
        return (0.0, half, z), (0.0, -half, z)

    @property
    def rigid_mass_kg(self) -> float:
        """Sum of all rigid-body masses (without the wheels' apparent spin mass), kg."""
        return lumped_base_mass_kg(self) + 2.0 * self.wheels.mass_kg

    def to_dict(self) -> dict[str, Any]:
        """The spec in the layout of a spec file (``load_spec`` reads it back unchanged).

        Examples
        --------
        >>> load_spec("turtlebot2").to_dict()["wheels"]["radius_m"]
        0.035
        """
        body: dict[str, Any] = {"shape": self.body.shape, "xyz_m": list(self.body.xyz_m)}
        if self.body.shape == "box":
            body["size_m"] = list(self.body.size_m)
        else:
            body["radius_m"] = 0.5 * self.body.size_m[0]
            body["height_m"] = self.body.size_m[2]
        cam = self.depth_camera
        return {
            "name": self.name,
            "description": self.description,
            "sources": list(self.sources),
            "base": {
                "mass_kg": self.base_mass_kg,
                "inertia_diag_kgm2": list(self.base_inertia_diag_kgm2),
                "link_height_m": self.base_link_height_m,
                "body": body,
            },
            "wheels": dataclasses.asdict(self.wheels),
            "casters": [
                {"x_m": c.xyz_m[0], "y_m": c.xyz_m[1], "radius_m": c.radius_m, "mass_kg": c.mass_kg}
                for c in self.casters
            ],
            "point_masses": [
                {"name": m.name, "mass_kg": m.mass_kg, "xyz_m": list(m.xyz_m)}
                for m in self.point_masses
            ],
            "limits": {"max_v_mps": self.max_v_mps, "max_w_radps": self.max_w_radps},
            "drive": self.drive.to_dict(),
            "priors": _priors_dict(self.priors, self.drive, self.geometry),
            "lidar": _plain(dataclasses.asdict(self.lidar)),
            "depth_camera": None if cam is None else _plain(dataclasses.asdict(cam)),
            "odometry": dataclasses.asdict(self.odometry),
        }

    def with_params(self, params: DriveParams) -> RobotSpec:
        """A copy of this spec whose default drive parameters are ``params`` (priors kept)."""
        return dataclasses.replace(self, drive=params)


def _priors_dict(
    priors: dict[str, Prior], drive: DriveParams, geometry: BaseGeometry
) -> dict[str, dict[str, float]]:
    """The ``priors`` section: the spec-given priors (generic ones are derived, not written)."""
    out: dict[str, dict[str, float]] = {}
    for name, p in priors.items():
        if p.source != "spec":
            continue
        ref = SCHEMA[name].reference(geometry)  # per-total frictions: written in N, N m, ...
        entry = {"sd": p.sd * ref, "session_sd": p.session_sd * ref}
        if p.nominal != float(getattr(drive, name)):
            entry = {"nominal": p.nominal, **entry}
        out[name] = entry
    return out


def _plain(d: dict[str, Any]) -> dict[str, Any]:
    """Tuples -> lists, so ``yaml.safe_dump`` writes plain sequences."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}


def lumped_base_mass_kg(spec: RobotSpec) -> float:
    """Mass of the base link in the generated model: base + point masses + casters, kg."""
    return (
        spec.base_mass_kg
        + sum(p.mass_kg for p in spec.point_masses)
        + sum(c.mass_kg for c in spec.casters)
    )


def lumped_base_inertia(spec: RobotSpec) -> Vec3:
    """(ixx, iyy, izz) of the lumped base link about the base_link origin, kg m^2."""
    ixx, iyy, izz = spec.base_inertia_diag_kgm2
    for m, (x, y, z) in [(p.mass_kg, p.xyz_m) for p in spec.point_masses] + [
        (c.mass_kg, c.xyz_m) for c in spec.casters
    ]:
        ixx += m * (y * y + z * z)
        iyy += m * (x * x + z * z)
        izz += m * (x * x + y * y)
    return ixx, iyy, izz


def _effective_geometry(
    base_mass: float, base_izz: float, wheels: WheelSpec, *, extra: list[tuple[float, Vec3]]
) -> BaseGeometry:
    r, half = wheels.radius_m, 0.5 * wheels.separation_m
    apparent = wheels.spin_inertia_kgm2 / (r * r)  # apparent mass of one spinning wheel
    mass = base_mass + sum(m for m, _ in extra) + 2.0 * (wheels.mass_kg + apparent)
    izz = base_izz + sum(m * (x * x + y * y) for m, (x, y, _) in extra)
    wheels_izz = 2.0 * (wheels.cross_inertia_kgm2 + (wheels.mass_kg + apparent) * half * half)
    izz += wheels_izz
    return BaseGeometry(
        mass_kg=mass,
        yaw_inertia_kgm2=izz,
        wheel_radius_m=r,
        wheel_separation_m=wheels.separation_m,
        wheels_mass_kg=2.0 * (wheels.mass_kg + apparent),
        wheels_yaw_inertia_kgm2=wheels_izz,
    )


# ----------------------------------------------------------------------------- loading


def list_robots() -> list[str]:
    """Names of the shipped robot specs, sorted.

    Examples
    --------
    >>> "turtlebot3_burger" in list_robots()
    True
    """
    return sorted(p.stem for p in SPECS_DIR.glob("*.yaml"))


def load_spec(name_or_path: str | Path) -> RobotSpec:
    """Load a shipped spec by name, or a spec file by path.

    Raises
    ------
    UnknownRobotError
        ``name_or_path`` is neither a shipped robot nor an existing file; lists the known names.
    SpecError
        The file has a missing, unknown or non-physical key (named in the message).

    Examples
    --------
    >>> load_spec("turtlebot2").depth_camera.hfov_deg
    60.0
    """
    text = str(name_or_path)
    path = Path(text)
    if not (path.suffix in (".yaml", ".yml") or path.is_file()):
        path = SPECS_DIR / f"{text}.yaml"
        if not path.is_file():
            close = difflib.get_close_matches(text, list_robots(), n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'? " if close else ""
            own = [f"{text}{ext}" for ext in (".yaml", ".yml") if Path(f"{text}{ext}").is_file()]
            if own:  # `robots new NAME` wrote NAME.yaml here: the file, not a shipped name
                hint = f"did you mean the file '{own[0]}'? "
            raise UnknownRobotError(
                f"unknown robot '{text}'; {hint}known robots are {list_robots()} "
                "(or give the path of a spec .yaml file, e.g. from `sim2real robots new`)"
            )
    if not path.is_file():
        folder = path.parent if path.parent.is_dir() else None
        files = (
            [f.name for f in folder.iterdir() if f.suffix in (".yaml", ".yml")] if folder else []
        )
        close = difflib.get_close_matches(path.name, sorted(files), n=1, cutoff=0.6)
        hint = f"did you mean '{path.parent / close[0]}'? " if close else ""
        raise UnknownRobotError(
            f"robot spec file '{path}' does not exist; {hint}known robots are {list_robots()}"
        )
    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        why = " ".join(str(exc).split())
        raise SpecError(f"robot spec '{path}' is not valid YAML ({why}); fix the file") from None
    return _parse(Section(doc, "", str(path)), path)


def _parse(top: Section, path: Path) -> RobotSpec:
    name = top.text("name")
    description = top.text("description")
    sources = top.raw("sources")
    if not (isinstance(sources, list) and sources and all(isinstance(s, str) for s in sources)):
        raise top.fail("sources", "must be a non-empty list of citation strings", sources)
    base_mass, inertia, height, body = _base(top.section("base"))
    wheels = _wheels(top.section("wheels"))
    casters = tuple(_caster(s, height) for s in top.sections("casters"))
    points = tuple(_point(s) for s in top.sections("point_masses"))
    limits = top.section("limits")
    max_v = limits.number("max_v_mps", positive=True)
    max_w = limits.number("max_w_radps", positive=True)
    limits.finish()
    drive = _drive(top.section("drive"))
    priors_raw = top.raw("priors", optional=True)
    lidar = _lidar(top.section("lidar"))
    cam_raw = top.raw("depth_camera")
    camera = None if cam_raw is None else _camera(top.section("depth_camera"))
    odometry = _odometry(top.section("odometry"))
    top.finish()
    extra = [(p.mass_kg, p.xyz_m) for p in points] + [(c.mass_kg, c.xyz_m) for c in casters]
    geometry = _effective_geometry(base_mass, inertia[2], wheels, extra=extra)
    priors = generic_priors(drive, geometry)
    if priors_raw is not None:
        priors |= _priors(top.section("priors"), drive, geometry)
    return RobotSpec(
        name=name,
        description=description,
        geometry=geometry,
        drive=drive,
        max_v_mps=max_v,
        max_w_radps=max_w,
        base_mass_kg=base_mass,
        base_inertia_diag_kgm2=(inertia[0], inertia[1], inertia[2]),
        base_link_height_m=height,
        body=body,
        wheels=wheels,
        casters=casters,
        point_masses=points,
        lidar=lidar,
        depth_camera=camera,
        odometry=odometry,
        sources=tuple(sources),
        path=path,
        priors=priors,
    )


def _base(base: Section) -> tuple[float, tuple[float, ...], float, BodySpec]:
    """The base section: mass (kg), inertia diagonal (kg m^2), link height (m) and body."""
    base_mass = base.number("mass_kg", positive=True)
    inertia = base.vector("inertia_diag_kgm2", positive=True)
    if 2.0 * max(inertia) > sum(inertia):
        raise base.fail(
            "inertia_diag_kgm2",
            "must obey the triangle inequality ixx + iyy >= izz etc. (a rigid body)",
            list(inertia),
        )
    height = base.number("link_height_m", nonneg=True)
    body = _body(base.section("body"))
    base.finish()
    return base_mass, inertia, height, body


def _vec3(values: tuple[float, ...]) -> Vec3:
    return (values[0], values[1], values[2])


def _body(s: Section) -> BodySpec:
    shape = s.text("shape", choices=("box", "cylinder"))
    xyz = _vec3(s.vector("xyz_m"))
    if shape == "box":
        size = _vec3(s.vector("size_m", positive=True))
    else:
        radius = s.number("radius_m", positive=True)
        size = (2.0 * radius, 2.0 * radius, s.number("height_m", positive=True))
    s.finish()
    return BodySpec(shape=shape, xyz_m=xyz, size_m=size)


def _wheels(s: Section) -> WheelSpec:
    w = WheelSpec(
        radius_m=s.number("radius_m", positive=True),
        width_m=s.number("width_m", positive=True),
        separation_m=s.number("separation_m", positive=True),
        mass_kg=s.number("mass_kg", positive=True),
        spin_inertia_kgm2=s.number("spin_inertia_kgm2", positive=True),
        cross_inertia_kgm2=s.number("cross_inertia_kgm2", positive=True),
    )
    s.finish()
    if w.spin_inertia_kgm2 > 2.0 * w.cross_inertia_kgm2:
        # a rigid body's principal moments obey the triangle inequality (pybullet zeroes them)
        raise s.fail(
            "spin_inertia_kgm2",
            "must be <= 2 x cross_inertia_kgm2 (a rigid wheel)",
            w.spin_inertia_kgm2,
        )
    return w


def _caster(s: Section, link_height: float) -> CasterSpec:
    x = s.number("x_m")
    y = s.number("y_m")
    radius = s.number("radius_m", positive=True)
    mass = s.number("mass_kg", nonneg=True)
    s.finish()
    return CasterSpec(xyz_m=(x, y, radius - link_height), radius_m=radius, mass_kg=mass)


def _point(s: Section) -> PointMass:
    p = PointMass(
        name=s.text("name"),
        mass_kg=s.number("mass_kg", positive=True),
        xyz_m=_vec3(s.vector("xyz_m")),
    )
    s.finish()
    return p


#: Drive keys a spec may leave out: their default is what most drivers do (both wheel
#: targets scaled together at the speed cap; wheel loops that run on across commands).
_OPTIONAL_DRIVE_KEYS = frozenset({"wheel_cap_per_side", "command_starts_new_move"})


def _drive(s: Section) -> DriveParams:
    values: dict[str, Any] = {}
    for name in DriveParams.names():
        if name in _OPTIONAL_DRIVE_KEYS and name not in s.data:
            continue
        # the DriveParams validation below gives the rule; here only "is it a number"
        values[name] = s.number(name, allow_inf=True) if name in s.data else s.raw(name)
    s.finish()
    try:
        return DriveParams(**values)
    except RobotsValueError as exc:
        raise SpecError(f"robot spec '{s.source}': section '{s.where}': {exc}") from None


def _priors(s: Section, drive: DriveParams, geometry: BaseGeometry) -> dict[str, Prior]:
    """The spec's ``priors`` section: ``field: {sd, session_sd[, nominal]}`` (see RobotSpec;
    per-total friction spreads are read in the value's unit and divided by the spec total)."""
    out: dict[str, Prior] = {}
    for name in list(s.data):
        if name not in SCHEMA:
            continue  # finish() names it as unknown
        entry = s.section(name)
        nominal = (
            entry.number("nominal", allow_inf=True)
            if "nominal" in entry.data
            else float(getattr(drive, name))
        )
        try:
            out[name] = Prior(
                name=name,
                nominal=nominal,
                sd=entry.number("sd", nonneg=True) / SCHEMA[name].reference(geometry),
                session_sd=entry.number("session_sd", nonneg=True)
                / SCHEMA[name].reference(geometry),
                source="spec",
            )
        except RobotsValueError as exc:
            raise SpecError(f"robot spec '{s.source}': section '{entry.where}': {exc}") from None
        entry.finish()
    s.finish()
    return out


def _lidar(s: Section) -> LidarSpec:
    lidar = LidarSpec(
        beams=s.integer("beams"),
        angle_min_rad=s.number("angle_min_rad"),
        angle_max_rad=s.number("angle_max_rad"),
        range_min_m=s.number("range_min_m", positive=True),
        range_max_m=s.number("range_max_m", positive=True),
        xyz_m=_vec3(s.vector("xyz_m")),
        rate_hz=s.number("rate_hz", positive=True),
    )
    s.finish()
    if lidar.range_max_m <= lidar.range_min_m:
        raise s.fail("range_max_m", "must be > range_min_m", lidar.range_max_m)
    if not (0.0 <= lidar.angle_max_rad - lidar.angle_min_rad < 2.0 * math.pi):
        raise s.fail(
            "angle_max_rad", "must be in [angle_min_rad, angle_min_rad + 2 pi)", lidar.angle_max_rad
        )
    return lidar


def _camera(s: Section) -> CameraSpec:
    cam = CameraSpec(
        width=s.integer("width"),
        height=s.integer("height"),
        hfov_deg=s.number("hfov_deg", positive=True),
        near_m=s.number("near_m", positive=True),
        far_m=s.number("far_m", positive=True),
        xyz_m=_vec3(s.vector("xyz_m")),
        rpy_rad=_vec3(s.vector("rpy_rad")),
        rate_hz=s.number("rate_hz", positive=True),
    )
    s.finish()
    if cam.hfov_deg >= 180.0:
        raise s.fail("hfov_deg", "must be < 180", cam.hfov_deg)
    if cam.far_m <= cam.near_m:
        raise s.fail("far_m", "must be > near_m", cam.far_m)
    return cam


def _odometry(s: Section) -> OdometrySpec:
    odo = OdometrySpec(
        v_source=s.text("v_source", choices=("wheels",)),
        w_source=s.text("w_source", choices=("imu", "wheels")),
        rate_hz=s.number("rate_hz", positive=True),
    )
    s.finish()
    return odo
