r"""Foreign plants: a differential-drive base simulator that is *not* the project's drive model.

:mod:`robots.reduced` (and the pybullet robot) implement the drive chain that ``sysid`` fits.
Checking a fit, a calibrated band or a report on data produced by that same chain only shows
that the model can fit itself. This module simulates a base with the physics real bases have
and the model does not (or has differently), so the tools can be judged on data the model does
not contain:

- **transport**: every command reaches the firmware after its own latency (session mean plus
  jitter, arrival order kept), and the firmware stops the wheels when no command arrived for
  ``cmd_timeout_s``; an optional velocity smoother (acceleration limits) follows the clamp;
- **firmware**: speed clamps, wheel targets from the kinematics scaled together when one
  exceeds the wheel-speed cap, and a discrete per-wheel **PI** speed loop at
  ``control_rate_hz`` with conditional-integration anti-windup, its integrator cleared by a
  zero target (the model has a continuous P loop);
- **motors**: an H-bridge DC motor whose torque is limited by the torque-speed line
  :math:`|\tau + k\omega| \le \tau_{stall} V/V_{nom}`, with the battery voltage :math:`V`
  sagging under load (:math:`V = V_{batt} - R_{sag}(|\tau_L|+|\tau_R|)`); the model has a flat
  torque cap;
- **resistance**: Coulomb friction per wheel, different forward and backward and left and
  right, viscous rolling resistance per wheel, and a caster scrub torque that opposes turning
  most in place and fades with forward speed (the model has body-level Coulomb/viscous terms);
- **sensing**: quantised wheel encoders (``ticks_per_rev``) read at ``odom_rate_hz`` from the
  firmware's own clock; v from the tick differences over each period, w from a gyro (white
  noise and a small bias) or from the wheel tick differences, as the robot spec's odometry
  sources say; header stamps with jitter; a few dropped messages.

Per-session variation (payload, floor friction, battery charge, latency) is drawn from a
seeded :class:`numpy.random.Generator` (:func:`draw_session`), so :func:`make_fleet` gives the
logs of several sessions of one base. Everything is deterministic for a seed.

Integration: semi-implicit Euler of the rigid base (mass and yaw inertia with the wheels'
spin inertia, :attr:`robots.spec.RobotSpec.geometry`) at ``physics_dt_s`` (0.5 ms) in a numba
kernel; Coulomb terms are regularised with ``tanh`` over a contact speed small enough to be
stable at that step. A 90 s session takes tens of milliseconds after the first compile
(``benchmarks/bench_plants.py`` measures it).

Examples
--------
>>> from sim2real.plants.diff_drive import make_fleet
>>> traces = make_fleet("turtlebot3_burger", 2, seed=1, duration_s=20.0)
>>> len(traces), traces[0].meas_t_ns.size > 500
(2, True)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

import numba
import numpy as np
from numpy.typing import NDArray

from robots.spec import load_spec
from robots.units import GRAVITY_MPS2, nanoseconds
from sim2real._arrays import FloatArray
from sim2real.errors import Sim2RealValueError
from sim2real.logs import integrate_pose, write_trace
from sim2real.logs.trace import Trace, TraceMeta
from sim2real.plants._clock import (
    check_commands,
    command_arrivals,
    firmware_tick,
    negative_field,
    odometry_clock,
)
from sysid.synthetic import step_commands

if TYPE_CHECKING:
    from typing_extensions import Unpack  # typing.Unpack from Python 3.11

__all__ = [
    "PROFILES",
    "T0_NS",
    "PlantParams",
    "PlantRun",
    "SessionOptions",
    "SessionVariation",
    "command_profile",
    "draw_session",
    "make_fleet",
    "make_sessions",
    "plant_from_spec",
    "run_plant",
    "run_to_trace",
    "write_fleet",
]


#: Epoch of the simulated logs' clock (1.7e9 s after the Unix epoch; an arbitrary start), ns.
T0_NS = 1_700_000_000_000_000_000

#: Command profiles of :func:`command_profile`.
PROFILES = (
    "steps",
    "ramps",
    "arcs",
    "reversals",
    "turns",
    "teleop",
    "goals",
    "random_steps",
    "mixed",
)


@dataclass(frozen=True, kw_only=True)
class PlantParams:
    """Everything the foreign plant simulates (SI units; see the module docstring).

    Attributes
    ----------
    robot : str
        Name of the robot spec the values come from.
    mass_kg, yaw_inertia_kgm2 : float
        Effective mass and yaw inertia (with wheel spin inertia and payload).
    wheel_radius_m, wheel_separation_m : float
        Wheel radius and track, m.
    max_v_mps, max_w_radps : float
        Firmware clamps of the command.
    accel_lim_v_mps2, accel_lim_w_radps2 : float
        Velocity smoother limits (``inf``: no smoother).
    wheel_speed_max_radps : float
        Firmware cap of a wheel target; both targets are scaled together when one exceeds it.
    cmd_timeout_s : float
        The firmware stops when no command arrived for this long (``inf``: never).
    control_rate_hz : float
        Rate of the firmware loop (command handling and PI update), Hz.
    kp_nms_per_rad, ki_nm_per_rad : float
        Proportional and integral gain of each wheel's PI speed loop.
    stall_torque_nm : float
        Motor stall torque at the wheel at the nominal battery voltage.
    no_load_speed_radps : float
        Wheel no-load speed at the nominal battery voltage.
    battery_nominal_v, battery_v : float
        Nominal and session (state-of-charge) battery voltage, V.
    sag_v_per_nm : float
        Battery sag per N m of total wheel torque (internal resistance), V/(N m).
    coulomb_fwd_n, coulomb_bwd_n : tuple of float
        (left, right) Coulomb friction at the wheel contact, rolling forward / backward, N.
    viscous_ns_per_m : tuple of float
        (left, right) viscous rolling resistance, N s/m of contact speed.
    scrub_nm : float
        Caster scrub torque in an in-place turn, N m.
    scrub_fade_mps : float
        Forward speed at which the scrub torque has halved, m/s.
    latency_s, latency_jitter_s : float
        Mean command transport latency and the std of its per-message jitter, s.
    odom_rate_hz : float
        Odometry rate, Hz.
    ticks_per_rev : int
        Encoder ticks per wheel revolution.
    w_source : str
        ``"imu"`` (gyro) or ``"wheels"`` (encoder difference).
    gyro_noise_radps, gyro_bias_radps : float
        Gyro white-noise std and bias, rad/s.
    stamp_jitter_s : float
        Std of the odometry header-stamp jitter, s (clipped at 0.3 periods).
    odom_drop_fraction : float
        Share of odometry messages lost by the recorder.
    physics_dt_s : float
        Integration step, s.
    """

    robot: str
    mass_kg: float
    yaw_inertia_kgm2: float
    wheel_radius_m: float
    wheel_separation_m: float
    max_v_mps: float
    max_w_radps: float
    accel_lim_v_mps2: float
    accel_lim_w_radps2: float
    wheel_speed_max_radps: float
    cmd_timeout_s: float
    control_rate_hz: float
    kp_nms_per_rad: float
    ki_nm_per_rad: float
    stall_torque_nm: float
    no_load_speed_radps: float
    battery_nominal_v: float
    battery_v: float
    sag_v_per_nm: float
    coulomb_fwd_n: tuple[float, float]
    coulomb_bwd_n: tuple[float, float]
    viscous_ns_per_m: tuple[float, float]
    scrub_nm: float
    scrub_fade_mps: float
    latency_s: float
    latency_jitter_s: float
    odom_rate_hz: float
    ticks_per_rev: int
    w_source: str
    gyro_noise_radps: float
    gyro_bias_radps: float
    stamp_jitter_s: float
    odom_drop_fraction: float
    physics_dt_s: float = 0.0005

    def __post_init__(self) -> None:
        bad = negative_field(self, text=("robot", "w_source"))
        if bad is not None:
            raise Sim2RealValueError(
                f"PlantParams.{bad[0]} must be a non-negative number, got {bad[1]!r}; "
                "give a value >= 0 (inf where the docstring allows 'no limit')"
            )
        if self.w_source not in ("imu", "wheels"):
            raise Sim2RealValueError(
                f"PlantParams.w_source must be 'imu' or 'wheels', got {self.w_source!r}"
            )
        for name in ("mass_kg", "yaw_inertia_kgm2", "wheel_radius_m", "wheel_separation_m"):
            if not 0 < getattr(self, name) < math.inf:
                raise Sim2RealValueError(
                    f"PlantParams.{name} must be positive and finite, got {getattr(self, name)}"
                )
        if self.ticks_per_rev < 1 or self.odom_rate_hz <= 0 or self.control_rate_hz <= 0:
            raise Sim2RealValueError(
                "PlantParams.ticks_per_rev, odom_rate_hz and control_rate_hz must be positive, "
                f"got {self.ticks_per_rev}, {self.odom_rate_hz}, {self.control_rate_hz}"
            )

    def replace(self, **changes: Any) -> PlantParams:
        """A copy with ``changes`` applied (validated again)."""
        return dataclasses.replace(self, **changes)


def plant_from_spec(robot: str, **changes: Any) -> PlantParams:
    """Plant parameters derived from the robot spec ``robots.load_spec(robot)``.

    Geometry, mass, clamps, smoother limits, wheel-speed cap, command timeout, nominal latency
    and the odometry rate and w source come from the spec. The rest are typical values for a
    small base, scaled to it: the PI loop has the spec's speed-loop gain and a 0.1 s integral
    time, the motor stalls at 2.5 times the spec's wheel torque cap and runs free 15 % above
    the wheel-speed cap, Coulomb friction is 4 % of the weight per wheel (10 % more backward,
    the right wheel 15 % stiffer), and the caster scrub is a third of the in-place turning
    torque the friction gives.

    Examples
    --------
    >>> p = plant_from_spec("turtlebot3_burger")
    >>> p.wheel_radius_m, p.odom_rate_hz, p.w_source
    (0.033, 30.0, 'imu')
    """
    spec = load_spec(robot)
    geo, drive, odo = spec.geometry, spec.drive, spec.odometry
    weight_n = spec.rigid_mass_kg * GRAVITY_MPS2
    c = 0.04 * weight_n / 2.0
    wheel_cap = drive.wheel_speed_max_radps
    if not math.isfinite(wheel_cap):
        wheel_cap = 1.2 * spec.max_v_mps / geo.wheel_radius_m
    torque_cap = drive.wheel_torque_max_nm
    if not math.isfinite(torque_cap):
        torque_cap = 0.5 * weight_n / 2.0 * geo.wheel_radius_m
    values: dict[str, Any] = {
        "robot": spec.name,
        "mass_kg": geo.mass_kg,
        "yaw_inertia_kgm2": geo.yaw_inertia_kgm2,
        "wheel_radius_m": geo.wheel_radius_m,
        "wheel_separation_m": geo.wheel_separation_m,
        "max_v_mps": min(drive.speed_lim_v_mps, spec.max_v_mps),
        "max_w_radps": min(drive.speed_lim_w_radps, spec.max_w_radps),
        "accel_lim_v_mps2": drive.accel_lim_v_mps2,
        "accel_lim_w_radps2": drive.accel_lim_w_radps2,
        "wheel_speed_max_radps": wheel_cap,
        "cmd_timeout_s": drive.cmd_timeout_s,
        "control_rate_hz": 100.0,
        "kp_nms_per_rad": drive.motor_gain_nms_per_rad,
        "ki_nm_per_rad": drive.motor_gain_nms_per_rad / 0.1,
        "stall_torque_nm": 2.5 * torque_cap,
        "no_load_speed_radps": 1.15 * wheel_cap,
        "battery_nominal_v": 12.0,
        "battery_v": 12.0,
        "sag_v_per_nm": 0.3 / torque_cap,
        "coulomb_fwd_n": (c, 1.15 * c),
        "coulomb_bwd_n": (1.1 * c, 1.25 * c),
        "viscous_ns_per_m": (0.3 * spec.rigid_mass_kg, 0.35 * spec.rigid_mass_kg),
        "scrub_nm": 0.33 * c * geo.wheel_separation_m,
        "scrub_fade_mps": 0.05,
        "latency_s": max(drive.delay_s, 0.02),
        "latency_jitter_s": 0.01,
        "odom_rate_hz": odo.rate_hz,
        "ticks_per_rev": 4096,
        "w_source": odo.w_source,
        "gyro_noise_radps": 0.012,
        "gyro_bias_radps": 0.003,
        "stamp_jitter_s": 0.001,
        "odom_drop_fraction": 0.01,
    }
    values.update(changes)
    return PlantParams(**values)


# --- per-session variation -----------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class SessionVariation:
    """Ranges of the per-session draws of :func:`draw_session` (uniform unless noted).

    Attributes
    ----------
    payload_fraction : tuple of float
        Payload as a fraction of the base mass (its yaw inertia as a 0.1 m radius of gyration).
    floor_friction : tuple of float
        Factor on Coulomb, viscous and scrub terms (floor, tyres, caster).
    battery_charge : tuple of float
        Battery voltage as a fraction of nominal (0.92: a tired pack, 1.05: freshly charged).
    latency_s : tuple of float
        Mean transport latency, s.
    """

    payload_fraction: tuple[float, float] = (0.0, 0.4)
    floor_friction: tuple[float, float] = (0.7, 1.4)
    battery_charge: tuple[float, float] = (0.92, 1.05)
    latency_s: tuple[float, float] = (0.06, 0.16)


def draw_session(
    base: PlantParams, rng: np.random.Generator, variation: SessionVariation | None = None
) -> PlantParams:
    """One session of ``base``: payload, floor friction, battery charge and latency drawn.

    Examples
    --------
    >>> import numpy as np
    >>> base = plant_from_spec("turtlebot3_burger")
    >>> s = draw_session(base, np.random.default_rng(0))
    >>> s.mass_kg >= base.mass_kg and 0.06 <= s.latency_s <= 0.16
    True
    """
    var = variation or SessionVariation()
    payload = rng.uniform(*var.payload_fraction) * base.mass_kg
    friction = rng.uniform(*var.floor_friction)
    charge = rng.uniform(*var.battery_charge)
    latency = rng.uniform(*var.latency_s)
    scale = lambda pair: (pair[0] * friction, pair[1] * friction)  # noqa: E731
    return base.replace(
        mass_kg=base.mass_kg + payload,
        yaw_inertia_kgm2=base.yaw_inertia_kgm2 + payload * 0.1**2,
        coulomb_fwd_n=scale(base.coulomb_fwd_n),
        coulomb_bwd_n=scale(base.coulomb_bwd_n),
        viscous_ns_per_m=scale(base.viscous_ns_per_m),
        scrub_nm=base.scrub_nm * friction,
        battery_v=base.battery_nominal_v * charge,
        latency_s=latency,
    )


# --- command profiles ----------------------------------------------------------------------


def _hold(out: list[tuple[float, float, bool]], v: float, w: float, s: float, hz: float) -> None:
    out.extend([(v, w, True)] * max(1, round(s * hz)))


def _ramp(
    out: list[tuple[float, float, bool]], v0: float, v1: float, w: float, s: float, hz: float
) -> None:
    out.extend((float(x), w, True) for x in np.linspace(v0, v1, max(2, round(s * hz))))


def _block(
    kind: str,
    out: list[tuple[float, float, bool]],
    rng: np.random.Generator,
    vm: float,
    wm: float,
    hz: float,
) -> None:
    sign = 1.0 if rng.random() < 0.6 else -1.0
    if kind == "steps":
        if rng.random() < 0.5:
            _hold(out, sign * rng.uniform(0.2, 1.0) * vm, 0.0, rng.uniform(2.0, 3.5), hz)
        else:
            _hold(out, 0.0, sign * rng.uniform(0.15, 0.8) * wm, rng.uniform(1.5, 3.0), hz)
    elif kind == "ramps":
        top = sign * rng.uniform(0.5, 1.0) * vm
        _ramp(out, 0.0, top, 0.0, rng.uniform(1.5, 3.0), hz)
        _ramp(out, top, 0.0, 0.0, rng.uniform(1.5, 3.0), hz)
    elif kind == "arcs":
        _hold(
            out,
            rng.uniform(0.4, 1.0) * vm,
            sign * rng.uniform(0.1, 0.6) * wm,
            rng.uniform(2, 3.5),
            hz,
        )
    elif kind == "reversals":
        level = rng.uniform(0.5, 0.9) * vm
        _hold(out, level, 0.0, rng.uniform(1.5, 2.5), hz)
        _hold(out, -level, 0.0, rng.uniform(1.5, 2.5), hz)
    elif kind == "turns":
        _hold(out, 0.0, sign * rng.uniform(0.3, 0.9) * wm, rng.uniform(1.5, 2.5), hz)
        _hold(out, 0.0, -sign * rng.uniform(0.3, 0.9) * wm, rng.uniform(1.5, 2.5), hz)
    elif kind == "goals":  # go-to-goal: a proportional in-place turn, then a gently steered leg
        heading = rng.uniform(-2.5, 2.5)
        while abs(heading) > 0.05:
            w = float(np.clip(1.2 * heading, -0.55 * wm, 0.55 * wm))
            out.append((0.0, w, True))
            heading -= w * 0.7 / hz
        speed, phase = rng.uniform(0.45, 1.0) * vm, rng.uniform(0.0, 2.0 * math.pi)
        for k in range(round(rng.uniform(3.0, 6.0) * hz)):
            out.append((speed, 0.05 * wm * math.sin(phase + 0.9 * k / hz), True))
    else:  # teleop: held key combinations; sometimes the publisher stops (key released)
        for _ in range(int(rng.integers(2, 4))):
            v = float(rng.choice([0.0, 0.5, 0.9, -0.5])) * vm
            w = float(rng.choice([0.0, 0.0, 0.3, -0.3, 0.6])) * wm
            _hold(out, v, w, rng.uniform(1.0, 2.5), hz)
        if rng.random() < 0.5:  # silence: the firmware's command timeout stops the base
            out.extend([(0.0, 0.0, False)] * round(rng.uniform(0.8, 1.5) * hz))
    _hold(out, 0.0, 0.0, rng.uniform(0.6, 1.4), hz)


def command_profile(
    kind: str,
    duration_s: float,
    *,
    rng: np.random.Generator,
    max_v_mps: float,
    max_w_radps: float,
    rate_hz: float = 10.0,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Commands ``(t_s, v, w)`` republished at ``rate_hz`` for ``duration_s`` seconds.

    ``kind`` is one of :data:`PROFILES`: ``steps`` (v or w steps), ``ramps`` (up and down in
    v), ``arcs`` (v and w together), ``reversals`` (forward then backward), ``turns`` (in place,
    both ways), ``teleop`` (held key combinations with moments where the publisher falls
    silent), ``goals`` (go-to-goal legs: a proportional in-place turn with decaying w, then a
    leg with gentle heading corrections), ``random_steps``
    (:func:`sysid.synthetic.step_commands`) or ``mixed`` (random blocks of the first six). Each profile starts with 1.5 s at rest; blocks end with a pause.
    Times with no command published (teleop silences) are missing from ``t_s``.

    Examples
    --------
    >>> import numpy as np
    >>> t, v, w = command_profile("turns", 10.0, rng=np.random.default_rng(0), max_v_mps=0.2,
    ...                           max_w_radps=2.0)
    >>> bool(np.all(v == 0.0) and np.abs(w).max() > 0.5)
    True
    """
    if kind not in PROFILES:
        raise Sim2RealValueError(
            f"command profile must be one of {', '.join(PROFILES)}, got {kind!r}"
        )
    if not duration_s > 0:
        raise Sim2RealValueError(f"duration_s must be positive, got {duration_s}")
    if kind == "random_steps":
        seed = int(rng.integers(2**31))
        return step_commands(
            duration_s, seed=seed, rate_hz=rate_hz, v_max_mps=max_v_mps, w_max_radps=max_w_radps
        )
    out: list[tuple[float, float, bool]] = []
    _hold(out, 0.0, 0.0, 1.5, rate_hz)
    kinds = PROFILES[:6]  # "mixed": the excitation blocks and teleop
    n = int(duration_s * rate_hz)
    while len(out) < n:
        block = kinds[int(rng.integers(len(kinds)))] if kind == "mixed" else kind
        _block(block, out, rng, max_v_mps, max_w_radps, rate_hz)
    cmd = np.asarray(out[:n], dtype=np.float64)
    t = np.arange(n) / rate_hz
    sent = cmd[:, 2] > 0.5
    return t[sent], cmd[sent, 0], cmd[sent, 1]


# --- the simulator -------------------------------------------------------------------------

_P_FIELDS = (
    "mass_kg",
    "yaw_inertia_kgm2",
    "wheel_radius_m",
    "wheel_separation_m",
    "max_v_mps",
    "max_w_radps",
    "accel_lim_v_mps2",
    "accel_lim_w_radps2",
    "wheel_speed_max_radps",
    "cmd_timeout_s",
    "kp_nms_per_rad",
    "ki_nm_per_rad",
    "stall_torque_nm",
    "no_load_speed_radps",
    "battery_nominal_v",
    "battery_v",
    "sag_v_per_nm",
    "scrub_nm",
    "scrub_fade_mps",
)


def _pack(p: PlantParams) -> FloatArray:
    head = [float(getattr(p, name)) for name in _P_FIELDS]
    tail = [*p.coulomb_fwd_n, *p.coulomb_bwd_n, *p.viscous_ns_per_m]
    return np.asarray(head + tail, dtype=np.float64)


@numba.njit(cache=True)
def _coulomb(c: float, speed: float, scale: float) -> float:
    return c * math.tanh(speed / scale)


@numba.njit(cache=True)
def _pi(err: float, integ: float, kp: float, ki_dt: float, lo: float, hi: float) -> tuple:  # type: ignore[type-arg]
    """One PI update with torque limits [lo, hi] and conditional-integration anti-windup."""
    u = kp * err + integ + ki_dt * err
    if u > hi:
        return hi, integ + ki_dt * err if err < 0 else integ
    if u < lo:
        return lo, integ + ki_dt * err if err > 0 else integ
    return u, integ + ki_dt * err


#: Layout of the plant's integration state (:func:`_kernel`): body velocities, wheel angles,
#: PI integrators, wheel torques, smoothed references, index of the last arrived command,
#: clock, next firmware tick, and the previous step's (v, w, angle L, angle R).
_STATE = (
    "v",
    "w",
    "ang_l",
    "ang_r",
    "integ_l",
    "integ_r",
    "torque_l",
    "torque_r",
    "ref_v",
    "ref_w",
    "last_cmd",
    "t",
    "next_ctrl",
    "prev_v",
    "prev_w",
    "prev_ang_l",
    "prev_ang_r",
)


def _fresh_state() -> FloatArray:
    """The integration state of a base at rest at t = 0 with no command arrived."""
    state = np.zeros(len(_STATE))
    state[_STATE.index("last_cmd")] = -1.0
    return state


@numba.njit(cache=True)
def _write_out(
    out: FloatArray, k: int, a: float, prev: FloatArray, v: float, w: float, ang: FloatArray
) -> None:
    """Row ``k`` of ``out``: (v, w, wheel angles) a fraction ``a`` of the step from ``prev``."""
    out[k, 0] = prev[0] + a * (v - prev[0])
    out[k, 1] = prev[1] + a * (w - prev[1])
    out[k, 2] = prev[2] + a * (ang[0] - prev[2])
    out[k, 3] = prev[3] + a * (ang[1] - prev[3])


@numba.njit(cache=True)
def _kernel(
    p: FloatArray,
    arr_t: FloatArray,
    arr_v: FloatArray,
    arr_w: FloatArray,
    out_t: FloatArray,
    dt: float,
    ctrl_dt: float,
    out: FloatArray,
    state: FloatArray,
) -> None:
    """Integrate the plant from ``state`` until every ``out_t`` is reached.

    Writes (v, w, wheel angle L, wheel angle R) at ``out_t`` (increasing; times the state has
    already passed are interpolated over its last step) and leaves the state at the first
    physics step at or after the last, so a run can go on with later commands and times.
    """
    m, inertia, r, sep = p[0], p[1], p[2], p[3]
    limits = p[4:10]  # max v, max w, accel v, accel w, wheel speed cap, timeout
    kp, ki, stall, noload, vnom, vbatt, sag, scrub, fade = (
        p[10],
        p[11],
        p[12],
        p[13],
        p[14],
        p[15],
        p[16],
        p[17],
        p[18],
    )
    cf = (p[19], p[20])
    cb = (p[21], p[22])
    visc = (p[23], p[24])
    half = 0.5 * sep
    k_emf = stall / noload
    # contact-speed scale of the tanh Coulomb terms: stable for explicit Euler at dt
    m_mode = min(0.5 * m, inertia / (sep * sep))
    cmax = max(cf[0], cf[1], cb[0], cb[1], scrub / half, 1e-9)
    scale = max(0.002, 4.0 * cmax * dt / m_mode)
    v, w = state[0], state[1]
    ang = state[2:4].copy()
    integ = state[4:6].copy()
    torque = state[6:8].copy()
    ref_v, ref_w = state[8], state[9]
    j = int(state[10])  # last arrived command
    t, next_ctrl = state[11], state[12]
    prev = state[13:17].copy()
    k_out = 0
    n_out = out_t.size
    while k_out < n_out and out_t[k_out] <= t:  # passed in the last step of an earlier call
        _write_out(out, k_out, (out_t[k_out] - (t - dt)) / dt, prev, v, w, ang)
        k_out += 1
    while k_out < n_out:
        if t >= next_ctrl - 1e-12:
            next_ctrl += ctrl_dt
            j, ref_v, ref_w, tgt_l, tgt_r = firmware_tick(
                t, j, ref_v, ref_w, arr_t, arr_v, arr_w, limits, ctrl_dt, half, r
            )
            volts = max(vbatt - sag * (abs(torque[0]) + abs(torque[1])), 0.0)
            for i in range(2):
                speed = (v - half * w) / r if i == 0 else (v + half * w) / r
                tgt = tgt_l if i == 0 else tgt_r
                if tgt == 0.0:
                    integ[i] = 0.0  # a stop command clears the integrator (no creep at rest)
                err = tgt - speed
                hi = stall * volts / vnom - k_emf * speed
                lo = -stall * volts / vnom - k_emf * speed
                torque[i], integ[i] = _pi(err, integ[i], kp, ki * ctrl_dt, lo, hi)
        # forces at the wheel contacts (drive minus Coulomb), then the rigid base
        force = np.zeros(2)
        for i in range(2):
            cs = v - half * w if i == 0 else v + half * w
            c = cf[i] if cs > 0 else cb[i]
            force[i] = torque[i] / r - _coulomb(c, cs, scale)
        scrub_now = scrub / (1.0 + abs(v) / fade) if fade > 0 else scrub
        f_v = force[0] + force[1]
        t_w = half * (force[1] - force[0]) - _coulomb(scrub_now, half * w, scale)
        # viscous terms implicitly: c_v = visc_l + visc_r on v, half^2 (visc_l + visc_r) on w,
        # cross terms half (visc_r - visc_l) handled explicitly
        bs = visc[0] + visc[1]
        bd = visc[1] - visc[0]
        v_new = (v + dt * (f_v - half * bd * w) / m) / (1.0 + dt * bs / m)
        w_new = (w + dt * (t_w - half * bd * v) / inertia) / (1.0 + dt * half * half * bs / inertia)
        t_new = t + dt
        prev[0], prev[1], prev[2], prev[3] = v, w, ang[0], ang[1]
        ang[0] += dt * (v_new - half * w_new) / r
        ang[1] += dt * (v_new + half * w_new) / r
        v, w = v_new, w_new
        while k_out < n_out and out_t[k_out] <= t_new:
            _write_out(out, k_out, (out_t[k_out] - t) / dt, prev, v, w, ang)
            k_out += 1
        t = t_new
    state[0], state[1] = v, w
    state[2:4] = ang
    state[4:6] = integ
    state[6:8] = torque
    state[8], state[9] = ref_v, ref_w
    state[10] = j
    state[11], state[12] = t, next_ctrl
    state[13:17] = prev


@dataclass(frozen=True, kw_only=True)
class PlantRun:
    """One simulated session (see :func:`run_plant`).

    Attributes
    ----------
    params : PlantParams
        The session's plant.
    cmd_t_s, cmd_v, cmd_w : ndarray
        Commands as published (and recorded), s, m/s, rad/s.
    arrival_t_s : ndarray
        When each command reached the firmware, s.
    tick_t_s : ndarray
        Odometry instants on the firmware clock (every sample, before drops), s.
    stamp_t_s : ndarray
        Their header stamps (jittered), s.
    true_v, true_w : ndarray
        Body velocities at ``tick_t_s``.
    ticks_l, ticks_r : ndarray of int64
        Encoder counts at ``tick_t_s``.
    meas_v, meas_w : ndarray
        What the odometry message reports at each tick.
    kept : ndarray of bool
        Messages the recorder kept.
    """

    params: PlantParams
    cmd_t_s: FloatArray
    cmd_v: FloatArray
    cmd_w: FloatArray
    arrival_t_s: FloatArray
    tick_t_s: FloatArray
    stamp_t_s: FloatArray
    true_v: FloatArray
    true_w: FloatArray
    ticks_l: NDArray[np.int64]
    ticks_r: NDArray[np.int64]
    meas_v: FloatArray
    meas_w: FloatArray
    kept: NDArray[np.bool_]


def run_plant(
    params: PlantParams,
    cmd_t_s: Sequence[float] | FloatArray,
    cmd_v: Sequence[float] | FloatArray,
    cmd_w: Sequence[float] | FloatArray,
    *,
    duration_s: float,
    rng: np.random.Generator,
) -> PlantRun:
    """Simulate the plant under the commands for ``duration_s`` seconds.

    Draws, in this order, from ``rng``: the command latencies, the phase of the odometry
    clock, the gyro noise, the stamp jitter and the drops.

    Examples
    --------
    >>> import numpy as np
    >>> p = plant_from_spec("turtlebot3_burger")
    >>> run = run_plant(p, [0.0], [0.1], [0.0], duration_s=3.0, rng=np.random.default_rng(0))
    >>> round(float(run.true_v[-1]), 2)
    0.0
    """
    t, cv, cw = check_commands(cmd_t_s, cmd_v, cmd_w)
    if not np.all(np.isfinite(cv)) or not np.all(np.isfinite(cw)) or not duration_s > 0:
        raise Sim2RealValueError("commands must be finite and duration_s positive")
    arrival = command_arrivals(rng, t, params.latency_s, params.latency_jitter_s, floor_s=0.002)
    period, ticks_t = odometry_clock(rng, params.odom_rate_hz, duration_s)
    out = np.zeros((ticks_t.size, 4))
    _kernel(
        _pack(params),
        arrival,
        cv,
        cw,
        ticks_t,
        params.physics_dt_s,
        1.0 / params.control_rate_hz,
        out,
        _fresh_state(),
    )
    ticks_l, ticks_r, meas_v, meas_w = _odometry(params, out, period, rng)
    lim = 0.3 * period
    jitter = np.clip(params.stamp_jitter_s * rng.standard_normal(ticks_t.size), -lim, lim)
    kept = rng.random(ticks_t.size) >= params.odom_drop_fraction
    kept[0] = True
    return PlantRun(
        params=params,
        cmd_t_s=t,
        cmd_v=cv,
        cmd_w=cw,
        arrival_t_s=arrival,
        tick_t_s=ticks_t,
        stamp_t_s=ticks_t + jitter,
        true_v=out[:, 0].copy(),
        true_w=out[:, 1].copy(),
        ticks_l=ticks_l,
        ticks_r=ticks_r,
        meas_v=meas_v,
        meas_w=meas_w,
        kept=kept,
    )


def _odometry(
    params: PlantParams, out: FloatArray, period: float, rng: np.random.Generator
) -> tuple[NDArray[np.int64], NDArray[np.int64], FloatArray, FloatArray]:
    """(encoder ticks L, R, reported v, reported w) at the odometry ticks from the true
    (v, w, wheel angles) ``out``: v from the quantised encoders, w from them or the gyro
    (bias and noise, drawn from ``rng``)."""
    tick = 2.0 * math.pi / params.ticks_per_rev
    ticks_l = np.floor(out[:, 2] / tick).astype(np.int64)
    ticks_r = np.floor(out[:, 3] / tick).astype(np.int64)
    r, sep = params.wheel_radius_m, params.wheel_separation_m
    d_l = np.diff(ticks_l, prepend=ticks_l[0]) * tick * r
    d_r = np.diff(ticks_r, prepend=ticks_r[0]) * tick * r
    meas_v = 0.5 * (d_l + d_r) / period
    gyro = out[:, 1] + params.gyro_bias_radps
    gyro = gyro + params.gyro_noise_radps * rng.standard_normal(out.shape[0])
    meas_w = gyro if params.w_source == "imu" else (d_r - d_l) / sep / period
    return ticks_l, ticks_r, meas_v, meas_w


def run_to_trace(run: PlantRun, *, t0_ns: int = T0_NS, name: str = "") -> Trace:
    """The recorded log of a run: published commands and the kept odometry messages.

    The pose is dead-reckoned from the reported velocities
    (:func:`sim2real.logs.integrate_pose`), as the base's odometry does.
    """
    k = run.kept
    meas_t_ns = t0_ns + nanoseconds(run.stamp_t_s[k])
    x, y, yaw = integrate_pose(meas_t_ns, run.meas_v[k], run.meas_w[k])
    return Trace(
        cmd_t_ns=t0_ns + nanoseconds(run.cmd_t_s),
        cmd_v=run.cmd_v,
        cmd_w=run.cmd_w,
        meas_t_ns=meas_t_ns,
        meas_v=run.meas_v[k],
        meas_w=run.meas_w[k],
        pose_x=x,
        pose_y=y,
        pose_yaw=yaw,
        meta=TraceMeta(path=name, cmd_topic="/cmd_vel", meas_topic="/odom"),
    )


# --- fleets --------------------------------------------------------------------------------


class SessionOptions(TypedDict, total=False):
    """The optional keywords of :func:`make_sessions`, which :func:`make_fleet` and
    :func:`write_fleet` pass on to it."""

    duration_s: float
    profile: str
    variation: SessionVariation | None
    cmd_rate_hz: float


def make_sessions(
    robot: str | PlantParams,
    n_sessions: int,
    *,
    seed: int,
    duration_s: float = 90.0,
    profile: str = "mixed",
    variation: SessionVariation | None = None,
    cmd_rate_hz: float = 10.0,
) -> list[PlantRun]:
    """``n_sessions`` runs of one base, each with its own draw and its own command sequence.

    ``robot`` is a spec name (:func:`plant_from_spec`) or a :class:`PlantParams`. Session
    ``i`` uses ``numpy.random.default_rng([seed, i])``: adding sessions never changes the
    earlier ones.
    """
    if n_sessions < 1:
        raise Sim2RealValueError(f"n_sessions must be at least 1, got {n_sessions}")
    base = plant_from_spec(robot) if isinstance(robot, str) else robot
    runs = []
    for i in range(n_sessions):
        rng = np.random.default_rng([seed, i])
        params = draw_session(base, rng, variation)
        t, v, w = command_profile(
            profile,
            duration_s,
            rng=rng,
            max_v_mps=params.max_v_mps,
            max_w_radps=params.max_w_radps,
            rate_hz=cmd_rate_hz,
        )
        runs.append(run_plant(params, t, v, w, duration_s=duration_s, rng=rng))
    return runs


def make_fleet(
    robot: str | PlantParams, n_sessions: int, *, seed: int, **options: Unpack[SessionOptions]
) -> list[Trace]:
    """The logs (:class:`~sim2real.logs.Trace`) of :func:`make_sessions` (same arguments).

    Examples
    --------
    >>> tr = make_fleet("turtlebot2", 1, seed=3, duration_s=10.0)[0]
    >>> round(1e9 / float(np.median(np.diff(tr.meas_t_ns))))  # the spec's 50 Hz odometry
    50
    """
    runs = make_sessions(robot, n_sessions, seed=seed, **options)
    return [run_to_trace(run, name=f"session_{i}") for i, run in enumerate(runs)]


def write_fleet(
    out_dir: str | Path,
    robot: str | PlantParams,
    n_sessions: int,
    *,
    seed: int,
    prefix: str = "session",
    **options: Unpack[SessionOptions],
) -> list[Path]:
    """Write :func:`make_fleet`'s sessions as ROS 2 MCAP files ``OUT/<prefix>_<i>.mcap``
    (``robot``, ``n_sessions`` and the ``options`` as :func:`make_sessions` takes them).

    Each file holds ``/cmd_vel`` (``geometry_msgs/msg/Twist``) and ``/odom``
    (``nav_msgs/msg/Odometry``) in CDR (:func:`sim2real.logs.write_trace`).
    """
    out = Path(out_dir)
    if not out.is_dir():
        raise Sim2RealValueError(f"out_dir '{out}' is not an existing folder; create it first")
    traces = make_fleet(robot, n_sessions, seed=seed, **options)
    return [write_trace(out / f"{prefix}_{i}.mcap", tr) for i, tr in enumerate(traces)]
