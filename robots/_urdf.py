"""Generate the pybullet URDF of a robot from its spec (no hand-copied URDF files).

Links, in joint order (pybullet joint index in brackets):

- ``base_link`` (base): mass = base + point masses + casters, centre of mass at the base_link
  origin (x, y on the wheel-axle midpoint), inertia diagonal of :func:`robots.spec.lumped_base_inertia`;
  collision = the body shape plus one sphere per caster (the base link gets zero friction, so the
  casters are frictionless); each caster sphere sits ``CASTER_CLEARANCE_M`` (0: touching) above
  flat ground: with the centre of mass over the axle the wheels carry the weight at rest, and
  a caster takes load when the base pitches onto it (hard braking: up to 83 % of the weight on
  a fitted P3-DX; see :func:`robots.pybullet_robot.tyre_friction`).
- ``wheel_left_link`` [0], ``wheel_right_link`` [1]: continuous joints at y = +-L/2 on the axle
  (z = r above ground), axis along +y of base_link (positive joint speed drives forward);
  collision = a sphere of the wheel radius (one contact point, rolling radius exactly r).
- ``lidar_link`` [2] and ``camera_link`` [3] (when the robot has a camera): fixed, massless in
  effect (``SENSOR_LINK_MASS_KG``), no collision, at the nominal mounts.
"""

from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path

from robots.files import write_text_atomic
from robots.spec import RobotSpec, lumped_base_inertia, lumped_base_mass_kg

__all__ = [
    "CASTER_CLEARANCE_M",
    "LEFT_WHEEL_JOINT",
    "RIGHT_WHEEL_JOINT",
    "SENSOR_LINK_MASS_KG",
    "urdf_path",
    "urdf_text",
]

#: Gap between each caster sphere and flat ground, m.
CASTER_CLEARANCE_M = 0.0
#: Mass of the sensor frame links (the sensors' real mass is in the spec's point masses), kg.
SENSOR_LINK_MASS_KG = 1e-6
#: pybullet joint index of the left and of the right wheel.
LEFT_WHEEL_JOINT, RIGHT_WHEEL_JOINT = 0, 1


def _f(x: float) -> str:
    return f"{x:.9g}"


def _xyz(v: tuple[float, float, float]) -> str:
    return " ".join(_f(x) for x in v)


def _inertial(mass: float, diag: tuple[float, float, float]) -> str:
    ixx, iyy, izz = diag
    return (
        f'<inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="{_f(mass)}"/>'
        f'<inertia ixx="{_f(ixx)}" ixy="0" ixz="0" iyy="{_f(iyy)}" iyz="0" izz="{_f(izz)}"/>'
        "</inertial>"
    )


def _body_geometry(spec: RobotSpec) -> str:
    sx, sy, sz = spec.body.size_m
    if spec.body.shape == "box":
        return f'<box size="{_f(sx)} {_f(sy)} {_f(sz)}"/>'
    return f'<cylinder radius="{_f(0.5 * sx)}" length="{_f(sz)}"/>'


def _base_link(spec: RobotSpec) -> str:
    shape = _body_geometry(spec)
    origin = f'<origin xyz="{_xyz(spec.body.xyz_m)}" rpy="0 0 0"/>'
    parts = [
        '<link name="base_link">',
        _inertial(lumped_base_mass_kg(spec), lumped_base_inertia(spec)),
        f"<visual>{origin}<geometry>{shape}</geometry></visual>",
        f"<collision>{origin}<geometry>{shape}</geometry></collision>",
    ]
    for c in spec.casters:
        x, y, z = c.xyz_m
        xyz = (x, y, z + CASTER_CLEARANCE_M)
        parts.append(
            f'<collision><origin xyz="{_xyz(xyz)}" rpy="0 0 0"/>'
            f'<geometry><sphere radius="{_f(c.radius_m)}"/></geometry></collision>'
        )
    parts.append("</link>")
    return "".join(parts)


def _wheel(spec: RobotSpec, side: str, xyz: tuple[float, float, float]) -> str:
    w = spec.wheels
    diag = (w.cross_inertia_kgm2, w.cross_inertia_kgm2, w.spin_inertia_kgm2)
    cyl = f'<cylinder radius="{_f(w.radius_m)}" length="{_f(w.width_m)}"/>'
    # rpy -pi/2 about x turns the wheel's z (its axle) onto +y of base_link
    return (
        f'<joint name="wheel_{side}_joint" type="continuous"><parent link="base_link"/>'
        f'<child link="wheel_{side}_link"/><origin xyz="{_xyz(xyz)}" rpy="-1.5707963267948966 0 0"/>'
        '<axis xyz="0 0 1"/><dynamics damping="0" friction="0"/></joint>'
        f'<link name="wheel_{side}_link">{_inertial(w.mass_kg, diag)}'
        f"<visual><geometry>{cyl}</geometry></visual>"
        f'<collision><geometry><sphere radius="{_f(w.radius_m)}"/></geometry></collision></link>'
    )


def _sensor_link(
    name: str, xyz: tuple[float, float, float], rpy: tuple[float, float, float]
) -> str:
    tiny = SENSOR_LINK_MASS_KG * 1e-4
    return (
        f'<joint name="{name}_joint" type="fixed"><parent link="base_link"/>'
        f'<child link="{name}_link"/><origin xyz="{_xyz(xyz)}" rpy="{_xyz(rpy)}"/></joint>'
        f'<link name="{name}_link">{_inertial(SENSOR_LINK_MASS_KG, (tiny, tiny, tiny))}</link>'
    )


def urdf_text(spec: RobotSpec) -> str:
    """The URDF document of ``spec`` (see the module docstring for its links)."""
    left, right = spec.wheel_positions_m
    parts = [
        f'<?xml version="1.0"?><robot name="{spec.name}">',
        _base_link(spec),
        _wheel(spec, "left", left),
        _wheel(spec, "right", right),
        _sensor_link("lidar", spec.lidar.xyz_m, (0.0, 0.0, 0.0)),
    ]
    if spec.depth_camera is not None:
        parts.append(_sensor_link("camera", spec.depth_camera.xyz_m, spec.depth_camera.rpy_rad))
    parts.append("</robot>")
    return "\n".join(parts) + "\n"


def urdf_path(spec: RobotSpec) -> Path:
    """Write the URDF of ``spec`` to a cache file (keyed by its content) and return the path.

    The file lives in ``$TMPDIR/sim2real-urdf/``; it is written atomically
    (:func:`robots.files.atomic_write`), so concurrent processes never read a half-written file.
    """
    text = urdf_text(spec)
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    folder = Path(tempfile.gettempdir()) / "sim2real-urdf"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{spec.name}-{digest}.urdf"
    if not path.is_file():
        write_text_atomic(path, text)
    return path
