"""Synthetic velocity logs with known parameters and realistic odometry defects.

Used by the accuracy tests and the benchmark: a seeded random step command sequence (as a
teleop or planner publishes at 10 Hz) drives the reduced model with hidden parameters, and the
"odometry" is built the way real bases build it: forward speed from quantised wheel-encoder
tick differences over each odometry period, yaw rate from a noisy gyro, jittered stamps, dropped
messages and one impossible spike (like the 1.35 m/s sample of the Drexel TurtleBot3 log).

Examples
--------
>>> import numpy as np
>>> from robots.params import BaseGeometry, DriveParams
>>> geo = BaseGeometry(mass_kg=1.5, yaw_inertia_kgm2=0.015, wheel_radius_m=0.033,
...                    wheel_separation_m=0.287)
>>> t, v, w = step_commands(20.0, seed=1)
>>> log = synthetic_log(DriveParams(delay_s=0.1), geo, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=1)
>>> bool(log.meas_t_s.size > 800)
True
"""

from __future__ import annotations

import math

import numpy as np

from robots.arrays import FloatArray
from robots.params import BaseGeometry, DriveParams
from robots.reduced import DEFAULT_DT_S, simulate
from sysid._logs import LogArrays
from sysid.plan import ExcitationPlan

__all__ = [
    "WAFFLE_LIKE_BASE",
    "WAFFLE_LIKE_GEOMETRY",
    "WAFFLE_LIKE_TRUTH",
    "degrade_odometry",
    "jittered_model_log",
    "step_commands",
    "synthetic_log",
]


#: A TurtleBot3-Waffle-Pi-like base (spec mass and inertia, r = 0.033 m, L = 0.287 m).
WAFFLE_LIKE_GEOMETRY = BaseGeometry(
    mass_kg=1.55, yaw_inertia_kgm2=0.0146, wheel_radius_m=0.033, wheel_separation_m=0.287
)
#: Its "spec" drive defaults: what a fit starts from.
WAFFLE_LIKE_BASE = DriveParams(
    motor_gain_nms_per_rad=0.01, speed_lim_v_mps=0.26, speed_lim_w_radps=1.82
)
#: A hidden truth with a non-default value for every parameter the fit frees (an arm's mass
#: and inertia, friction, smoother limits, a wheel-speed cap): the accuracy tests and the
#: benchmark recover it.
WAFFLE_LIKE_TRUTH = WAFFLE_LIKE_BASE.replace(
    delay_s=0.12,
    added_mass_kg=0.6,
    added_yaw_inertia_kgm2=0.02,
    viscous_v_ns_per_m=2.0,
    viscous_w_nms_per_rad=0.05,
    coulomb_v_fwd_n=0.4,
    coulomb_v_bwd_n=0.5,
    coulomb_w_nm=0.03,
    accel_lim_v_mps2=1.0,
    accel_lim_w_radps2=6.0,
    wheel_speed_max_radps=7.0,
)


def step_commands(
    duration_s: float,
    *,
    seed: int,
    rate_hz: float = 10.0,
    v_max_mps: float = 0.22,
    w_max_radps: float = 1.5,
    hold_s: tuple[float, float] = (0.8, 2.5),
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Random piecewise-constant (v, w) commands republished at ``rate_hz``.

    Each hold draws one of: stop, straight forward/backward, in-place turn, arc; levels are
    uniform in ``[-max, max]``, so the sequence reverses, turns and runs arcs.

    Returns
    -------
    (t_s, v, w) : tuple of ndarray
    """
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, 1.0 / rate_hz)
    v = np.zeros_like(t)
    w = np.zeros_like(t)
    start = 1.0  # the robot rests for the first second
    while start < duration_s:
        end = start + rng.uniform(*hold_s)
        kind = rng.choice(["stop", "line", "turn", "arc", "arc"])
        lv = rng.uniform(-v_max_mps, v_max_mps) if kind in ("line", "arc") else 0.0
        lw = rng.uniform(-w_max_radps, w_max_radps) if kind in ("turn", "arc") else 0.0
        sel = (t >= start) & (t < end)
        v[sel], w[sel] = lv, lw
        start = end
    return t, v, w


def synthetic_log(
    params: DriveParams,
    geometry: BaseGeometry,
    *,
    cmd_t_s: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    seed: int,
    odom_rate_hz: float = 50.0,
    noise_v_mps: float = 0.004,
    noise_w_radps: float = 0.02,
    ticks_per_rev: int = 4096,
    jitter_s: float = 0.002,
    drop_fraction: float = 0.05,
    spike_mps: float | None = 1.35,
    dt_s: float = 0.001,
    name: str = "synthetic",
    arrival_jitter_s: float = 0.0,
) -> LogArrays:
    """Odometry of the reduced model driven by the commands, with realistic defects.

    Parameters
    ----------
    params, geometry : DriveParams, BaseGeometry
        The hidden truth.
    cmd_t_s, cmd_v, cmd_w : ndarray
        Commands (s, m/s, rad/s).
    seed : int
        Seed of the numpy Generator for noise, jitter, drops and the spike position.
    odom_rate_hz : float
        Nominal odometry rate, Hz.
    noise_v_mps, noise_w_radps : float
        White noise on v (on top of the encoder quantisation) and on the gyro yaw rate.
    ticks_per_rev : int
        Encoder resolution (TurtleBot3 Dynamixel: 4096).
    jitter_s : float
        Standard deviation of the stamp error, s.
    drop_fraction : float
        Share of odometry messages dropped at random.
    spike_mps : float or None
        Value of one impossible v sample in the middle of the log (None: no spike).
    dt_s : float
        Integration step of the truth simulation, s.
    name : str
        The log's name.
    arrival_jitter_s : float
        Standard deviation of each command's arrival time about its logged time, s: the truth
        acts on every command after its own normal draw (order kept, from a generator of its
        own, ``numpy.random.default_rng([seed, 1])``), the log keeps the logged times (a
        transport whose latency varies from message to message; 0: none).
    """
    rng = np.random.default_rng(seed)
    arrive_s = np.asarray(cmd_t_s, dtype=np.float64)
    if arrival_jitter_s > 0:
        late = arrival_jitter_s * np.random.default_rng([seed, 1]).standard_normal(arrive_s.size)
        arrive_s = np.maximum.accumulate(arrive_s + late)
    duration = float(cmd_t_s[-1]) + 1.0
    t_true = np.arange(0.0, duration, 1.0 / odom_rate_hz)
    t_true = t_true + rng.uniform(0.0, 0.5 / odom_rate_hz, t_true.size)  # sample instants
    t_true.sort()
    fine = np.arange(0.0, duration + 0.1, dt_s)
    truth = simulate(
        params, geometry, cmd_t_s=arrive_s, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=fine, dt_s=dt_s
    )
    r, half = geometry.wheel_radius_m, 0.5 * geometry.wheel_separation_m
    ang_r = np.concatenate(([0.0], np.cumsum((truth.v[:-1] + truth.w[:-1] * half) / r * dt_s)))
    ang_l = np.concatenate(([0.0], np.cumsum((truth.v[:-1] - truth.w[:-1] * half) / r * dt_s)))
    tick = 2.0 * math.pi / ticks_per_rev
    ticks_r = np.floor(np.interp(t_true, fine, ang_r) / tick)
    ticks_l = np.floor(np.interp(t_true, fine, ang_l) / tick)
    period = np.diff(t_true, prepend=t_true[0] - 1.0 / odom_rate_hz)
    dist = (
        0.5
        * r
        * tick
        * (np.diff(ticks_r, prepend=ticks_r[0]) + np.diff(ticks_l, prepend=ticks_l[0]))
    )
    stamps, meas_v, meas_w = degrade_odometry(
        t_true,
        dist / period,
        np.interp(t_true, fine, truth.w),
        seed=rng,  # v is already quantised by the encoder ticks
        noise_v_mps=noise_v_mps,
        noise_w_radps=noise_w_radps,
        jitter_s=jitter_s,
        drop_fraction=drop_fraction,
        spike_mps=spike_mps,
    )
    return LogArrays(
        cmd_t_s=np.asarray(cmd_t_s, dtype=np.float64),
        cmd_v=np.asarray(cmd_v, dtype=np.float64),
        cmd_w=np.asarray(cmd_w, dtype=np.float64),
        meas_t_s=stamps,
        meas_v=meas_v,
        meas_w=meas_w,
        name=name,
    )


def degrade_odometry(
    t_s: FloatArray,
    v: FloatArray,
    w: FloatArray,
    *,
    seed: int | np.random.Generator,
    quantum_v_mps: float = 0.0,
    noise_v_mps: float = 0.004,
    noise_w_radps: float = 0.02,
    jitter_s: float = 0.002,
    drop_fraction: float = 0.05,
    spike_mps: float | None = 1.35,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Make clean velocity samples look like real odometry (e.g. from the pybullet robot).

    v is rounded to ``quantum_v_mps`` (one encoder tick per odometry period) and both channels
    get white noise; stamps get Gaussian jitter; ``drop_fraction`` of the messages are dropped;
    one sample in the middle becomes a ``spike_mps`` glitch. Returns sorted (t, v, w). The
    draws come from ``numpy.random.default_rng(seed)`` (a Generator is drawn from as it is).

    Examples
    --------
    >>> import numpy as np
    >>> t, v, w = degrade_odometry(np.arange(100) * 0.02, np.zeros(100), np.zeros(100), seed=0)
    >>> bool(t.size < 100 and v.max() == 1.35)
    True
    """
    rng = np.random.default_rng(seed)
    n = t_s.size
    v = np.asarray(v, dtype=np.float64).copy()
    if quantum_v_mps > 0:
        v = np.round(v / quantum_v_mps) * quantum_v_mps
    v = v + rng.normal(0.0, noise_v_mps, n)
    w = np.asarray(w, dtype=np.float64) + rng.normal(0.0, noise_w_radps, n)
    stamps = np.asarray(t_s, dtype=np.float64) + rng.normal(0.0, jitter_s, n)
    keep = rng.random(n) >= drop_fraction
    keep[:3] = True
    if spike_mps is not None:
        v[n // 2] = spike_mps
        keep[n // 2] = True
    order = np.argsort(stamps[keep], kind="stable")
    return stamps[keep][order], v[keep][order], w[keep][order]


def jittered_model_log(
    params: DriveParams,
    geometry: BaseGeometry,
    plan: ExcitationPlan,
    *,
    seed: int,
    arrival_jitter_s: float,
    noise: tuple[float, float] = (0.004, 0.02),
    dt_s: float = DEFAULT_DT_S,
) -> LogArrays:
    """The reduced model's own response to ``plan`` with no defect but white noise and late
    commands.

    Each command reaches the model ``arrival_jitter_s`` times a normal draw late (order kept);
    the log keeps the published times. v and w are read at 30 Hz over the plan's duration with
    white noise of sd ``noise`` (m/s, rad/s). The draws come from
    ``numpy.random.default_rng(seed)``: the arrivals, then the v noise, then the w noise. A
    known truth for the fit's arrival-time treatment (:mod:`sysid._timing`); ``dt_s`` is the
    truth's integration step, s.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> from sysid.plan import plan_excitation
    >>> spec = load_spec("turtlebot3_burger")
    >>> plan = plan_excitation(spec, 30.0)
    >>> log = jittered_model_log(spec.drive, spec.geometry, plan, seed=0, arrival_jitter_s=0.01)
    >>> log.meas_t_s.size, bool(log.cmd_t_s is plan.t_s)
    (900, True)
    """
    rng = np.random.default_rng(seed)
    late = arrival_jitter_s * rng.standard_normal(plan.t_s.size)
    t = np.arange(0.0, plan.duration_s, 1.0 / 30.0)
    out = simulate(
        params,
        geometry,
        cmd_t_s=np.maximum.accumulate(plan.t_s + late),
        cmd_v=plan.v_mps,
        cmd_w=plan.w_radps,
        t_out_s=t,
        dt_s=dt_s,
    )
    meas_v = out.v + noise[0] * rng.standard_normal(t.size)
    meas_w = out.w + noise[1] * rng.standard_normal(t.size)
    return LogArrays(
        cmd_t_s=plan.t_s, cmd_v=plan.v_mps, cmd_w=plan.w_radps, meas_t_s=t, meas_v=meas_v,
        meas_w=meas_w,
    )  # fmt: skip
