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
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "MIN_STEADY_SAMPLES",
    "MOVING_SPEEDS",
    "SPEED_NOISE_PARTS",
    "SPEED_SPREAD",
    "STEADY_AFTER_S",
    "SpeedNoise",
    "SteadyNoise",
    "difference_sd",
    "held_at_zero_noise",
    "measurement_lead_s",
    "motion_noise",
    "pooled_steady_noise",
    "robust_sd",
    "speed_bins",
    "speed_noise",
    "steady_noise",
    "steady_samples",
    "steady_stretches",
    "variance_law",
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


def steady_samples(
    t: np.ndarray, cmd_v: np.ndarray, cmd_w: np.ndarray, ahead_s: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """The mask of the samples under a non-zero command held for over
    :data:`STEADY_AFTER_S` (and for ``ahead_s`` more after them), and their stretch labels
    (:func:`steady_stretches`).

    Examples
    --------
    >>> t = np.arange(0.0, 3.0, 0.5)
    >>> mask, labels = steady_samples(t, np.r_[0.0, 0.2, 0.2, 0.2, 0.2, 0.3], np.zeros(6))
    >>> mask.tolist(), labels.tolist()
    ([False, False, False, False, True, False], [4])
    """
    change = np.ones(t.size, dtype=bool)
    change[1:] = (np.diff(cmd_v) != 0) | (np.diff(cmd_w) != 0)
    step = np.cumsum(change) - 1
    held_s = t - t[change][step]
    steady = (held_s > STEADY_AFTER_S) & ((cmd_v != 0) | (cmd_w != 0))
    if ahead_s > 0.0:
        steady &= np.r_[t[change][1:], np.inf][step] - t > ahead_s
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
    steady, ids = steady_samples(
        t, np.asarray(cmd_v, dtype=np.float64), np.asarray(cmd_w, dtype=np.float64)
    )
    keep = np.ones(ids.size, dtype=bool)
    (sd_v, n), (sd_w, _) = (_stretch_sd(y, steady, ids, keep) for y in (meas_v, meas_w))
    if n < MIN_STEADY_SAMPLES:
        return SteadyNoise(std_v_mps=math.nan, std_w_radps=math.nan, n_samples=n)
    return SteadyNoise(std_v_mps=sd_v, std_w_radps=sd_w, n_samples=n)


def _stretch_deviations(
    y: ArrayLike, steady: np.ndarray, ids: np.ndarray, keep: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The deviations of the ``keep`` steady samples of ``y`` from their stretch's median, over
    stretches of :data:`MIN_STRETCH` or more, and that median at each of them."""
    ys = np.asarray(y, dtype=np.float64)[steady][keep]
    _, index, counts = np.unique(ids[keep], return_inverse=True, return_counts=True)
    long_enough = counts[index] >= MIN_STRETCH
    level = np.array([np.median(ys[index == k]) for k in range(counts.size)], dtype=np.float64)
    return (ys - level[index])[long_enough], level[index][long_enough]


def _stretch_sd(
    y: ArrayLike, steady: np.ndarray, ids: np.ndarray, keep: np.ndarray
) -> tuple[float, int]:
    """Robust sd (MAD) of ``y`` about its stretch medians over the ``keep`` steady samples of
    stretches of :data:`MIN_STRETCH` or more, and their number (NaN sd for none)."""
    dev, _ = _stretch_deviations(y, steady, ids, keep)
    return (robust_sd(dev), dev.size) if dev.size else (math.nan, 0)


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
    steady, ids = steady_samples(t, cv, cw)
    out = []
    for moves in (True, False):
        sds = []
        for y, cmd in ((meas_v, cv), (meas_w, cw)):
            sd, n = _stretch_sd(y, steady, ids, (cmd[steady] != 0) == moves)
            sds.append((sd if n >= MIN_STEADY_SAMPLES else math.nan, n))
        (sd_v, n_v), (sd_w, n_w) = sds
        out.append(SteadyNoise(std_v_mps=sd_v, std_w_radps=sd_w, n_samples=min(n_v, n_w)))
    return out[0], out[1]


def robust_sd(x: ArrayLike, *, about: float | None = None) -> float:
    """The sd of Gaussian samples estimated robustly: 1.4826 x the median absolute deviation
    from the median, or from ``about`` when given (e.g. 0 for residuals centred on zero by
    construction); NaN for no samples.

    Examples
    --------
    >>> round(robust_sd(np.random.default_rng(0).normal(0.0, 0.02, 10_000)), 3)
    0.02
    >>> robust_sd([1.0, 2.0, 4.0]), robust_sd([1.0, 2.0, 4.0], about=0.0)
    (1.4826, 2.9652)
    """
    a = np.asarray(x, dtype=np.float64)
    if a.size == 0:
        return math.nan
    centre = np.median(a) if about is None else about
    return float(1.4826 * np.median(np.abs(a - centre)))


def difference_sd(x: ArrayLike) -> float:
    """The sd of white noise on a signal that changes slowly between samples, from its first
    differences: :func:`robust_sd` of the differences about zero over :math:`\\sqrt 2` (a step
    or a ramp moves few differences, so the median ignores it); NaN for fewer than 2 samples.

    Examples
    --------
    >>> x = np.r_[np.zeros(500), np.ones(500)] + np.random.default_rng(0).normal(0, 0.01, 1000)
    >>> round(difference_sd(x), 3)
    0.01
    """
    return robust_sd(np.diff(np.asarray(x, dtype=np.float64)), about=0.0) / math.sqrt(2.0)


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
    steady, _ = steady_samples(t, cv, cw)
    sds = []
    for y, cmd in ((meas_v, cv), (meas_w, cw)):
        held = np.asarray(y, dtype=np.float64)[steady & (cmd == 0)]
        n = int(held.size)
        sds.append((robust_sd(held, about=0.0) if n >= MIN_STEADY_SAMPLES else math.nan, n))
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


#: A log tells the floor of its noise from the part that grows with speed when the speeds of
#: its steady samples spread by this factor (rms speed of its fastest bin over its slowest's).
SPEED_SPREAD = 2.0

#: Speeds (v m/s, w rad/s) below which the noise's growth with speed is too small to tell
#: from its floor: a log tells the fraction only where its fastest bin moves this fast.
MOVING_SPEEDS = (0.05, 0.2)

#: The parts of a :class:`SpeedNoise`, in the words of its notes.
SPEED_NOISE_PARTS = ("floor_v_mps", "fraction_v", "floor_w_radps", "fraction_w")


@dataclass(frozen=True, kw_only=True)
class SpeedNoise:
    r"""Odometry noise that grows with speed, per axis (:func:`speed_noise`):

    .. math:: \sigma(s)^2 = \sigma_0^2 + (r\,|s|)^2,

    with :math:`s` the speed of that axis. A velocity differenced from a pose over stamps
    that jitter by :math:`\delta` is off by :math:`s\,\delta / \Delta t`: the error of a
    7 Hz pose-derived velocity is a share of the speed, which one sd per axis cannot follow
    (a log that spins at 2 rad/s reads many times the yaw noise of one that drives straight).

    Attributes
    ----------
    floor_v_mps, floor_w_radps : float
        :math:`\sigma_0`: the sd of v (m/s) and w (rad/s) at zero speed of that axis (the
        other axis may move). NaN when neither the log nor the fallback tells it.
    fraction_v, fraction_w : float
        :math:`r`: the sd per unit speed of the axis (m/s per m/s, rad/s per rad/s). NaN when
        neither the log nor the fallback tells it.
    n_v, n_w : int
        Steady samples of each axis in the log (0 when every part is the fallback's).
    told : tuple of str
        The parts (names of :data:`SPEED_NOISE_PARTS`) the log itself measured; the others
        are the fallback's (or, for a log whose steady samples all share one speed and no
        fallback, the constant noise it shows: ``fraction`` 0).

    Examples
    --------
    >>> law = SpeedNoise(floor_v_mps=0.001, fraction_v=0.05, floor_w_radps=0.005,
    ...                  fraction_w=0.06, n_v=60, n_w=60)
    >>> sd_v, sd_w = law.std_at(np.array([0.0, 0.3]), np.array([2.0, 0.0]))
    >>> sd_v.round(4).tolist(), sd_w.round(4).tolist()
    ([0.001, 0.015], [0.1201, 0.005])
    """

    floor_v_mps: float
    fraction_v: float
    floor_w_radps: float
    fraction_w: float
    n_v: int = 0
    n_w: int = 0
    told: tuple[str, ...] = ()

    def std_at(self, v: ArrayLike, w: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The noise sd at speeds ``v`` (m/s) and ``w`` (rad/s): m/s and rad/s (an unknown
        fraction counts as 0, an unknown floor gives NaN)."""
        return (
            np.hypot(self.floor_v_mps, _known(self.fraction_v) * np.abs(np.asarray(v, float))),
            np.hypot(self.floor_w_radps, _known(self.fraction_w) * np.abs(np.asarray(w, float))),
        )


def measurement_lead_s(measurement: Any) -> float:
    """How early a log's measured velocity sees a change of motion, s: half the window of a
    pose derivative (:class:`robots.measurement.MeasurementModel` of kind ``"pose"``), else 0.

    Examples
    --------
    >>> measurement_lead_s(None)
    0.0
    """
    if getattr(measurement, "kind", None) != "pose":
        return 0.0
    return 0.5 * float(measurement.window_s)


def _known(x: float) -> float:
    return x if math.isfinite(x) else 0.0


def speed_noise(
    logs: Sequence[tuple[ArrayLike, ArrayLike, ArrayLike, ArrayLike, ArrayLike]],
    *,
    fallback: SpeedNoise | None = None,
    ahead_s: float = 0.0,
) -> SpeedNoise:
    r"""The :class:`SpeedNoise` of one or more logs of one odometry source.

    Each axis's steady samples (:func:`steady_noise`'s stretches, under a non-zero command
    held over :data:`STEADY_AFTER_S`, the axis's own command zero or not) give their
    deviation from their stretch's median and that median's size as the speed. Sorted by
    speed into bins of :data:`MIN_STEADY_SAMPLES`, the bins' robust variances are
    :math:`\sigma_0^2 + r^2 \overline{s^2}` (:func:`variance_law`). What the log can tell:

    - both parts, when it has two bins or more whose rms speeds spread by
      :data:`SPEED_SPREAD`, the fastest at :data:`MOVING_SPEEDS` or more (e.g. an axis held
      at zero while the other moves, whose speed counts as 0, and moving);
    - the floor alone, when every steady sample holds the axis at zero (or moves it slower
      than :data:`MOVING_SPEEDS`): the fraction is the fallback's (the fit logs', as the
      per-motion rule takes them);
    - one speed's noise alone (the axis moves at about one speed): the floor is the
      fallback's (at most that noise) and the fraction the rest; with no fallback floor, the
      constant noise it shows (fraction 0);
    - nothing, with fewer than :data:`MIN_STEADY_SAMPLES` steady samples of the axis: the
      fallback's parts (NaN without one).

    Parameters
    ----------
    logs : sequence of (meas_t_s, cmd_v, cmd_w, meas_v, meas_w)
        Per log and measurement: its time (s, increasing), the command held then (m/s,
        rad/s), the measured v (m/s) and w (rad/s).
    fallback : SpeedNoise, optional
        The parts a log cannot tell (the fit logs' law: ``settings.measurement_noise``).
    ahead_s : float
        A steady sample also needs its command held this long after it, s: a velocity
        derived from the pose over a centred window of width :math:`W` sees the next
        command's motion :math:`W/2` early (:func:`measurement_lead_s`), which reads as noise.

    Returns
    -------
    SpeedNoise

    Examples
    --------
    >>> t = np.arange(0.0, 40.0, 0.1)
    >>> spin = t >= 20.0  # drive straight at 0.3 m/s, then spin at 2 rad/s
    >>> rng = np.random.default_rng(0)
    >>> cmd_v, cmd_w = np.where(spin, 0.0, 0.3), np.where(spin, 2.0, 0.0)
    >>> meas_w = cmd_w + rng.normal(0.0, np.hypot(0.005, 0.06 * cmd_w))
    >>> law = speed_noise([(t, cmd_v, cmd_w, cmd_v, meas_w)])
    >>> round(law.floor_w_radps, 3), round(law.fraction_w, 2), law.told[-2:]
    (0.005, 0.06, ('floor_w_radps', 'fraction_w'))
    """
    axes: list[tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]] = [
        ([], [], []),
        ([], [], []),
    ]
    for meas_t_s, cmd_v, cmd_w, meas_v, meas_w in logs:
        t = np.asarray(meas_t_s, dtype=np.float64)
        cv, cw = np.asarray(cmd_v, dtype=np.float64), np.asarray(cmd_w, dtype=np.float64)
        steady, ids = steady_samples(t, cv, cw, ahead_s)
        for (devs, speeds, still), y, cmd in zip(axes, (meas_v, meas_w), (cv, cw), strict=True):
            for held_at_zero in (False, True):
                dev, level = _stretch_deviations(y, steady, ids, (cmd[steady] == 0) == held_at_zero)
                devs.append(dev)
                # an axis held at zero stands: its level's offset from 0 is no speed
                speeds.append(0.0 * level if held_at_zero else np.abs(level))
                still.append(np.full(dev.size, held_at_zero))
    parts: dict[str, float] = {}
    told: list[str] = []
    counts = []
    for (devs, speeds, still), floor_name, fraction_name, moving in zip(
        axes, SPEED_NOISE_PARTS[::2], SPEED_NOISE_PARTS[1::2], MOVING_SPEEDS, strict=True
    ):
        dev, speed = np.concatenate(devs), np.concatenate(speeds)
        known = (
            (getattr(fallback, floor_name), getattr(fallback, fraction_name))
            if fallback is not None
            else (math.nan, math.nan)
        )
        (floor, fraction), shown = _axis_law(dev, speed, np.concatenate(still), known, moving)
        parts[floor_name], parts[fraction_name] = floor, fraction
        told += [name for name, own in zip((floor_name, fraction_name), shown, strict=True) if own]
        counts.append(int(dev.size) if dev.size >= MIN_STEADY_SAMPLES else 0)
    return SpeedNoise(**parts, n_v=counts[0], n_w=counts[1], told=tuple(told))


def _axis_law(
    dev: np.ndarray,
    speed: np.ndarray,
    still: np.ndarray,
    fallback: tuple[float, float],
    moving: float,
) -> tuple[tuple[float, float], tuple[bool, bool]]:
    """(floor, fraction) of one axis (:func:`speed_noise`'s rules) and which of the two the
    deviations told; ``still`` marks the samples whose axis is held at zero, ``moving`` is
    the axis's :data:`MOVING_SPEEDS`."""
    if dev.size < MIN_STEADY_SAMPLES:
        return fallback, (False, False)
    bins = speed_bins(speed, MIN_STEADY_SAMPLES, classes=still)
    rms = sorted(math.sqrt(float(np.mean(speed[b] ** 2))) for b in bins)
    if len(bins) > 1 and rms[-1] >= moving and rms[-1] >= SPEED_SPREAD * rms[0]:
        c0, c1 = variance_law(
            dev, speed, bin_samples=MIN_STEADY_SAMPLES, classes=still, refine=True
        )
        return (math.sqrt(c0), math.sqrt(c1)), (True, True)
    sd = robust_sd(dev)
    if still.all() or rms[-1] < moving:  # the floor; the fraction is the fallback's
        return (sd, fallback[1]), (True, False)
    if not math.isfinite(fallback[0]):  # one speed, nothing to split it by: a constant
        return (sd, 0.0), (False, False)
    floor = min(fallback[0], sd)
    s = math.sqrt(float(np.mean(speed**2)))
    return (floor, math.sqrt(sd**2 - floor**2) / s), (False, True)


def speed_bins(
    speeds: ArrayLike, bin_samples: int, *, classes: ArrayLike | None = None
) -> list[np.ndarray]:
    """Indices of ``speeds`` in bins of consecutive speeds, ``bin_samples`` or more each (one
    bin when there are fewer); with ``classes``, each class is binned on its own (no bin
    mixes two: a robust variance of a mixture of two noises is neither's).

    Examples
    --------
    >>> [b.tolist() for b in speed_bins([0.3, 0.0, 0.1, 0.2], 2)]
    [[1, 2], [3, 0]]
    >>> [b.tolist() for b in speed_bins([0.3, 0.0, 0.1, 0.2], 2, classes=[0, 0, 1, 1])]
    [[1, 0], [2, 3]]
    """
    a = np.asarray(speeds, dtype=np.float64)
    labels = np.zeros(a.size, dtype=np.int64) if classes is None else np.asarray(classes)
    out: list[np.ndarray] = []
    for label in np.unique(labels):
        members = np.flatnonzero(labels == label)
        order = members[np.argsort(a[members], kind="stable")]
        out += np.array_split(order, max(order.size // bin_samples, 1))
    return out


def variance_law(
    values: ArrayLike,
    speeds: ArrayLike,
    *,
    bin_samples: int,
    variance_floor: float = 0.0,
    classes: ArrayLike | None = None,
    refine: bool = False,
) -> tuple[float, float]:
    r"""The coefficients :math:`c_0, c_1` of :math:`\operatorname{var}(x) = c_0 + c_1 s^2`:
    zero-mean ``values`` :math:`x` whose spread grows with ``speeds`` :math:`s` (a speed, or
    any rate).

    The values are sorted by :math:`s` into bins of ``bin_samples`` or more
    (:func:`speed_bins`, per class of ``classes``); each bin's robust variance
    (:func:`robust_sd` squared) is :math:`c_0 + c_1 \overline{s^2}`, fitted by non-negative
    least squares in relative terms (a bin's variance is known to a relative error of about
    one over the root of its size, and to no better than ``variance_floor``). One bin:
    :math:`c_1 = 0`. NaN, NaN without values. Weighted by each bin's own variance, a bin that
    reads low by chance weighs more, and the law comes out low (by ~15 % in :math:`c_1` at 30
    samples a bin); ``refine`` weighs the bins by the law once fitted instead (two passes),
    which removes that bias.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> s = rng.uniform(0.0, 3.0, 4000)
    >>> c0, c1 = variance_law(rng.normal(0.0, np.hypot(0.01, 0.04 * s)), s, bin_samples=100)
    >>> round(math.sqrt(c0), 3), round(math.sqrt(c1), 3)
    (0.009, 0.039)
    """
    x = np.asarray(values, dtype=np.float64)
    a = np.asarray(speeds, dtype=np.float64)
    if x.size == 0:
        return math.nan, math.nan
    bins = speed_bins(a, bin_samples, classes=classes)
    scale = np.array([robust_sd(x[b]) ** 2 for b in bins])
    rows = np.array([[1.0, float(np.mean(a[b] ** 2))] for b in bins])
    floor = max(variance_floor, 1e-6 * float(scale.max()))
    if len(bins) == 1 or floor == 0.0:
        return float(scale[0]), 0.0
    sizes = np.sqrt([b.size for b in bins])
    c = _nonnegative_lstsq(rows * (sizes / np.maximum(scale, floor))[:, None], scale * sizes
                           / np.maximum(scale, floor))  # fmt: skip
    for _ in range(2 if refine else 0):
        weight = sizes / np.maximum(rows @ np.array(c), floor)
        c = _nonnegative_lstsq(rows * weight[:, None], scale * weight)
    return c


def _nonnegative_lstsq(a: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Least squares of two coefficients, both >= 0 (the exact non-negative solution).

    The unconstrained solution where both are >= 0; otherwise the better of the two
    one-coefficient fits (the other at 0), each clipped at 0: the optimum of a convex problem
    with two bounds lies in one of those faces. numpy only, which keeps ``agree`` free of scipy.
    """
    x, *_ = np.linalg.lstsq(a, y, rcond=None)
    if x[0] >= 0.0 and x[1] >= 0.0:
        return float(x[0]), float(x[1])
    best = (0.0, 0.0)
    best_cost = float(y @ y)
    for j in (0, 1):
        col = a[:, j]
        norm = float(col @ col)
        c = max(float(col @ y) / norm, 0.0) if norm > 0.0 else 0.0
        cost = float(np.sum((y - c * col) ** 2))
        if cost < best_cost:
            best, best_cost = ((c, 0.0) if j == 0 else (0.0, c)), cost
    return best
