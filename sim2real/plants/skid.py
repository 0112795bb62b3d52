r"""A foreign skid-steer plant: four wheels that slip, *not* the project's drive model.

:mod:`sim2real.plants.diff_drive` checks the tools on a differential drive whose wheels roll. This module
simulates a Husky-like four-wheel skid steer whose slip comes out of tyre-ground friction, so
``sysid`` and the agreement can be judged on a base whose turning the model only approximates
(the model's slip is one number, ``track_factor``; here it comes out of tyre forces, builds up
and decays with the body's lateral and yaw dynamics, the driver's multiplier does not match
it, and the encoder speed sees the longitudinal slip):

- **contacts**: four wheels at :math:`(\pm a, \pm B/2)` (half wheelbase, half track), each
  pressed by a quarter of the weight. The ground force on a wheel opposes its contact's slip
  velocity :math:`s = (v_c - r\omega_{side}, v_{c,y})` with a friction *ellipse*
  :math:`F = -\mu N\, q/\sqrt{1 + |q|^2}`, :math:`q = (s_x/\epsilon_x, s_y/\epsilon_y)`
  (regularised Coulomb friction: stiff tyre while gripping, :math:`\mu N` when sliding, the
  longitudinal and lateral parts sharing one budget). Turning drags the wheels sideways
  (lateral scrub, which resists the turn) and the traction that overcomes the scrub makes the
  outer wheels spin ahead of the ground and the inner ones behind it: the instantaneous
  centres of rotation of the two sides move outwards and the effective track exceeds the
  geometric one (Mandow et al. 2007, "Experimental kinematics for wheeled skid-steer mobile
  robots", IROS: ICR-based kinematics of a four-wheel skid steer, ICRs nearly constant on
  one surface). With this ellipse a steady turn's ratio is set by the tyre stiffnesses and
  the wheel layout, not by the turn rate (1.53 for :func:`husky_like`,
  :func:`effective_track_factor`); it moves in transients and with the ground's ``mu`` only
  through them;
- **rigid body** in the plane (forward, lateral and yaw velocity) with the wheels' forces;
  each side's two wheels turn together (one motor and a chain per side, as on the Husky)
  with their spin inertia and a rolling resistance;
- **firmware**: the driver's kinematics with a fixed separation multiplier (Clearpath's
  ``wheel_separation_multiplier``, 1.875 for the Husky: calibrated once, so it matches the real
  slip only on average), speed clamps, acceleration limits, per-side speed cap (both sides
  scaled together), command timeout; a discrete PI speed loop per side at ``control_rate_hz``
  (anti-windup; the Husky's firmware runs a PID loop, :func:`husky_like`) and a DC-motor
  torque-speed line. The integral term matters for the contrast with a differential-drive
  model: it holds the wheels at their targets, so a yaw command turns the base at
  :math:`w\,m/\chi` (driver multiplier *m*, slip :math:`\chi`) whatever the scrub; a
  proportional loop instead droops under the scrub, a droop that a differential model with
  yaw friction reproduces (the slip then hides in the friction, the v channel shows nothing);
- **sensing**: command latency with jitter; odometry at ``odom_rate_hz`` with v from the wheel
  encoders (it sees the longitudinal slip) and w from a gyro (noise, bias).

Integration: explicit Euler at ``physics_dt_s`` (0.25 ms) in a numba kernel; the tyre
regularisation speeds are wide enough for it to be stable.

Examples
--------
>>> from sim2real.plants.skid import husky_like, make_skid_sessions
>>> tr = make_skid_sessions(husky_like(), 1, seed=0, duration_s=10.0)[0]
>>> tr.meas_t_ns.size > 400
True
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np

from robots.spec import RobotSpec
from robots.units import GRAVITY_MPS2 as _G
from robots.units import nanoseconds
from sim2real._arrays import FloatArray
from sim2real.errors import Sim2RealValueError
from sim2real.logs.trace import Trace, TraceMeta
from sim2real.plants._clock import (
    check_commands,
    command_arrivals,
    firmware_tick,
    negative_field,
    odometry_clock,
)
from sim2real.plants.diff_drive import T0_NS, command_profile

__all__ = [
    "CHI_RANGE",
    "MU_RANGE",
    "SkidPlantParams",
    "effective_track_factor",
    "husky_like",
    "make_skid_sessions",
    "plant_odometry",
    "run_skid_plant",
    "skid_robot",
]


@dataclass(frozen=True, kw_only=True)
class SkidPlantParams:
    """Everything the skid-steer plant simulates (SI units; see the module docstring).

    Attributes
    ----------
    mass_kg, yaw_inertia_kgm2 : float
        Body mass and yaw inertia (wheels included).
    wheel_radius_m, track_m, wheelbase_m : float
        Wheel radius, distance between the left and right wheels, between front and rear.
    side_inertia_kgm2 : float
        Spin inertia of one side (two wheels, chain, reflected motor rotor), kg m^2.
    mu, slip_long_mps, slip_lat_mps : float
        Tyre-ground friction coefficient and the longitudinal / lateral slip speeds at which
        the force reaches ~70 % of :math:`\\mu N` (tyre stiffness).
    rolling_resistance : float
        Rolling resistance coefficient (force / normal force).
    separation_multiplier : float
        The driver's effective-track multiplier.
    max_v_mps, max_w_radps, accel_v_mps2, accel_w_radps2 : float
        Driver clamps and acceleration limits.
    side_speed_max_radps : float
        Per-side wheel-speed cap of the driver.
    cmd_timeout_s : float
        The driver stops the wheels when no command arrived for this long.
    control_rate_hz, kp_nms_per_rad, ki_nm_per_rad : float
        Per-side PI speed loop.
    stall_torque_nm, no_load_speed_radps : float
        Torque-speed line of one side's motor at the wheel.
    latency_s, latency_jitter_s : float
        Command transport latency and its jitter (std), s.
    odom_rate_hz : float
        Odometry rate, Hz.
    gyro_noise_radps, gyro_bias_radps, v_noise_mps : float
        Measurement noise (std) and gyro bias.
    physics_dt_s : float
        Integration step, s.
    """

    mass_kg: float
    yaw_inertia_kgm2: float
    wheel_radius_m: float
    track_m: float
    wheelbase_m: float
    side_inertia_kgm2: float
    mu: float
    slip_long_mps: float
    slip_lat_mps: float
    rolling_resistance: float
    separation_multiplier: float
    max_v_mps: float
    max_w_radps: float
    accel_v_mps2: float
    accel_w_radps2: float
    side_speed_max_radps: float
    cmd_timeout_s: float
    control_rate_hz: float
    kp_nms_per_rad: float
    ki_nm_per_rad: float
    stall_torque_nm: float
    no_load_speed_radps: float
    latency_s: float
    latency_jitter_s: float
    odom_rate_hz: float
    gyro_noise_radps: float
    gyro_bias_radps: float
    v_noise_mps: float
    physics_dt_s: float = 0.00025

    def __post_init__(self) -> None:
        bad = negative_field(self)
        if bad is not None:
            raise Sim2RealValueError(
                f"SkidPlantParams.{bad[0]} must be a number >= 0, got {bad[1]!r}"
            )

    def replace(self, **changes: Any) -> SkidPlantParams:
        """A copy with ``changes`` applied (validated again)."""
        return dataclasses.replace(self, **changes)


def husky_like() -> SkidPlantParams:
    """A Clearpath Husky A200-like base.

    Published: track 0.555 m (the A200 user manual's "effective track" of its kinematics),
    wheel radius 0.165 m, mass ~50 kg, top speed 1.0 m/s; the ROS driver's limits
    (``husky_control/config/control.yaml``: 1.0 m/s, 2.0 rad/s, 3.0 m/s^2, 6.0 rad/s^2,
    ``cmd_vel_timeout`` 0.25 s) and its ``wheel_separation_multiplier`` of 1.875. The speed
    loops: the A200 user manual (Clearpath 2011, p. 9, "Control modes") says speed control
    "activates a PID feedback control loop" on the left and right wheel speeds, and the ROS
    driver (``husky_base``: ``horizon_legacy`` ``SetDifferentialSpeed``, per-side speeds in
    m/s) leaves the loop to the firmware, whose ``SetDifferentialControl`` message carries
    per side a P, I and D gain, a feed-forward, a stiction compensation and an integral limit.
    The gains are not published; assumed here: a PI loop with ``kp_nms_per_rad`` 20 (loop
    time constant ~0.05 s with the side's inertia and half the mass) and ``ki_nm_per_rad`` 50
    (integral time kp/ki = 0.4 s; a 0.5 m/s step overshoots ~7 %), no D term, the
    feed-forward and stiction terms left out (with the integral term they change transients
    only). Assumed as well: wheelbase 0.512 m, a box's yaw inertia, asphalt-like friction
    (mu 0.8), tyre stiffness and a motor line of a base that reaches its top speed in ~0.3 s.
    """
    m, length, width = 50.0, 0.99, 0.67
    return SkidPlantParams(
        mass_kg=m,
        yaw_inertia_kgm2=m * (length**2 + width**2) / 12.0,
        wheel_radius_m=0.165,
        track_m=0.555,
        wheelbase_m=0.512,
        side_inertia_kgm2=0.4,
        mu=0.8,
        slip_long_mps=0.05,
        slip_lat_mps=0.08,
        rolling_resistance=0.03,
        separation_multiplier=1.875,
        max_v_mps=1.0,
        max_w_radps=2.0,
        accel_v_mps2=3.0,
        accel_w_radps2=6.0,
        side_speed_max_radps=1.0 / 0.165,
        cmd_timeout_s=0.25,
        control_rate_hz=50.0,
        kp_nms_per_rad=20.0,
        ki_nm_per_rad=50.0,
        stall_torque_nm=80.0,
        no_load_speed_radps=9.0,
        latency_s=0.05,
        latency_jitter_s=0.005,
        odom_rate_hz=50.0,
        gyro_noise_radps=0.01,
        gyro_bias_radps=0.003,
        v_noise_mps=0.005,
    )


#: Published effective-track ratios of four-wheel skid steers on hard ground: Clearpath's
#: drivers ship ``wheel_separation_multiplier`` 1.5 for the Jackal and 1.875 for the Husky
#: (``jackal_control`` / ``husky_control`` ``config/control.yaml``, checked in the stored
#: copies of jackal/jackal and husky/husky), calibrated on their own bases. Mandow et al. 2007
#: (Pioneer 3-AT, IROS), Pentzer et al. 2014 (JFR) and Wang et al. 2015 (Sensors 15:9681, P3-AT)
#: fit ICR-based kinematics with effective tracks above the geometric one; their tables were
#: not at hand to narrow this range. :func:`skid_robot` draws from it.
CHI_RANGE = (1.5, 1.9)
#: Tyre-ground friction of rubber on dry concrete or asphalt (assumed range).
MU_RANGE = (0.6, 0.95)


def _slip_lat_for(params: SkidPlantParams, chi: float) -> float:
    """The lateral tyre stiffness (``slip_lat_mps``) whose steady in-place turn has ratio
    ``chi`` (bisection in log slip speed; the ratio falls as the lateral slip speed grows)."""
    lo, hi = math.log(0.02), math.log(0.3)
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        if effective_track_factor(params.replace(slip_lat_mps=math.exp(mid)), 0.0, 1.0) > chi:
            lo = mid
        else:
            hi = mid
    return math.exp(0.5 * (lo + hi))


def skid_robot(seed: int) -> SkidPlantParams:
    """A Husky-like base on one ground, drawn for ``seed``: its slip and friction.

    From ``default_rng([seed, 12])``: the steady effective-track ratio uniform in
    :data:`CHI_RANGE` (set through the lateral tyre stiffness, :func:`_slip_lat_for`) and the
    friction coefficient uniform in :data:`MU_RANGE`. Everything else is :func:`husky_like`,
    the driver's multiplier included (calibrated once by the maker, so it matches this
    robot's slip only on average).

    Examples
    --------
    >>> p = skid_robot(3)
    >>> 1.5 <= round(effective_track_factor(p, 0.0, 1.0), 2) <= 1.9 and 0.6 <= p.mu <= 0.95
    True
    """
    rng = np.random.default_rng([seed, 12])
    chi = float(rng.uniform(*CHI_RANGE))
    mu = float(rng.uniform(*MU_RANGE))
    base = husky_like().replace(mu=mu)
    return base.replace(slip_lat_mps=_slip_lat_for(base, chi))


_P_FIELDS = (
    "mass_kg",
    "yaw_inertia_kgm2",
    "wheel_radius_m",
    "track_m",
    "wheelbase_m",
    "side_inertia_kgm2",
    "mu",
    "slip_long_mps",
    "slip_lat_mps",
    "rolling_resistance",
    "separation_multiplier",
    "max_v_mps",
    "max_w_radps",
    "accel_v_mps2",
    "accel_w_radps2",
    "side_speed_max_radps",
    "cmd_timeout_s",
    "kp_nms_per_rad",
    "ki_nm_per_rad",
    "stall_torque_nm",
    "no_load_speed_radps",
)


@numba.njit(cache=True)
def _tyre(sx: float, sy: float, limit: float, ex: float, ey: float) -> tuple[float, float]:
    """Ground force on a wheel (friction ellipse, regularised Coulomb) for slip (sx, sy)."""
    qx, qy = sx / ex, sy / ey
    k = limit / math.sqrt(1.0 + qx * qx + qy * qy)
    return -k * qx, -k * qy


@numba.njit(cache=True)
def _simulate(
    p: FloatArray,
    arr_t: FloatArray,
    arr_v: FloatArray,
    arr_w: FloatArray,
    out_t: FloatArray,
    dt: float,
    ctrl_dt: float,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    """Integrate; writes (v, lateral v, w, left wheel speed, right wheel speed) at ``out_t``."""
    m, inertia, r, track, base, jside = p[0], p[1], p[2], p[3], p[4], p[5]
    mu, ex, ey, crr, mult = p[6], p[7], p[8], p[9], p[10]
    limits = p[11:17]  # max v, max w, accel v, accel w, wheel speed cap, timeout
    kp, ki, stall, noload = p[17], p[18], p[19], p[20]
    half_b, half_a = 0.5 * track, 0.5 * base
    limit = mu * m * _G / 4.0
    roll = crr * m * _G / 4.0
    vx, vy, w = 0.0, 0.0, 0.0
    spin = np.zeros(2)  # left, right
    integ = np.zeros(2)
    torque = np.zeros(2)
    ref_v, ref_w = 0.0, 0.0
    j = -1
    t = 0.0
    next_ctrl = 0.0
    k_out = 0
    n_out = out_t.size
    while k_out < n_out:
        if t >= next_ctrl - 1e-12:
            next_ctrl += ctrl_dt
            j, ref_v, ref_w, tgt_l, tgt_r = firmware_tick(
                t, j, ref_v, ref_w, arr_t, arr_v, arr_w, limits, ctrl_dt, mult * half_b, r
            )
            for i in range(2):
                tgt = tgt_l if i == 0 else tgt_r
                if tgt == 0.0:  # a stop clears the integrator (no creep at rest)
                    integ[i] = 0.0
                err = tgt - spin[i]
                hi = stall * (1.0 - spin[i] / noload)
                lo = -stall * (1.0 + spin[i] / noload)
                u = kp * err + integ[i] + ki * ctrl_dt * err
                if u > hi:
                    u = hi
                elif u < lo:
                    u = lo
                else:
                    integ[i] += ki * ctrl_dt * err
                torque[i] = u
        fx_sum, fy_sum, mz = 0.0, 0.0, 0.0
        side_force = np.zeros(2)
        for c in range(4):
            side = 0 if c < 2 else 1  # 0, 1: left front/rear; 2, 3: right
            y = half_b if side == 0 else -half_b  # ROS body frame: y points left
            x = half_a if c % 2 == 0 else -half_a
            vcx = vx - w * y
            vcy = vy + w * x
            fx, fy = _tyre(vcx - r * spin[side], vcy, limit, ex, ey)
            fx_sum += fx
            fy_sum += fy
            mz += x * fy - y * fx
            side_force[side] += fx
        for i in range(2):
            resist = roll * 2.0 * r * math.tanh(spin[i] / 0.05)
            spin[i] += dt * (torque[i] - r * side_force[i] - resist) / jside
        ax = fx_sum / m + w * vy
        ay = fy_sum / m - w * vx
        vx += dt * ax
        vy += dt * ay
        w += dt * mz / inertia
        t_new = t + dt
        while k_out < n_out and out_t[k_out] <= t_new:
            out[k_out, 0] = vx
            out[k_out, 1] = vy
            out[k_out, 2] = w
            out[k_out, 3] = spin[0]
            out[k_out, 4] = spin[1]
            k_out += 1
        t = t_new


def _states(
    params: SkidPlantParams,
    arrival: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    ticks: FloatArray,
) -> FloatArray:
    """(v, lateral v, w, left and right wheel speed) at ``ticks`` (numba kernel)."""
    out = np.zeros((ticks.size, 5))
    packed = np.array([float(getattr(params, f)) for f in _P_FIELDS])
    dt, ctrl_dt = params.physics_dt_s, 1.0 / params.control_rate_hz
    _simulate(packed, arrival, cmd_v, cmd_w, ticks, dt, ctrl_dt, out)
    return out


def plant_odometry(spec: RobotSpec) -> RobotSpec:
    """``spec`` with the plant's odometry sources: v from the wheel encoders, w from the gyro.

    ``robots new`` writes wheel-encoder yaw rates, which read the wheels' speeds, not the
    body's rate (:func:`robots.measurement.yaw_reading_factor`); the plant's gyro reads the
    body's.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> spec = load_spec("turtlebot3_burger")
    >>> encoders = dataclasses.replace(spec.odometry, w_source="wheels")
    >>> plant_odometry(dataclasses.replace(spec, odometry=encoders)).odometry.w_source
    'imu'
    """
    odometry = dataclasses.replace(spec.odometry, v_source="wheels", w_source="imu")
    return dataclasses.replace(spec, odometry=odometry)


def effective_track_factor(
    params: SkidPlantParams, v_mps: float, w_radps: float, *, settle_s: float = 4.0
) -> float:
    r"""The plant's slip in a steady turn: :math:`r(\omega_r - \omega_l) / (B\,\omega)`.

    The ratio of the effective track (the one the wheel speeds imply for the body's yaw rate)
    to the geometric one, after ``settle_s`` seconds of the command (v, w): what the drive
    model's ``track_factor`` stands for (Mandow et al. 2007).

    Examples
    --------
    >>> round(effective_track_factor(husky_like(), 0.0, 1.0), 1)
    1.5
    """
    t = np.arange(0.0, settle_s, 0.05)
    steady = params.replace(cmd_timeout_s=2.0 * settle_s)
    last = _states(
        steady, t, np.full(t.size, v_mps), np.full(t.size, w_radps), np.array([settle_s])
    )
    _, _, w, left, right = last[0]
    return float(params.wheel_radius_m * (right - left) / (params.track_m * w))


def run_skid_plant(
    params: SkidPlantParams,
    cmd_t_s: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    *,
    duration_s: float,
    rng: np.random.Generator,
    name: str = "skid",
) -> Trace:
    """The recorded log (:class:`~sim2real.logs.Trace`) of the plant under the commands.

    Draws from ``rng``, in this order: the command latencies, the odometry clock's phase,
    the encoder-v noise and the gyro noise.
    """
    t, cv, cw = check_commands(cmd_t_s, cmd_v, cmd_w)
    arrival = command_arrivals(rng, t, params.latency_s, params.latency_jitter_s, floor_s=0.0)
    _, ticks = odometry_clock(rng, params.odom_rate_hz, duration_s)
    out = _states(params, arrival, cv, cw, ticks)
    r = params.wheel_radius_m
    meas_v = 0.5 * r * (out[:, 3] + out[:, 4])
    meas_v = meas_v + params.v_noise_mps * rng.standard_normal(ticks.size)
    meas_w = out[:, 2] + params.gyro_bias_radps
    meas_w = meas_w + params.gyro_noise_radps * rng.standard_normal(ticks.size)
    return Trace(
        cmd_t_ns=T0_NS + nanoseconds(t),
        cmd_v=cv,
        cmd_w=cw,
        meas_t_ns=T0_NS + nanoseconds(ticks),
        meas_v=meas_v,
        meas_w=meas_w,
        meta=TraceMeta(path=name, cmd_topic="/cmd_vel", meas_topic="/odometry/filtered"),
    )


def make_skid_sessions(
    params: SkidPlantParams,
    n_sessions: int,
    *,
    seed: int,
    duration_s: float = 90.0,
    profile: str = "mixed",
    cmd_rate_hz: float = 10.0,
    turn_share: float = 1.0,
    ground_sd: float = 0.05,
) -> list[Trace]:
    """``n_sessions`` logs of the plant, each with its own commands (``default_rng([seed, i])``)
    from :func:`sim2real.plants.diff_drive.command_profile` (yaw rates up to ``turn_share`` x the
    driver's top rate) and its own day on the ground: mu times :math:`e^{\\sigma N(0,1)}`,
    :math:`\\sigma` = ``ground_sd`` (default 5 %: the same floor on another day, an assumed
    figure; a different ground is a different ``params.mu``).

    A fit on one session predicts another on a different ground nearly as well as on the
    same: the slip is set by the tyre stiffnesses, and the yaw scrub, which grows with mu,
    only loads the wheel loops, whose integral term takes it up
    (``benchmarks/bench_skid.py`` measures a fit at one mu on sessions at other mu).
    """
    if n_sessions < 1:
        raise Sim2RealValueError(f"n_sessions must be at least 1, got {n_sessions}")
    if not (math.isfinite(ground_sd) and 0.0 <= ground_sd <= 1.0):
        raise Sim2RealValueError(f"ground_sd must be in [0, 1], got {ground_sd}")
    out = []
    for i in range(n_sessions):
        rng = np.random.default_rng([seed, i])
        session = params.replace(mu=params.mu * float(np.exp(ground_sd * rng.standard_normal())))
        t, v, w = command_profile(
            profile,
            duration_s,
            rng=rng,
            max_v_mps=params.max_v_mps,
            max_w_radps=turn_share * params.max_w_radps,
            rate_hz=cmd_rate_hz,
        )
        out.append(
            run_skid_plant(session, t, v, w, duration_s=duration_s, rng=rng, name=f"skid_{i}")
        )
    return out
