r"""The MJCF (MuJoCo) model of a robot with its identified drive: one mapping, one writer.

:func:`mjcf_mapping` is the one place that says which MJCF value carries which drive
parameter; :func:`mjcf_text` writes the model from it, every value commented with the field it
comes from; ``sim2real.mujoco`` edits a compiled ``MjModel`` through the same entries (an
ensemble member without recompiling). ``docs/mujoco.md`` prints the table.

The model (bodies as in the pybullet URDF, :mod:`robots._urdf`):

- ``base_link`` on a free joint: the lumped base mass and inertia of the spec plus
  ``added_mass_kg`` and ``added_yaw_inertia_kgm2``; the body shape and one frictionless sphere
  per caster (``condim="1"``);
- ``wheel_left_link`` / ``wheel_right_link`` on hinge joints about +y of ``base_link``
  (positive speed drives forward), a sphere of the wheel radius (rolling radius exactly r)
  with the tyre friction of :func:`robots._pybullet_robot.tyre_friction`; the joints'
  ``actuatorfrcrange`` is the torque cap ``wheel_torque_max_nm`` on the sum of both actuators;
- per wheel a ``velocity`` actuator ``wheel_*_speed`` (``kv`` = the speed loop's P gain
  ``motor_gain_nms_per_rad``; ``ctrl`` = the wheel speed target, capped at
  ``wheel_speed_max_radps``) and a ``motor`` actuator ``wheel_*_loop`` for the rest of the
  loop's torque that a controller computes (the integral term, a skid steer's track);
- two fixed tendons over the wheel joints: ``forward`` (length rate = v while the tyres roll)
  and ``yaw`` (rate = yaw rate), whose ``damping`` and ``frictionloss`` are the axis frictions
  ``viscous_*`` and ``coulomb_*``: the force acts on the base's axes, as in the drive model.

What MJCF cannot express (command delay and timeout, the firmware clamp and acceleration
limits, the wheel targets of a (v, w) command, the PI integral, the motors' torque-speed
line, a direction-dependent Coulomb force, a skid steer's effective track) is the controller
``sim2real.mujoco.MujocoDrive``; the entries with ``mjcf=None`` in :func:`mjcf_mapping` say
what it does with each.

Examples
--------
>>> from robots.spec import load_spec
>>> spec = load_spec("turtlebot3_burger")
>>> text = mjcf_text(spec, spec.drive)
>>> text.splitlines()[0]
'<mujoco model="turtlebot3_burger">'
>>> entry = {e.name: e for e in mjcf_mapping(spec, spec.drive)}["speed_loop_gain"]
>>> entry.source, entry.value
('motor_gain_nms_per_rad', 0.011323)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from robots.errors import ParamsFileError
from robots.files import write_text_atomic
from robots.params import DriveParams
from robots.reduced import DEFAULT_DT_S
from robots.spec import RobotSpec, lumped_base_inertia, lumped_base_mass_kg
from robots.units import GRAVITY_MPS2 as _G

__all__ = [
    "MAX_TYRE_FRICTION",
    "MJCF_TIMESTEP_S",
    "WHEELS",
    "MjcfValue",
    "check_drive_kind",
    "mjcf_mapping",
    "mjcf_text",
    "wheel_torque_cap_nm",
    "write_mjcf",
]


#: Physics step of the exported model, s (the reduced model's integration step).
MJCF_TIMESTEP_S = DEFAULT_DT_S
#: The wheel sides, in actuator and joint order.
WHEELS = ("left", "right")
#: Largest tyre friction coefficient written: MuJoCo's contact solver leaves the drive model
#: beyond about 10 (the base lurches), and a drive that asks more than 5 times its weight's
#: grip at a wheel is beyond what a tyre has anyway.
MAX_TYRE_FRICTION = 5.0
#: The axis frictions' dry-friction constraints, stiff: MuJoCo's default softness lets an axis
#: creep under a force below its Coulomb level (a 0.006 rad/s turn command held a fitted Neato's
#: yaw at 0 in the drive model and turned it at 0.023 rad/s with the defaults; 0.003 rad/s at
#: most over a whole recording with these).
_DRY = 'solreffriction="0.008 1" solimpfriction="0.999 0.9999 0.001"'


@dataclass(frozen=True, kw_only=True)
class MjcfValue:
    """One value of the exported model and the drive parameter (or spec fact) it carries.

    :func:`mjcf_mapping` returns one for every value; ``docs/mujoco.md`` prints them as a
    table, and ``sim2real.mujoco.MujocoRobot.set_params`` writes the ``model`` ones into a
    compiled model.

    Attributes
    ----------
    name, source : str
        Identifier of the entry; the :class:`~robots.params.DriveParams` field (or spec key)
        it comes from.
    value : float
        The value written (SI units; ``inf`` = no such limit).
    mjcf : str or None
        Where it sits in the MJCF (element and attribute); None when MJCF cannot express it
        and ``sim2real.mujoco.MujocoDrive`` applies it.
    model : tuple or None
        ``(kind, names, array, column)`` of the compiled ``MjModel`` field it sets: the row of
        each named object (``kind``: body, joint, actuator, tendon, geom; a ``dof_`` array: the
        joint's degree of freedom) of ``getattr(model, array)``, that column of a 2-D array (a
        ``*range`` array: the symmetric limit, inf = none); None when it is not a model field.
    note : str
        How the value follows from the source (a formula, or what the controller does).
    """

    name: str
    value: float
    source: str
    mjcf: str | None
    model: tuple[str, tuple[str, ...], str, int] | None
    note: str


_JOINTS = tuple(f"wheel_{s}_joint" for s in WHEELS)
_SPEED = tuple(f"wheel_{s}_speed" for s in WHEELS)


def check_drive_kind(spec: RobotSpec, params: DriveParams, *, where: str = "the params") -> None:
    """Refuse skid-steer parameters (``track_factor`` != 1) for a differential-drive spec.

    A spec is a differential drive when its ``track_factor`` is 1 with no prior spread (what
    ``robots new --drive diff`` and the shipped specs write).

    Raises
    ------
    ParamsFileError
        ``params`` are a skid steer's and ``spec`` a differential drive's.
    """
    prior = spec.priors.get("track_factor")
    diff_spec = spec.drive.track_factor == 1.0 and (prior is None or prior.sd == 0.0)
    if diff_spec and params.track_factor != 1.0:
        raise ParamsFileError(
            f"{where} have track_factor {params.track_factor:g} (a skid steer) but robot "
            f"'{spec.name}' is a differential drive (track_factor 1); export with the skid "
            "steer's spec ('robots new NAME --drive skid') or fit the params with this spec"
        )


#: The values the MJCF carries, one a row: name | source | where in the MJCF | ``MjModel``
#: field (kind, names, array, column) | how the value follows from the source.
_IN_MJCF = """
base_mass | added_mass_kg | body base_link / inertial mass | body base_link body_mass 0 | the spec's lumped base mass (base, casters, point masses) + added_mass_kg
base_yaw_inertia | added_yaw_inertia_kgm2 | body base_link / inertial diaginertia[2] | body base_link body_inertia 2 | the spec's lumped base izz + added_yaw_inertia_kgm2
speed_loop_gain | motor_gain_nms_per_rad | actuator velocity wheel_*_speed / kv | actuator wheel_left_speed,wheel_right_speed actuator_gainprm 0 | torque K (ctrl - wheel speed); biasprm[2] = -K
wheel_speed_cap | wheel_speed_max_radps | actuator velocity wheel_*_speed / ctrlrange | actuator wheel_left_speed,wheel_right_speed actuator_ctrlrange 1 | the speed target's range +-cap (MujocoDrive scales both targets together or clips each, by wheel_cap_per_side)
wheel_torque_cap | wheel_torque_max_nm | joint wheel_*_joint / actuatorfrcrange | joint wheel_left_joint,wheel_right_joint jnt_actfrcrange 1 | +-cap on the sum of the wheel's two actuators, at most what a tyre carries at MAX_TYRE_FRICTION
motor_inertia | wheels.spin_inertia_kgm2 | joint wheel_*_joint / armature | joint wheel_left_joint,wheel_right_joint dof_armature 0 | 0: the spec's wheel spin inertia (motor included) is the wheel body's iyy
forward_viscous | viscous_v_ns_per_m | tendon fixed forward / damping | tendon forward tendon_damping 0 | tendon = (r/2)(q_left + q_right): its rate is v
forward_coulomb | coulomb_v_fwd_n | tendon fixed forward / frictionloss | tendon forward tendon_frictionloss 0 | MujocoDrive sets coulomb_v_bwd_n while the base moves backward
yaw_viscous | viscous_w_nms_per_rad | tendon fixed yaw / damping | tendon yaw tendon_damping 0 | tendon = (r/L)(q_right - q_left): its rate is the yaw rate
yaw_coulomb | coulomb_w_nm | tendon fixed yaw / frictionloss | tendon yaw tendon_frictionloss 0 | dry friction of the yaw rate
tyre_friction | wheel_torque_max_nm, coulomb_*, viscous_*, added_mass_kg | geom wheel_*_tyre / friction[0] | geom wheel_left_tyre,wheel_right_tyre geom_friction 0 | enough grip for every force the drive asks (the pybullet robot's rule), at most MAX_TYRE_FRICTION
"""


def _model_field(text: str) -> tuple[str, tuple[str, ...], str, int]:
    """``'kind name,name array column'`` -> (kind, names, array, column)."""
    kind, names, array, column = text.split()
    return kind, tuple(names.split(",")), array, int(column)


def wheel_torque_cap_nm(spec: RobotSpec, params: DriveParams) -> float:
    """The wheels' torque cap in MuJoCo: ``wheel_torque_max_nm``, at most the traction of a
    tyre at :data:`MAX_TYRE_FRICTION` under half the weight, N m.

    A fit on the ridge where mass, gain and torque scale together can leave the cap far
    beyond any grip (a Warthog fit: 15600 N m on 27 kg); a tyre slips there, and the PI loop's
    integrator, never clipped, winds the slipping wheel up until the simulation diverges.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> spec = load_spec("turtlebot3_burger")
    >>> wheel_torque_cap_nm(spec, spec.drive)  # its cap, well within the grip
    0.081
    """
    weight = params.total_mass_kg(spec.geometry) * _G
    grip = MAX_TYRE_FRICTION * 0.5 * weight * spec.wheels.radius_m
    return min(params.wheel_torque_max_nm, grip)


def mjcf_mapping(spec: RobotSpec, params: DriveParams) -> tuple[MjcfValue, ...]:
    """Every drive parameter's place in the MuJoCo model (the one mapping; see the module).

    Parameters
    ----------
    spec : RobotSpec
        The robot (geometry, inertias).
    params : DriveParams
        The identified drive (a ``sysid fit`` result or the spec defaults).

    Returns
    -------
    tuple of MjcfValue
        One entry per value, those the MJCF carries first.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> spec = load_spec("turtlebot2")
    >>> [e.source for e in mjcf_mapping(spec, spec.drive) if e.mjcf is None][:2]
    ['delay_s', 'cmd_timeout_s']
    """
    from robots._pybullet_robot import tyre_friction  # the tyre rule the pybullet robot uses

    d = params
    values = {
        "base_mass": lumped_base_mass_kg(spec) + d.added_mass_kg,
        "base_yaw_inertia": lumped_base_inertia(spec)[2] + d.added_yaw_inertia_kgm2,
        "speed_loop_gain": d.motor_gain_nms_per_rad,
        "wheel_speed_cap": d.wheel_speed_max_radps,
        "wheel_torque_cap": wheel_torque_cap_nm(spec, d),
        "motor_inertia": 0.0,
        "forward_viscous": d.viscous_v_ns_per_m,
        "forward_coulomb": d.coulomb_v_fwd_n,
        "yaw_viscous": d.viscous_w_nms_per_rad,
        "yaw_coulomb": d.coulomb_w_nm,
        "tyre_friction": min(tyre_friction(spec, d), MAX_TYRE_FRICTION),
    }
    rows = [[c.strip() for c in row.split("|")] for row in _IN_MJCF.strip().splitlines()]
    in_mjcf = tuple(
        MjcfValue(
            name=n,
            value=float(values[n]),
            source=s,
            mjcf=m,
            model=_model_field(f),
            note=t.replace("MAX_TYRE_FRICTION", f"{MAX_TYRE_FRICTION:g}"),
        )
        for n, s, m, f, t in rows
    )
    return in_mjcf + tuple(
        MjcfValue(name=n, value=float(getattr(d, n)), source=n, mjcf=None, model=None, note=t)
        for n, t in _DRIVE_ONLY
    )


#: What MujocoDrive applies, field by field (MJCF cannot express it).
_DRIVE_ONLY = (
    ("delay_s", "commands act this long after their stamp"),
    ("cmd_timeout_s", "the targets fall to 0 this long after a command"),
    ("speed_lim_v_mps", "clamps the commanded v"),
    ("speed_lim_w_radps", "clamps the commanded w"),
    ("accel_lim_v_mps2", "rate-limits the reference v"),
    ("accel_lim_w_radps2", "rate-limits the reference w"),
    ("driver_track_factor", "the wheel targets of a (v, w) command"),
    ("wheel_cap_per_side", "the wheel targets beyond the speed cap: both scaled, or each clipped"),
    ("command_starts_new_move", "clears the loops' integrators when the wheel targets change"),
    ("speed_loop_ki_per_s", "K ki (integrated speed error) on the wheel_*_loop actuators"),
    ("track_factor", "the loops' wheel speeds on the effective track (wheel_*_loop)"),
    ("wheel_stall_torque_nm", "the wheel joints' actfrcrange on the torque-speed line"),
    ("wheel_no_load_speed_radps", "the torque-speed line's other end"),
    ("coulomb_v_bwd_n", "the forward tendon's frictionloss while the base moves backward"),
)


def _f(x: float) -> str:
    return f"{x:.9g}"


def _range(limit: float) -> str:
    """``ctrlrange``/``forcerange`` text of a symmetric limit (MuJoCo's limited="auto")."""
    return f'"{_f(-limit)} {_f(limit)}"' if math.isfinite(limit) else '"0 0"'


#: Half the yaw inertia, raised by more than the 9-significant-digit rounding of ``_f`` can take
#: from each of roll, pitch and yaw (up to 5e-9 relative), so that the written text keeps A + B >= C.
_HALF_WITH_MARGIN = 0.5 * (1.0 + 1e-7)


def _base(spec: RobotSpec, v: dict[str, MjcfValue]) -> list[str]:
    # roll and pitch do not act on flat ground: raised where the yaw inertia needs it (MuJoCo's
    # triangle inequality A + B >= C), with a margin above the rounding of the 9-digit text
    izz = v["base_yaw_inertia"].value
    ixx, iyy = (max(i, _HALF_WITH_MARGIN * izz) for i in lumped_base_inertia(spec)[:2])
    sx, sy, sz = spec.body.size_m
    bx, by, bz = spec.body.xyz_m
    shape = (
        f'type="box" size="{_f(sx / 2)} {_f(sy / 2)} {_f(sz / 2)}"'
        if spec.body.shape == "box"
        else f'type="cylinder" size="{_f(sx / 2)} {_f(sz / 2)}"'
    )
    lines = [
        f'    <body name="base_link" pos="0 0 {_f(spec.base_link_height_m)}">',
        '      <freejoint name="base"/>',
        f"      <!-- mass: {v['base_mass'].source}: {v['base_mass'].note}; diaginertia[2]: "
        f"{v['base_yaw_inertia'].source}: {v['base_yaw_inertia'].note} -->",
        f'      <inertial pos="0 0 0" mass="{_f(v["base_mass"].value)}" '
        f'diaginertia="{_f(ixx)} {_f(iyy)} {_f(v["base_yaw_inertia"].value)}"/>',
        f'      <geom name="body" {shape} pos="{_f(bx)} {_f(by)} {_f(bz)}" condim="1" '
        'priority="1" mass="0"/>',
        '      <site name="base" pos="0 0 0"/>',
    ]
    for i, c in enumerate(spec.casters):
        x, y, z = c.xyz_m
        lines.append(
            f'      <geom name="caster_{i}" type="sphere" size="{_f(c.radius_m)}" '
            f'pos="{_f(x)} {_f(y)} {_f(z)}" condim="1" priority="1" mass="0"/>  <!-- frictionless caster -->'
        )
    return lines


def _wheel(spec: RobotSpec, side: str, v: dict[str, MjcfValue]) -> list[str]:
    w = spec.wheels
    left, right = spec.wheel_positions_m
    x, y, z = left if side == "left" else right
    tmax = v["wheel_torque_cap"].value
    return [
        f'      <body name="wheel_{side}_link" pos="{_f(x)} {_f(y)} {_f(z)}">',
        f"        <!-- actuatorfrcrange: {v['wheel_torque_cap'].source} (both actuators' sum); "
        f"armature: {v['motor_inertia'].source} ({v['motor_inertia'].note}) -->",
        f'        <joint name="wheel_{side}_joint" type="hinge" axis="0 1 0" '
        f"actuatorfrcrange={_range(tmax)} "
        f'armature="{_f(v["motor_inertia"].value)}" damping="0" frictionloss="0"/>',
        f'        <inertial pos="0 0 0" mass="{_f(w.mass_kg)}" diaginertia="'
        f'{_f(w.cross_inertia_kgm2)} {_f(w.spin_inertia_kgm2)} {_f(w.cross_inertia_kgm2)}"/>',
        f"        <!-- friction[0]: from {v['tyre_friction'].source}: "
        f"{v['tyre_friction'].note} -->",
        f'        <geom name="wheel_{side}_tyre" type="sphere" size="{_f(w.radius_m)}" '
        f'friction="{_f(v["tyre_friction"].value)} 0 0" condim="3" priority="1" solref="0.008 1" solimp="0.99 0.999 0.001" mass="0"/>',
        "      </body>",
    ]


def _tendons(spec: RobotSpec, v: dict[str, MjcfValue]) -> list[str]:
    r, sep = spec.wheels.radius_m, spec.wheels.separation_m
    fv, fc, yv, yc = (
        v[k] for k in ("forward_viscous", "forward_coulomb", "yaw_viscous", "yaw_coulomb")
    )
    return [
        "  <tendon>",
        f"    <!-- damping: {fv.source}; frictionloss: {fc.source} ({fc.note}) -->",
        f'    <fixed name="forward" damping="{_f(fv.value)}" frictionloss="{_f(fc.value)}" {_DRY}>',
        f'      <joint joint="wheel_left_joint" coef="{_f(r / 2)}"/>',
        f'      <joint joint="wheel_right_joint" coef="{_f(r / 2)}"/>',
        "    </fixed>",
        f"    <!-- damping: {yv.source}; frictionloss: {yc.source} -->",
        f'    <fixed name="yaw" damping="{_f(yv.value)}" frictionloss="{_f(yc.value)}" {_DRY}>',
        f'      <joint joint="wheel_left_joint" coef="{_f(-r / sep)}"/>',
        f'      <joint joint="wheel_right_joint" coef="{_f(r / sep)}"/>',
        "    </fixed>",
        "  </tendon>",
    ]


def _actuators(v: dict[str, MjcfValue]) -> list[str]:
    k, cap = v["speed_loop_gain"], v["wheel_speed_cap"]
    lines = [
        "  <actuator>",
        f"    <!-- kv: {k.source} ({k.note}); ctrlrange: {cap.source} -->",
    ]
    for side in WHEELS:
        lines.append(
            f'    <velocity name="wheel_{side}_speed" joint="wheel_{side}_joint" '
            f'kv="{_f(k.value)}" ctrlrange={_range(cap.value)}/>'
        )
    lines.append(
        "    <!-- the loop's torque beyond K (target - speed): MujocoDrive "
        "(speed_loop_ki_per_s, track_factor) -->"
    )
    lines += [
        f'    <motor name="wheel_{side}_loop" joint="wheel_{side}_joint" gear="1"/>'
        for side in WHEELS
    ]
    lines.append("  </actuator>")
    return lines


def mjcf_text(spec: RobotSpec, params: DriveParams) -> str:
    """The MJCF document of ``spec`` driven by ``params`` (see the module docstring).

    Parameters
    ----------
    spec : RobotSpec
        The robot.
    params : DriveParams
        The drive (e.g. ``load_drive_params("params.yaml", robot=..., base=spec.drive)``).

    Returns
    -------
    str
        The MJCF XML, every drive value commented with its parameter.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> spec = load_spec("turtlebot2")
    >>> 'name="forward"' in mjcf_text(spec, spec.drive)
    True
    """
    check_drive_kind(spec, params)
    v = {e.name: e for e in mjcf_mapping(spec, params)}
    missing = [e for e in v.values() if e.mjcf is None]
    header = [
        f'<mujoco model="{spec.name}">',
        f"  <!-- written by 'sim2real robots export' from robot spec {spec.path.name}; "
        "the drive values below carry the params fields named beside them -->",
        "  <!-- not expressible in MJCF, applied by sim2real.mujoco.MujocoDrive: "
        + ", ".join(f"{e.source}={e.value:g}" for e in missing)
        + " -->",
        '  <compiler angle="radian" autolimits="true"/>',
        f'  <option timestep="{_f(MJCF_TIMESTEP_S)}" integrator="implicitfast"/>',
        "  <worldbody>",
        '    <geom name="floor" type="plane" size="0 0 1" friction="1 0 0"/>',
    ]
    body = _base(spec, v) + _wheel(spec, "left", v) + _wheel(spec, "right", v)
    body.append("    </body>")
    footer = ["  </worldbody>", *_tendons(spec, v), *_actuators(v), "</mujoco>"]
    return "\n".join(header + body + footer) + "\n"


def write_mjcf(path: str | Path, spec: RobotSpec, params: DriveParams) -> Path:
    """Write :func:`mjcf_text` to ``path`` atomically; returns the path."""
    return write_text_atomic(Path(path), mjcf_text(spec, params))
