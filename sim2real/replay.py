r"""Replay a real log in simulation: the logged commands, at their logged times, drive a model.

The commanded velocities of a log are fed, at their real times, into the pybullet robot
(``engine="pybullet"``, the default) or the reduced drive model (``engine="reduced"``), with
the spec's default drive parameters or a sysid result, and the simulated base velocity is
recorded at every real measurement time.

Timing
------
The simulation starts at the first measurement time :math:`t_0` in the measured state
(:math:`v(t_0), \omega(t_0)` = first odometry sample). Commands are a zero-order hold: each
holds until the next one or until ``cmd_timeout_s`` after it (then 0, as the base firmware
does). What was commanded before the log began is unknown; when no logged command covers
:math:`t_0 - \text{delay}`, the replay assumes the measured state was being commanded (a
synthetic command :math:`(v(t_0), \omega(t_0))` at :math:`t_0 - \text{delay}`), so a log that
starts in motion does not begin with a spurious stop.

- ``pybullet``: the robot is stepped between consecutive *events* (command times, timeout
  times and measurement times merged), each time with the command held at the start of the
  interval, for a whole number of physics steps (240 Hz by default). Step counts come from the
  event times rounded to the physics grid, so time never drifts (error <= half a physics step).
  The transport delay is the robot's own (``DriveParams.delay_s``); the robot's delay line
  and velocity smoother are preloaded with the synthetic start command.
- ``reduced``: :func:`robots.reduced.simulate` over the whole command history.

Example
-------
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
from numpy.typing import NDArray

from robots.params import BaseGeometry, DriveParams
from sim2real.errors import Sim2RealValueError

__all__ = [
    "ENGINES",
    "ReplayResult",
    "RobotSpecLike",
    "TraceLike",
    "replay",
    "resolve_robot",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Simulation engines :func:`replay` accepts.
ENGINES = ("pybullet", "reduced")

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
class RobotSpecLike(Protocol):
    """What replay needs from a robot spec (:class:`robots.RobotSpec` has it)."""

    @property
    def name(self) -> str: ...
    @property
    def geometry(self) -> BaseGeometry: ...
    @property
    def drive(self) -> DriveParams: ...


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
        ``"pybullet"`` or ``"reduced"``.
    robot : str
        Robot (spec) name.
    params : DriveParams
        Drive parameters used.
    physics_hz : float
        Physics rate of the pybullet engine (the reduced engine's integration rate otherwise).
    elapsed_s : float
        Wall-clock time the replay took, s.
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

    @property
    def duration_s(self) -> float:
        """Simulated span (first to last measurement), s."""
        return float(self.t_s[-1] - self.t_s[0]) if self.t_s.size else 0.0


def resolve_robot(robot: str | RobotSpecLike) -> RobotSpecLike:
    """A robot spec from a name (via :func:`robots.load_spec`) or a spec object as given."""
    if isinstance(robot, str):
        from robots.spec import load_spec

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
    engine: str = "pybullet",
    physics_hz: float = DEFAULT_PHYSICS_HZ,
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
    engine : {"pybullet", "reduced"}
        The pybullet rigid-body robot or the reduced drive model.
    physics_hz : float
        Physics rate of the pybullet engine, Hz.

    Returns
    -------
    ReplayResult
        Simulated ``v`` (m/s) and ``w`` (rad/s) at every measurement time of ``trace``.

    Examples
    --------
    >>> sim = replay(trace, robot="turtlebot3_burger", engine="reduced")  # doctest: +SKIP
    """
    if engine not in ENGINES:
        raise Sim2RealValueError(
            f"engine must be one of {list(ENGINES)}, got {engine!r}; e.g. --engine reduced"
        )
    if not (math.isfinite(physics_hz) and physics_hz > 0):
        raise Sim2RealValueError(f"physics_hz must be a finite number > 0, got {physics_hz!r}")
    spec = resolve_robot(robot)
    p = spec.drive if params is None else params
    cmd_t, cmd_v, cmd_w, meas_t, meas_v, meas_w = _check_trace(trace)
    cmd_t, cmd_v, cmd_w = _with_start_command(
        cmd_t, cmd_v, cmd_w, float(meas_t[0]) - p.delay_s, float(meas_v[0]), float(meas_w[0])
    )
    start = time.perf_counter()
    if engine == "reduced":
        from robots.reduced import DEFAULT_DT_S, simulate

        resp = simulate(
            p,
            spec.geometry,
            cmd_t_s=cmd_t,
            cmd_v=cmd_v,
            cmd_w=cmd_w,
            t_out_s=meas_t,
            v0=float(meas_v[0]),
            w0=float(meas_w[0]),
        )
        v, w, rate = resp.v, resp.w, 1.0 / DEFAULT_DT_S
    else:
        v, w = _replay_pybullet(
            spec, p, cmd_t, cmd_v, cmd_w, meas_t, (float(meas_v[0]), float(meas_w[0])), physics_hz
        )
        rate = float(physics_hz)
    return ReplayResult(
        t_s=meas_t,
        t_ns=np.asarray(trace.meas_t_ns, dtype=np.int64),
        v=np.asarray(v, dtype=np.float64),
        w=np.asarray(w, dtype=np.float64),
        engine=engine,
        robot=spec.name,
        params=p,
        physics_hz=rate,
        elapsed_s=time.perf_counter() - start,
    )


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


@dataclass(frozen=True, kw_only=True)
class _EventPlan:
    """The merged event grid of a pybullet replay."""

    n_steps: IntArray  # physics steps from event i to event i+1
    cmd_v: FloatArray  # command held during interval i
    cmd_w: FloatArray
    meas_event: IntArray  # event index of each measurement


def plan_events(
    cmd_t: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    meas_t: FloatArray,
    *,
    timeout_s: float,
    physics_hz: float,
) -> _EventPlan:
    """Merge command, timeout and measurement times from ``meas_t[0]`` on into one grid."""
    t0 = float(meas_t[0])
    parts = [cmd_t, meas_t]
    if math.isfinite(timeout_s):
        ends = cmd_t + timeout_s
        nxt = np.append(cmd_t[1:], np.inf)
        parts.append(ends[ends < nxt])
    events = np.unique(np.concatenate(parts))
    events = events[(events >= t0) & (events <= meas_t[-1])]
    idx = np.searchsorted(cmd_t, events, side="right") - 1
    held = idx >= 0
    safe = np.clip(idx, 0, None)
    if math.isfinite(timeout_s):
        held &= events - cmd_t[safe] < timeout_s
    ev_v = np.where(held, cmd_v[safe], 0.0)
    ev_w = np.where(held, cmd_w[safe], 0.0)
    ticks = np.rint((events - t0) * physics_hz).astype(np.int64)
    return _EventPlan(
        n_steps=np.diff(ticks),
        cmd_v=ev_v[:-1],
        cmd_w=ev_w[:-1],
        meas_event=np.searchsorted(events, meas_t).astype(np.int64),
    )


def _make_pybullet_robot(spec: RobotSpecLike, params: DriveParams, physics_hz: float) -> Any:
    from robots.pybullet_robot import PybulletRobot  # heavy import (pybullet) only when needed

    return PybulletRobot(spec, params=params, physics_hz=physics_hz)  # type: ignore[arg-type]


def _preload_commands(
    robot: Any,
    cmd_t: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    t_start: float,
) -> None:
    """Put the commands sent before ``t_start`` into the robot's delay line.

    ``PybulletRobot`` has no public way to preload its command history (times on its own clock,
    which is 0 at ``t_start``), so this writes it directly; a robot without that history
    starts with an empty delay line.
    """
    if not all(hasattr(robot, a) for a in ("_cmd_t", "_cmd_v", "_cmd_w")):
        return
    before = cmd_t < t_start
    robot._cmd_t[:0] = (cmd_t[before] - t_start).tolist()
    robot._cmd_v[:0] = cmd_v[before].tolist()
    robot._cmd_w[:0] = cmd_w[before].tolist()


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
    plan = plan_events(
        cmd_t, cmd_v, cmd_w, meas_t, timeout_s=params.cmd_timeout_s, physics_hz=physics_hz
    )
    robot = _make_pybullet_robot(spec, params, physics_hz)
    try:
        robot.set_velocity(*initial)
        _preload_commands(robot, cmd_t, cmd_v, cmd_w, float(meas_t[0]))
        n_events = plan.n_steps.size + 1
        ev_v = np.empty(n_events)
        ev_w = np.empty(n_events)
        v, w = initial
        ev_v[0], ev_w[0] = v, w
        dt = 1.0 / physics_hz
        steps, uv, uw = plan.n_steps.tolist(), plan.cmd_v.tolist(), plan.cmd_w.tolist()
        for i in range(n_events - 1):
            if steps[i] > 0:
                v, w = robot.step(uv[i], uw[i], steps[i] * dt)
            ev_v[i + 1], ev_w[i + 1] = v, w
    finally:
        close = getattr(robot, "close", None)
        if callable(close):
            close()
    return ev_v[plan.meas_event], ev_w[plan.meas_event]
