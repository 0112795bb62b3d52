r"""Episode metrics of the navigation envs (the standard metrics of Liang et al. 2020).

Success, collision and timeout; path length; time to goal; and smoothness as the mean absolute
change of the measured v and w per control step and the mean absolute jerk
:math:`|\Delta^2 v| / \Delta t^2` (and the same for w).

Examples
--------
>>> from sim2real.envs.metrics import MetricsTracker
>>> tr = MetricsTracker(control_dt_s=0.1)
>>> tr.reset(0.0, 0.0)
>>> for k in range(3):
...     tr.record(x=0.1 * (k + 1), y=0.0, v=1.0, w=0.0)
>>> m = tr.finish("success")
>>> round(m.path_length_m, 3), round(m.time_to_goal_s, 3)
(0.3, 0.3)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from sim2real.errors import Sim2RealValueError

__all__ = ["OUTCOMES", "EpisodeMetrics", "MetricsTracker", "episode_metrics"]

#: Episode outcomes: reached the goal, touched an obstacle or person, ran out of time, or (in a
#: task that asks for a stop at the goal) left the goal's tolerance disc without stopping in it.
OUTCOMES = ("success", "collision", "timeout", "overshoot")


@dataclass(frozen=True, kw_only=True)
class EpisodeMetrics:
    """Metrics of one finished episode (reported in ``info["metrics"]`` at its end).

    Attributes
    ----------
    outcome : str
        ``"success"``, ``"collision"``, ``"timeout"`` or ``"overshoot"``.
    success, collision, timeout, overshoot : bool
        One-hot view of ``outcome``.
    steps : int
        Control steps taken.
    episode_time_s : float
        Simulated time, s.
    path_length_m : float
        Length of the driven path, m.
    time_to_goal_s : float
        Episode time when the goal was reached, s (NaN otherwise).
    mean_abs_dv_mps, mean_abs_dw_radps : float
        Mean absolute change of the measured v (m/s) and w (rad/s) per control step.
    mean_abs_jerk_v_mps3, mean_abs_jerk_w_radps3 : float
        Mean absolute second difference of v and w over the step squared (m/s^3, rad/s^3).
    """

    outcome: str
    success: bool
    collision: bool
    timeout: bool
    overshoot: bool
    steps: int
    episode_time_s: float
    path_length_m: float
    time_to_goal_s: float
    mean_abs_dv_mps: float
    mean_abs_dw_radps: float
    mean_abs_jerk_v_mps3: float
    mean_abs_jerk_w_radps3: float

    def to_dict(self) -> dict[str, float | bool | str | int]:
        """Plain mapping (for ``info`` and tables)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


class MetricsTracker:
    """Accumulates pose and velocity per control step; :meth:`finish` returns the metrics."""

    def __init__(self, *, control_dt_s: float) -> None:
        self.control_dt_s = float(control_dt_s)
        self.reset(0.0, 0.0)

    def reset(self, x: float, y: float) -> None:
        """Start a new episode at (x, y), at rest."""
        self._last_xy = (float(x), float(y))
        self._path = 0.0
        self._v: list[float] = [0.0]
        self._w: list[float] = [0.0]

    @property
    def steps(self) -> int:
        """Control steps recorded so far."""
        return len(self._v) - 1

    @property
    def path_length_m(self) -> float:
        """Path length so far, m."""
        return self._path

    def record(self, *, x: float, y: float, v: float, w: float) -> None:
        """Record the pose (m) and measured velocity (m/s, rad/s) after one control step."""
        self._path += math.hypot(x - self._last_xy[0], y - self._last_xy[1])
        self._last_xy = (float(x), float(y))
        self._v.append(float(v))
        self._w.append(float(w))

    def finish(self, outcome: str) -> EpisodeMetrics:
        """The metrics of the episode ending now with ``outcome`` (one of :data:`OUTCOMES`)."""
        return episode_metrics(
            outcome,
            np.asarray(self._v),
            np.asarray(self._w),
            path_length_m=self._path,
            control_dt_s=self.control_dt_s,
        )


def episode_metrics(
    outcome: str,
    v: np.ndarray,
    w: np.ndarray,
    *,
    path_length_m: float,
    control_dt_s: float,
) -> EpisodeMetrics:
    """The metrics of an episode from its measured ``v`` (m/s) and ``w`` (rad/s) per control
    step (index 0 = the start, at rest) and its path length (m).

    What :meth:`MetricsTracker.finish` returns; the native vector envs call it with their
    arrays.

    Examples
    --------
    >>> import numpy as np
    >>> m = episode_metrics("timeout", np.array([0.0, 1.0, 1.0]), np.zeros(3),
    ...                     path_length_m=0.2, control_dt_s=0.1)
    >>> m.steps, round(m.mean_abs_dv_mps, 3)
    (2, 0.5)
    """
    if outcome not in OUTCOMES:
        raise Sim2RealValueError(f"outcome must be one of {OUTCOMES}, got {outcome!r}")
    dt = float(control_dt_s)
    steps = v.shape[0] - 1
    t = steps * dt

    def mean_abs(x: np.ndarray) -> float:
        return float(np.mean(np.abs(x))) if x.size else 0.0

    return EpisodeMetrics(
        outcome=outcome,
        success=outcome == "success",
        collision=outcome == "collision",
        timeout=outcome == "timeout",
        overshoot=outcome == "overshoot",
        steps=steps,
        episode_time_s=t,
        path_length_m=path_length_m,
        time_to_goal_s=t if outcome == "success" else math.nan,
        mean_abs_dv_mps=mean_abs(np.diff(v)),
        mean_abs_dw_radps=mean_abs(np.diff(w)),
        mean_abs_jerk_v_mps3=mean_abs(np.diff(v, 2)) / dt**2,
        mean_abs_jerk_w_radps3=mean_abs(np.diff(w, 2)) / dt**2,
    )
