r"""Reduced-order drive model: the drive chain of :mod:`robots.params` integrated in numba.

This is the model sysid fits (thousands of simulations per fit) and the ``dynamics="reduced"``
back-end of the envs. The pybullet robot implements the same chain with real rigid bodies.

Numerics
--------
The command is a zero-order-hold signal (each command holds until the next one, or until
``cmd_timeout_s``). It is delayed by ``delay_s`` and averaged exactly over each integration
step of length ``dt_s`` (through its running integral), so the response is a smooth function of
the delay, which the least-squares fit needs for sub-sample delays.
Each step then applies the speed clamp, the rate limiter, the per-wheel speed cap and a
backward-Euler step of the PI wheel loops and viscous friction; Coulomb friction is
applied as a proximal step (it can stop the base but never reverse it). When a wheel's torque
would exceed ``wheel_torque_max_nm`` the step uses the saturated torques instead.

Example
-------
>>> import numpy as np
>>> from robots.params import BaseGeometry, DriveParams
>>> from robots.reduced import simulate
>>> geo = BaseGeometry(mass_kg=1.0, yaw_inertia_kgm2=0.01, wheel_radius_m=0.033,
...                    wheel_separation_m=0.16)
>>> t = np.arange(0.0, 2.0, 0.02)
>>> resp = simulate(DriveParams(delay_s=0.1), geo, cmd_t_s=np.array([0.0]),
...                 cmd_v=np.array([0.2]), cmd_w=np.array([0.0]), t_out_s=t)
>>> round(float(resp.v[-1]), 3)
0.2
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robots import _jit
from robots._jit import njit
from robots._kernel import drive_step, pack_params
from robots.errors import RobotsValueError
from robots.params import BaseGeometry, DriveParams

__all__ = [
    "DEFAULT_DT_S",
    "ReducedDrive",
    "ReducedResponse",
    "delayed_step_average",
    "pack_params",
    "simulate",
]

#: Most integration steps one simulation call may take (~5.8 h at the default 240 Hz): a
#: longer span means a log with a long pause; split it into its segments instead.
MAX_SIM_STEPS = 5_000_000

#: ``simulate(..., python=None)`` interprets while the kernels are not compiled and this process
#: has interpreted fewer steps than this (~0.25 s of CPU, about half of what loading numba and
#: its compiled kernels costs): a one-off replay of a short log never imports numba, a process
#: that simulates more compiles once.
INTERPRET_BUDGET_STEPS = 45_000
_interpreted_steps = 0

# Initial rows of ReducedDrive's command history (it compacts or grows when full).
_HISTORY_ROWS = 256

#: Default integration step of the reduced model, s: pybullet's default 240 Hz physics step, so
#: the reduced model and :class:`robots.PybulletRobot` step on the same grid by default.
DEFAULT_DT_S = 1.0 / 240.0

FloatArray = NDArray[np.float64]


@njit(cache=True)
def _step(
    state: FloatArray, u_v: float, u_w: float, dt: float, p: FloatArray
) -> None:  # pragma: no cover - compiled
    """Advance ``state = [v, w, ref_v, ref_w, ir, il]`` by one step with command (u_v, u_w).

    ``ir``, ``il`` are the wheel-loop integrators. The arithmetic is the shared kernel
    :func:`robots._kernel.drive_step`.
    """
    v1, w1, rv, rw, ir, il, _, _ = drive_step(
        state[0], state[1], state[2], state[3], state[4], state[5], u_v, u_w, dt, p
    )
    state[0], state[1], state[2], state[3], state[4], state[5] = v1, w1, rv, rw, ir, il


@njit(cache=True)
def _integrate(
    u_v: FloatArray, u_w: FloatArray, dt: float, p: FloatArray, v0: float, w0: float
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover - compiled
    """Integrate over all steps; returns v, w at the n+1 grid times (index 0 = initial)."""
    n = u_v.shape[0]
    out_v = np.empty(n + 1)
    out_w = np.empty(n + 1)
    state = np.array([v0, w0, v0, w0, 0.0, 0.0])
    out_v[0], out_w[0] = v0, w0
    for i in range(n):
        _step(state, u_v[i], u_w[i], dt, p)
        out_v[i + 1] = state[0]
        out_w[i + 1] = state[1]
    return out_v, out_w


def _integrate_python(
    u_v: FloatArray, u_w: FloatArray, dt: float, p: FloatArray, v0: float, w0: float
) -> tuple[FloatArray, FloatArray]:
    """The same loop in Python, one kernel call per step (the benchmark baseline).

    On Python floats and lists (numpy scalars would triple the cost of the arithmetic).
    """
    step = _step.py_func
    n = u_v.shape[0]
    out_v = [v0] * (n + 1)
    out_w = [w0] * (n + 1)
    state = [v0, w0, v0, w0, 0.0, 0.0]
    packed = p.tolist()
    for i, (a, b) in enumerate(zip(u_v.tolist(), u_w.tolist(), strict=True), start=1):
        step(state, a, b, dt, packed)
        out_v[i] = state[0]
        out_w[i] = state[1]
    return np.array(out_v), np.array(out_w)


@njit(cache=True, inline="always")
def _held_mean(
    cmd_t: FloatArray, cmd_v: FloatArray, cmd_w: FloatArray, a: float, dt: float, timeout: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    """Mean zero-order-hold command over ``[a, a + dt)``: the overlap of that window with each
    held segment ``[t_i, min(t_{i+1}, t_i + timeout))``."""
    m = cmd_t.shape[0]
    b = a + dt
    u_v = 0.0
    u_w = 0.0
    for i in range(m):
        end = cmd_t[i + 1] if i + 1 < m else math.inf
        end = min(end, cmd_t[i] + timeout)
        lo = max(a, cmd_t[i])
        hi = min(b, end)
        if hi > lo:
            u_v += cmd_v[i] * (hi - lo)
            u_w += cmd_w[i] * (hi - lo)
    return u_v / dt, u_w / dt


@njit(cache=True)
def _advance_held(
    state: FloatArray,
    cmd_t: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    t0: float,
    dt: float,
    n: int,
    delay: float,
    timeout: float,
    p: FloatArray,
) -> None:  # pragma: no cover - compiled
    """``n`` steps from time ``t0`` with the delayed zero-order-hold command history.

    The same numbers as :func:`delayed_step_average` followed by ``n`` calls of :func:`_step`
    (up to rounding), in one compiled call (:func:`_held_mean` of each delayed step).
    """
    for k in range(n):
        u_v, u_w = _held_mean(cmd_t, cmd_v, cmd_w, t0 + k * dt - delay, dt, timeout)
        _step(state, u_v, u_w, dt, p)


@njit(cache=True)
def _delayed_commands(
    cmd_t: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    t0: float,
    dt: float,
    n: int,
    delay: float,
    timeout: float,
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover - compiled
    """The delayed mean commands (u_v, u_w) of ``n`` steps of ``dt`` s from ``t0``.

    What :func:`delayed_step_average` gives on that grid (up to rounding), in one compiled call
    for a short history (:class:`robots.PybulletRobot` calls it once per control step).
    """
    u_v = np.empty(n)
    u_w = np.empty(n)
    for k in range(n):
        u_v[k], u_w[k] = _held_mean(cmd_t, cmd_v, cmd_w, t0 + k * dt - delay, dt, timeout)
    return u_v, u_w


@njit(cache=True)
def _advance_history(
    state: FloatArray,
    hist: FloatArray,
    n_hist: int,
    t0: float,
    dt: float,
    n: int,
    delay: float,
    timeout: float,
    p: FloatArray,
) -> None:  # pragma: no cover - compiled
    """:func:`_advance_held` over the rows of a ``(time, v, w)`` history that still act.

    Only commands from the one held at the start of the delayed window on contribute.
    """
    first = n_hist - 1
    while first > 0 and hist[first, 0] > t0 - delay:
        first -= 1
    rows = hist[first:n_hist]
    _advance_held(state, rows[:, 0], rows[:, 1], rows[:, 2], t0, dt, n, delay, timeout, p)


def _zoh_breakpoints(
    cmd_t_s: FloatArray, values: FloatArray, timeout_s: float
) -> tuple[FloatArray, FloatArray]:
    """Breakpoints and running integral of the held command (zero after a timeout)."""
    n = cmd_t_s.shape[0]
    ends = np.empty(n)
    ends[:-1] = cmd_t_s[1:]
    ends[-1] = math.inf
    if math.isfinite(timeout_s):
        ends = np.minimum(ends, cmd_t_s + timeout_s)
    # segment i holds values[i] on [cmd_t_s[i], ends[i]), then 0 until cmd_t_s[i+1]
    last_end = ends[-1] if math.isfinite(ends[-1]) else cmd_t_s[-1] + 1e9
    ends[-1] = last_end
    knots = np.empty(2 * n)
    knots[0::2] = cmd_t_s
    knots[1::2] = ends
    seg = np.zeros(2 * n - 1)
    seg[0::2] = values * (ends - cmd_t_s)
    integral = np.concatenate(([0.0], np.cumsum(seg)))
    return knots, integral


def delayed_step_average(
    cmd_t_s: FloatArray,
    values: FloatArray,
    grid_t_s: FloatArray,
    dt_s: float,
    *,
    delay_s: float,
    timeout_s: float = math.inf,
) -> FloatArray:
    """Mean of the delayed zero-order-hold command over each step ``[t_k, t_k + dt)``.

    Before the first command the command is 0. The result is exact for a piecewise-constant
    command and continuous in ``delay_s``.

    Examples
    --------
    >>> import numpy as np
    >>> delayed_step_average(np.array([0.0]), np.array([1.0]), np.array([0.0, 0.1]), 0.1,
    ...                      delay_s=0.05)
    array([0.5, 1. ])
    """
    knots, integral = _zoh_breakpoints(cmd_t_s, values, timeout_s)
    a = np.interp(grid_t_s - delay_s, knots, integral, left=0.0)
    b = np.interp(grid_t_s + dt_s - delay_s, knots, integral, left=0.0)
    result: FloatArray = (b - a) / dt_s
    return result


@dataclass(frozen=True, kw_only=True)
class ReducedResponse:
    """Simulated base velocity at the requested times.

    Attributes
    ----------
    t_s : ndarray
        Output times, s (same clock as the commands).
    v : ndarray
        Forward velocity, m/s.
    w : ndarray
        Yaw rate, rad/s.
    """

    t_s: FloatArray
    v: FloatArray
    w: FloatArray


def _check_inputs(
    cmd_t_s: FloatArray, cmd_v: FloatArray, cmd_w: FloatArray, t_out_s: FloatArray, dt_s: float
) -> None:
    if not (math.isfinite(dt_s) and dt_s > 0):
        raise RobotsValueError(f"dt_s must be a finite number > 0, got {dt_s!r}")
    if cmd_t_s.ndim != 1 or cmd_t_s.shape != cmd_v.shape or cmd_t_s.shape != cmd_w.shape:
        raise RobotsValueError(
            "cmd_t_s, cmd_v and cmd_w must be 1-D arrays of the same length, got shapes "
            f"{cmd_t_s.shape}, {cmd_v.shape}, {cmd_w.shape}"
        )
    if cmd_t_s.size == 0:
        raise RobotsValueError("cmd_t_s is empty; the model needs at least one command")
    if t_out_s.ndim != 1 or t_out_s.size == 0:
        raise RobotsValueError(f"t_out_s must be a non-empty 1-D array, got shape {t_out_s.shape}")
    for name, arr in (
        ("cmd_t_s", cmd_t_s),
        ("cmd_v", cmd_v),
        ("cmd_w", cmd_w),
        ("t_out_s", t_out_s),
    ):
        if not np.all(np.isfinite(arr)):
            raise RobotsValueError(f"{name} contains NaN or inf; clean the log first")
    if np.any(np.diff(cmd_t_s) < 0) or np.any(np.diff(t_out_s) < 0):
        raise RobotsValueError("cmd_t_s and t_out_s must be sorted in time (non-decreasing)")
    span_s = float(t_out_s[-1] - t_out_s[0])
    if span_s / dt_s > MAX_SIM_STEPS:
        raise RobotsValueError(
            f"t_out_s spans {span_s:.4g} s, {span_s / dt_s:.3g} integration steps of {dt_s:g} s "
            f"(at most {MAX_SIM_STEPS} are allowed, a bound on memory); simulate the parts of "
            "a log between its pauses one by one (sim2real.logs.Trace.segments())"
        )


def simulate(
    params: DriveParams,
    geometry: BaseGeometry,
    *,
    cmd_t_s: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    t_out_s: FloatArray,
    dt_s: float = DEFAULT_DT_S,
    v0: float = 0.0,
    w0: float = 0.0,
    python: bool | None = False,
) -> ReducedResponse:
    """Simulate the drive chain for a logged command sequence.

    Parameters
    ----------
    params, geometry : DriveParams, BaseGeometry
        The drive parameters and the base they act on.
    cmd_t_s, cmd_v, cmd_w : ndarray
        Command times (s, sorted) and commanded forward (m/s) and yaw (rad/s) velocity.
    t_out_s : ndarray
        Times (s, sorted) at which to report the simulated velocity, e.g. odometry stamps.
        The simulation starts at ``t_out_s[0]`` in state (``v0``, ``w0``).
    dt_s : float
        Integration step, s.
    python : bool or None
        ``True``: run the plain-Python loop instead of the numba kernel (same numbers, ~100x
        slower per step, but no numba to load). ``None``: choose; plain Python while the
        kernels are not compiled yet and the process has interpreted fewer than
        :data:`INTERPRET_BUDGET_STEPS` steps (a one-off replay of a short log, e.g.
        ``sim2real agree --engine reduced``), numba otherwise.

    Returns
    -------
    ReducedResponse
        ``v`` and ``w`` linearly interpolated from the integration grid at ``t_out_s``.
    """
    cmd_t_s = np.asarray(cmd_t_s, dtype=np.float64)
    cmd_v = np.asarray(cmd_v, dtype=np.float64)
    cmd_w = np.asarray(cmd_w, dtype=np.float64)
    t_out_s = np.asarray(t_out_s, dtype=np.float64)
    _check_inputs(cmd_t_s, cmd_v, cmd_w, t_out_s, dt_s)
    t0 = float(t_out_s[0])
    n = max(1, math.ceil((float(t_out_s[-1]) - t0) / dt_s))
    grid = t0 + dt_s * np.arange(n, dtype=np.float64)
    u_v = delayed_step_average(
        cmd_t_s, cmd_v, grid, dt_s, delay_s=params.delay_s, timeout_s=params.cmd_timeout_s
    )
    u_w = delayed_step_average(
        cmd_t_s, cmd_w, grid, dt_s, delay_s=params.delay_s, timeout_s=params.cmd_timeout_s
    )
    packed = pack_params(params, geometry)
    if python is None:
        python = _within_interpret_budget(n)
    if python:
        with _jit.interpreted():
            out_v, out_w = _integrate_python(u_v, u_w, float(dt_s), packed, float(v0), float(w0))
    else:
        out_v, out_w = _integrate(u_v, u_w, float(dt_s), packed, float(v0), float(w0))
    t_grid = t0 + dt_s * np.arange(n + 1, dtype=np.float64)
    return ReducedResponse(
        t_s=t_out_s, v=np.interp(t_out_s, t_grid, out_v), w=np.interp(t_out_s, t_grid, out_w)
    )


def _within_interpret_budget(n_steps: int) -> bool:
    """Whether ``simulate(python=None)`` interprets a run of ``n_steps`` (and count them)."""
    global _interpreted_steps
    if _jit.compiled() or _interpreted_steps + n_steps > INTERPRET_BUDGET_STEPS:
        return False
    _interpreted_steps += n_steps
    return True


class ReducedDrive:
    """Step-by-step reduced drive model for envs (``dynamics="reduced"``).

    Commands are given once per control step; the transport delay is realised with a command
    history, exactly as :func:`simulate` does for a log.

    Examples
    --------
    >>> from robots.params import BaseGeometry, DriveParams
    >>> geo = BaseGeometry(mass_kg=1.0, yaw_inertia_kgm2=0.01, wheel_radius_m=0.033,
    ...                    wheel_separation_m=0.16)
    >>> drive = ReducedDrive(DriveParams(), geo)
    >>> for _ in range(20):
    ...     v, w = drive.step(0.2, 0.0, 0.1)
    >>> round(v, 3)
    0.2
    """

    def __init__(
        self, params: DriveParams, geometry: BaseGeometry, *, dt_s: float = DEFAULT_DT_S
    ) -> None:
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise RobotsValueError(f"dt_s must be a finite number > 0, got {dt_s!r}")
        self.geometry = geometry
        self.dt_s = dt_s
        self.params = params
        self.reset()

    @property
    def params(self) -> DriveParams:
        """The drive parameters in use."""
        return self._params

    @params.setter
    def params(self, params: DriveParams) -> None:
        self._params = params
        self._packed = pack_params(params, self.geometry)

    def reset(self, v: float = 0.0, w: float = 0.0) -> None:
        """Set the base velocity and clear the command history."""
        self.time_s = 0.0
        self._state = np.array([v, w, v, w, 0.0, 0.0], dtype=np.float64)
        # command history: rows of (time s, v m/s, w rad/s); the first self._n rows are used
        self._hist = np.empty((_HISTORY_ROWS, 3), dtype=np.float64)
        self._n = 0

    @property
    def velocity(self) -> tuple[float, float]:
        """Current (v [m/s], w [rad/s])."""
        return float(self._state[0]), float(self._state[1])

    def step(self, cmd_v: float, cmd_w: float, duration_s: float) -> tuple[float, float]:
        """Issue command (cmd_v, cmd_w) now and advance ``duration_s``; return (v, w)."""
        if not (math.isfinite(cmd_v) and math.isfinite(cmd_w)):
            raise RobotsValueError(f"command must be finite, got ({cmd_v!r}, {cmd_w!r})")
        if self._n == self._hist.shape[0]:
            self._compact_history()
        row = self._hist[self._n]
        row[0], row[1], row[2] = self.time_s, cmd_v, cmd_w
        self._n += 1
        n = max(1, round(duration_s / self.dt_s))
        _advance_history(
            self._state,
            self._hist,
            self._n,
            self.time_s,
            duration_s / n,
            n,
            self._params.delay_s,
            self._params.cmd_timeout_s,
            self._packed,
        )
        self.time_s += duration_s
        return float(self._state[0]), float(self._state[1])

    def _compact_history(self) -> None:
        """Forget commands that can no longer take effect; grow the buffer if none can go.

        One command before the delay horizon is kept, with a 1 s margin so that the history
        stays right if the delay is raised by up to 1 s later.
        """
        horizon = self.time_s - self._params.delay_s - 1.0
        times = self._hist[: self._n, 0]
        first = max(int(np.searchsorted(times, horizon, side="right")) - 1, 0)
        if first == 0:
            self._hist = np.concatenate((self._hist, np.empty_like(self._hist)))
            return
        kept = self._n - first
        self._hist[:kept] = self._hist[first : self._n]
        self._n = kept
