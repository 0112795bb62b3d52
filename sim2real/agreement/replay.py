r"""Replay a real log in simulation: the logged commands, at their logged times, drive a model.

The commanded velocities of a log are fed, at their real times, into the pybullet robot
(``engine="pybullet"``, the default), the reduced drive model (``engine="reduced"``) or the
exported MuJoCo robot (``engine="mujoco"``, the ``[mujoco]`` extra), with
the spec's default drive parameters or a sysid result, and the simulated base velocity is
recorded at every real measurement time. The engines run the body's yaw rate; a log whose
yaw rate comes from the wheel encoders (the spec's ``odometry.w_source: wheels``) reads it
times the effective over the driver's track (:func:`robots.measurement.yaw_reading_factor`),
as ``sysid fit`` does.

Timing
------
The simulation starts at the first measurement time :math:`t_0` in the measured state
(:math:`v(t_0), \omega(t_0)` = first odometry sample). Commands are a zero-order hold: each
holds until the next one or until ``cmd_timeout_s`` after it (then 0, as the base firmware
does). What was commanded before the log began is unknown; when no logged command covers
:math:`t_0 - \text{delay}`, the replay assumes the measured state was being commanded (a
synthetic command :math:`(v(t_0), \omega(t_0))` at :math:`t_0 - \text{delay}`), so a log that
starts in motion does not begin with a spurious stop.

- ``pybullet``: :meth:`robots.pybullet_robot.PybulletRobot.replay` steps the rigid-body robot
  on its physics grid (240 Hz by default) from :math:`t_0`; each physics step gets the delayed,
  zero-order-hold command averaged over the step (with the command timeout), from the whole
  command history, so commands sent before :math:`t_0` act through the delay; the base
  velocity is interpolated linearly at each measurement time.
- ``reduced``: :func:`robots.reduced.simulate` over the whole command history, the same way.
- ``mujoco``: :meth:`sim2real.mujoco.MujocoRobot.replay`, the same way on the MuJoCo model's
  240 Hz grid; the robot is compiled once per spec, and each parameter set (an ensemble
  member) is written into its ``MjModel`` in place.
- ``mujoco-lifted``: the same MuJoCo robot with its wheels off the ground, for a recording
  made on a stand (``MujocoRobot(..., lifted=True)``: the base held, (v, w) from the wheels
  on the effective track, as the reduced engine reads such a log).

Segments
--------
A log whose odometry pauses (a gap longer than ``max(2 s, 20 sampling steps)``, see
:meth:`sim2real.logs.Trace.segments`) is replayed segment by segment, each from its own first
measurement as above, and the results are joined in time order: no simulation runs across a
gap, so memory and time follow the number of messages, not the time span.

Examples
--------
>>> from sim2real.logs import read_trace  # doctest: +SKIP
>>> trace = read_trace("data/demo_validate.mcap")  # doctest: +SKIP
>>> sim = replay(trace, robot="turtlebot3_burger", engine="reduced")  # doctest: +SKIP
>>> sim.v.shape == trace.meas_v.shape  # doctest: +SKIP
True
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from robots.measurement import yaw_reading_factor
from robots.params import BaseGeometry, DriveParams
from robots.reduced import DEFAULT_DT_S, simulate
from robots.spec import OdometrySpec, load_spec
from sim2real._arrays import FloatArray, IntArray
from sim2real.errors import Sim2RealValueError
from sim2real.mujoco import Commands, MujocoRobot
from sysid.odometry import window_mean

__all__ = [
    "ENGINES",
    "ReplayEngine",
    "ReplayResult",
    "RobotSpecLike",
    "TraceLike",
    "replay",
    "resolve_robot",
]


#: Simulation engines :func:`replay` accepts.
ENGINES = ("pybullet", "reduced", "mujoco", "mujoco-lifted")

#: Default physics rate of the pybullet engine, Hz.
DEFAULT_PHYSICS_HZ = 240.0


class TraceLike(Protocol):
    """What replay and agreement need from a log (:class:`sim2real.logs.Trace` has it)."""

    @property
    def cmd_t_ns(self) -> IntArray: ...
    @property
    def meas_t_ns(self) -> IntArray: ...
    @property
    def cmd_t_s(self) -> FloatArray: ...
    @property
    def meas_t_s(self) -> FloatArray: ...
    @property
    def cmd_v(self) -> FloatArray: ...
    @property
    def cmd_w(self) -> FloatArray: ...
    @property
    def meas_v(self) -> FloatArray: ...
    @property
    def meas_w(self) -> FloatArray: ...
    def cmd_at_meas(self) -> tuple[FloatArray, FloatArray]: ...


@runtime_checkable
class ReplayEngine(Protocol):
    """A simulator :func:`replay` drives besides its named engines (e.g. a model fitted by
    another toolbox): logged commands in, base velocity at the requested times out.

    :meth:`replay` has the contract of :meth:`sim2real.mujoco.MujocoRobot.replay`: commands
    ``cmd`` = (stamps s, v m/s, w rad/s), the run starting at ``t_out_s[0]`` with the base
    moving at ``start`` = (v, w); returns (v, w) at ``t_out_s``.
    """

    @property
    def name(self) -> str: ...
    def replay(
        self, cmd: Commands, t_out_s: FloatArray, start: tuple[float, float]
    ) -> tuple[FloatArray, FloatArray]: ...


@runtime_checkable
class RobotSpecLike(Protocol):
    """What replay needs from a robot spec (:class:`robots.RobotSpec` has it)."""

    @property
    def name(self) -> str: ...
    @property
    def geometry(self) -> BaseGeometry: ...
    @property
    def drive(self) -> DriveParams: ...
    @property
    def odometry(self) -> OdometrySpec: ...


@dataclass(frozen=True, kw_only=True)
class ReplayResult:
    """Simulated base velocity at the real measurement times of a log.

    Attributes
    ----------
    t_s : ndarray
        Measurement times, s since the log's ``t0``.
    t_ns : ndarray of int64
        The same times as absolute nanosecond stamps (the log's odometry stamps).
    v, w : ndarray
        Simulated forward velocity (m/s) and yaw rate (rad/s) at ``t_s``.
    engine : str
        ``"pybullet"``, ``"reduced"``, ``"mujoco"``, ``"mujoco-lifted"`` or a
        :class:`ReplayEngine`'s name.
    robot : str
        Robot (spec) name.
    params : DriveParams
        Drive parameters used.
    physics_hz : float
        Physics rate of the pybullet engine (the reduced engine's integration rate otherwise).
    elapsed_s : float
        Wall-clock time the replay took, s.
    odom_v_window_s : float
        Odometry window of ``v``, s (0 = instantaneous; see :func:`replay`).
    measurement : str
        The log's measurement operator applied to ``v`` and ``w`` (``"pose"``, ``"hold"``;
        "" for none; see :mod:`robots.measurement`).
    """

    t_s: FloatArray
    t_ns: IntArray
    v: FloatArray
    w: FloatArray
    engine: str
    robot: str
    params: DriveParams
    physics_hz: float
    elapsed_s: float
    odom_v_window_s: float = 0.0
    measurement: str = ""

    @property
    def duration_s(self) -> float:
        """Simulated span (first to last measurement), s."""
        return float(self.t_s[-1] - self.t_s[0]) if self.t_s.size else 0.0


def resolve_robot(robot: str | RobotSpecLike) -> RobotSpecLike:
    """A robot spec from a name (via :func:`robots.load_spec`) or a spec object as given."""
    if isinstance(robot, str):
        spec: RobotSpecLike = load_spec(robot)
        return spec
    if isinstance(robot, RobotSpecLike):
        return robot
    raise Sim2RealValueError(
        f"robot must be a robot name or a RobotSpec, got {type(robot).__name__}; "
        "pass e.g. robot='turtlebot3_burger'"
    )


def _check_trace(trace: TraceLike) -> tuple[FloatArray, ...]:
    cmd_t = np.asarray(trace.cmd_t_s, dtype=np.float64)
    meas_t = np.asarray(trace.meas_t_s, dtype=np.float64)
    where = getattr(getattr(trace, "meta", None), "path", None) or "the log"
    if cmd_t.size == 0:
        raise Sim2RealValueError(
            f"{where} has no velocity commands, so there is nothing to replay; record the "
            "command topic (geometry_msgs/msg/Twist) or choose it with --cmd-topic"
        )
    if meas_t.size == 0:
        raise Sim2RealValueError(
            f"{where} has no velocity measurements, so there is nothing to compare; record "
            "the odometry topic (nav_msgs/msg/Odometry) or choose it with --odom-topic"
        )
    arrays = (
        cmd_t,
        np.asarray(trace.cmd_v, dtype=np.float64),
        np.asarray(trace.cmd_w, dtype=np.float64),
        meas_t,
        np.asarray(trace.meas_v, dtype=np.float64),
        np.asarray(trace.meas_w, dtype=np.float64),
    )
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise Sim2RealValueError(f"{where} holds NaN or inf values; clean the log first")
    return arrays


def replay(
    trace: TraceLike,
    *,
    robot: str | RobotSpecLike,
    params: DriveParams | None = None,
    engine: str | ReplayEngine = "pybullet",
    physics_hz: float = DEFAULT_PHYSICS_HZ,
    odom_v_window_s: float = 0.0,
) -> ReplayResult:
    """Replay the commands of ``trace`` on a simulated robot (see the module docstring).

    Parameters
    ----------
    trace : Trace
        A log read by :func:`sim2real.logs.read_trace`.
    robot : str or RobotSpec
        Robot name (``sim2real robots list``) or a loaded spec.
    params : DriveParams, optional
        Drive parameters; the spec defaults when omitted.
    engine : {"pybullet", "reduced", "mujoco", "mujoco-lifted"} or ReplayEngine
        The pybullet rigid-body robot, the reduced drive model, the exported MuJoCo robot
        (on the ground, or held up for a log recorded with the wheels lifted), or
        another simulator (:class:`ReplayEngine`; ``params`` then gives only the command delay
        and timeout that the start command and the log's screening use).
    physics_hz : float
        Physics rate of the pybullet engine, Hz.
    odom_v_window_s : float
        Odometry sensor model of v (see "Odometry v window" in the module docstring): report
        the simulated v as the mean over the preceding window of this length, s, in [0, 1];
        e.g. ``1 / spec.odometry.rate_hz`` for encoder odometry. 0 (default) reports the
        instantaneous base velocity. A trace with a measurement operator
        (``trace.measurement``: a pose derivative, a zero-order hold) is read through that
        operator instead, in v and w (:mod:`robots.measurement`), as ``sysid fit`` reads it.

    Returns
    -------
    ReplayResult
        Simulated ``v`` (m/s) and ``w`` (rad/s) at every measurement time of ``trace``.

    Examples
    --------
    >>> sim = replay(trace, robot="turtlebot3_burger", engine="reduced")  # doctest: +SKIP
    >>> sim_odom = replay(trace, robot="turtlebot3_burger", engine="reduced",
    ...                   odom_v_window_s=1 / 30)  # doctest: +SKIP
    """
    _check_replay_args(engine, physics_hz, odom_v_window_s)
    spec = resolve_robot(robot)
    p = spec.drive if params is None else params
    segments = trace.segments() if hasattr(trace, "segments") else (trace,)
    if len(segments) > 1:
        return _replay_segments(trace, segments, spec, p, engine, physics_hz, odom_v_window_s)
    cmd_t, cmd_v, cmd_w, meas_t, meas_v, meas_w = _check_trace(trace)
    cmd_t, cmd_v, cmd_w = _with_start_command(
        cmd_t, cmd_v, cmd_w, float(meas_t[0]) - p.delay_s, float(meas_v[0]), float(meas_w[0])
    )
    start = time.perf_counter()
    rate = float(physics_hz)
    if not isinstance(engine, str) or engine in ("reduced", "mujoco", "mujoco-lifted"):
        rate = 1.0 / DEFAULT_DT_S
    model = getattr(trace, "measurement", None)
    op = None if model is None else model.operator(meas_t)
    # with a window, also read the simulation at every integration step so the window mean
    # of its piecewise-linear output is exact (the run itself does not change)
    t_out = meas_t
    if op is not None:
        t_out = op.t_query
    elif odom_v_window_s > 0:
        t_out = _fine_times(meas_t, 1.0 / rate)
    # the engines run the body's yaw rate; the log reads it through its odometry's sensor
    w_factor = yaw_reading_factor(spec.odometry.w_source, p)
    initial = (float(meas_v[0]), float(meas_w[0]) / w_factor)
    if not isinstance(engine, str):
        v, w = engine.replay((cmd_t, cmd_v, cmd_w), t_out, initial)
    elif engine == "reduced":
        v, w = _replay_reduced(spec, p, cmd_t, cmd_v, cmd_w, t_out, initial)
    elif engine in ("mujoco", "mujoco-lifted"):
        lifted = engine == "mujoco-lifted"
        v, w = _replay_mujoco(spec, p, (cmd_t, cmd_v, cmd_w), t_out, initial, lifted=lifted)
    else:
        v, w = _replay_pybullet(spec, p, cmd_t, cmd_v, cmd_w, t_out, initial, physics_hz)
    w = w * w_factor
    if op is not None:  # the log's own measurement operator, in v and w
        v, w = op.apply(v), op.apply(w)
    elif odom_v_window_s > 0:
        # before the first measurement the base is taken to run at the measured start state
        # (window_mean holds the first value), as the start command assumes
        v = window_mean(t_out, v, meas_t, odom_v_window_s)
        w = np.interp(meas_t, t_out, w)
    return ReplayResult(
        t_s=meas_t,
        t_ns=np.asarray(trace.meas_t_ns, dtype=np.int64),
        v=np.asarray(v, dtype=np.float64),
        w=np.asarray(w, dtype=np.float64),
        engine=engine if isinstance(engine, str) else engine.name,
        robot=spec.name,
        params=p,
        physics_hz=rate,
        elapsed_s=time.perf_counter() - start,
        odom_v_window_s=0.0 if op is not None else float(odom_v_window_s),
        measurement="" if model is None else model.kind,
    )


def _check_replay_args(
    engine: str | ReplayEngine, physics_hz: float, odom_v_window_s: float
) -> None:
    known = engine in ENGINES if isinstance(engine, str) else isinstance(engine, ReplayEngine)
    if not known:
        raise Sim2RealValueError(
            f"engine must be one of {list(ENGINES)}, got {engine!r}; e.g. --engine reduced"
        )
    if not (math.isfinite(physics_hz) and physics_hz > 0):
        raise Sim2RealValueError(f"physics_hz must be a finite number > 0, got {physics_hz!r}")
    _check_window(odom_v_window_s)


def _replay_reduced(
    spec: RobotSpecLike,
    p: DriveParams,
    cmd_t: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    t_out: FloatArray,
    initial: tuple[float, float],
) -> tuple[FloatArray, FloatArray]:
    """(v, w) at ``t_out`` of the reduced drive model from the start state ``initial``."""
    resp = simulate(
        p,
        spec.geometry,
        cmd_t_s=cmd_t,
        cmd_v=cmd_v,
        cmd_w=cmd_w,
        t_out_s=t_out,
        v0=initial[0],
        w0=initial[1],
        python=None,  # a short one-off replay runs without loading numba
    )
    return np.asarray(resp.v, dtype=np.float64), np.asarray(resp.w, dtype=np.float64)


def _replay_segments(
    trace: TraceLike,
    segments: tuple[TraceLike, ...],
    spec: RobotSpecLike,
    params: DriveParams,
    engine: str | ReplayEngine,
    physics_hz: float,
    odom_v_window_s: float,
) -> ReplayResult:
    """Replay each segment on its own and join the results (times of the whole trace)."""
    start = time.perf_counter()
    parts = [
        replay(
            seg,
            robot=spec,
            params=params,
            engine=engine,
            physics_hz=physics_hz,
            odom_v_window_s=odom_v_window_s,
        )
        for seg in segments
    ]
    return ReplayResult(
        t_s=np.asarray(trace.meas_t_s, dtype=np.float64),
        t_ns=np.asarray(trace.meas_t_ns, dtype=np.int64),
        v=np.concatenate([r.v for r in parts]),
        w=np.concatenate([r.w for r in parts]),
        engine=parts[0].engine,
        robot=spec.name,
        params=params,
        physics_hz=parts[0].physics_hz,
        elapsed_s=time.perf_counter() - start,
        odom_v_window_s=parts[0].odom_v_window_s,
        measurement=parts[0].measurement,
    )


def _check_window(window_s: float) -> None:
    if (
        isinstance(window_s, bool)
        or not isinstance(window_s, int | float)
        or not (math.isfinite(window_s) and 0.0 <= window_s <= 1.0)
    ):
        raise Sim2RealValueError(
            f"odom_v_window_s (--odom-v-window) must be seconds in [0, 1], got {window_s!r}; "
            "e.g. 1/30 for a 30 Hz encoder odometry, 0 for the instantaneous velocity"
        )


def _fine_times(meas_t: FloatArray, dt_s: float) -> FloatArray:
    """The measurement times merged with the engines' integration grid ``t0 + k dt``."""
    t0, t_end = float(meas_t[0]), float(meas_t[-1])
    n = max(1, math.ceil((t_end - t0) / dt_s))
    grid = t0 + dt_s * np.arange(n + 1, dtype=np.float64)
    return np.union1d(meas_t, grid[grid <= t_end])


def _with_start_command(
    cmd_t: FloatArray, cmd_v: FloatArray, cmd_w: FloatArray, t_pre: float, v0: float, w0: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Prepend the synthetic start command (v0, w0) at ``t_pre`` unless a command covers it."""
    if cmd_t[0] <= t_pre:
        return cmd_t, cmd_v, cmd_w
    return (
        np.concatenate(([t_pre], cmd_t)),
        np.concatenate(([v0], cmd_v)),
        np.concatenate(([w0], cmd_w)),
    )


#: The compiled MuJoCo robot of the last spec replayed: an ensemble's members (the same spec,
#: other parameters) edit its ``MjModel`` in place instead of compiling a model each.
_MUJOCO_ROBOT: list[Any] = []


def _replay_mujoco(
    spec: Any,
    params: DriveParams,
    cmd: Commands,
    t_out: FloatArray,
    start: tuple[float, float],
    *,
    lifted: bool = False,
) -> tuple[FloatArray, FloatArray]:
    """(v, w) at ``t_out`` of the exported MuJoCo robot (:class:`sim2real.mujoco.MujocoRobot`;
    ``lifted``: its wheels off the ground)."""
    if _MUJOCO_ROBOT and _MUJOCO_ROBOT[0].spec is spec and _MUJOCO_ROBOT[0].lifted == lifted:
        robot = _MUJOCO_ROBOT[0]
        robot.set_params(params)
    else:
        robot = MujocoRobot(spec, params, lifted=lifted)
        _MUJOCO_ROBOT[:] = [robot]
    return robot.replay(cmd, t_out, start)


def _replay_pybullet(
    spec: RobotSpecLike,
    params: DriveParams,
    cmd_t: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    meas_t: FloatArray,
    initial: tuple[float, float],
    physics_hz: float,
) -> tuple[FloatArray, FloatArray]:
    from robots.pybullet_robot import PybulletRobot  # heavy import (pybullet) only when needed

    robot = PybulletRobot(spec, params=params, physics_hz=physics_hz)  # type: ignore[arg-type]
    try:
        out = robot.replay(
            cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=meas_t, v0=initial[0], w0=initial[1]
        )
    finally:
        robot.close()
    return np.asarray(out.v, dtype=np.float64), np.asarray(out.w, dtype=np.float64)
