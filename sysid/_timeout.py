"""The command timeout from the logs instead of the spec (private; used by :func:`fit_drive`).

Drivers differ: some stop the base when commands stop arriving (TurtleBot3 firmware: 0.5 s),
others hold the last command forever (the Neato driver: 9 commands in 27 s while it spins).
Velocity logs reveal which wherever the command stream pauses while a non-zero command holds:

- a pause of at least :data:`MIN_GAP_S` through whose last 30 % the base still moves at
  >= 30 % of the held command (v or w) shows commands are *held* for at least that long;
- a pause in which the base stops (its last moving sample, then still until the next command)
  shows a timeout of about the time from the last command to that stop, less the transport
  delay.

All pauses hold -> ``cmd_timeout_s = inf`` (none); stops -> the median stop time less the
delay (finite); a stop shorter than a held pause -> the logs disagree and the spec value stays.
No such pause -> the logs cannot tell and the spec value stays. The result is one sentence.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from robots.params import DriveParams
from sysid._logs import LogArrays

__all__ = ["MIN_GAP_S", "fit_cmd_timeout"]

#: Shortest pause in the command stream that says anything about the timeout, s.
MIN_GAP_S = 1.0
_MOVING = 0.3  # fraction of the held command that counts as still moving
_EPS_V, _EPS_W = 0.02, 0.05


def _pauses(log: LogArrays) -> list[tuple[float, float, float, float]]:
    """(start, end, v, w) of every pause >= MIN_GAP_S with a non-zero command held."""
    t = np.asarray(log.cmd_t_s, dtype=np.float64)
    ends = np.append(t[1:], float(np.asarray(log.meas_t_s)[-1]))
    out = []
    for start, end, v, w in zip(t.tolist(), ends.tolist(), log.cmd_v, log.cmd_w, strict=True):
        if end - start >= MIN_GAP_S and (abs(v) > _EPS_V or abs(w) > _EPS_W):
            out.append((start, end, float(v), float(w)))
    return out


def _motion(log: LogArrays, v: float, w: float, sel: np.ndarray) -> np.ndarray:
    """Fraction of the held command the base achieves, per measurement in ``sel``."""
    mv, mw = np.asarray(log.meas_v)[sel], np.asarray(log.meas_w)[sel]
    parts = []
    if abs(v) > _EPS_V:
        parts.append(mv / v)
    if abs(w) > _EPS_W:
        parts.append(mw / w)
    return np.max(np.vstack(parts), axis=0)


def _evidence(logs: Sequence[LogArrays]) -> tuple[list[float], list[float]]:
    """Held pause lengths and stop times (s after the last command) over all logs."""
    holds, stops = [], []
    for log in logs:
        mt = np.asarray(log.meas_t_s, dtype=np.float64)
        for start, end, v, w in _pauses(log):
            sel = (mt > start) & (mt < end)
            if np.count_nonzero(sel) < 3:
                continue
            moving = _motion(log, v, w, sel) >= _MOVING
            tail = mt[sel] >= start + 0.7 * (end - start)
            if np.any(moving & tail):
                holds.append(end - start)
            elif np.any(moving):
                stops.append(float(mt[sel][np.flatnonzero(moving)[-1]] - start))
    return holds, stops


def fit_cmd_timeout(
    logs: Sequence[LogArrays], params: DriveParams
) -> tuple[DriveParams, list[str]]:
    """``params`` with ``cmd_timeout_s`` as the logs show it, and the sentence saying so.

    Examples
    --------
    >>> t = np.array([0.0, 0.1, 0.2, 5.0])
    >>> mt = np.arange(0.0, 6.0, 0.05)
    >>> log = LogArrays(cmd_t_s=t, cmd_v=np.array([0.2, 0.2, 0.2, 0.0]), cmd_w=np.zeros(4),
    ...                 meas_t_s=mt, meas_v=np.where(mt < 5.1, 0.2, 0.0), meas_w=0 * mt)
    >>> p, notes = fit_cmd_timeout([log], DriveParams(cmd_timeout_s=0.5))
    >>> p.cmd_timeout_s
    inf
    """
    holds, stops = _evidence(logs)
    spec = params.cmd_timeout_s
    if not holds and not stops:
        return params, []
    if stops:
        estimate = max(float(np.median(stops)) - params.delay_s, 0.01)
        if holds and max(holds) > estimate:
            return params, [
                f"cmd_timeout_s: the base stopped {estimate:.2f} s after the last command in "
                f"{len(stops)} pause(s) but kept moving through {len(holds)} longer one(s) "
                f"(up to {max(holds):.1f} s), so the logs disagree and the spec value {spec:g} "
                "s is kept"
            ]
        value = round(estimate, 2)
        why = (
            f"the base stopped {value:.2f} s (median, less the {params.delay_s:.2f} s delay) "
            f"after the last command in {len(stops)} pause(s) of the command stream"
        )
    else:
        value = math.inf
        why = (
            f"the base kept moving through {len(holds)} pause(s) of the command stream of up to "
            f"{max(holds):.1f} s, so the driver holds the last command"
        )
    shown = "none (inf)" if math.isinf(value) else f"{value:.2f} s"
    note = f"cmd_timeout_s fitted from the logs: {why}: {shown} (spec: {spec:g} s)"
    return params.replace(cmd_timeout_s=value), [note]
