r"""Step-like segments of a log and their response figures (rise time, overshoot, error).

A *step* is a command change of at least :data:`MIN_JUMP` (m/s on v, rad/s on w) on one axis
that is then held (within :data:`HOLD_TOL_FRAC` of the change) for at least :data:`MIN_HOLD_S`.
For a step from command :math:`u_0` to :math:`u_1` on an axis with response :math:`y(t)`:

- settled value :math:`y_{ss}`: the mean over the last 30 % of the hold; :math:`y_0` is the
  response at the step time;
- rise time: time from 10 % to 90 % of the response's own change :math:`y_{ss} - y_0`
  (classical definition, so a base that settles under the command still has one), linearly
  interpolated between samples;
- overshoot: :math:`\max(0, \max_t \mathrm{sgn}(\Delta u)(y - y_{ss})) / |\Delta u|`, in %
  of the commanded change :math:`\Delta u = u_1 - u_0`;
- steady-state error: :math:`y_{ss} - u_1` (m/s or rad/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim2real._arrays import FloatArray

__all__ = ["Step", "StepResponse", "find_steps", "step_response"]


@dataclass(frozen=True, kw_only=True)
class Step:
    """A held command change on one axis.

    Attributes
    ----------
    axis : str
        ``"v"`` (m/s) or ``"w"`` (rad/s).
    t_start_s, t_end_s : float
        Time of the change and end of the hold, s since the log start.
    before, after : float
        Command before and after the change.
    """

    axis: str
    t_start_s: float
    t_end_s: float
    before: float
    after: float


@dataclass(frozen=True, kw_only=True)
class StepResponse:
    """Response figures of one trace to one step (NaN when not measurable).

    Attributes
    ----------
    rise_time_s : float
        10-90 % rise time, s.
    overshoot_pct : float
        Overshoot beyond the settled value, % of the commanded change.
    ss_error : float
        Settled value minus the command (m/s or rad/s).
    """

    rise_time_s: float
    overshoot_pct: float
    ss_error: float


#: The smallest command change that makes a step, per axis (m/s on v, rad/s on w).
MIN_JUMP = {"v": 0.05, "w": 0.3}
#: How long the new command must be held, s, ...
MIN_HOLD_S = 1.0
#: ... within this fraction of the change.
HOLD_TOL_FRAC = 0.05


def find_steps(
    cmd_t_s: FloatArray, cmd_v: FloatArray, cmd_w: FloatArray, *, max_steps: int = 12
) -> list[Step]:
    """The first ``max_steps`` held command changes in a command sequence, in time order (see
    the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.array([0.0, 1.0, 3.0])
    >>> find_steps(t, np.array([0.0, 0.2, 0.2]), np.zeros(3))[0].after
    0.2
    """
    t = np.asarray(cmd_t_s, dtype=np.float64)
    out: list[Step] = []
    for axis, u in (("v", cmd_v), ("w", cmd_w)):
        u = np.asarray(u, dtype=np.float64)
        for i in range(1, t.size):
            delta = u[i] - u[i - 1]
            if abs(delta) < MIN_JUMP[axis]:
                continue
            tol = max(HOLD_TOL_FRAC * abs(delta), 1e-9)
            j = i + 1
            while j < t.size and abs(u[j] - u[i]) <= tol:
                j += 1
            t_end = t[j] if j < t.size else t[-1]
            if t_end - t[i] >= MIN_HOLD_S:
                out.append(
                    Step(
                        axis=axis,
                        t_start_s=float(t[i]),
                        t_end_s=float(t_end),
                        before=float(u[i - 1]),
                        after=float(u[i]),
                    )
                )
    out.sort(key=lambda s: s.t_start_s)
    return out[:max_steps]


def _crossing_time(t: FloatArray, y: FloatArray, level: float, sign: float) -> float:
    above = sign * (y - level) >= 0
    if not above.any():
        return math.nan
    k = int(np.argmax(above))
    if k == 0:
        return float(t[0])
    y0, y1 = y[k - 1], y[k]
    frac = (level - y0) / (y1 - y0) if y1 != y0 else 1.0
    return float(t[k - 1] + frac * (t[k] - t[k - 1]))


def step_response(t_s: FloatArray, y: FloatArray, step: Step) -> StepResponse:
    """Rise time, overshoot and steady-state error of ``y(t_s)`` for ``step``.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 4.0, 401)
    >>> y = np.where(t < 1.0, 0.0, 0.2 * (1 - np.exp(-(t - 1.0) / 0.1)))
    >>> r = step_response(t, y, Step(axis="v", t_start_s=1.0, t_end_s=4.0, before=0, after=0.2))
    >>> round(r.rise_time_s, 2)
    0.22
    """
    t = np.asarray(t_s, dtype=np.float64)
    yy = np.asarray(y, dtype=np.float64)
    sel = (t >= step.t_start_s) & (t <= step.t_end_s)
    if sel.sum() < 4:
        return StepResponse(rise_time_s=math.nan, overshoot_pct=math.nan, ss_error=math.nan)
    ts, ys = t[sel], yy[sel]
    delta = step.after - step.before
    sign = 1.0 if delta > 0 else -1.0
    y0 = float(np.interp(step.t_start_s, t, yy))
    tail = ts >= step.t_start_s + 0.7 * (step.t_end_s - step.t_start_s)
    y_ss = float(np.mean(ys[tail])) if tail.any() else float(ys[-1])
    change = y_ss - y0
    if sign * change <= 0.1 * abs(delta):  # the response did not follow the step
        t10 = t90 = math.nan
    else:
        t10 = _crossing_time(ts, ys, y0 + 0.1 * change, sign)
        t90 = _crossing_time(ts, ys, y0 + 0.9 * change, sign)
    peak = float(np.max(sign * (ys - y_ss)))
    return StepResponse(
        rise_time_s=t90 - t10 if math.isfinite(t10) and math.isfinite(t90) else math.nan,
        overshoot_pct=100.0 * max(0.0, peak) / abs(delta),
        ss_error=y_ss - step.after,
    )
