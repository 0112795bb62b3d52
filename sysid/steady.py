"""A log's own odometry noise, measured where the robot runs steady, with no model.

Where a non-zero command has been held for over :data:`STEADY_AFTER_S` (past the delay and the
rise), the robot runs steady and what the measurement does about its level (the median of that
stretch) is the measurement's noise: its robust sd (MAD) per axis, the statistic the fit uses
on its residuals. :func:`steady_stretches` is the one labeller of steady stretches, for this
module and for the calibration's within-stretch scatter. The noise describes the odometry
source (encoders and their rate, a pose-derived or a twist velocity, a gyro), not the drive
model: the same base logged through another source shows another noise. A log with fewer than
:data:`MIN_STEADY_SAMPLES` such samples cannot tell its noise.

Examples
--------
>>> import numpy as np
>>> t = np.arange(0.0, 20.0, 0.1)
>>> rng = np.random.default_rng(0)
>>> own = steady_noise(t, np.full(t.size, 0.2), np.zeros(t.size),
...                    0.2 + rng.normal(0.0, 0.01, t.size), rng.normal(0.0, 0.05, t.size))
>>> own.measured, round(own.std_v_mps, 2), round(own.std_w_radps, 2)
(True, 0.01, 0.05)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "MIN_STEADY_SAMPLES",
    "STEADY_AFTER_S",
    "SteadyNoise",
    "held_at_zero_noise",
    "motion_noise",
    "pooled_steady_noise",
    "robust_sd",
    "steady_noise",
    "steady_stretches",
]


@dataclass(frozen=True, kw_only=True)
class SteadyNoise:
    """A log's own odometry noise, measured where it runs steady (:func:`steady_noise`):
    ``std_v_mps`` and ``std_w_radps``, the robust sd of the measured v (m/s) and w (rad/s)
    about their steady level (NaN when the log has too few steady samples), over
    ``n_samples`` steady samples. ``method`` says how it was measured: ``"steady"`` here,
    ``"high-frequency"`` by :func:`sysid.hfnoise.highfreq_noise` (``n_samples`` its stencils),
    joined with ``"+"`` when pooled over both."""

    std_v_mps: float
    std_w_radps: float
    n_samples: int
    method: str = "steady"

    @property
    def measured(self) -> bool:
        """True when the log has :data:`MIN_STEADY_SAMPLES` steady samples or more."""
        return self.n_samples >= MIN_STEADY_SAMPLES


#: A non-zero command held this long has settled: past the command delay and the rise of the
#: bases of the development set (delays 0.1-0.3 s, rise times under 0.5 s), s.
STEADY_AFTER_S = 1.0
#: Fewer steady samples than this do not measure a log's own noise.
MIN_STEADY_SAMPLES = 30
#: A steady stretch needs this many samples for its level (median) to stand.
MIN_STRETCH = 5


def steady_stretches(since_step_s: ArrayLike, steady: ArrayLike) -> np.ndarray:
    """A label per ``steady`` sample naming its stretch: the run of steady samples after one
    command step (a new stretch where the time since the step stops growing or a sample
    between is not steady).

    Examples
    --------
    >>> since = np.array([1.0, 1.2, 0.1, 1.1, 1.3, 1.5, 0.2, 1.0])
    >>> steady_stretches(since, since >= 1.0).tolist()
    [0, 0, 2, 2, 2, 4]
    """
    since = np.asarray(since_step_s, dtype=np.float64)
    mask = np.asarray(steady, dtype=bool)
    new = np.ones(since.size, dtype=bool)
    new[1:] = ~(np.diff(since) > 0.0) | ~mask[:-1]
    out: np.ndarray = (np.cumsum(new) - 1)[mask]
    return out


def _steady(t: np.ndarray, cmd_v: np.ndarray, cmd_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mask of the samples under a non-zero command held for over
    :data:`STEADY_AFTER_S`, and their stretch labels (:func:`steady_stretches`)."""
    change = np.ones(t.size, dtype=bool)
    change[1:] = (np.diff(cmd_v) != 0) | (np.diff(cmd_w) != 0)
    held_s = t - t[change][np.cumsum(change) - 1]
    steady = (held_s > STEADY_AFTER_S) & ((cmd_v != 0) | (cmd_w != 0))
    return steady, steady_stretches(held_s, steady)


def steady_noise(
    meas_t_s: ArrayLike, cmd_v: ArrayLike, cmd_w: ArrayLike, meas_v: ArrayLike, meas_w: ArrayLike
) -> SteadyNoise:
    """The odometry noise of one log (module docstring).

    Parameters
    ----------
    meas_t_s, cmd_v, cmd_w, meas_v, meas_w : array_like
        Per measurement: its time (s, increasing), the command held then (m/s, rad/s) and
        the measured v (m/s) and w (rad/s).

    Returns
    -------
    SteadyNoise
        NaN sds when the log has fewer than :data:`MIN_STEADY_SAMPLES` steady samples.
    """
    t = np.asarray(meas_t_s, dtype=np.float64)
    steady, ids = _steady(
        t, np.asarray(cmd_v, dtype=np.float64), np.asarray(cmd_w, dtype=np.float64)
    )
    keep = np.ones(ids.size, dtype=bool)
    (sd_v, n), (sd_w, _) = (_stretch_sd(y, steady, ids, keep) for y in (meas_v, meas_w))
    if n < MIN_STEADY_SAMPLES:
        return SteadyNoise(std_v_mps=math.nan, std_w_radps=math.nan, n_samples=n)
    return SteadyNoise(std_v_mps=sd_v, std_w_radps=sd_w, n_samples=n)


def _stretch_sd(
    y: ArrayLike, steady: np.ndarray, ids: np.ndarray, keep: np.ndarray
) -> tuple[float, int]:
    """Robust sd (MAD) of ``y`` about its stretch medians over the ``keep`` steady samples of
    stretches of :data:`MIN_STRETCH` or more, and their number (NaN sd for none)."""
    ys = np.asarray(y, dtype=np.float64)[steady][keep]
    _, index, counts = np.unique(ids[keep], return_inverse=True, return_counts=True)
    long_enough = counts[index] >= MIN_STRETCH
    n = int(long_enough.sum())
    if n == 0:
        return math.nan, 0
    level = np.array([np.median(ys[index == k]) for k in range(counts.size)])
    dev = (ys - level[index])[long_enough]
    return robust_sd(dev), n


def motion_noise(
    meas_t_s: ArrayLike, cmd_v: ArrayLike, cmd_w: ArrayLike, meas_v: ArrayLike, meas_w: ArrayLike
) -> tuple[SteadyNoise, SteadyNoise]:
    """The log's noise of each axis where that axis is commanded to move, and where it is not.

    :func:`steady_noise` pools every steady stretch, but an axis held at zero reads far less
    noise than one that moves (a Neato's v while it spins in place reads 0 to the bit; its v
    while driving scatters by ~1 cm/s). Returns ``(moving, still)``: ``moving.std_v_mps`` over
    the steady stretches whose ``cmd_v`` is not 0, ``moving.std_w_radps`` over those whose
    ``cmd_w`` is not 0, ``still`` over the others (the other axis moving). An axis with fewer
    than :data:`MIN_STEADY_SAMPLES` samples of its class has a NaN sd; ``n_samples`` is the
    smaller count of the two axes.

    Examples
    --------
    >>> t = np.arange(0.0, 40.0, 0.1)
    >>> spin = t >= 20.0  # drive straight, then spin in place
    >>> cmd_v, cmd_w = np.where(spin, 0.0, 0.3), np.where(spin, 1.0, 0.0)
    >>> rng = np.random.default_rng(0)
    >>> meas_v = np.where(spin, 0.0, 0.3 + rng.normal(0.0, 0.01, t.size))
    >>> moving, still = motion_noise(t, cmd_v, cmd_w, meas_v, cmd_w)
    >>> round(moving.std_v_mps, 2), still.std_v_mps
    (0.01, 0.0)
    """
    t = np.asarray(meas_t_s, dtype=np.float64)
    cv, cw = np.asarray(cmd_v, dtype=np.float64), np.asarray(cmd_w, dtype=np.float64)
    steady, ids = _steady(t, cv, cw)
    out = []
    for moves in (True, False):
        sds = []
        for y, cmd in ((meas_v, cv), (meas_w, cw)):
            sd, n = _stretch_sd(y, steady, ids, (cmd[steady] != 0) == moves)
            sds.append((sd if n >= MIN_STEADY_SAMPLES else math.nan, n))
        (sd_v, n_v), (sd_w, n_w) = sds
        out.append(SteadyNoise(std_v_mps=sd_v, std_w_radps=sd_w, n_samples=min(n_v, n_w)))
    return out[0], out[1]


def robust_sd(x: ArrayLike) -> float:
    """The sd of Gaussian samples estimated robustly: 1.4826 x the median absolute deviation
    from the median (NaN for no samples).

    Examples
    --------
    >>> round(robust_sd(np.random.default_rng(0).normal(0.0, 0.02, 10_000)), 3)
    0.02
    """
    a = np.asarray(x, dtype=np.float64)
    if a.size == 0:
        return math.nan
    return float(1.4826 * np.median(np.abs(a - np.median(a))))


def held_at_zero_noise(
    meas_t_s: ArrayLike, cmd_v: ArrayLike, cmd_w: ArrayLike, meas_v: ArrayLike, meas_w: ArrayLike
) -> SteadyNoise:
    """The log's scatter of each axis about zero where that axis is held at zero and the other
    moves (steady stretches, as :func:`motion_noise`): a robust sd (1.4826 x the median of
    |y|) about zero, not about the stretch's level. Spinning in place, a drive model's v is
    exactly zero; the odometry's v is not (the wheels turn at not quite opposite speeds),
    and that offset is the band's to cover as much as the scatter about it. An axis with fewer
    than :data:`MIN_STEADY_SAMPLES` such samples has a NaN sd; ``n_samples`` is the smaller
    count of the two axes.

    Examples
    --------
    >>> t = np.arange(0.0, 20.0, 0.1)
    >>> spin = np.ones(t.size)
    >>> off = held_at_zero_noise(t, 0 * t, spin, np.full(t.size, 0.002), spin)
    >>> round(off.std_v_mps, 4), off.std_w_radps
    (0.003, nan)
    """
    t = np.asarray(meas_t_s, dtype=np.float64)
    cv, cw = np.asarray(cmd_v, dtype=np.float64), np.asarray(cmd_w, dtype=np.float64)
    steady, _ = _steady(t, cv, cw)
    sds = []
    for y, cmd in ((meas_v, cv), (meas_w, cw)):
        held = np.asarray(y, dtype=np.float64)[steady & (cmd == 0)]
        n = int(held.size)
        sds.append(
            (1.4826 * float(np.median(np.abs(held))) if n >= MIN_STEADY_SAMPLES else math.nan, n)
        )
    (sd_v, n_v), (sd_w, n_w) = sds
    return SteadyNoise(std_v_mps=sd_v, std_w_radps=sd_w, n_samples=min(n_v, n_w))


def pooled_steady_noise(noises: Sequence[SteadyNoise]) -> SteadyNoise:
    """The noise of several logs of one source: the variances of the measured ones pooled by
    their steady samples (NaN, 0 samples, when none is measured).

    Examples
    --------
    >>> a = SteadyNoise(std_v_mps=0.01, std_w_radps=0.02, n_samples=100)
    >>> b = SteadyNoise(std_v_mps=math.nan, std_w_radps=math.nan, n_samples=3)
    >>> pooled_steady_noise([a, b]) == a
    True
    """
    own = [n for n in noises if n.measured]
    if not own:
        return SteadyNoise(std_v_mps=math.nan, std_w_radps=math.nan, n_samples=0)
    methods = "+".join(sorted({part for n in own for part in n.method.split("+")}, reverse=True))
    weights = np.array([n.n_samples for n in own], dtype=np.float64)
    return SteadyNoise(
        std_v_mps=float(np.sqrt(np.average([n.std_v_mps**2 for n in own], weights=weights))),
        std_w_radps=float(np.sqrt(np.average([n.std_w_radps**2 for n in own], weights=weights))),
        n_samples=int(weights.sum()),
        method=methods,
    )
