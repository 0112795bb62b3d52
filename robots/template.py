"""A complete robot spec from a few published numbers (``sim2real robots new``).

Only the wheel separation is required. Every other fact a spec needs gets a *documented
prior*: a typical value derived from the given numbers, explained in a comment, and -- for the
drive parameters -- an explicit wide prior in the spec's ``priors`` section (format of
:mod:`robots.spec`, coordinates of :data:`robots.params.SCHEMA`) that sysid narrows with data.
Numbers that are given get narrow priors.

Typical-value rules (from the published specs of small indoor bases to field robots:
TurtleBot3 Burger/Waffle, Kobuki, Neato, Jackal, Husky):

- wheel radius ``r = 0.2 b`` for wheel separation ``b`` (those bases span 0.12-0.30 b);
- total mass ``m = 250 b^3`` kg (a base's volume grows with its size cubed; those bases sit
  within a factor 3 of it), clipped to 0.5-200 kg;
- top speed 0.5 m/s, top yaw rate ``2 v_max / b`` (both wheels at the cap, opposite; over the
  effective track ``1.6 b`` for a skid steer);
- footprint radius ``0.7 b`` (at least ``b/2`` plus half a wheel width);
- wheel speed loop time constant 0.1 s, traction ``mu = 0.5``, Coulomb friction 1 % of the
  weight, viscous drag 0.1 /s of the mass.

Examples
--------
>>> text = spec_text("neato", wheel_separation_m=0.248, max_speed_mps=0.3)
>>> "max_v_mps: 0.3  # given" in text
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from robots.errors import RobotsValueError
from robots.units import GRAVITY_MPS2 as _G

__all__ = ["DRIVES", "WHEEL_CAPS", "NewRobot", "spec_text"]

#: ``--drive`` choices: differential drive, skid steer.
DRIVES = ("diff", "skid")
#: ``--wheel-cap`` choices: how the driver holds wheel targets to the speed cap (both scaled
#: together, or each clipped on its own; ``robots.params.DriveParams.wheel_cap_per_side``).
WHEEL_CAPS = ("joint", "per-side")
_SKID_CHI = 1.6  # prior track factor of a skid steer (see _render)


@dataclass(frozen=True, kw_only=True)
class NewRobot:
    """The numbers of a new robot, given or filled with the typical-value rules.

    ``given`` names the fields the user gave (their priors are narrow).
    """

    name: str
    wheel_separation_m: float
    wheel_radius_m: float
    mass_kg: float
    max_speed_mps: float
    max_turn_rate_radps: float
    footprint_radius_m: float
    drive: str
    driver_track_factor: float
    track_factor: float
    wheel_cap: str
    new_move: bool
    given: frozenset[str]

    @classmethod
    def from_facts(
        cls,
        name: str,
        *,
        wheel_separation_m: float,
        wheel_radius_m: float | None = None,
        mass_kg: float | None = None,
        max_speed_mps: float | None = None,
        max_turn_rate_radps: float | None = None,
        footprint_radius_m: float | None = None,
        drive: str = "diff",
        driver_track_factor: float | None = None,
        track_factor: float | None = None,
        wheel_cap: str | None = None,
        new_move: bool = False,
    ) -> NewRobot:
        """Fill the facts not given (see the module docstring for the rules).

        ``driver_track_factor`` is the driver's ``wheel_separation_multiplier`` (its wheel
        targets use that many times the geometric track; Clearpath's Husky driver ships 1.875,
        the Jackal's 1.5); when not given: 1 for a differential drive, the skid prior (1.6)
        for a skid steer. ``track_factor`` is a skid steer's effective over geometric track as
        its recordings see it (1 when they read the yaw rate from the wheel encoders, which turn
        on the geometric track); when not given, the skid prior (1.6). ``wheel_cap`` (one of
        :data:`WHEEL_CAPS`) is how the driver holds the wheel targets to the speed cap; when not
        given, ``joint`` (both scaled together). ``new_move``: the firmware runs each command
        as a new move, its wheel loops' integrators cleared (the Neato's ``SetMotor``); when not
        given, the loops run on across commands.
        """
        facts = {
            "wheel_separation_m": wheel_separation_m,
            "wheel_radius_m": wheel_radius_m,
            "mass_kg": mass_kg,
            "max_speed_mps": max_speed_mps,
            "max_turn_rate_radps": max_turn_rate_radps,
            "footprint_radius_m": footprint_radius_m,
            "driver_track_factor": driver_track_factor,
        }
        _check_facts(name, drive, facts)
        if track_factor is not None and not (drive == "skid" and 1.0 <= track_factor <= 4.0):
            raise RobotsValueError(
                f"track_factor must be in [1, 4] on a skid steer (--drive skid), got "
                f"{track_factor!r} on drive {drive!r}; a differential drive's is 1"
            )
        if wheel_cap is not None and wheel_cap not in WHEEL_CAPS:
            raise RobotsValueError(
                f"wheel_cap must be one of {list(WHEEL_CAPS)}, got {wheel_cap!r}; 'per-side' "
                "when the driver clips each wheel's target at the cap on its own"
            )
        b = wheel_separation_m
        r = wheel_radius_m or 0.2 * b
        v = max_speed_mps or 0.5
        min_footprint = 0.5 * b + 0.25 * r
        if footprint_radius_m is not None and footprint_radius_m < min_footprint:
            raise RobotsValueError(
                f"footprint_radius_m {footprint_radius_m} is smaller than half the wheel "
                f"separation plus half a wheel width ({min_footprint:.4g} m): the wheels would "
                "stick out; give the radius of the circle that contains the whole base"
            )
        return cls(
            name=name,
            wheel_separation_m=b,
            wheel_radius_m=r,
            mass_kg=mass_kg or min(max(250.0 * b**3, 0.5), 200.0),
            max_speed_mps=v,
            max_turn_rate_radps=max_turn_rate_radps
            or 2.0 * v / (b * (_SKID_CHI if drive == "skid" else 1.0)),
            footprint_radius_m=footprint_radius_m or max(0.7 * b, min_footprint),
            drive=drive,
            driver_track_factor=driver_track_factor or (_SKID_CHI if drive == "skid" else 1.0),
            track_factor=track_factor or (_SKID_CHI if drive == "skid" else 1.0),
            wheel_cap=wheel_cap or "joint",
            new_move=bool(new_move),
            given=frozenset(
                [k for k, val in facts.items() if val is not None]
                + (["track_factor"] if track_factor is not None else [])
                + (["wheel_cap"] if wheel_cap is not None else [])
            ),
        )


def _check_facts(name: str, drive: str, facts: dict[str, float | None]) -> None:
    """Refuse a name, drive or number :meth:`NewRobot.from_facts` cannot use, in one sentence."""
    for key, value in facts.items():
        if value is not None and not (math.isfinite(value) and value > 0):
            raise RobotsValueError(
                f"{key} must be a finite number > 0, got {value!r}; give it in SI units "
                "(m, kg, m/s, rad/s)"
            )
    if not name.replace("_", "").replace("-", "").isalnum():
        raise RobotsValueError(
            f"robot name must be letters, digits, '_' or '-', got {name!r}; e.g. my_robot"
        )
    if drive not in DRIVES:
        raise RobotsValueError(f"drive must be one of {list(DRIVES)}, got {drive!r}")
    factor = facts["driver_track_factor"]
    if factor is not None and not 0.5 <= factor <= 5.0:
        raise RobotsValueError(
            f"driver_track_factor (the driver's wheel_separation_multiplier) must be in "
            f"[0.5, 5], got {factor!r}; e.g. 1.875 for a Husky's driver"
        )


def _g(x: float) -> str:
    """A number as YAML (6 significant digits; .inf).

    YAML 1.1 (PyYAML) reads an exponent form as a float only with a dot in the mantissa and a
    sign in the exponent: ``6e-05`` is the *string* '6e-05', so it is written ``6.0e-05``.
    """
    if math.isinf(x):
        return ".inf"
    if abs(x) < 1e-12:
        return "0.0"
    text = f"{x:.6g}"
    mantissa, e, exponent = text.partition("e")
    if e and "." not in mantissa:
        text = f"{mantissa}.0e{exponent}"
    return text


def _src(robot: NewRobot, key: str, rule: str) -> str:
    return "given" if key in robot.given else f"prior: {rule}, not given"


def spec_text(name: str, *, wheel_separation_m: float, **facts: float | str | None) -> str:
    """The commented YAML text of a complete spec (see :class:`NewRobot` for ``facts``).

    The text loads with :func:`robots.spec.load_spec` and passes :func:`robots.check.check_spec`.
    """
    robot = NewRobot.from_facts(name, wheel_separation_m=wheel_separation_m, **facts)  # type: ignore[arg-type]
    return _render(robot)


@dataclass(frozen=True, kw_only=True)
class _Derived:
    """The numbers a spec derives from a :class:`NewRobot` (SI units)."""

    width: float
    m_wheel: float
    spin: float
    cross: float
    m_base: float
    height: float
    clearance: float
    izz: float
    ixx: float
    z_body: float
    caster_r: float
    caster_x: float
    i_eff: float
    k_motor: float
    tau_max: float


def _derive(robot: NewRobot) -> _Derived:
    b, r, m = robot.wheel_separation_m, robot.wheel_radius_m, robot.mass_kg
    fr = robot.footprint_radius_m
    width = 0.5 * r
    m_wheel = 0.03 * m
    spin = 0.5 * m_wheel * r * r
    cross = m_wheel * (3 * r * r + width * width) / 12.0
    m_base = m - 2 * m_wheel
    height = max(0.4 * fr, 1.2 * r)
    clearance = 0.3 * r
    izz = 0.5 * m_base * fr * fr
    caster_r = 0.3 * r
    # mass and inertia as the reduced model lumps them (robots.spec mass model)
    m_eff = m + 2 * spin / (r * r)
    return _Derived(
        width=width,
        m_wheel=m_wheel,
        spin=spin,
        cross=cross,
        m_base=m_base,
        height=height,
        clearance=clearance,
        izz=izz,
        ixx=m_base * (3 * fr * fr + height * height) / 12.0,
        z_body=clearance + 0.5 * height - r,  # base_link sits at axle height r
        caster_r=caster_r,
        caster_x=fr - caster_r,
        i_eff=izz + 2 * (cross + m_wheel * b * b / 4) + 2 * spin * b * b / (4 * r * r),
        k_motor=m_eff * r * r / (2 * 0.1),
        tau_max=0.5 * m * _G / 2 * r,
    )


def _render(robot: NewRobot) -> str:
    d = _derive(robot)
    lines = [
        *_header_lines(robot),
        *_body_lines(robot, d),
        *_drive_lines(robot, d),
        *_prior_lines(robot, d),
        *_sensor_lines(d),
    ]
    return "\n".join(lines) + "\n"


def _header_lines(robot: NewRobot) -> list[str]:
    skid = robot.drive == "skid"
    return [
        f"# {robot.name}: a spec written by `sim2real robots new` from the numbers given below;",
        "# every other fact is a documented prior (comments say which rule made it; see",
        "# robots/template.py). Edit any number you know better, then run",
        f"# `sim2real robots check {robot.name}.yaml`. sysid fits the drive section against the",
        "# priors at the end, so the wide ones are narrowed by your logs.",
        f"name: {robot.name}",
        f"description: {robot.name}, {'skid-steer' if skid else 'differential-drive'} base "
        "(spec from published numbers and documented priors)",
        *(
            [
                "# skid steer: the two wheels below stand for the two sides' wheel sets; the",
                "# treads' slip is the drive's track_factor (effective / geometric track, fitted",
                "# by sysid) and their lateral scrub the yaw Coulomb torque coulomb_w_nm",
            ]
            if skid
            else []
        ),
        "sources:",
        f'  - "given: {", ".join(sorted(robot.given))}"',
        '  - "priors: robots/template.py typical-value rules (TurtleBot3, Kobuki, Neato, '
        'Jackal, Husky)"',
    ]


def _body_lines(robot: NewRobot, d: _Derived) -> list[str]:
    b, r, m = robot.wheel_separation_m, robot.wheel_radius_m, robot.mass_kg
    v, w, fr = robot.max_speed_mps, robot.max_turn_rate_radps, robot.footprint_radius_m
    return [
        "base:",
        f"  mass_kg: {_g(d.m_base)}  # total {_g(m)} kg ({_src(robot, 'mass_kg', 'm = 250 b^3')})"
        " less two wheels",
        f"  inertia_diag_kgm2: [{_g(d.ixx)}, {_g(d.ixx)}, {_g(d.izz)}]  # prior: solid cylinder"
        " of the footprint",
        f"  link_height_m: {_g(r)}  # base_link at axle height",
        f"  body: {{shape: cylinder, radius_m: {_g(fr)}, height_m: {_g(d.height)}, xyz_m: [0.0,"
        f" 0.0, {_g(d.z_body)}]}}  # footprint ({_src(robot, 'footprint_radius_m', '0.7 b')});"
        f" prior: height 0.4 x radius, {_g(d.clearance)} m ground clearance",
        "wheels:",
        f"  radius_m: {_g(r)}  # {_src(robot, 'wheel_radius_m', 'r = 0.2 b')}",
        f"  width_m: {_g(d.width)}  # prior: 0.5 r",
        f"  separation_m: {_g(b)}  # given",
        f"  mass_kg: {_g(d.m_wheel)}  # prior: 3 % of the total mass",
        f"  spin_inertia_kgm2: {_g(d.spin)}  # prior: solid disc, m r^2 / 2",
        f"  cross_inertia_kgm2: {_g(d.cross)}  # prior: solid disc, m (3 r^2 + w^2) / 12",
        *_caster_lines(robot, d),
        "point_masses: []",
        "limits:",
        f"  max_v_mps: {_g(v)}  # {_src(robot, 'max_speed_mps', '0.5 m/s')}",
        f"  max_w_radps: {_g(w)}  # {_src(robot, 'max_turn_rate_radps', '2 v_max / b')}",
    ]


def _caster_lines(robot: NewRobot, d: _Derived) -> list[str]:
    if robot.drive != "skid":
        return [
            "casters:  # prior: frictionless skids front and back, so the base cannot tip",
            f"  - {{x_m: {_g(d.caster_x)}, y_m: 0.0, radius_m: {_g(d.caster_r)}, mass_kg: 0.0}}",
            f"  - {{x_m: {_g(-d.caster_x)}, y_m: 0.0, radius_m: {_g(d.caster_r)}, mass_kg: 0.0}}",
        ]
    # A skid steer's other wheels stand at the corners of its footprint: skids there keep the
    # base level through a hard turn-and-reverse, where two skids on the centre line let it
    # roll onto one and lift a drive wheel off the ground.
    c = d.caster_x / math.sqrt(2.0)
    return [
        "casters:  # prior: frictionless skids at the four corners of the footprint, where the"
        " other wheels stand, so the base cannot tip or roll",
        *(
            f"  - {{x_m: {_g(sx * c)}, y_m: {_g(sy * c)}, radius_m: {_g(d.caster_r)}, mass_kg: 0.0}}"
            for sx in (1.0, -1.0)
            for sy in (1.0, -1.0)
        ),
    ]


def _skid_rules(robot: NewRobot) -> tuple[str, str, str]:
    """The comments of track_factor, driver_track_factor and coulomb_w_nm."""
    skid = robot.drive == "skid"
    # Skid steer (Mandow et al. 2007, "Experimental kinematics for wheeled skid-steer mobile
    # robots": chi ~1.5-2 for their four-wheel base; Clearpath's separation multipliers are
    # 1.5 (Jackal) and 1.875 (Husky)); the treads' lateral scrub resists turning with about
    # a tenth of the weight at half the track (differential drive: 1 % for a caster's drag).
    chi_rule = (
        "given: the effective / geometric track the recordings see (1 when they read the yaw "
        "rate from the wheel encoders)"
        if "track_factor" in robot.given
        else "prior: skid steer, effective track ~1.6 x the geometric one (Mandow 2007, Clearpath)"
        if skid
        else "prior: differential drive, the wheels roll without lateral slip"
    )
    driver_rule = (
        "given: the driver's wheel_separation_multiplier"
        if "driver_track_factor" in robot.given
        else "prior: the driver's wheel_separation_multiplier, assumed calibrated to the slip "
        "(Husky ships 1.875, Jackal 1.5); give your driver's value (--driver-track-factor)"
        if skid
        else "the driver's wheel targets use the geometric track (--driver-track-factor: "
        "your driver's wheel_separation_multiplier)"
    )
    scrub_rule = (
        "tread scrub, 10 % of the weight at half the track"
        if skid
        else "1 % of the weight at half the track"
    )
    return chi_rule, driver_rule, scrub_rule


def _drive_lines(robot: NewRobot, d: _Derived) -> list[str]:
    r, m, v, w = robot.wheel_radius_m, robot.mass_kg, robot.max_speed_mps, robot.max_turn_rate_radps
    given, skid = robot.given, robot.drive == "skid"
    chi = robot.track_factor
    scrub = (0.1 if skid else 0.01) * m * _G * robot.wheel_separation_m / 2
    chi_rule, driver_rule, scrub_rule = _skid_rules(robot)
    return [
        "drive:",
        "  delay_s: 0.1  # prior: typical ROS command latency 0.05-0.3 s",
        "  cmd_timeout_s: .inf  # prior: none known (sysid tells whether the log shows one)",
        "  speed_lim_v_mps: .inf  # the top speed is the wheel-speed cap below (set a firmware",
        "  # clamp here if your driver clamps v itself before the wheels)",
        f"  speed_lim_w_radps: {_g(w) if 'max_turn_rate_radps' in given else '.inf'}  # "
        f"{'given top yaw rate' if 'max_turn_rate_radps' in given else 'the wheel cap limits it'}",
        "  accel_lim_v_mps2: .inf  # prior: no velocity smoother known",
        "  accel_lim_w_radps2: .inf",
        f"  wheel_speed_max_radps: {_g(v / r)}  # top speed / r",
        f"  motor_gain_nms_per_rad: {_g(d.k_motor)}  # prior: speed-loop time constant 0.1 s,"
        " K = m_eff r^2 / (2 T)",
        "  speed_loop_ki_per_s: 0.0  # a P loop until sysid identifies the integral term",
        f"  wheel_torque_max_nm: {_g(d.tau_max)}  # prior: traction mu = 0.5 on half the weight",
        "  wheel_stall_torque_nm: .inf  # the motors' torque-speed line: none until you give the"
        " datasheet's stall torque and no-load speed at the wheel (and priors below)",
        "  wheel_no_load_speed_radps: .inf",
        f"  coulomb_v_fwd_n: {_g(0.01 * m * _G)}  # prior: 1 % of the weight",
        f"  coulomb_v_bwd_n: {_g(0.01 * m * _G)}",
        f"  coulomb_w_nm: {_g(scrub)}  # prior: {scrub_rule}",
        f"  viscous_v_ns_per_m: {_g(0.1 * m)}  # prior: 0.1 /s of the mass",
        f"  viscous_w_nms_per_rad: {_g(0.1 * d.i_eff)}  # prior: 0.1 /s of the yaw inertia",
        "  added_mass_kg: 0.0",
        "  added_yaw_inertia_kgm2: 0.0",
        f"  track_factor: {_g(chi)}  # {chi_rule}",
        f"  driver_track_factor: {_g(robot.driver_track_factor)}  # {driver_rule}",
        *_wheel_cap_lines(robot),
        *_new_move_lines(robot),
    ]


def _wheel_cap_lines(robot: NewRobot) -> list[str]:
    per_side = robot.wheel_cap == "per-side"
    how = (
        "the driver clips each wheel's target at the cap on its own"
        if per_side
        else "a command beyond the cap scales both wheel targets together, keeping the turn "
        "radius (as most drivers do: Clearpath's husky_base, the Neato's)"
    )
    source = "given" if "wheel_cap" in robot.given else "prior"
    return [
        f"  wheel_cap_per_side: {1 if per_side else 0}  # {source}: {how}; a driver setting "
        "(--wheel-cap)",
    ]


def _new_move_lines(robot: NewRobot) -> list[str]:
    how = (
        "given: the firmware runs each command as a new move, so the wheel loops' integrators "
        "clear when the wheel targets change (the Neato's SetMotor)"
        if robot.new_move
        else "prior: the firmware's wheel loops run on across commands"
    )
    return [
        f"  command_starts_new_move: {int(robot.new_move)}  # {how}; a driver setting "
        "(--command-starts-new-move)"
    ]


def _prior_lines(robot: NewRobot, d: _Derived) -> list[str]:
    m, given, skid = robot.mass_kg, robot.given, robot.drive == "skid"
    scrub_sd = (0.1 if skid else 0.05) * m * _G * robot.wheel_separation_m / 2
    return [
        "# Priors (robots.params.SCHEMA coordinates: lin = the unit of the value; log and",
        "# log_total_* = a relative spread, 0.7 ~ a factor 2). Wide where a number was not given.",
        "priors:",
        "  delay_s: {sd: 0.15, session_sd: 0.03}  # 0-0.4 s",
        "  cmd_timeout_s: {sd: 0.0, session_sd: 0.0}  # a firmware setting: sysid detects it",
        f"  speed_lim_v_mps: {{sd: {0.05 if 'max_speed_mps' in given else 0.7}, session_sd: 0.0}}",
        f"  speed_lim_w_radps: {{sd: {0.05 if 'max_turn_rate_radps' in given else 0.7}, "
        "session_sd: 0.0}",
        "  accel_lim_v_mps2: {sd: 1.0, session_sd: 0.05}  # no centre (inf): fitted freely",
        "  accel_lim_w_radps2: {sd: 1.0, session_sd: 0.05}",
        f"  wheel_speed_max_radps: {{sd: {0.15 if 'max_speed_mps' in given else 0.7}, "
        "session_sd: 0.05}  # battery sag",
        "  motor_gain_nms_per_rad: {sd: 1.5, session_sd: 0.05}  # time constant 0.02-0.5 s",
        "  speed_loop_ki_per_s: {nominal: 10.0, sd: 10.0, session_sd: 0.0}  # firmware PI loops:"
        " integral time ~ the 0.1 s loop time constant",
        "  wheel_torque_max_nm: {sd: 1.0, session_sd: 0.15}  # floor and tyres",
        "  wheel_stall_torque_nm: {sd: 0.0, session_sd: 0.0}  # no line (inf above)",
        "  wheel_no_load_speed_radps: {sd: 0.0, session_sd: 0.0}",
        f"  coulomb_v_fwd_n: {{sd: {_g(0.04 * m * _G)}, session_sd: {_g(0.005 * m * _G)}}}"
        "  # 0-8 % of the weight",
        f"  coulomb_v_bwd_n: {{sd: {_g(0.04 * m * _G)}, session_sd: {_g(0.005 * m * _G)}}}",
        f"  coulomb_w_nm: {{sd: {_g(scrub_sd)}, session_sd: {_g(0.2 * scrub_sd)}}}",
        f"  viscous_v_ns_per_m: {{sd: {_g(1.5 * m)}, session_sd: {_g(0.2 * m)}}}",
        f"  viscous_w_nms_per_rad: {{sd: {_g(1.5 * d.i_eff)}, session_sd: {_g(0.2 * d.i_eff)}}}",
        f"  added_mass_kg: {{sd: {0.3 if 'mass_kg' in given else 0.7}, session_sd: 0.1}}"
        "  # payload; a factor 2 when the mass was not given",
        "  added_yaw_inertia_kgm2: {sd: 0.7, session_sd: 0.15}  # body shape is a guess",
        f"  track_factor: {{sd: {_track_sd(robot)}, session_sd: {0.1 if skid else 0.0}}}  "
        f"# {_track_note(robot)}",
        "  driver_track_factor: {sd: 0.0, session_sd: 0.0}  # a driver setting: edit it above",
        "  wheel_cap_per_side: {sd: 0.0, session_sd: 0.0}  # a driver setting: edit it above",
        "  command_starts_new_move: {sd: 0.0, session_sd: 0.0}  # a driver setting: edit it above",
    ]


def _track_note(robot: NewRobot) -> str:
    if robot.drive != "skid":
        return "a differential drive: exactly 1"
    return "given (narrow)" if "track_factor" in robot.given else "1.2-2.5, the surface changes it"


def _track_sd(robot: NewRobot) -> float:
    """The track factor's prior sd: 0 on a differential drive, narrow when given."""
    if robot.drive != "skid":
        return 0.0
    return 0.1 if "track_factor" in robot.given else 0.3


def _sensor_lines(d: _Derived) -> list[str]:
    return [
        "lidar:  # placeholder: a typical 360-beam 2D lidar on top; edit to your sensor",
        "  beams: 360",
        "  angle_min_rad: 0.0",
        f"  angle_max_rad: {2 * math.pi * 359 / 360!r}",
        "  range_min_m: 0.12",
        "  range_max_m: 3.5",
        f"  xyz_m: [0.0, 0.0, {_g(d.z_body + 0.5 * d.height + 0.03)}]",
        "  rate_hz: 5.0",
        "depth_camera: null",
        "odometry:  # prior: wheel encoders for both (edit w_source to imu if a gyro is used)",
        "  v_source: wheels",
        "  w_source: wheels",
        "  rate_hz: 20.0",
    ]
