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

Examples
--------
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
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robots import _jit
from robots._jit import njit
from robots._kernel import PackedParams, drive_step, pack_params
from robots.arrays import FloatArray
from robots.errors import RobotsValueError
from robots.params import BaseGeometry, DriveParams

__all__ = [
    "DEFAULT_DT_S",
    "GridCommands",
    "ReducedDrive",
    "ReducedResponse",
    "delayed_step_average",
    "pack_params",
    "simulate",
    "simulate_grid",
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


#: :func:`robots._kernel.drive_step` inlined into the simulation loop :func:`_run` (numba-IR
#: inlining: the same arithmetic, ~25 % less time per step than a call, whose 8-tuple result
#: the loop mostly discards). Not cached on its own: it is compiled into its callers.
_drive_step_inlined = njit(cache=False, inline="always")(drive_step.py_func)


@njit(cache=True, inline="always")
def _lerp(x: float, x0: float, x1: float, y0: float, y1: float) -> float:  # pragma: no cover
    """``np.interp``'s arithmetic on one interval ``x0 <= x < x1`` (the same bits)."""
    if x == x0:
        return y0
    slope = (y1 - y0) / (x1 - x0)
    y = slope * (x - x0) + y0
    if math.isnan(y):  # numpy tries the other end, then the common value
        y = slope * (x - x1) + y1
        if math.isnan(y) and y0 == y1:
            y = y0
    return y


@njit(cache=True)
def _run(
    u_v: FloatArray,
    u_w: FloatArray,
    offset: int,
    n: int,
    t0: float,
    dt: float,
    p: FloatArray,
    v0: float,
    w0: float,
    t_out: FloatArray,
    shift: float,
    out_v: FloatArray,
    out_w: FloatArray,
) -> None:  # pragma: no cover - compiled
    """Integrate ``n`` steps of ``dt`` from ``t0`` with commands ``u[offset:offset + n]`` and
    write v, w at the times ``t_out - shift`` (sorted) into ``out_v``, ``out_w``: linear
    interpolation between the grid's states, held at its ends, bit for bit what ``np.interp``
    gives on the grid ``t0 + dt * arange(n + 1)``.

    One pass and no trajectory: each time is read while its grid interval is integrated.
    """
    m = len(t_out)
    j = 0
    while j < m and t_out[j] - shift < t0:
        out_v[j], out_w[j] = v0, w0
        j += 1
    cur_v, cur_w, rv, rw, ir, il = v0, w0, v0, w0, 0.0, 0.0
    x1 = t0
    for k in range(1, n + 1):
        if j == m:
            return
        prev_v, prev_w, x0 = cur_v, cur_w, x1
        cur_v, cur_w, rv, rw, ir, il, _, _ = _drive_step_inlined(
            cur_v, cur_w, rv, rw, ir, il, u_v[offset + k - 1], u_w[offset + k - 1], dt, p
        )
        x1 = t0 + dt * float(k)
        while j < m and t_out[j] - shift < x1:
            x = t_out[j] - shift
            out_v[j] = _lerp(x, x0, x1, prev_v, cur_v)
            out_w[j] = _lerp(x, x0, x1, prev_w, cur_w)
            j += 1
    while j < m:
        out_v[j], out_w[j] = cur_v, cur_w
        j += 1


@njit(cache=True)
def _run_many(
    u_v: FloatArray,
    u_w: FloatArray,
    which: NDArray[np.int64],
    n: int,
    t0: float,
    dt: float,
    packed: FloatArray,
    v0: float,
    w0: FloatArray,
    t_out: FloatArray,
    shifts: FloatArray,
    out_v: FloatArray,
    out_w: FloatArray,
) -> None:  # pragma: no cover - compiled
    """:func:`_run` for each row ``c`` of ``packed`` with the commands of row ``which[c]`` of
    ``u_v``, ``u_w``, its own start yaw rate ``w0[c]`` and shift, into its own output row."""
    for c in range(packed.shape[0]):
        k = which[c]
        args = (packed[c], v0, w0[c], t_out, shifts[c], out_v[c], out_w[c])
        _run(u_v[k], u_w[k], 0, n, t0, dt, *args)


def _run_python(args: tuple[Any, ...], out_v: FloatArray, out_w: FloatArray) -> None:
    """:func:`_run` in plain Python, one kernel call per step (its own loop on Python floats and
    lists, faster to interpret than numpy scalars): ``args`` are its arguments but the outputs
    (the benchmark baseline and the interpreted mode)."""
    lists = [a.tolist() if isinstance(a, np.ndarray) else a for a in args]
    list_v, list_w = [0.0] * out_v.shape[0], [0.0] * out_w.shape[0]
    _run.py_func(*lists, list_v, list_w)
    out_v[:], out_w[:] = list_v, list_w


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
    """``n`` steps from time ``t0`` with the delayed zero-order-hold commands of the rows of a
    ``(time, v, w)`` history that still act.

    The same numbers as :func:`delayed_step_average` followed by ``n`` calls of :func:`_step`
    (up to rounding), in one compiled call (:func:`_held_mean` of each delayed step). Only
    commands from the one held at the start of the delayed window on contribute.
    """
    first = n_hist - 1
    while first > 0 and hist[first, 0] > t0 - delay:
        first -= 1
    cmd_t, cmd_v, cmd_w = hist[first:n_hist, 0], hist[first:n_hist, 1], hist[first:n_hist, 2]
    for k in range(n):
        u_v, u_w = _held_mean(cmd_t, cmd_v, cmd_w, t0 + k * dt - delay, dt, timeout)
        _step(state, u_v, u_w, dt, p)


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
    args = (n, t0, float(dt_s), packed, float(v0), float(w0))
    if python is None:
        python = _within_interpret_budget(n)
    v, w = np.empty(t_out_s.size), np.empty(t_out_s.size)
    if python:
        with _jit.interpreted():
            _run_python((u_v, u_w, 0, *args, t_out_s, 0.0), v, w)
    else:
        _run(u_v, u_w, 0, *args, t_out_s, 0.0, v, w)
    return ReducedResponse(t_s=t_out_s, v=v, w=w)


@dataclass(frozen=True, kw_only=True)
class GridCommands:
    """A log's delayed command history averaged over the steps of one integration grid (what
    :func:`simulate` computes first), kept so that many simulations of the log with the same
    delay -- a fit's Jacobian columns -- compute it once (:func:`simulate_grid`).

    Build it with :meth:`build`.

    Attributes
    ----------
    t0_s, dt_s : float
        Start time and step of the integration grid, s.
    delay_s, timeout_s : float
        The delay and command timeout the commands were averaged with, s.
    u_v, u_w : ndarray
        Mean delayed held command over each step, m/s and rad/s.
    """

    t0_s: float
    dt_s: float
    delay_s: float
    timeout_s: float
    u_v: FloatArray
    u_w: FloatArray

    @classmethod
    def build(
        cls,
        cmd_t_s: FloatArray,
        cmd_v: FloatArray,
        cmd_w: FloatArray,
        *,
        t0_s: float,
        dt_s: float,
        n: int,
        delay_s: float,
        timeout_s: float,
    ) -> GridCommands:
        """Averages over ``n`` steps of ``dt_s`` from ``t0_s`` (:func:`delayed_step_average`)."""
        grid = t0_s + dt_s * np.arange(n, dtype=np.float64)
        kw = {"delay_s": delay_s, "timeout_s": timeout_s}
        return cls(
            t0_s=t0_s,
            dt_s=dt_s,
            delay_s=delay_s,
            timeout_s=timeout_s,
            u_v=delayed_step_average(cmd_t_s, cmd_v, grid, dt_s, **kw),
            u_w=delayed_step_average(cmd_t_s, cmd_w, grid, dt_s, **kw),
        )

    @property
    def n(self) -> int:
        """Steps the grid covers."""
        return int(self.u_v.size)


def simulate_grid(
    commands: Sequence[GridCommands],
    packed: FloatArray,
    t_out_s: FloatArray,
    shifts_s: FloatArray,
    *,
    v0: float,
    w0: float | FloatArray,
    python: bool = False,
) -> tuple[FloatArray, FloatArray]:
    """Simulate several parameter sets of one log in one compiled call.

    Row ``c`` of ``packed`` (:func:`pack_params`) runs with the grid commands
    ``commands[c]`` (all on one grid; rows may share them) from ``t0_s`` in state
    (``v0``, ``w0``; ``w0`` one yaw rate, or one per row) and is read at the times ``t_out_s - shifts_s[c]`` (``t_out_s`` sorted):
    bit for bit :func:`simulate` with those commands' delay and timeout and the output times
    ``[t0_s, *(t_out_s - shifts_s[c])]`` (its first output dropped). Returns v and w, shape
    ``(rows, t_out_s.size)``. ``python=True`` runs the plain-Python loop instead (the same
    numbers, the benchmark baseline).

    Examples
    --------
    >>> import numpy as np
    >>> from robots.params import BaseGeometry, DriveParams
    >>> geo = BaseGeometry(mass_kg=1.0, yaw_inertia_kgm2=0.01, wheel_radius_m=0.033,
    ...                    wheel_separation_m=0.16)
    >>> cmds = GridCommands.build(np.array([0.0]), np.array([0.2]), np.array([0.0]),
    ...                           t0_s=0.0, dt_s=0.01, n=200, delay_s=0.1, timeout_s=np.inf)
    >>> v, w = simulate_grid([cmds], pack_params(DriveParams(), geo)[None, :],
    ...                      np.array([0.1, 2.0]), np.zeros(1), v0=0.0, w0=0.0)
    >>> [round(float(x), 3) for x in v[0]]
    [0.0, 0.2]
    """
    rows = packed.shape[0]
    first = commands[0]
    if len(commands) != rows or any(
        (c.t0_s, c.dt_s, c.n) != (first.t0_s, first.dt_s, first.n) for c in commands
    ):
        raise RobotsValueError(
            f"simulate_grid needs one GridCommands per parameter row ({rows}), all on one grid; "
            f"got {len(commands)}"
        )
    index: dict[int, int] = {}
    which = np.array([index.setdefault(id(c), len(index)) for c in commands], dtype=np.int64)
    unique = list({id(c): c for c in commands}.values())
    u_v = np.stack([c.u_v for c in unique])
    u_w = np.stack([c.u_w for c in unique])
    t_out_s = np.ascontiguousarray(t_out_s, dtype=np.float64)
    packed = np.ascontiguousarray(packed, dtype=np.float64)
    shifts_s = np.ascontiguousarray(shifts_s, dtype=np.float64)
    grid = (first.n, float(first.t0_s), float(first.dt_s))
    w0s = np.ascontiguousarray(np.broadcast_to(np.asarray(w0, dtype=np.float64), (rows,)))
    out_v, out_w = np.empty((rows, t_out_s.size)), np.empty((rows, t_out_s.size))
    if python:
        for c in range(rows):
            row = (u_v[which[c]], u_w[which[c]], 0, *grid, packed[c], float(v0), float(w0s[c]))
            _run_python((*row, t_out_s, float(shifts_s[c])), out_v[c], out_w[c])
        return out_v, out_w
    _run_many(
        u_v, u_w, which, *grid, packed, float(v0), w0s, t_out_s, shifts_s, out_v, out_w
    )  # fmt: skip
    return out_v, out_w


def _within_interpret_budget(n_steps: int) -> bool:
    """Whether ``simulate(python=None)`` interprets a run of ``n_steps`` (and count them)."""
    global _interpreted_steps
    if _jit.compiled() or _interpreted_steps + n_steps > INTERPRET_BUDGET_STEPS:
        return False
    _interpreted_steps += n_steps
    return True


class ReducedDrive(PackedParams):
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
