r"""Identify a 2-D lidar's noise, invalid returns, timing and mounting yaw from a recording.

:func:`estimate_sensor` takes the scans and the odometry poses of one or more recordings
(:class:`ScanArrays`, :class:`PoseArrays`; reading them from a log is the caller's job) and
returns a :class:`SensorEstimate` with 95 % intervals:

Range noise
    In *still stretches* (odometry pose unchanged over the scan and half a second around it)
    each beam sees one surface; the spread of its returns from scan to scan is the noise. Per
    beam and stretch, returns further than ``max(5 cm, 6 x 1.4826 MAD)`` from the median are
    set aside (spurious returns), the sample variance of the rest with ``n - 1`` degrees of
    freedom is one observation of :math:`\sigma(r)^2` at the median range ``r``, and the
    model :math:`\sigma(r) = \sigma_0 + \sigma_1 r + \sigma_2 r^2` (all >= 0; a triangulation
    sensor's error grows with the square of range) is fitted by maximum likelihood (Fisher
    scoring), after dropping the groups beyond the 99.9 % chi-square quantile of the median
    variance of their range bin (mixed returns at edges).
Range noise while moving
    Consecutive scans that are not both still are matched and each return of the later one is
    compared with the earlier one's range at the same bearing (:mod:`sysid._scannoise`); the
    squared residuals over their variance factor, summed per fine range bin, are fitted with
    the same model. With still stretches this is a check (``moving_noise_std_m``); without
    any it gives the noise model (``noise_source="moving"``), its band widened in quadrature
    by 3 % for the approximations of comparing two moving scans.
Invalid returns
    A return is invalid when it is NaN, infinite, ``<= 0``, below ``range_min_m`` or at or
    beyond ``range_max_m``. In still stretches a beam "has a surface" when at least 3 and 30 %
    of its returns are valid; the invalid fraction over such beams is the dropout rate, given
    overall, per range bin (median range of the beam) and per beam. Returns more than the
    outlier gate *shorter* than the median are the spurious short returns.
Timing and mounting yaw
    Consecutive scans are matched (point-to-line ICP, odometry as the initial guess). The yaw
    increments of the matches are compared with the odometry's yaw increments between the
    scan stamps shifted by ``time_offset_s`` (the odometry yaw scale is fitted alongside, so
    a gyro or wheel scale error does not bias the offset); the offset is the best of a 2 ms
    grid over +-0.4 s refined by a parabola. The mounting yaw is the angle between the
    matched translations and the odometry translations of the lidar's mount point.
Uncertainty
    Percentile intervals of a bootstrap: beams resampled (noise, dropout: all stretches of a
    beam move together) and blocks of 10 consecutive scan pairs (timing, yaw).

What a recording does not excite is named in :attr:`SensorEstimate.unidentified` and the
matching fields are NaN: no still stretch (dropout; the noise too unless moving scans give
it), no change of yaw rate (offset), no translation (mounting yaw).

Examples
--------
>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> angles = np.linspace(-np.pi, np.pi, 360, endpoint=False)
>>> truth = 2.0 + np.cos(3 * angles)  # a static scene seen from a still robot
>>> ranges = truth + rng.normal(0.0, 0.01, (50, 360))
>>> scans = ScanArrays(t_s=np.arange(50) * 0.2, ranges_m=ranges, angle_min_rad=-np.pi,
...                    angle_increment_rad=2 * np.pi / 360, range_min_m=0.06, range_max_m=5.0)
>>> odom = PoseArrays(t_s=np.arange(-10, 120) * 0.1, x_m=np.zeros(130), y_m=np.zeros(130),
...                   yaw_rad=np.zeros(130))
>>> est = estimate_sensor(scans, odom, n_boot=50)
>>> bool(0.009 < est.noise_std_at(2.0) < 0.011)
True
>>> any("time_offset_s" in note for note in est.unidentified)
True
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray
from scipy.stats import chi2

from robots.arrays import BoolArray, FloatArray
from robots.files import atomic_write
from sysid._scanmatch import (
    Pose,
    compose,
    invert,
    match_scans,
    scan_points,
    translation_conditioning,
)
from sysid._scannoise import PairResiduals, pair_residuals
from sysid.errors import ExcitationError, ResultFileError, SysidValueError
from sysid.steady import robust_sd

__all__ = [
    "FORMAT",
    "DepthEstimate",
    "PoseArrays",
    "ScanArrays",
    "SensorEstimate",
    "StillSpread",
    "estimate_depth",
    "estimate_sensor",
    "load_sensor",
    "still_spread",
    "still_stretches",
]

Interval = tuple[float, float]

#: The ``format`` key of a sensor result file.
FORMAT = "sim2real.sysid.sensors/1"
_STILL_TRANS_M = 0.003
_STILL_YAW_RAD = 0.003
_STILL_MARGIN_S = 0.5
_MIN_STRETCH = 5
_GATE_FLOOR_M = 0.05
_MAX_PAIR_GAP_S = 1.0
_STRIDE = 3
_OFFSET_SPAN_S = 0.4
_OFFSET_STEP_S = 0.002
_MAX_OFFSET_CI_S = 0.3
_BLOCK = 10
_MIN_TRANS_M = 0.02
_MIN_TRANSLATING = 20
_MIN_CONDITIONING = 0.1
_N_BINS = 6
_SIGMA_FLOOR_M = 1e-4
_NAN_PAIR = (math.nan, math.nan)
_MIN_RESIDUALS = 200
_GATE_BINS = 20
_GATE_SIGMAS = 5.0
_FIT_BINS = 30
_MOVING_SYS = 0.03
_DEPTH_MIXED_BINS = 30


@dataclass(frozen=True, kw_only=True)
class ScanArrays:
    """Lidar scans of one recording (ROS ``LaserScan`` conventions).

    Attributes
    ----------
    t_s : ndarray, shape (n,)
        Scan stamps, s (the same clock as the odometry).
    ranges_m : ndarray, shape (n, beams)
        Ranges, m, invalid returns as recorded (NaN, inf, 0, beyond the limits).
    angle_min_rad, angle_increment_rad : float
        Angle of beam 0 and between beams in the lidar frame, rad.
    range_min_m, range_max_m : float
        The sensor's valid range interval, m.
    """

    t_s: FloatArray
    ranges_m: FloatArray
    angle_min_rad: float
    angle_increment_rad: float
    range_min_m: float
    range_max_m: float

    @property
    def angles_rad(self) -> FloatArray:
        """Beam angles in the lidar frame, rad."""
        beams = self.ranges_m.shape[1]
        return self.angle_min_rad + self.angle_increment_rad * np.arange(beams, dtype=np.float64)

    def valid(self) -> BoolArray:
        """Which returns are valid (finite, > 0, within the range limits)."""
        r = self.ranges_m
        with np.errstate(invalid="ignore"):
            return np.isfinite(r) & (r > 0.0) & (r >= self.range_min_m) & (r < self.range_max_m)


@dataclass(frozen=True, kw_only=True)
class PoseArrays:
    """Odometry poses of one recording: stamps (s) and planar pose (m, rad)."""

    t_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    yaw_rad: FloatArray

    def at(self, t_s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The pose linearly interpolated at ``t_s`` (yaw unwrapped first), held at the ends."""
        yaw = np.unwrap(self.yaw_rad)
        return (
            np.interp(t_s, self.t_s, self.x_m),
            np.interp(t_s, self.t_s, self.y_m),
            np.interp(t_s, self.t_s, yaw),
        )


@dataclass(frozen=True, kw_only=True)
class NoiseModel:
    """A range sensor's noise model and invalid-return rate; every ``*_ci`` is a 95 % interval.

    Attributes
    ----------
    noise_std_0_m, noise_std_per_m, noise_std_per_m2 : float
        The noise model :math:`\\sigma(r) = \\sigma_0 + \\sigma_1 r + \\sigma_2 r^2` (m, m/m
        and 1/m) against range (a lidar) or depth (a camera) ``r``.
    noise_range_m, noise_std_m, noise_std_lo_m, noise_std_hi_m : tuple of float
        The model at the centres of six range bins of the data, with its interval (m).
    dropout, dropout_ci : float, interval
        Fraction of invalid returns of beams (pixels) that see a surface.
    dropout_by_range : tuple of float
        The same per range bin (``noise_range_m``), NaN where no beam fell.
    """

    noise_std_0_m: float
    noise_std_0_ci: tuple[float, float]
    noise_std_per_m: float
    noise_std_per_m_ci: tuple[float, float]
    noise_std_per_m2: float
    noise_std_per_m2_ci: tuple[float, float]
    noise_range_m: tuple[float, ...]
    noise_std_m: tuple[float, ...]
    noise_std_lo_m: tuple[float, ...]
    noise_std_hi_m: tuple[float, ...]
    dropout: float
    dropout_ci: Interval
    dropout_by_range: tuple[float, ...]

    def noise_std_at(self, range_m: float) -> float:
        """The identified noise standard deviation at ``range_m``, m."""
        return (
            self.noise_std_0_m + (self.noise_std_per_m + self.noise_std_per_m2 * range_m) * range_m
        )


@dataclass(frozen=True, kw_only=True)
class SensorEstimate(NoiseModel):
    """A lidar identified from recordings; every ``*_ci`` is a 95 % interval.

    Attributes
    ----------
    beams, angle_min_rad, angle_increment_rad, range_min_m, range_max_m, scan_rate_hz
        The sensor's layout as recorded (rad, m, Hz).
    noise_std_0_m ... dropout_by_range
        The noise model and invalid-return rate (:class:`NoiseModel`).
    dropout_by_beam : tuple of float
        The same per beam, NaN where a beam never saw a surface while still.
    spurious_short, spurious_short_ci : float, interval
        Fraction of valid returns far shorter than the beam's median while still.
    time_offset_s, time_offset_ci : float, interval
        Add to the scan stamps to put them on the odometry's clock, s.
    yaw_scale : float
        Matched yaw increments over odometry yaw increments.
    mounting_yaw_rad, mounting_yaw_ci : float, interval
        Yaw of the lidar frame in base_link, rad.
    still_scans, matched_pairs : int
        Scans in still stretches and consecutive scan pairs matched.
    unidentified : tuple of str
        One sentence per quantity the recordings could not identify (its fields are NaN).
    sources : tuple of str
        Names of the recordings.
    noise_source : str
        Where the noise model comes from: ``"still"`` stretches, ``"moving"`` scan pairs (no
        still stretch) or ``"none"``.
    moving_noise_std_m, moving_noise_std_lo_m, moving_noise_std_hi_m : tuple of float
        The noise model fitted to the matched moving scan pairs alone, at ``noise_range_m``,
        with its interval (m): a check on the still stretches' model; empty when too few
        returns compared.
    moving_residuals : int
        Returns of moving scan pairs compared with the other scan of their pair.
    depth : DepthEstimate or None
        The depth camera of the same recordings, where a depth image topic was identified.
    """

    beams: int
    angle_min_rad: float
    angle_increment_rad: float
    range_min_m: float
    range_max_m: float
    scan_rate_hz: float
    dropout_by_beam: tuple[float, ...]
    spurious_short: float
    spurious_short_ci: Interval
    time_offset_s: float
    time_offset_ci: Interval
    yaw_scale: float
    mounting_yaw_rad: float
    mounting_yaw_ci: Interval
    still_scans: int
    matched_pairs: int
    unidentified: tuple[str, ...]
    sources: tuple[str, ...] = ()
    noise_source: str = "still"
    moving_noise_std_m: tuple[float, ...] = ()
    moving_noise_std_lo_m: tuple[float, ...] = ()
    moving_noise_std_hi_m: tuple[float, ...] = ()
    moving_residuals: int = 0
    depth: DepthEstimate | None = None

    def to_dict(self) -> dict[str, object]:
        """Plain YAML-ready values, with the ``format`` key."""
        return {"format": FORMAT, **_plain_fields(self)}

    def save(self, path: str | Path) -> None:
        """Write the estimate as YAML (temp file, then renamed)."""
        with atomic_write(path, "w", encoding="utf-8") as fh:
            yaml.safe_dump(self.to_dict(), fh, sort_keys=False)


@dataclass(frozen=True, kw_only=True)
class DepthEstimate(NoiseModel):
    """A depth camera's noise identified from its still frames; ``*_ci`` are 95 % intervals.

    Attributes
    ----------
    noise_std_0_m ... dropout_by_range
        The noise model against depth and the fraction of invalid pixels (NaN, inf or 0)
        among pixels that see a surface (:class:`NoiseModel`).
    topic, encoding : str
        The image topic and its encoding (``16UC1`` mm or ``32FC1`` m).
    size_px : tuple of int
        Image width and height, pixels.
    pixels, still_frames : int
        Pixels used (a regular grid) and frames in still stretches.
    """

    topic: str
    encoding: str
    size_px: tuple[int, int]
    pixels: int
    still_frames: int


def estimate_depth(
    t_s: FloatArray,
    depth_m: FloatArray,
    odom: PoseArrays,
    *,
    source: tuple[str, str, tuple[int, int]] = ("", "", (0, 0)),
    n_boot: int = 200,
    seed: int = 0,
) -> DepthEstimate | None:
    """Identify a depth camera's noise against depth and its invalid-pixel rate from the
    frames of still stretches, as the lidar's (each pixel a beam); None without a still
    stretch of five frames.

    Parameters
    ----------
    t_s : ndarray, shape (n,)
        Frame stamps on the odometry's clock, s.
    depth_m : ndarray, shape (n, pixels)
        Depth per frame and pixel, m (NaN, inf or 0: no return).
    odom : PoseArrays
        The odometry of the same recording.
    source : tuple
        Where the frames came from (kept in the result): topic, encoding and the image's
        width and height in pixels.
    n_boot, seed : int
        Bootstrap resamples (pixels) and their seed.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> truth = np.linspace(0.5, 4.0, 400)
    >>> frames = truth + rng.normal(0.0, 1.0, (30, 400)) * (0.002 * truth**2)
    >>> z = np.zeros(100)
    >>> est = estimate_depth(0.2 * np.arange(30), frames, PoseArrays(
    ...     t_s=0.1 * np.arange(100) - 2.0, x_m=z, y_m=z, yaw_rad=z), n_boot=30)
    >>> bool(abs(est.noise_std_at(3.0) / 0.018 - 1.0) < 0.15)
    True
    """
    frames = ScanArrays(
        t_s=np.asarray(t_s, dtype=np.float64),
        ranges_m=np.asarray(depth_m, dtype=np.float64),
        angle_min_rad=0.0,
        angle_increment_rad=1.0,
        range_min_m=0.0,
        range_max_m=math.inf,
    )
    still = _still_mask(frames, odom)
    groups = _groups([frames], [still])
    if groups.noise_ok.sum() < 10:
        return None
    pixels = frames.ranges_m.shape[1]
    rng = np.random.default_rng(seed)
    result = _still_estimates(groups, pixels, n_boot, rng, _DEPTH_MIXED_BINS)
    std, lo, hi = _model_fields(result.theta, result.theta_boot, result.centres, 0.0)
    boot = result.theta_boot
    return DepthEstimate(
        topic=source[0],
        encoding=source[1],
        size_px=source[2],
        pixels=pixels,
        noise_std_0_m=float(result.theta[0]),
        noise_std_0_ci=_ci(boot[:, 0]),
        noise_std_per_m=float(result.theta[1]),
        noise_std_per_m_ci=_ci(boot[:, 1]),
        noise_std_per_m2=float(result.theta[2]),
        noise_std_per_m2_ci=_ci(boot[:, 2]),
        noise_range_m=_floats(result.centres),
        noise_std_m=std,
        noise_std_lo_m=lo,
        noise_std_hi_m=hi,
        dropout=result.dropout,
        dropout_ci=_ci(result.dropout_boot),
        dropout_by_range=_floats(result.dropout_by_range),
        still_frames=int(still.sum()),
    )


def _plain_fields(obj: object) -> dict[str, object]:
    """A dataclass's fields as plain YAML values (NaN as None, tuples as lists)."""
    out: dict[str, object] = {}
    for f in dataclasses.fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, f.name)
        if isinstance(value, tuple):
            value = [v if isinstance(v, str) else _plain(v) for v in value]
        elif isinstance(value, float):
            value = _plain(value)
        elif dataclasses.is_dataclass(value):
            value = _plain_fields(value)
        out[f.name] = value
    return out


def _plain(v: float) -> float | None:
    """A float for YAML: None for NaN."""
    return None if math.isnan(float(v)) else float(v)


def load_sensor(path: str | Path) -> SensorEstimate:
    """Read a file written by :meth:`SensorEstimate.save`.

    Raises
    ------
    ResultFileError
        The file is missing, not YAML or not a sensor result.
    """
    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        raise ResultFileError(f"sensor file '{p}' cannot be read as YAML ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ResultFileError(
            f"sensor file '{p}' is not a '{FORMAT}' file; write one with `sim2real sysid sensors`"
        )
    return _from_mapping(SensorEstimate, data, p)  # type: ignore[return-value]


def _from_mapping(cls: type, data: dict[str, Any], p: Path) -> object:
    """A result dataclass from its plain YAML values (fields with defaults may be missing)."""
    kwargs: dict[str, object] = {}
    for f in dataclasses.fields(cls):
        if f.name not in data and f.default is dataclasses.MISSING:
            raise ResultFileError(f"sensor file '{p}' lacks the key '{f.name}'; write it again")
        if f.name not in data:
            continue
        value = data[f.name]
        if f.name == "depth":
            value = None if value is None else _from_mapping(DepthEstimate, value, p)
        elif f.name == "size_px":
            value = (int(value[0]), int(value[1]))
        elif isinstance(value, list):
            value = tuple(v if isinstance(v, str) else _num(v) for v in value)
        elif f.type == "int":
            value = int(value)
        elif not isinstance(value, str):
            value = _num(value)
        kwargs[f.name] = value
    return cls(**kwargs)


def _num(v: object) -> float:
    return math.nan if v is None else float(v)  # type: ignore[arg-type]


# ----------------------------------------------------------------------------- still stretches


@dataclass(frozen=True)
class _Groups:
    """Per beam and still stretch: median range, sample variance, dof, counts."""

    beam: NDArray[np.intp]
    median_m: FloatArray
    var_m2: FloatArray
    dof: FloatArray
    n_scans: FloatArray
    n_invalid: FloatArray
    n_short: FloatArray
    n_valid: FloatArray
    noise_ok: BoolArray


def _still_mask(scans: ScanArrays, odom: PoseArrays) -> BoolArray:
    """Scans whose odometry pose does not change within half a second of the stamp."""
    t = scans.t_s
    lo = odom.at(t - _STILL_MARGIN_S)
    hi = odom.at(t + _STILL_MARGIN_S)
    mid = odom.at(t)
    still = np.ones(t.size, dtype=bool)
    for a in (lo, hi):
        still &= np.hypot(a[0] - mid[0], a[1] - mid[1]) < _STILL_TRANS_M
        still &= np.abs(a[2] - mid[2]) < _STILL_YAW_RAD
    inside = (t - _STILL_MARGIN_S >= odom.t_s[0]) & (t + _STILL_MARGIN_S <= odom.t_s[-1])
    return still & inside


def still_stretches(scans: ScanArrays, odom: PoseArrays) -> list[tuple[int, int]]:
    """The still stretches of one recording as ``(start, stop)`` scan indices: at least five
    consecutive scans whose odometry pose does not change within half a second.

    Examples
    --------
    >>> import numpy as np
    >>> scans = ScanArrays(t_s=0.2 * np.arange(20), ranges_m=np.ones((20, 4)), angle_min_rad=0.0,
    ...                    angle_increment_rad=0.1, range_min_m=0.1, range_max_m=5.0)
    >>> z = np.zeros(60)
    >>> still_stretches(scans, PoseArrays(t_s=0.1 * np.arange(60) - 1.0, x_m=z, y_m=z, yaw_rad=z))
    [(0, 20)]
    """
    return _stretches(_still_mask(scans, odom))


def _stretches(mask: BoolArray) -> list[tuple[int, int]]:
    """Runs of at least ``_MIN_STRETCH`` consecutive True values, as ``(start, stop)``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(int(a), int(b)) for a, b in zip(starts, stops, strict=True) if b - a >= _MIN_STRETCH]


def _stretch_groups(r: FloatArray, valid: BoolArray) -> dict[str, FloatArray]:
    """Statistics of one still stretch (scans x beams) per beam."""
    m = r.shape[0]
    rv = np.where(valid, r, np.nan)
    n_valid = valid.sum(axis=0).astype(np.float64)
    surface = (n_valid >= 3) & (n_valid >= 0.3 * m)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN beams give NaN medians
        med = np.nanmedian(rv, axis=0)
        mad = np.nanmedian(np.abs(rv - med), axis=0)
        gate = np.maximum(_GATE_FLOOR_M, 6.0 * 1.4826 * mad)
        dev = rv - med
        inlier = valid & (np.abs(dev) <= gate)
        short = valid & (dev < -gate)
        n_in = inlier.sum(axis=0).astype(np.float64)
        mean = np.where(inlier, r, 0.0).sum(axis=0) / np.maximum(n_in, 1.0)
        ss = np.where(inlier, (r - mean) ** 2, 0.0).sum(axis=0)
    dof = n_in - 1.0
    return {
        "surface": surface,
        "median_m": med,
        "var_m2": ss / np.maximum(dof, 1.0),
        "dof": dof,
        "n_scans": np.full(r.shape[1], float(m)),
        "n_invalid": m - n_valid,
        "n_short": short.sum(axis=0).astype(np.float64),
        "n_valid": n_valid,
    }


def _groups(scans_list: Sequence[ScanArrays], stills: Sequence[BoolArray]) -> _Groups:
    cols: dict[str, list[FloatArray]] = {}
    beams: list[NDArray[np.intp]] = []
    for scans, still in zip(scans_list, stills, strict=True):
        valid = scans.valid()
        for a, b in _stretches(still):
            g = _stretch_groups(scans.ranges_m[a:b], valid[a:b])
            keep = g.pop("surface")
            beams.append(np.flatnonzero(keep))
            for k, v in g.items():
                cols.setdefault(k, []).append(v[keep])
    if not beams:
        e = np.zeros(0)
        return _Groups(np.zeros(0, np.intp), e, e, e, e, e, e, e, np.zeros(0, bool))
    c = {k: np.concatenate(v) for k, v in cols.items()}
    return _Groups(
        beam=np.concatenate(beams),
        median_m=c["median_m"],
        var_m2=c["var_m2"],
        dof=c["dof"],
        n_scans=c["n_scans"],
        n_invalid=c["n_invalid"],
        n_short=c["n_short"],
        n_valid=c["n_valid"],
        noise_ok=c["dof"] >= 2,
    )


# ----------------------------------------------------------------------------- noise model


def _fit_noise(
    r: FloatArray, s2: FloatArray, k: FloatArray, w: FloatArray, start: FloatArray | None = None
) -> FloatArray:
    """ML fit of ``sigma(r) = a + b r + c r^2`` (``a, b, c >= 0``) to sample variances ``s2``
    with dof ``k`` (weights ``w``: bootstrap counts): projected Fisher scoring with step
    halving from a constant, a proportional and a quadratic start, the best of them (a bounded
    fit's likelihood can have several optima on its bounds), or from ``start`` alone."""
    kw = k * w
    x = np.column_stack([np.ones_like(r), r, r * r])

    def nll(th: FloatArray) -> float:
        sig2 = np.maximum(x @ th, _SIGMA_FLOOR_M) ** 2
        return float(np.sum(kw * (np.log(sig2) + s2 / sig2)))

    if start is not None:
        return _score_fit(start, x, s2, kw, nll)
    used = kw > 0
    starts = [np.array([math.sqrt(max(float(np.average(s2, weights=kw)), 1e-12)), 0.0, 0.0])]
    for power in (1, 2):
        ratio = np.sqrt(s2[used]) / np.maximum(r[used], 1e-3) ** power
        start = np.zeros(3)
        start[power] = max(float(np.median(ratio)) if ratio.size else 0.0, 1e-6)
        starts.append(start)
    fits = [_score_fit(start, x, s2, kw, nll) for start in starts]
    return min(fits, key=nll)


def _score_fit(
    theta: FloatArray,
    x: FloatArray,
    s2: FloatArray,
    kw: FloatArray,
    nll: Callable[[FloatArray], float],
) -> FloatArray:
    """Projected Fisher scoring with step halving from ``theta`` (a parameter held at its
    bound 0 by the score is left out of the step)."""
    cost = nll(theta)
    for _ in range(50):
        sig = np.maximum(x @ theta, _SIGMA_FLOOR_M)
        score = x.T @ (kw * (s2 / sig**2 - 1.0) / sig)
        info = (x * (2.0 * kw / sig**2)[:, None]).T @ x
        step = np.linalg.solve(info + 1e-12 * np.eye(theta.size), score)
        free = ~((theta <= 0.0) & (step < 0.0))  # a bound that holds: step the others alone
        if not free.all():
            step = np.zeros(theta.size)
            if free.any():
                sub = np.ix_(free, free)
                step[free] = np.linalg.solve(
                    info[sub] + 1e-12 * np.eye(int(free.sum())), score[free]
                )
        for _ in range(30):
            trial = np.maximum(theta + step, 0.0)
            trial_cost = nll(trial)
            if trial_cost <= cost:
                break
            step = 0.5 * step
        else:
            break
        moved = float(np.max(np.abs(trial - theta)))
        theta, cost = trial, trial_cost
        if moved < 1e-9:
            break
    return theta


def _ci(samples: FloatArray) -> Interval:
    finite = samples[np.isfinite(samples)]
    if finite.size == 0:
        return _NAN_PAIR
    lo, hi = np.percentile(finite, [2.5, 97.5])
    return (float(lo), float(hi))


def _not_mixed(r: FloatArray, s2: FloatArray, k: FloatArray, bins: int = _N_BINS) -> BoolArray:
    """Groups whose variance is within the 99.9 % chi-square quantile of the median variance
    of their range bin (a beam on an edge mixes two surfaces), judged without a model."""
    edges = np.quantile(r, np.linspace(0.0, 1.0, bins + 1))
    which = np.clip(np.searchsorted(edges, r, side="right") - 1, 0, bins - 1)
    keep = np.ones(r.size, dtype=bool)
    for b in range(bins):
        sel = which == b
        if not sel.any():
            continue
        ref = float(np.median(s2[sel] / (chi2.ppf(0.5, k[sel]) / k[sel])))
        keep[sel] = s2[sel] <= ref * chi2.ppf(0.999, k[sel]) / k[sel]
    return keep


@dataclass(frozen=True, kw_only=True)
class StillSpread:
    """Scan-to-scan spread per beam and still stretch, as the noise fit uses it.

    Attributes
    ----------
    median_m, std_m : ndarray
        Median range (m) and sample standard deviation of the inlier returns (m) per group.
    dof : ndarray
        Degrees of freedom of each standard deviation (inlier returns - 1).
    beam : ndarray of int
        The beam of each group.
    """

    median_m: FloatArray
    std_m: FloatArray
    dof: FloatArray
    beam: NDArray[np.intp]


def still_spread(
    scans: ScanArrays | Sequence[ScanArrays], odom: PoseArrays | Sequence[PoseArrays]
) -> StillSpread:
    """The per-beam spread of the still stretches (mixed-return groups left out).

    Examples
    --------
    >>> import numpy as np
    >>> ranges = 2.0 + np.random.default_rng(0).normal(0.0, 0.01, (20, 90))
    >>> scans = ScanArrays(t_s=0.2 * np.arange(20), ranges_m=ranges, angle_min_rad=0.0,
    ...                    angle_increment_rad=0.07, range_min_m=0.1, range_max_m=5.0)
    >>> z = np.zeros(60)
    >>> spread = still_spread(scans, PoseArrays(t_s=0.1 * np.arange(60) - 1.0, x_m=z, y_m=z,
    ...                                         yaw_rad=z))
    >>> bool(0.009 < np.median(spread.std_m) < 0.011)
    True
    """
    scans_list = [scans] if isinstance(scans, ScanArrays) else list(scans)
    odoms = [odom] if isinstance(odom, PoseArrays) else list(odom)
    g = _groups(scans_list, [_still_mask(s, o) for s, o in zip(scans_list, odoms, strict=True)])
    ok = g.noise_ok
    keep = _not_mixed(g.median_m[ok], g.var_m2[ok], g.dof[ok]) if ok.any() else ok[ok]
    return StillSpread(
        median_m=g.median_m[ok][keep],
        std_m=np.sqrt(g.var_m2[ok][keep]),
        dof=g.dof[ok][keep],
        beam=g.beam[ok][keep],
    )


@dataclass(frozen=True)
class _StillResult:
    theta: FloatArray
    theta_boot: FloatArray
    centres: FloatArray
    dropout: float
    dropout_boot: FloatArray
    dropout_by_range: FloatArray
    dropout_by_beam: FloatArray
    short: float
    short_boot: FloatArray


def _still_estimates(
    g: _Groups, beams: int, n_boot: int, rng: np.random.Generator, mixed_bins: int = _N_BINS
) -> _StillResult:
    ok = g.noise_ok
    r, s2, k = g.median_m[ok], g.var_m2[ok], g.dof[ok]
    inl = _not_mixed(r, s2, k, mixed_bins)
    r, s2, k, nb = r[inl], s2[inl], k[inl], g.beam[ok][inl]
    theta = _fit_noise(r, s2, k, np.ones_like(r))
    edges = np.quantile(g.median_m, np.linspace(0.0, 1.0, _N_BINS + 1))
    centres = 0.5 * (edges[1:] + edges[:-1])
    which = np.clip(np.searchsorted(edges, g.median_m, side="right") - 1, 0, _N_BINS - 1)
    inv_bin = np.bincount(which, g.n_invalid, _N_BINS)
    tot_bin = np.bincount(which, g.n_scans, _N_BINS)
    inv_beam = np.bincount(g.beam, g.n_invalid, beams)
    tot_beam = np.bincount(g.beam, g.n_scans, beams)
    short_beam = np.bincount(g.beam, g.n_short, beams)
    valid_beam = np.bincount(g.beam, g.n_valid, beams)
    theta_boot = np.empty((n_boot, 3))
    drop_boot, short_boot = np.empty(n_boot), np.empty(n_boot)
    for i in range(n_boot):
        counts = np.bincount(rng.integers(0, beams, beams), minlength=beams).astype(np.float64)
        theta_boot[i] = _fit_noise(r, s2, k, counts[nb] + 1e-9)
        drop_boot[i] = counts @ inv_beam / max(float(counts @ tot_beam), 1.0)
        short_boot[i] = counts @ short_beam / max(float(counts @ valid_beam), 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return _StillResult(
            theta=theta,
            theta_boot=theta_boot,
            centres=centres,
            dropout=float(inv_beam.sum() / tot_beam.sum()),
            dropout_boot=drop_boot,
            dropout_by_range=inv_bin / tot_bin,
            dropout_by_beam=np.where(tot_beam > 0, inv_beam / np.maximum(tot_beam, 1), np.nan),
            short=float(short_beam.sum() / max(valid_beam.sum(), 1.0)),
            short_boot=short_boot,
        )


@dataclass(frozen=True)
class _MovingResult:
    theta: FloatArray
    theta_boot: FloatArray
    centres: FloatArray
    count: int


def _gate(rho: FloatArray, z: FloatArray) -> BoolArray:
    """Residuals (over their factor's square root) within ``_GATE_SIGMAS`` robust standard
    deviations of zero, judged per range bin: a return that hit another surface is left out."""
    edges = np.quantile(rho, np.linspace(0.0, 1.0, _GATE_BINS + 1))
    which = np.clip(np.searchsorted(edges, rho, side="right") - 1, 0, _GATE_BINS - 1)
    sd = np.array(
        [
            robust_sd(z[which == b], about=0.0) if (which == b).any() else 0.0
            for b in range(_GATE_BINS)
        ]
    )
    return np.abs(z) <= _GATE_SIGMAS * sd[which]


def _moving_noise(pairs: _Pairs, n_boot: int, rng: np.random.Generator) -> _MovingResult | None:
    """The noise model from the range residuals of the matched moving scan pairs: squared
    residuals over their factor, summed per pair and fine range bin (each bin one observation
    of sigma(r)^2 with as many degrees of freedom as residuals), fitted by maximum likelihood;
    the interval from blocks of ``_BLOCK`` consecutive pairs."""
    sizes = np.array([res[0].size for res in pairs.residuals], dtype=np.intp)
    if int(sizes.sum()) < _MIN_RESIDUALS:
        return None
    rho = np.concatenate([res[0] for res in pairs.residuals])
    z = np.concatenate([res[1] / np.sqrt(res[2]) for res in pairs.residuals])
    pair = np.repeat(np.arange(sizes.size), sizes)
    keep = _gate(rho, z)
    rho, z2, pair = rho[keep], z[keep] ** 2, pair[keep]
    edges = np.quantile(rho, np.linspace(0.0, 1.0, _FIT_BINS + 1))
    which = np.clip(np.searchsorted(edges, rho, side="right") - 1, 0, _FIT_BINS - 1)
    cell = pair * _FIT_BINS + which
    shape = (sizes.size, _FIT_BINS)
    n_cell = np.bincount(cell, minlength=shape[0] * shape[1]).reshape(shape).astype(np.float64)
    z_cell = np.bincount(cell, z2, shape[0] * shape[1]).reshape(shape)
    r_cell = np.bincount(cell, rho, shape[0] * shape[1]).reshape(shape)

    def fit(counts: FloatArray, start: FloatArray | None = None) -> FloatArray:
        n = counts @ n_cell
        ok = n > 0
        r, s2 = (counts @ r_cell)[ok] / n[ok], (counts @ z_cell)[ok] / n[ok]
        return _fit_noise(r, s2, n[ok], np.ones(int(ok.sum())), start)

    theta = fit(np.ones(sizes.size))
    boot = np.stack([fit(_blocks(sizes.size, rng), theta) for _ in range(n_boot)])
    bins = np.quantile(rho, np.linspace(0.0, 1.0, _N_BINS + 1))
    return _MovingResult(theta, boot, 0.5 * (bins[1:] + bins[:-1]), int(rho.size))


# ----------------------------------------------------------------------------- timing and yaw


@dataclass(frozen=True)
class _Pairs:
    """Consecutive scan pairs matched: stamps, matched motion, per recording index."""

    t0: FloatArray
    t1: FloatArray
    rec: NDArray[np.intp]
    dx: FloatArray
    dy: FloatArray
    dth: FloatArray
    conditioning: FloatArray
    residuals: list[PairResiduals]  # of the consecutive moving pairs, in time order


@dataclass(frozen=True)
class _Track:
    """One recording's scans as points, with the odometry's lidar-frame guess between two."""

    t: FloatArray
    inside: BoolArray
    pose: tuple[FloatArray, FloatArray, FloatArray]
    pts: list[FloatArray]
    mount: Pose

    def match(self, i: int, j: int) -> Pose | None:
        """Scan ``j``'s lidar frame in scan ``i``'s (None: too far apart or no overlap)."""
        t, (x, y, yaw) = self.t, self.pose
        if not (self.inside[i] and self.inside[j]) or t[j] - t[i] > _MAX_PAIR_GAP_S:
            return None
        base = compose(invert((x[i], y[i], yaw[i])), (x[j], y[j], yaw[j]))
        guess = compose(compose(invert(self.mount), base), self.mount)
        return match_scans(self.pts[j], self.pts[i], guess)


def _match_pairs(
    scans_list: Sequence[ScanArrays],
    odoms: Sequence[PoseArrays],
    stills: Sequence[BoolArray],
    mount_xy: tuple[float, float],
) -> _Pairs:
    """Scans ``_STRIDE`` apart matched, odometry as the guess; and consecutive scans that are
    not both still matched for their range residuals (a short baseline keeps each return's
    ray close to the other scan's beams)."""
    rows: list[tuple[float, ...]] = []
    residuals: list[PairResiduals] = []
    for ri, (scans, odom, still) in enumerate(zip(scans_list, odoms, stills, strict=True)):
        valid = scans.valid()
        ang, t, r = scans.angles_rad, scans.t_s, scans.ranges_m
        track = _Track(
            t=t,
            inside=(t >= odom.t_s[0]) & (t <= odom.t_s[-1]),
            pose=odom.at(t),
            pts=[scan_points(r[i], ang, valid[i]) for i in range(t.size)],
            mount=(mount_xy[0], mount_xy[1], 0.0),
        )
        for i in range(t.size - _STRIDE):
            j = i + _STRIDE
            pose = track.match(i, j)
            if pose is not None:
                cond = translation_conditioning(track.pts[j], track.pts[i], pose)
                rows.append((t[i], t[j], ri, *pose, cond))
        for i in range(t.size - 1):
            pose = None if still[i] and still[i + 1] else track.match(i, i + 1)
            if pose is not None:
                residuals.append(pair_residuals(r[i], valid[i], r[i + 1], valid[i + 1], ang, pose))
    a = np.array(rows, dtype=np.float64).reshape(-1, 7)
    return _Pairs(
        a[:, 0], a[:, 1], a[:, 2].astype(np.intp), a[:, 3], a[:, 4], a[:, 5], a[:, 6], residuals
    )


def _odom_increments(
    pairs: _Pairs, odoms: Sequence[PoseArrays], offset_s: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Odometry motion between the shifted stamps of each pair, in the base frame at t0."""
    dx, dy, dth = (np.empty(pairs.t0.size) for _ in range(3))
    for ri, odom in enumerate(odoms):
        sel = pairs.rec == ri
        x0, y0, a0 = odom.at(pairs.t0[sel] + offset_s)
        x1, y1, a1 = odom.at(pairs.t1[sel] + offset_s)
        c, s = np.cos(a0), np.sin(a0)
        ex, ey = x1 - x0, y1 - y0
        dx[sel], dy[sel], dth[sel] = c * ex + s * ey, -s * ex + c * ey, a1 - a0
    return dx, dy, dth


def _offset_curve(
    pairs: _Pairs, odoms: Sequence[PoseArrays]
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per grid offset: odometry yaw increments (grid x pairs), the offsets, pair weights."""
    grid = np.arange(-_OFFSET_SPAN_S, _OFFSET_SPAN_S + 1e-9, _OFFSET_STEP_S)
    inc = np.stack([_odom_increments(pairs, odoms, float(d))[2] for d in grid])
    return grid, inc, np.ones(pairs.t0.size)


def _best_offset(
    grid: FloatArray, inc: FloatArray, meas: FloatArray, w: FloatArray
) -> tuple[float, float]:
    """Offset (parabola through the grid minimum) and yaw scale minimising the weighted
    squared yaw-increment misfit ``meas - scale * inc``."""
    sxy = inc @ (w * meas)
    sxx = (inc**2) @ w
    scale = sxy / np.maximum(sxx, 1e-12)
    cost = (w * meas**2).sum() - scale * sxy
    j = int(np.argmin(cost))
    off = float(grid[j])
    if 0 < j < grid.size - 1:
        c0, c1, c2 = cost[j - 1], cost[j], cost[j + 1]
        den = c0 - 2.0 * c1 + c2
        if den > 0:
            off += 0.5 * _OFFSET_STEP_S * (c0 - c2) / den
    return off, float(scale[j])


def _mount_yaw(
    pairs: _Pairs,
    odoms: Sequence[PoseArrays],
    offset_s: float,
    mount_xy: tuple[float, float],
    w: FloatArray,
) -> float:
    """Circular weighted mean angle from the mount's odometry translation to the matched one."""
    bx, by, bth = _odom_increments(pairs, odoms, offset_s)
    lx, ly = mount_xy
    c, s = np.cos(bth), np.sin(bth)
    ux = bx + (c - 1.0) * lx - s * ly
    uy = by + s * lx + (c - 1.0) * ly
    big = (np.hypot(ux, uy) >= _MIN_TRANS_M) & (pairs.conditioning >= _MIN_CONDITIONING)
    if int(big.sum()) < _MIN_TRANSLATING:
        return math.nan
    turn = np.exp(1j * (np.arctan2(uy, ux) - np.arctan2(pairs.dy, pairs.dx)))
    centre = np.angle(np.sum(turn[big]))  # circular: mounts near +-pi stay whole
    for _ in range(3):
        keep = big & (np.abs(np.angle(turn * np.exp(-1j * centre))) < 0.2)
        if not keep.any():
            return math.nan
        centre = np.angle(np.sum(turn[keep]))
    ang = np.angle(turn)
    wt = w * (ux**2 + uy**2) * keep
    if wt.sum() <= 0:
        return math.nan
    return float(np.angle(np.sum(wt * np.exp(1j * ang))))


def _blocks(n: int, rng: np.random.Generator) -> FloatArray:
    """Bootstrap counts for ``n`` items resampled in blocks of ``_BLOCK`` consecutive ones."""
    nb = max(1, -(-n // _BLOCK))
    picks = rng.integers(0, nb, nb)
    counts = np.bincount(picks, minlength=nb).astype(np.float64)
    return np.repeat(counts, _BLOCK)[:n]


@dataclass(frozen=True)
class _Timing:
    offset: float
    offset_boot: FloatArray
    scale: float
    yaw: float
    yaw_boot: FloatArray
    turning: bool
    moving: bool


def _timing(
    pairs: _Pairs,
    odoms: Sequence[PoseArrays],
    mount_xy: tuple[float, float],
    n_boot: int,
    rng: np.random.Generator,
) -> _Timing:
    grid, inc, w = _offset_curve(pairs, odoms)
    off, scale = _best_offset(grid, inc, pairs.dth, w)
    resid = pairs.dth - scale * inc[int(np.argmin(np.abs(grid - off)))]
    w = (np.abs(resid) <= max(6.0 * robust_sd(resid), 1e-3)).astype(np.float64)
    off, scale = _best_offset(grid, inc, pairs.dth, w)
    accel = np.diff(inc[int(np.argmin(np.abs(grid)))]) if pairs.t0.size > 1 else np.zeros(0)
    turning = bool(np.sum(np.abs(accel) > 0.02) >= 5)
    yaw = _mount_yaw(pairs, odoms, off, mount_xy, w)
    moving = math.isfinite(yaw)
    off_boot, yaw_boot = np.full(n_boot, np.nan), np.full(n_boot, np.nan)
    for i in range(n_boot):
        wb = w * _blocks(pairs.t0.size, rng)
        off_boot[i] = _best_offset(grid, inc, pairs.dth, wb)[0]
        if moving:
            yaw_boot[i] = _mount_yaw(pairs, odoms, off, mount_xy, wb)
    lo, hi = _ci(off_boot)
    turning = turning and hi - lo <= _MAX_OFFSET_CI_S
    if moving:  # the draws as angles next to the estimate (intervals across +-pi stay whole)
        yaw_boot = yaw + np.angle(np.exp(1j * (yaw_boot - yaw)))
    return _Timing(off, off_boot, scale, yaw, yaw_boot, turning, moving)


# ----------------------------------------------------------------------------- entry point


def _check_layout(scans_list: Sequence[ScanArrays], names: Sequence[str]) -> None:
    first = scans_list[0]
    for scans, name in zip(scans_list, names, strict=True):
        if scans.ranges_m.ndim != 2 or scans.ranges_m.shape[0] != scans.t_s.size:
            raise SysidValueError(
                f"scans of '{name}' have shape {scans.ranges_m.shape} for {scans.t_s.size} "
                "stamps; pass one row of ranges per stamp"
            )
        if scans.ranges_m.shape[1] != first.ranges_m.shape[1]:
            raise SysidValueError(
                f"scans of '{name}' have {scans.ranges_m.shape[1]} beams and those of "
                f"'{names[0]}' {first.ranges_m.shape[1]}; identify one sensor layout at a time"
            )


def estimate_sensor(
    scans: ScanArrays | Sequence[ScanArrays],
    odom: PoseArrays | Sequence[PoseArrays],
    *,
    mount_xy_m: tuple[float, float] = (0.0, 0.0),
    names: Sequence[str] | None = None,
    n_boot: int = 200,
    seed: int = 0,
) -> SensorEstimate:
    """Identify a lidar from scans and odometry of one or more recordings of one sensor.

    Parameters
    ----------
    scans, odom : ScanArrays, PoseArrays or sequences of them
        The scans and odometry poses of each recording, stamps on one clock per recording.
    mount_xy_m : tuple
        The lidar's position in base_link, m (from the robot spec).
    names : sequence of str, optional
        Names of the recordings (messages and ``sources``).
    n_boot : int
        Bootstrap resamples for the 95 % intervals.
    seed : int
        Seed of the bootstrap's numpy Generator.

    Returns
    -------
    SensorEstimate

    Raises
    ------
    SysidValueError
        Scans of different beam counts, or ranges that do not match their stamps.
    ExcitationError
        No still stretch and no moving scan pair: nothing can be identified.
    """
    scans_list = [scans] if isinstance(scans, ScanArrays) else list(scans)
    odoms = [odom] if isinstance(odom, PoseArrays) else list(odom)
    names = list(names) if names is not None else [f"recording {i}" for i in range(len(scans_list))]
    _check_layout(scans_list, names)
    rng = np.random.default_rng(seed)
    first = scans_list[0]
    beams = first.ranges_m.shape[1]
    stills = [_still_mask(s, o) for s, o in zip(scans_list, odoms, strict=True)]
    groups = _groups(scans_list, stills)
    pairs = _match_pairs(scans_list, odoms, stills, mount_xy_m)
    moving_pairs = int(
        np.sum(~np.isclose(pairs.dth, 0.0, atol=0.01) | (np.hypot(pairs.dx, pairs.dy) > 0.01))
    )
    if groups.beam.size == 0 and moving_pairs == 0:
        raise ExcitationError(
            f"recordings {', '.join(names)} have no still stretch ({_MIN_STRETCH} scans with the "
            "odometry pose unchanged) and no scan pair with motion; record 10 s standing "
            "still facing a wall, then drive slowly through a static room"
        )
    still = _still_estimates(groups, beams, n_boot, rng) if groups.noise_ok.sum() >= 10 else None
    timing = _timing(pairs, odoms, mount_xy_m, n_boot, rng) if pairs.t0.size >= 20 else None
    moving = _moving_noise(pairs, n_boot, rng)
    dt = np.concatenate([np.diff(s.t_s) for s in scans_list])
    return SensorEstimate(
        beams=beams,
        angle_min_rad=float(first.angle_min_rad),
        angle_increment_rad=float(first.angle_increment_rad),
        range_min_m=float(first.range_min_m),
        range_max_m=float(first.range_max_m),
        scan_rate_hz=float(1.0 / np.median(dt)) if dt.size else math.nan,
        **_noise_fields(still, moving),
        **_dropout_fields(still, beams),
        **_timing_fields(timing),
        still_scans=int(sum(int(s.sum()) for s in stills)),
        matched_pairs=int(pairs.t0.size),
        unidentified=_notes(still, moving, timing),
        sources=tuple(names),
    )


def _notes(
    still: _StillResult | None, moving: _MovingResult | None, timing: _Timing | None
) -> tuple[str, ...]:
    """One sentence per quantity the recordings do not identify."""
    notes: list[str] = []
    if still is None and moving is None:
        notes.append(
            "noise and dropout: no still stretch of 5 scans or more and too few matched moving "
            f"scan pairs ({_MIN_RESIDUALS} compared returns), so the range noise, invalid-return "
            "rate and spurious returns are not identified"
        )
    elif still is None:
        notes.append(
            "dropout: no still stretch of 5 scans or more, so the invalid-return rate and "
            "spurious returns are not identified (the range noise comes from the moving scans)"
        )
    if timing is None or not timing.turning:
        notes.append(
            "time_offset_s: the yaw rate changes too little between matched scans (the 95 % "
            "interval would be wider than 0.3 s), so the scan timing against odometry is not "
            "identified"
        )
    if timing is None or not timing.moving:
        notes.append(
            "mounting_yaw_rad: fewer than 20 matched scan pairs translate 2 cm or more with "
            "the translation pinned in every direction (not a corridor), so the mounting yaw "
            "is not identified"
        )
    return tuple(notes)


def _model_fields(
    theta: FloatArray, theta_boot: FloatArray, centres: FloatArray, systematic: float
) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
    """The noise model at ``centres`` with its 95 % band, m: the bootstrap's percentiles,
    widened in quadrature by ``systematic`` times the model (a relative error the resampling
    does not see)."""
    x = np.column_stack([np.ones_like(centres), centres, centres * centres])
    std = x @ theta
    lo, hi = np.percentile(theta_boot @ x.T, [2.5, 97.5], axis=0)
    sys_m = systematic * std
    lo = std - np.hypot(std - lo, sys_m)
    hi = std + np.hypot(hi - std, sys_m)
    return _floats(std), _floats(lo), _floats(hi)


def _noise_fields(still: _StillResult | None, moving: _MovingResult | None) -> dict[str, Any]:
    """The noise model fields: from the still stretches, else from the moving scan pairs
    (NaN when neither); the moving pairs' model at the same ranges as a check."""
    nan_t = (math.nan,) * _N_BINS
    if still is None and moving is None:
        return {
            "noise_std_0_m": math.nan,
            "noise_std_0_ci": _NAN_PAIR,
            "noise_std_per_m": math.nan,
            "noise_std_per_m_ci": _NAN_PAIR,
            "noise_std_per_m2": math.nan,
            "noise_std_per_m2_ci": _NAN_PAIR,
            "noise_range_m": nan_t,
            "noise_std_m": nan_t,
            "noise_std_lo_m": nan_t,
            "noise_std_hi_m": nan_t,
            "noise_source": "none",
        }
    theta, boot, centres, source = (
        (still.theta, still.theta_boot, still.centres, "still")
        if still is not None
        else (moving.theta, moving.theta_boot, moving.centres, "moving")  # type: ignore[union-attr]
    )
    std, lo, hi = _model_fields(theta, boot, centres, 0.0 if still is not None else _MOVING_SYS)
    out: dict[str, Any] = {
        "noise_std_0_m": float(theta[0]),
        "noise_std_0_ci": _ci(boot[:, 0]),
        "noise_std_per_m": float(theta[1]),
        "noise_std_per_m_ci": _ci(boot[:, 1]),
        "noise_std_per_m2": float(theta[2]),
        "noise_std_per_m2_ci": _ci(boot[:, 2]),
        "noise_range_m": _floats(centres),
        "noise_std_m": std,
        "noise_std_lo_m": lo,
        "noise_std_hi_m": hi,
        "noise_source": source,
    }
    if moving is not None:
        m_std, m_lo, m_hi = _model_fields(moving.theta, moving.theta_boot, centres, _MOVING_SYS)
        out |= {
            "moving_noise_std_m": m_std,
            "moving_noise_std_lo_m": m_lo,
            "moving_noise_std_hi_m": m_hi,
            "moving_residuals": moving.count,
        }
    return out


def _dropout_fields(still: _StillResult | None, beams: int) -> dict[str, Any]:
    """The dropout and spurious-return fields (NaN when nothing was still)."""
    if still is None:
        return {
            "dropout": math.nan,
            "dropout_ci": _NAN_PAIR,
            "dropout_by_range": (math.nan,) * _N_BINS,
            "dropout_by_beam": (math.nan,) * beams,
            "spurious_short": math.nan,
            "spurious_short_ci": _NAN_PAIR,
        }
    return {
        "dropout": still.dropout,
        "dropout_ci": _ci(still.dropout_boot),
        "dropout_by_range": _floats(still.dropout_by_range),
        "dropout_by_beam": _floats(still.dropout_by_beam),
        "spurious_short": still.short,
        "spurious_short_ci": _ci(still.short_boot),
    }


def _timing_fields(timing: _Timing | None) -> dict[str, Any]:
    """The time offset, yaw scale and mounting yaw fields (NaN where not identified)."""
    turn = timing is not None and timing.turning
    move = timing is not None and timing.moving
    return {
        "time_offset_s": timing.offset if timing and turn else math.nan,
        "time_offset_ci": _ci(timing.offset_boot) if timing and turn else _NAN_PAIR,
        "yaw_scale": timing.scale if timing and turn else math.nan,
        "mounting_yaw_rad": timing.yaw if timing and move else math.nan,
        "mounting_yaw_ci": _ci(timing.yaw_boot) if timing and move else _NAN_PAIR,
    }


def _floats(values: FloatArray) -> tuple[float, ...]:
    return tuple(float(v) for v in values)
