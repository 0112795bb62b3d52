"""Time validation of a log's sample streams: gaps, segments and far stamp outliers (private).

A recording is a set of *segments*: runs of measurement samples whose consecutive stamps are
closer than the gap threshold :func:`gap_threshold_ns`, ``max(2 s, 20 x the median sampling
step)``. A longer pause (the robot was switched off for a night, the recorder was paused)
starts a new segment; anything that simulates a log (replay, sysid) runs each segment on its
own, so no time grid ever spans a gap and memory stays proportional to the number of
messages, never to the time span.

A segment with fewer than :data:`MIN_SEGMENT_SAMPLES` samples, while the log has a longer one,
is a *far stamp outlier* (a flipped byte in one ``header.stamp`` puts a sample years away
from the rest): it is dropped with a note naming the count. Commands are kept where a
segment can use them: within :data:`COMMAND_REACH_S` (or the gap threshold, when larger) of a
segment's measurements; farther commands are far outliers too.

Examples
--------
>>> import numpy as np
>>> t = np.array([0, 1, 2, 3, 4, 5, 10**10], dtype=np.int64) * 10**8  # last: 32 years on
>>> bounds = segment_bounds(t)
>>> [(int(a), int(b)) for a, b in bounds]
[(0, 6), (6, 7)]
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numpy.typing import NDArray

from robots.units import NS_PER_S, seconds
from sim2real._arrays import IntArray

__all__ = [
    "COMMAND_REACH_S",
    "GAP_FACTOR",
    "GAP_MIN_S",
    "MIN_SEGMENT_SAMPLES",
    "command_windows",
    "drop_far_commands",
    "drop_isolated",
    "drop_outliers",
    "gap_threshold_ns",
    "scratch_median",
    "segment_bounds",
]


#: A pause in the measurements longer than this (s) always starts a new segment ...
GAP_MIN_S = 2.0
#: ... and so does one longer than this many median sampling steps.
GAP_FACTOR = 20.0
#: A segment with fewer samples than this, beside a longer one, is a far stamp outlier.
MIN_SEGMENT_SAMPLES = 5
#: Commands farther than this (s) from every kept segment are far outliers.
COMMAND_REACH_S = 60.0


def scratch_median(a: np.ndarray) -> np.floating:
    """``np.median(a, overwrite_input=True)`` of a 1-D array, bit for bit, without its
    overhead (~4 us instead of ~12 us on a few hundred samples); ``a`` is reordered.

    The same steps as numpy's: partition at the middle (and at the end for floats, so a NaN
    shows there), then the mean of the one or two middle values as numpy's mean takes it
    (ints summed in float64 from 0, so -0.0 becomes 0.0; float16 summed in float32).

    Examples
    --------
    >>> float(scratch_median(np.array([3, 1, 2, 10], dtype=np.int64)))
    2.5
    >>> float(scratch_median(np.array([1.0, np.nan, 0.0])))
    nan
    """
    n = a.size
    if n == 0 or a.ndim != 1 or a.dtype.kind not in "fiu":
        return np.median(a, overwrite_input=True)  # type: ignore[no-any-return]
    h = n // 2
    floats = a.dtype.kind == "f"
    kth = [h - 1, h] if n % 2 == 0 else [h]
    if floats:
        kth.append(-1)
    a.partition(kth)
    if floats and math.isnan(a[-1]):
        return a.dtype.type(np.nan)  # type: ignore[no-any-return]
    mid = a[h : h + 1] if n % 2 else a[h - 1 : h + 1]
    # numpy's mean sums ints in float64 and float16 in float32 (two float16 values near the
    # float16 maximum would overflow their own sum), and gives floats back in their own type
    acc = None if floats and a.dtype.itemsize > 2 else (np.float32 if floats else np.float64)
    total = np.add.reduce(mid, dtype=acc)
    return (a.dtype.type if floats else np.float64)(total / mid.size)  # type: ignore[no-any-return]


def gap_threshold_ns(t_ns: IntArray) -> int:
    """The gap threshold of sorted measurement times: ``max(2 s, 20 x median step)`` in ns.

    The median of the positive steps is robust to a few outliers and to bursts.
    """
    steps = np.diff(np.asarray(t_ns, dtype=np.int64))
    positive = steps > 0
    if not positive.all():
        steps = steps[positive]
    del positive
    # the steps are scratch: the median may reorder them instead of copying them
    median = float(scratch_median(steps)) if steps.size else 0.0
    return int(max(GAP_MIN_S * NS_PER_S, GAP_FACTOR * median))


def segment_bounds(t_ns: IntArray) -> list[tuple[int, int]]:
    """Index ranges ``[start, stop)`` of the segments of sorted times ``t_ns``."""
    t = np.asarray(t_ns, dtype=np.int64)
    if t.size == 0:
        return []
    cuts = np.flatnonzero(np.diff(t) > gap_threshold_ns(t)) + 1
    edges = [0, *(int(c) for c in cuts), int(t.size)]
    return list(itertools.pairwise(edges))


def drop_isolated(t_ns: IntArray) -> NDArray[np.bool_]:
    """Mask of the samples to keep: all but those in too-short segments beside a long one."""
    keep = np.ones(np.asarray(t_ns).size, dtype=bool)
    bounds = segment_bounds(t_ns)
    if not bounds or max(b - a for a, b in bounds) < MIN_SEGMENT_SAMPLES:
        return keep
    for a, b in bounds:
        if b - a < MIN_SEGMENT_SAMPLES:
            keep[a:b] = False
    return keep


def _reach_ns(meas_t_ns: IntArray) -> int:
    return max(int(COMMAND_REACH_S * NS_PER_S), gap_threshold_ns(meas_t_ns))


def drop_far_commands(cmd_t_ns: IntArray, meas_t_ns: IntArray) -> NDArray[np.bool_]:
    """Mask of the commands within reach of a measurement segment (all when none exists)."""
    cmd = np.asarray(cmd_t_ns, dtype=np.int64)
    meas = np.asarray(meas_t_ns, dtype=np.int64)
    keep = np.zeros(cmd.size, dtype=bool)
    if meas.size == 0:
        return ~keep
    reach = _reach_ns(meas)
    for a, b in segment_bounds(meas):
        lo, hi = int(meas[a]) - reach, int(meas[b - 1]) + reach
        keep |= (cmd >= lo) & (cmd <= hi)
    return keep


def command_windows(cmd_t_ns: IntArray, meas_t_ns: IntArray) -> list[tuple[int, int]]:
    """Command index ranges ``[start, stop)`` that belong to each measurement segment.

    A segment's commands are those within reach of its measurements and on its side of the
    middle of each neighbouring gap, so the ranges never overlap and never span a gap.
    """
    cmd = np.asarray(cmd_t_ns, dtype=np.int64)
    meas = np.asarray(meas_t_ns, dtype=np.int64)
    bounds = segment_bounds(meas)
    reach = _reach_ns(meas)
    out = []
    for k, (a, b) in enumerate(bounds):
        lo = int(meas[a]) - reach
        hi = int(meas[b - 1]) + reach
        if k > 0:
            prev_end = int(meas[bounds[k - 1][1] - 1])
            lo = max(lo, prev_end + (int(meas[a]) - prev_end) // 2 + 1)
        if k + 1 < len(bounds):
            nxt = int(meas[bounds[k + 1][0]])
            hi = min(hi, int(meas[b - 1]) + (nxt - int(meas[b - 1])) // 2)
        c0 = int(np.searchsorted(cmd, lo, side="left"))
        c1 = int(np.searchsorted(cmd, hi, side="right"))
        out.append((c0, c1))
    return out


def drop_outliers(
    t: IntArray, cols: dict[str, np.ndarray], topic: str, warnings: list[str]
) -> tuple[IntArray, dict[str, np.ndarray]]:
    """Drop far stamp outliers of sorted times (see :func:`drop_isolated`), with a note."""
    keep = drop_isolated(t)
    if keep.all():
        return t, cols
    bad = int(keep.size - np.count_nonzero(keep))
    gap_s = seconds(gap_threshold_ns(t[keep]))
    warnings.append(
        f"dropped {bad} of {keep.size} samples of topic '{topic}' whose stamps lie far "
        f"outside the recording (more than {gap_s:.3g} s from all other samples, a corrupt "
        "stamp)"
    )
    return t[keep], {k: v[keep] for k, v in cols.items()}
