"""Block bootstrap over log segments: a check on the Jacobian standard errors.

The Jacobian errors assume the model is right and the residuals are (after the
autocorrelation inflation) independent. Refitting on logs rebuilt from randomly drawn
segments (with replacement) measures the spread the data actually support, including model
error that differs along the log. Each replicate starts at the full-data solution, so a few
iterations suffice.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from robots.arrays import FloatArray
from sysid._coords import Mapper
from sysid._logs import LogArrays, crop_log
from sysid._problem import Problem

__all__ = ["segment_bootstrap", "segments"]


def segments(logs: Sequence[LogArrays], segment_s: float) -> list[LogArrays]:
    """Consecutive windows of ``segment_s`` seconds with at least 10 samples each."""
    out = []
    for log in logs:
        t0, t1 = float(log.meas_t_s[0]), float(log.meas_t_s[-1])
        start = t0
        while start < t1:
            end = min(start + segment_s, t1 + 1e-9)
            n = int(np.sum((log.meas_t_s >= start) & (log.meas_t_s < end)))
            if n >= 10:
                out.append(crop_log(log, start, end))
            start = end
    return out


def segment_bootstrap(
    logs: Sequence[LogArrays],
    mapper: Mapper,
    free: Sequence[str],
    ties: dict[str, str],
    x_hat: FloatArray,
    *,
    solve: Callable[[Problem, FloatArray], Any],
    problem_kw: dict[str, Any],
    replicates: int,
    segment_s: float,
    seed: int,
) -> FloatArray:
    """Coordinates refitted on ``replicates`` resampled sets of segments (rows)."""
    pool = segments(logs, segment_s)
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(replicates):
        drawn = [pool[i] for i in rng.integers(0, len(pool), len(pool))]
        prob = Problem(drawn, mapper, free, ties, **problem_kw)
        rows.append(np.asarray(solve(prob, x_hat).x))
    return np.asarray(rows).reshape(replicates, len(free))
