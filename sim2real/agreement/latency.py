r"""How much of a sim-vs-real gap is latency and how much is noise: two reference figures.

A point estimate fitted on one session carries that session's command latency. Another
session of the same robot can run at another latency (another computer, another network,
another driver load), and no fit of other sessions can know it. :func:`session_latency`
finds the checked session's own best command latency, keeping every other parameter: the
gap between the fitted agreement and the agreement at that latency is latency; what is
left is dynamics (or noise).

:func:`noise_ceiling` is the agreement a perfect model would reach, given the odometry noise
the fit estimated (``agree`` undoes a calibration's noise factors,
:func:`sim2real.agreement.study.fitted_noise`): a sample's error is then the noise alone, so with white Gaussian noise
of standard deviation :math:`\sigma_v`, :math:`\sigma_w` (quantisation :math:`q` adds
:math:`q^2/12` to the variance)

.. math:: A_{\max} = \operatorname{erf}\!\Big(\frac{tol_v}{\sqrt2\,\sigma_v}\Big)\,
          \operatorname{erf}\!\Big(\frac{tol_w}{\sqrt2\,\sigma_w}\Big),

and the noise-only 90 % band is :math:`2 \cdot 1.645\,\sigma = 3.29\,\sigma` wide: no
predictive band that contains the real odometry can be narrower.

The noise is the checked log's own when the log can tell it (:func:`log_noise`): the noise a
fit estimated on one unit and one velocity source need not describe another unit's odometry, or
a pose-derived velocity. Where a non-zero command has been held for over
:data:`sysid.steady.STEADY_AFTER_S` (past the delay and the rise), the robot runs steady and
what the measurement does about its level (the median of that stretch) is noise: its robust sd
(MAD) per axis, the same statistic the fit uses on its residuals. A log with fewer than
:data:`sysid.steady.MIN_STEADY_SAMPLES` such samples keeps the fit's noise, and the note says
so. The band of ``agree --ensemble`` keeps the model's share of the noise, which grows with
the replay's rate of change (:class:`ModelShare`), and takes the log's own measurement noise of
each sample's motion in place of the fit logs' (:func:`band_sample_noise`): one noise model per
odometry source.

Examples
--------
>>> from robots.randomization import ObservationNoise
>>> c = noise_ceiling(ObservationNoise(std_v_mps=0.01, std_w_radps=0.05), tol_v=0.02, tol_w=0.1)
>>> round(c.agreement, 3), round(c.band_width_v_mps, 4)
(0.911, 0.0329)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from statistics import NormalDist
from typing import TYPE_CHECKING, Any

import numpy as np

from robots.randomization import apply_noise
from sim2real._arrays import FloatArray
from sim2real.agreement.figures import AgreementReport, measure_agreement
from sim2real.agreement.replay import RobotSpecLike, TraceLike, replay
from sysid.hfnoise import log_pose, response_noise
from sysid.metrics import active_mask
from sysid.steady import (
    MIN_STEADY_SAMPLES,
    SPEED_NOISE_PARTS,
    STEADY_AFTER_S,
    SpeedNoise,
    SteadyNoise,
    held_at_zero_noise,
    measurement_lead_s,
    motion_noise,
    speed_noise,
    steady_noise,
    variance_law,
)

if TYPE_CHECKING:
    from robots.params import DriveParams
    from robots.randomization import ObservationNoise

__all__ = [
    "LATENCY_COARSE_STEP_S",
    "LATENCY_FINE_STEP_S",
    "LATENCY_MAX_S",
    "REFERENCE_KEYS",
    "SHARE_BIN_SAMPLES",
    "ModelShare",
    "NoiseCeiling",
    "SampleNoise",
    "SessionLatency",
    "band_log_noise",
    "band_noise",
    "band_sample_noise",
    "bounded_ceiling",
    "fit_model_share",
    "fit_speed_noise",
    "jitter_timing_s",
    "log_noise",
    "motion_ceiling",
    "noise_ceiling",
    "noise_note",
    "replay_rate",
    "session_latency",
    "speed_noise_note",
]

#: JSON keys of ``sim2real agree --json`` with a params file (after the band's keys):
#: ``best_delay_s`` (this log's own best command latency, s), ``fitted_delay_s``,
#: ``agreement_at_best_delay`` (0..1), ``noise_ceiling`` (0..1; with the file's noise model),
#: ``noise_band_width_v_mps``, ``noise_band_width_w_radps`` (the noise-only band),
#: ``noise_std_v_mps``, ``noise_std_w_radps`` (the noise they assume: this log's own when it can
#: tell, else the fit's; the JSON's ``notes`` say which).
REFERENCE_KEYS = (
    "best_delay_s",
    "fitted_delay_s",
    "agreement_at_best_delay",
    "noise_ceiling",
    "noise_band_width_v_mps",
    "noise_band_width_w_radps",
    "noise_std_v_mps",
    "noise_std_w_radps",
)
#: The search range of a session's command latency, s (ROS command latencies: 0-0.6 s).
LATENCY_MAX_S = 0.6
#: Coarse and fine grid steps of the search, s.
LATENCY_COARSE_STEP_S = 0.05
LATENCY_FINE_STEP_S = 0.01
#: Residuals per bin of :func:`fit_model_share` (the robust sd of 100 Gaussian residuals has a
#: standard error of ~12 %).
SHARE_BIN_SAMPLES = 100


@dataclass(frozen=True, kw_only=True)
class SessionLatency:
    """The checked session's own best command latency and the agreement at it.

    Attributes
    ----------
    delay_s : float
        The command latency (transport delay) that maximises the point agreement on the
        checked log, every other parameter kept, s.
    fitted_delay_s : float
        The params' own delay, s.
    report : AgreementReport
        The agreement figures of the replay at ``delay_s``.
    """

    delay_s: float
    fitted_delay_s: float
    report: AgreementReport


@dataclass(frozen=True, kw_only=True)
class NoiseCeiling:
    """What the measurement noise alone allows (see the module docstring).

    Attributes
    ----------
    agreement : float
        Expected agreement (0..1) of a perfect model: both axes within tolerance.
    agreement_v, agreement_w : float
        The same per axis.
    band_width_v_mps, band_width_w_radps : float
        Width of the central 90 % band of the noise alone, m/s and rad/s.
    std_v_mps, std_w_radps : float
        The noise sd assumed (quantisation included), m/s and rad/s.
    note : str
        One sentence: whose noise it is (:func:`noise_note`); "" when not said.
    """

    agreement: float
    agreement_v: float
    agreement_w: float
    band_width_v_mps: float
    band_width_w_radps: float
    std_v_mps: float = 0.0
    std_w_radps: float = 0.0
    note: str = ""


def _within_prob(tol: float, sd: float) -> float:
    return 1.0 if sd <= 0.0 else math.erf(tol / (math.sqrt(2.0) * sd))


def noise_ceiling(
    noise: ObservationNoise, *, tol_v: float, tol_w: float, level: float = 0.9
) -> NoiseCeiling:
    """The agreement and band width that the odometry noise ``noise`` alone allows.

    Parameters
    ----------
    noise : ObservationNoise
        The params file's odometry noise (its ``randomization.noise``).
    tol_v, tol_w : float
        Agreement tolerances, m/s and rad/s.
    level : float
        Central probability of the band, in (0, 1).

    Returns
    -------
    NoiseCeiling
    """
    sd_v = math.hypot(noise.std_v_mps, noise.quantum_v_mps / math.sqrt(12.0))
    sd_w = math.hypot(noise.std_w_radps, noise.quantum_w_radps / math.sqrt(12.0))
    a_v, a_w = _within_prob(tol_v, sd_v), _within_prob(tol_w, sd_w)
    z = NormalDist().inv_cdf(0.5 + level / 2.0)
    return NoiseCeiling(
        agreement=a_v * a_w,
        agreement_v=a_v,
        agreement_w=a_w,
        band_width_v_mps=2.0 * z * sd_v,
        band_width_w_radps=2.0 * z * sd_w,
        std_v_mps=sd_v,
        std_w_radps=sd_w,
    )


def motion_ceiling(
    trace: TraceLike,
    noise: ObservationNoise,
    *,
    tol_v: float,
    tol_w: float,
    level: float = 0.9,
    fallback: SpeedNoise | None = None,
) -> NoiseCeiling:
    """:func:`noise_ceiling` with each scored sample's noise at its own speed (a pose
    derivative) or of its own motion (any other reading, :func:`_class_ceiling`).

    The agreement is scored on the active samples (:func:`sysid.metrics.active_mask`), and
    odometry reads more noise the faster its axis moves (:class:`sysid.steady.SpeedNoise`: a
    velocity differenced from a pose over jittery stamps is off by a share of the speed; an
    axis held at zero reads its floor). So each active sample gets, per axis, the log's own
    noise law (:func:`sysid.steady.speed_noise`, its steady samples clear of the next command
    by the lead of a pose derivative's window) at its measured speed, and the ceiling is the
    mean over the active samples of the product of the two axes' chances. A part of the law
    the log cannot tell is ``fallback``'s (the fit logs' law, :func:`fit_speed_noise`), else
    the constant ``noise``. The noise-only band and the sds stay ``noise``'s; the note gives
    the law and whose each part is.

    Examples
    --------
    >>> ceiling = motion_ceiling(trace, noise, tol_v=0.02, tol_w=0.1)  # doctest: +SKIP
    """
    pooled = noise_ceiling(noise, tol_v=tol_v, tol_w=tol_w, level=level)
    cmd_v, cmd_w = trace.cmd_at_meas()
    meas_v, meas_w = trace.meas_v, trace.meas_w
    active = active_mask(cmd_v, cmd_w, meas_v, meas_w, tol_v=tol_v, tol_w=tol_w)
    if not active.any():
        return pooled
    measurement = getattr(trace, "measurement", None)
    if getattr(measurement, "kind", None) != "pose":
        return _class_ceiling(trace, noise, pooled, active, tol_v=tol_v, tol_w=tol_w)
    law = speed_noise(
        [(trace.meas_t_s, cmd_v, cmd_w, meas_v, meas_w)],
        fallback=fallback,
        ahead_s=measurement_lead_s(measurement),
    )
    law = replace(
        law,
        floor_v_mps=_known(law.floor_v_mps, noise.std_v_mps),
        floor_w_radps=_known(law.floor_w_radps, noise.std_w_radps),
    )
    sd_v, sd_w = law.std_at(np.asarray(meas_v)[active], np.asarray(meas_w)[active])
    tau = jitter_timing_s(measurement)
    if tau > 0.0:  # the stamp jitter's error where the velocity changes
        t = trace.meas_t_s
        sd_v = np.hypot(sd_v, tau * _known(law.fraction_v, 0.0) * replay_rate(t, meas_v)[active])
        sd_w = np.hypot(sd_w, tau * _known(law.fraction_w, 0.0) * replay_rate(t, meas_w)[active])
    a_v = _within(tol_v, np.hypot(sd_v, noise.quantum_v_mps / math.sqrt(12.0)))
    a_w = _within(tol_w, np.hypot(sd_w, noise.quantum_w_radps / math.sqrt(12.0)))
    return replace(
        pooled,
        agreement=float(np.mean(a_v * a_w)),
        agreement_v=float(np.mean(a_v)),
        agreement_w=float(np.mean(a_w)),
        note=speed_noise_note(law),
    )


def bounded_ceiling(
    fit: ObservationNoise,
    trace: TraceLike,
    replayed: Any,
    *,
    tol_v: float,
    tol_w: float,
    level: float = 0.9,
) -> NoiseCeiling:
    r""":func:`noise_ceiling` of a log that cannot tell its own noise from steady stretches:
    the fit's noise, per axis no larger than the log's own upper bound on its noise.

    Such a log (a follower's or a teleop's command changes before the robot settles) takes
    the noise the fit estimated (``fit``, :func:`sim2real.agreement.study.fitted_noise`), of
    other logs and perhaps another unit or odometry rate. What the fitted point's replay
    ``replayed`` does not explain on this log (:func:`sysid.hfnoise.response_noise`, the band's
    rule, :func:`band_sample_noise`) bounds its noise from above: the residual is the noise plus
    the model's misses, independent of it. So per axis the ceiling assumes

    .. math:: \sigma = \min(\sigma_{fit},\ \sigma_{response}),

    never the bound alone: a model that misses inflates it, and an inflated noise makes a
    ceiling too low, which a poor fit would pass. A bound under the fit's noise is this log's
    proof that its noise is at most that, so the minimum is never further from the truth
    than the fit's noise, and it never lowers the ceiling. The noise-only band and the sds
    stay the fit's; the note gives the bound. Without a bound (too few readings), the fit's.

    Examples
    --------
    >>> ceiling = bounded_ceiling(fit, trace, sim, tol_v=0.02, tol_w=0.1)  # doctest: +SKIP
    """
    pooled = noise_ceiling(fit, tol_v=tol_v, tol_w=tol_w, level=level)
    bound = _response_noise(trace, replayed)
    if not bound.measured:
        return pooled
    capped = replace(
        fit,
        std_v_mps=min(fit.std_v_mps, bound.std_v_mps),
        std_w_radps=min(fit.std_w_radps, bound.std_w_radps),
    )
    ceiling = noise_ceiling(capped, tol_v=tol_v, tol_w=tol_w, level=level)
    return replace(
        pooled,
        agreement=ceiling.agreement,
        agreement_v=ceiling.agreement_v,
        agreement_w=ceiling.agreement_w,
        note=(
            f"the noise ceiling takes per axis the smaller of the fit's noise and this log's "
            f"own upper bound on its noise, what the fitted replay does not explain (v "
            f"{bound.std_v_mps:.3g} m/s, w {bound.std_w_radps:.3g} rad/s): v "
            f"{capped.std_v_mps:.3g} m/s, w {capped.std_w_radps:.3g} rad/s"
        ),
    )


def jitter_timing_s(measurement: Any) -> float:
    r"""The timing scale of a pose derivative's error where the velocity changes, per unit of
    its error share of the speed, s (0 for any other measurement).

    A velocity fitted as the least-squares slope of the pose over a window of updates at
    times :math:`u_j` about its centre, each pose taken :math:`\delta_j` off its stamp, is off
    by :math:`\sum_j c_j\,s(t_j)\,\delta_j` with :math:`c_j = u_j / \sum u^2`. At a
    steady speed that is :math:`s\,\sigma_\delta / \sqrt{\sum u^2}`: the share
    :math:`r` of :class:`sysid.steady.SpeedNoise`. Where the speed changes at a rate
    :math:`a`, it adds :math:`a\,\sigma_\delta \sqrt{\sum u^4} / \sum u^2 = r\,a\,\tau`,
    :math:`\tau = \sqrt{\sum u^4 / \sum u^2}` over updates one period apart within the
    window: the same jitter, with no further parameter.

    Examples
    --------
    >>> from robots.measurement import MeasurementModel
    >>> pose = MeasurementModel(kind="pose", window_s=0.75, update_period_s=0.15)
    >>> round(jitter_timing_s(pose), 3)  # 5 updates: 1.84 periods
    0.277
    """
    if getattr(measurement, "kind", None) != "pose":
        return 0.0
    period, half = float(measurement.update_period_s), 0.5 * float(measurement.window_s)
    if not (period > 0.0 and half >= period):
        return 0.0
    u = period * np.arange(-int(half // period), int(half // period) + 1)
    return math.sqrt(float(np.sum(u**4) / np.sum(u**2)))


def _class_ceiling(
    trace: TraceLike,
    noise: ObservationNoise,
    pooled: NoiseCeiling,
    active: Any,
    *,
    tol_v: float,
    tol_w: float,
) -> NoiseCeiling:
    """:func:`motion_ceiling` of a reading that is not a pose derivative: each active sample
    gets, per axis, the log's own noise of the steady stretches whose command on that axis is
    zero or not, like its own (:func:`sysid.steady.motion_noise`; ``noise``'s where the log
    cannot tell that class). No law of speed: the stamp jitter that makes one is a pose
    derivative's, and per bin of a short log the steady stretches of a heavy base still
    settling read as noise (a Warthog's 12 s: 0.28 of |v|)."""
    cmd_v, cmd_w = trace.cmd_at_meas()
    moving, still = motion_noise(trace.meas_t_s, cmd_v, cmd_w, trace.meas_v, trace.meas_w)
    chances = []
    for cmd, tol, quantum, name, fallback in (
        (cmd_v, tol_v, noise.quantum_v_mps, "std_v_mps", noise.std_v_mps),
        (cmd_w, tol_w, noise.quantum_w_radps, "std_w_radps", noise.std_w_radps),
    ):
        chance = {}
        for moves, own in ((True, moving), (False, still)):
            sd = math.hypot(_known(getattr(own, name), fallback), quantum / math.sqrt(12.0))
            chance[moves] = _within_prob(tol, sd)
        chances.append(np.where(np.asarray(cmd)[active] != 0, chance[True], chance[False]))
    a_v, a_w = chances
    unknown = any(math.isnan(getattr(n, f)) for n in (moving, still) for f in _SDS)
    return replace(
        pooled,
        agreement=float(np.mean(a_v * a_w)),
        agreement_v=float(np.mean(a_v)),
        agreement_w=float(np.mean(a_w)),
        note=(
            "the noise ceiling takes each scored sample's noise of its own motion: v "
            f"{moving.std_v_mps:.3g} m/s while driving, {still.std_v_mps:.3g} while not; w "
            f"{moving.std_w_radps:.3g} rad/s while turning, {still.std_w_radps:.3g} while not"
            + (" (nan: too few samples to tell, the pooled noise stands in)" if unknown else "")
        ),
    )


#: The sd fields of a :class:`SteadyNoise`.
_SDS = ("std_v_mps", "std_w_radps")


def _within(tol: float, sd: FloatArray) -> FloatArray:
    """P(|e| < tol) of zero-mean Gaussian errors of sd ``sd`` (1 where sd is 0)."""
    out: FloatArray = np.vectorize(_within_prob, otypes=[np.float64])(tol, sd)
    return out


def speed_noise_note(law: SpeedNoise) -> str:
    """One sentence: the noise law the ceiling takes, and which parts are the log's own.

    Examples
    --------
    >>> from sysid.steady import SpeedNoise
    >>> law = SpeedNoise(floor_v_mps=0.001, fraction_v=0.05, floor_w_radps=0.005,
    ...                  fraction_w=0.06, told=("floor_w_radps",))
    >>> speed_noise_note(law)[-106:]
    "0.005 rad/s + 6 % of |w| (this log's own: the floor of w; the others the fit logs', else its pooled noise)"
    """
    own = {"floor_v_mps": "the floor of v", "fraction_v": "the share of |v|",
           "floor_w_radps": "the floor of w", "fraction_w": "the share of |w|"}  # fmt: skip
    told = [own[k] for k in law.told] or ["none"]
    return (
        "the noise ceiling takes each scored sample's odometry noise at its own speed: v "
        f"{law.floor_v_mps:.3g} m/s + {100 * _known(law.fraction_v, 0.0):.3g} % of |v|, w "
        f"{law.floor_w_radps:.3g} rad/s + {100 * _known(law.fraction_w, 0.0):.3g} % of |w| "
        f"(this log's own: {', '.join(told)}; the others the fit logs', else its pooled noise)"
    )


def fit_speed_noise(settings: Any) -> SpeedNoise | None:
    """The fit logs' :class:`sysid.steady.SpeedNoise` a params file records
    (``settings.measurement_noise``: the parts its logs told, NaN for the others); None
    without any.

    Examples
    --------
    >>> law = fit_speed_noise({"measurement_noise": {"std_v_mps": 0.01, "fraction_w": 0.06}})
    >>> law.fraction_w, law.floor_w_radps
    (0.06, nan)
    """
    block = settings.get("measurement_noise") if isinstance(settings, Mapping) else None
    if not isinstance(block, Mapping):
        return None
    floor_v, fraction_v, floor_w, fraction_w = (_part(block.get(k)) for k in SPEED_NOISE_PARTS)
    if all(math.isnan(x) for x in (floor_v, fraction_v, floor_w, fraction_w)):
        return None
    return SpeedNoise(
        floor_v_mps=floor_v, fraction_v=fraction_v, floor_w_radps=floor_w, fraction_w=fraction_w
    )


def _part(x: Any) -> float:
    """``x`` when it is a finite number >= 0, else NaN."""
    ok = not isinstance(x, bool) and isinstance(x, int | float) and math.isfinite(x) and x >= 0
    return float(x) if ok else math.nan


def log_noise(trace: TraceLike) -> SteadyNoise:
    """The log's own odometry noise (module docstring, :func:`sysid.steady.steady_noise`);
    NaN sds when it has fewer than :data:`sysid.steady.MIN_STEADY_SAMPLES` steady samples
    (``measured`` is False).

    Examples
    --------
    >>> own = log_noise(trace)  # doctest: +SKIP
    >>> own.std_v_mps, own.n_samples  # doctest: +SKIP
    (0.0061, 412)
    """
    cmd_v, cmd_w = trace.cmd_at_meas()
    return steady_noise(trace.meas_t_s, cmd_v, cmd_w, trace.meas_v, trace.meas_w)


def band_log_noise(trace: TraceLike, *, replayed: Any = None) -> SteadyNoise:
    """The log's own measurement noise as the band sets it beside the model's share
    (:func:`band_noise`): :func:`log_noise`, with v read on the steady stretches under a
    non-zero v command where there are :data:`sysid.steady.MIN_STEADY_SAMPLES` of them
    (:func:`sysid.steady.motion_noise`). A band has v's scatter to cover where the model's v
    is not zero; spinning in place, odometry reads v close to exact zero, and pooled with
    the spins that scatter reads a fraction of itself.

    With ``replayed`` (a model's replay of the log, the fitted point's), a log with too few
    steady samples is measured by what that replay does not explain
    (:func:`sysid.hfnoise.response_noise`): the one rule of ``agree``'s band
    (:func:`band_sample_noise`) and of a calibration's model share
    (:func:`sim2real.agreement.calibration.held_out_model_noise`).

    Examples
    --------
    >>> band_log_noise(olin_teleop).std_v_mps  # driving; log_noise: 0.0010  # doctest: +SKIP
    0.0122
    """
    cmd_v, cmd_w = trace.cmd_at_meas()
    args = (trace.meas_t_s, cmd_v, cmd_w, trace.meas_v, trace.meas_w)
    own = steady_noise(*args)
    if own.measured:
        driving = motion_noise(*args)[0].std_v_mps
        return replace(own, std_v_mps=driving) if math.isfinite(driving) else own
    if replayed is None:
        return own
    response = _response_noise(trace, replayed)
    return response if response.measured else own


def _response_noise(trace: TraceLike, replayed: Any) -> SteadyNoise:
    """:func:`sysid.hfnoise.response_noise` of ``trace`` against ``replayed`` (its ``v``,
    ``w`` at the measurement times), through the log's measurement and pose."""
    cmd_v, cmd_w = trace.cmd_at_meas()
    return response_noise(
        trace.meas_t_s,
        cmd_v,
        cmd_w,
        trace.meas_v,
        trace.meas_w,
        (replayed.v, replayed.w),
        measurement=getattr(trace, "measurement", None),  # the pose derivative, a slow hold
        pose=log_pose(trace),
    )


@dataclass(frozen=True, kw_only=True)
class ModelShare:
    r"""The model's misses that look like noise, at each sample: a floor and a timing term.

    .. math:: \delta(a)^2 = \delta_0^2 + (\tau\,a)^2,

    with :math:`a` the rate of change of the fitted point's replay at that sample
    (:func:`replay_rate`, m/s² or rad/s²). A replay off in time by :math:`\tau` misses by
    :math:`\tau a`: the misses grow in the transients (starts, stops, turns begun and ended) and
    shrink where the robot runs steady, which one number per axis cannot follow.

    Attributes
    ----------
    std_v_mps, std_w_radps : float
        :math:`\delta_0`: the share where the replay is steady, m/s and rad/s.
    timing_v_s, timing_w_s : float
        :math:`\tau`: the timing scale of each axis's misses, s (0: a share that does not
        depend on the motion).

    Examples
    --------
    >>> share = ModelShare(std_v_mps=0.003, std_w_radps=0.004, timing_w_s=0.04)
    >>> [round(float(x), 4) for x in share.at(np.zeros(2), np.array([0.0, 1.0]))[1]]
    [0.004, 0.0402]
    """

    std_v_mps: float
    std_w_radps: float
    timing_v_s: float = 0.0
    timing_w_s: float = 0.0

    def at(self, rate_v: FloatArray, rate_w: FloatArray) -> tuple[FloatArray, FloatArray]:
        """:math:`\\delta` of v (m/s) and w (rad/s) at the replay's rates of change."""
        return (
            np.hypot(self.std_v_mps, self.timing_v_s * np.asarray(rate_v, dtype=np.float64)),
            np.hypot(self.std_w_radps, self.timing_w_s * np.asarray(rate_w, dtype=np.float64)),
        )


def replay_rate(t_s: Any, y: Any) -> FloatArray:
    """|dy/dt| of a replayed signal at its samples (central differences over the neighbours,
    one-sided at the ends; 0 where the neighbours share a time stamp).

    Examples
    --------
    >>> replay_rate([0.0, 0.1, 0.2, 0.3], [0.0, 0.0, 0.1, 0.1]).round(3).tolist()
    [0.0, 0.5, 0.5, 0.0]
    """
    t = np.asarray(t_s, dtype=np.float64)
    v = np.asarray(y, dtype=np.float64)
    if t.size < 2:
        return np.zeros(t.size)
    ahead, behind = np.r_[1 : t.size, t.size - 1], np.r_[0, 0 : t.size - 1]
    dt = t[ahead] - t[behind]
    out: FloatArray = np.abs(
        np.divide(v[ahead] - v[behind], dt, out=np.zeros(t.size), where=dt > 0)
    )
    return out


def fit_model_share(
    residuals: Any, rates: Any, *, measurement_std: float, at_least: float = 0.0
) -> tuple[float, float]:
    r"""The floor :math:`\delta_0` and timing :math:`\tau` of :class:`ModelShare` on held-out
    residuals of one axis.

    The residuals are sorted by the replay's rate of change :math:`a` into bins of
    :data:`SHARE_BIN_SAMPLES` or more; each bin's robust variance (MAD, the fit's statistic
    for its residuals) is :math:`c_0 + \tau^2 \overline{a^2}`, fitted by non-negative least
    squares in relative terms (each bin's variance is known to a relative error of about one
    over the root of its size; one bin: :math:`\tau = 0`). What the logs' own
    measurement noise ``measurement_std`` explains is taken out of :math:`c_0`;
    ``at_least`` stands in for :math:`\sqrt{c_0}` where it is larger (an axis a calibration
    widened on every sample). NaN, NaN without residuals or a measurement noise.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> a = rng.uniform(0.0, 3.0, 4000)
    >>> r = rng.normal(0.0, np.hypot(0.01, 0.04 * a))
    >>> d0, tau = fit_model_share(r, a, measurement_std=0.006)
    >>> round(d0, 3), round(tau, 3)
    (0.007, 0.039)
    """
    r = np.asarray(residuals, dtype=np.float64)
    if r.size == 0 or not math.isfinite(measurement_std):
        return math.nan, math.nan
    c0, tau2 = variance_law(
        r, rates, bin_samples=SHARE_BIN_SAMPLES, variance_floor=measurement_std**2
    )
    c0 = max(c0, at_least**2)
    return math.sqrt(max(c0 - measurement_std**2, 0.0)), math.sqrt(tau2)


@dataclass(frozen=True, kw_only=True)
class SampleNoise:
    """The band's odometry noise with an sd per measurement sample (the last axis of the
    replays it is added to), applied as :meth:`robots.randomization.ObservationNoise.apply`
    applies its single sd (the same draws).

    Attributes
    ----------
    std_v_mps, std_w_radps : ndarray
        White noise sd at each sample, m/s and rad/s.
    quantum_v_mps, quantum_w_radps : float
        Resolution of the reported values, 0 = none.
    """

    std_v_mps: FloatArray
    std_w_radps: FloatArray
    quantum_v_mps: float = 0.0
    quantum_w_radps: float = 0.0

    def apply(
        self, rng: np.random.Generator, v: Any, w: Any, *, spread: float = 1.0
    ) -> tuple[FloatArray, FloatArray]:
        """Noisy, quantised copies of ``v`` and ``w`` (:func:`robots.randomization.apply_noise`)."""
        return apply_noise(rng, v, w, noise=self, spread=spread)


def band_sample_noise(
    noise: ObservationNoise,
    settings: Any,
    trace: TraceLike,
    replayed: Any,
    *,
    calibration: Any = None,
) -> tuple[ObservationNoise | SampleNoise, str]:
    r"""The band's odometry noise on a checked log, sample by sample: each sample's model
    share beside the log's own measurement noise of its motion.

    .. math:: \sigma_{band,k}^2 = \delta(a_k)^2 + \sigma_{o,k}^2

    :math:`\delta` is the :class:`ModelShare` a calibration measured on logs the fit never
    saw (``calibration.model_noise_*``), at the rate of change :math:`a_k` of ``replayed``
    (the fitted point's replay of ``trace``). :math:`\sigma_o` is the log's own (as the noise
    ceiling takes it, :func:`motion_ceiling`): v where v is commanded from the log's steady
    stretches under a v command, v held at zero as its scatter about zero there
    (:func:`sysid.steady.held_at_zero_noise`: the replay's v is zero, so the odometry's offset
    is a miss too), w from all its steady stretches. Where the log holds no command long
    enough to tell v while driving or w, what ``replayed`` does not explain tells it
    (:func:`sysid.hfnoise.response_noise`: a follower's or a wall follower's commands change at
    every message); a class neither tells takes the fit logs' own
    (``settings.measurement_noise``), and a log that cannot tell its noise at all the file's
    (:func:`band_noise` keeps it too: the fit logs' robust sd need not describe another unit's
    odometry); none is taken below the quantisation's sd :math:`q / \sqrt{12}` (a robust sd of
    quantised readings is 0 once most sit on one step). Without a held-out share (no
    calibration, an older one), :func:`band_noise`.

    Examples
    --------
    >>> noise, note = band_sample_noise(file, settings, trace, sim, calibration=cal)
    ... # doctest: +SKIP
    """
    share = _held_out_share(calibration)
    block = settings.get("measurement_noise") if isinstance(settings, Mapping) else None
    fitted = _stds(block, "std_v_mps", "std_w_radps")
    cmd_v, cmd_w = trace.cmd_at_meas()
    args = (trace.meas_t_s, cmd_v, cmd_w, trace.meas_v, trace.meas_w)
    own = steady_noise(*args)
    if share is None:
        return band_noise(noise, settings, band_log_noise(trace), calibration=calibration)
    moving, still = motion_noise(*args)[0], held_at_zero_noise(*args)
    response = _response_noise(trace, replayed)  # where no command is held long enough
    # a log that cannot tell its noise keeps the file's, as the one-number band does
    fit_v, fit_w = (
        fitted
        if fitted is not None and (own.measured or response.measured)
        else (noise.std_v_mps, noise.std_w_radps)
    )
    sd_v = np.where(
        np.asarray(cmd_v) != 0,
        _known(moving.std_v_mps, _known(response.std_v_mps, fit_v)),
        _known(still.std_v_mps, fit_v),
    )
    sd_w = np.full(sd_v.shape, _known(own.std_w_radps, _known(response.std_w_radps, fit_w)))
    # a robust sd of readings on a lattice says 0 once most of them sit on one step: below
    # the quantum the noise is the quantisation's at least
    sd_v = np.maximum(sd_v, noise.quantum_v_mps / math.sqrt(12.0))
    sd_w = np.maximum(sd_w, noise.quantum_w_radps / math.sqrt(12.0))
    t = trace.meas_t_s
    model_v, model_w = share.at(replay_rate(t, replayed.v), replay_rate(t, replayed.w))
    out = SampleNoise(
        std_v_mps=np.hypot(model_v, sd_v),
        std_w_radps=np.hypot(model_w, sd_w),
        quantum_v_mps=noise.quantum_v_mps,
        quantum_w_radps=noise.quantum_w_radps,
    )
    return out, (
        f"the band's odometry noise is, at each sample, the model's share measured on the "
        f"calibration logs the fit never saw (v {share.std_v_mps:.3g} m/s + "
        f"{share.timing_v_s:.3g} s x the replay's acceleration, w {share.std_w_radps:.3g} rad/s "
        f"+ {share.timing_w_s:.3g} s x its angular acceleration) beside this log's own "
        f"measurement noise of that motion (the fit logs' where it cannot tell): median v "
        f"{float(np.median(out.std_v_mps)):.3g} m/s, w {float(np.median(out.std_w_radps)):.3g} "
        f"rad/s (the file's: {noise.std_v_mps:.3g}, {noise.std_w_radps:.3g})"
    )


def _known(x: float, fallback: float) -> float:
    return x if math.isfinite(x) else fallback


def _held_out_share(calibration: Any) -> ModelShare | None:
    """The :class:`ModelShare` a calibration block records (None without one)."""
    held = _stds(calibration, "model_noise_std_v_mps", "model_noise_std_w_radps")
    timing = _stds(calibration, "model_noise_timing_v_s", "model_noise_timing_w_s")
    if held is None or timing is None:
        return None
    return ModelShare(
        std_v_mps=held[0], std_w_radps=held[1], timing_v_s=timing[0], timing_w_s=timing[1]
    )


def band_noise(
    noise: ObservationNoise, settings: Any, own: SteadyNoise, *, calibration: Any = None
) -> tuple[ObservationNoise, str]:
    r"""The odometry noise of the band on a checked log: a noise model per odometry source.

    The band's white noise is the checked log's own measurement noise :math:`\sigma_o`
    (:func:`band_log_noise`) beside the model's misses that look like noise, :math:`\delta`, per
    axis:

    .. math:: \sigma_{band}^2 = \delta^2 + \sigma_o^2.

    :math:`\delta` is judged out of sample where it can be: ``sysid calibrate`` replays the
    fitted point on logs the fit never saw and records the robust sd of its residuals beyond
    those logs' own measurement noise (``calibration.model_noise_std_v_mps``, ``_w_radps``).
    In sample, the fit's residual sd :math:`\sigma` (the file's noise) holds what the loops
    of the fitted model absorbed, so a more flexible loop form reads a smaller share; only a
    file without that record gives :math:`\delta^2 = \max(\sigma^2 - \sigma_f^2, 0)`, with
    :math:`\sigma_f` the fit logs' own scatter where they run steady
    (``settings.measurement_noise``). Where neither is recorded or the checked log cannot tell
    :math:`\sigma_o`, the file's noise; the note is then "".

    Examples
    --------
    >>> from robots.randomization import ObservationNoise
    >>> file = ObservationNoise(std_v_mps=0.016, std_w_radps=0.016)
    >>> fitted = {"measurement_noise": {"std_v_mps": 0.012, "std_w_radps": 0.015}}
    >>> own = SteadyNoise(std_v_mps=0.0006, std_w_radps=0.03, n_samples=200)
    >>> noise, _ = band_noise(file, fitted, own)
    >>> round(noise.std_v_mps, 4), round(noise.std_w_radps, 4)
    (0.0106, 0.0305)
    >>> held_out = {"model_noise_std_v_mps": 0.008, "model_noise_std_w_radps": 0.0}
    >>> noise, _ = band_noise(file, fitted, own, calibration=held_out)
    >>> round(noise.std_v_mps, 4), round(noise.std_w_radps, 4)
    (0.008, 0.03)
    """
    if not own.measured:
        return noise, ""
    shares, whose = _model_share(noise, settings, calibration)
    if shares is None:
        return noise, ""
    out = replace(
        noise,
        std_v_mps=math.hypot(shares[0], own.std_v_mps),
        std_w_radps=math.hypot(shares[1], own.std_w_radps),
    )
    return out, (
        f"the band's odometry noise is this log's own measurement noise (v {own.std_v_mps:.3g} "
        f"m/s, w {own.std_w_radps:.3g} rad/s) beside {whose}: v "
        f"{noise.std_v_mps:.3g} -> {out.std_v_mps:.3g} m/s, w {noise.std_w_radps:.3g} -> "
        f"{out.std_w_radps:.3g} rad/s"
    )


def _model_share(
    noise: ObservationNoise, settings: Any, calibration: Any
) -> tuple[tuple[float, float] | None, str]:
    """The model's share of the noise (v m/s, w rad/s) as :func:`band_noise` takes it, and
    the words that say whose it is; (None, "") when the file records neither."""
    held = _stds(calibration, "model_noise_std_v_mps", "model_noise_std_w_radps")
    if held is not None:
        return held, (
            f"the model's share of the noise, measured on the calibration logs the fit never "
            f"saw (v {held[0]:.3g} m/s, w {held[1]:.3g} rad/s)"
        )
    block = settings.get("measurement_noise") if isinstance(settings, Mapping) else None
    fitted = _stds(block, "std_v_mps", "std_w_radps")
    if fitted is None:
        return None, ""
    share = (
        math.sqrt(max(noise.std_v_mps**2 - fitted[0] ** 2, 0.0)),
        math.sqrt(max(noise.std_w_radps**2 - fitted[1] ** 2, 0.0)),
    )
    return share, (
        f"the model's share of the file's noise (the fit logs' own was v {fitted[0]:.3g}, w "
        f"{fitted[1]:.3g})"
    )


def _stds(block: Any, key_v: str, key_w: str) -> tuple[float, float] | None:
    """The two non-negative finite numbers ``block`` holds at ``key_v`` and ``key_w``; None
    when it is no mapping or either is missing or not such a number."""
    if not isinstance(block, Mapping):
        return None
    out = []
    for key in (key_v, key_w):
        x = block.get(key)
        if isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(x) or x < 0:
            return None
        out.append(float(x))
    return out[0], out[1]


def noise_note(own: SteadyNoise, fit: ObservationNoise | None) -> str:
    """One sentence: whose odometry noise the noise ceiling and the noise-only band assume
    ("" when there is none to assume)."""
    if own.measured:
        said = (
            f"the noise ceiling and the noise-only band use this log's own odometry noise, v "
            f"{own.std_v_mps:.3g} m/s and w {own.std_w_radps:.3g} rad/s (robust sd about the "
            f"level of {own.n_samples} samples under commands held over {STEADY_AFTER_S:g} s)"
        )
        if fit is None:
            return said
        return (
            f"{said}; the fit estimated v {fit.std_v_mps:.3g} m/s and w {fit.std_w_radps:.3g} rad/s"
        )
    if fit is None:
        return ""
    return (
        f"this log has {own.n_samples} samples under commands held over {STEADY_AFTER_S:g} s "
        f"({MIN_STEADY_SAMPLES} needed to measure its own odometry noise), so the noise ceiling "
        f"and the noise-only band use the fit's: v {fit.std_v_mps:.3g} m/s and w "
        f"{fit.std_w_radps:.3g} rad/s"
    )


def _score(rep: AgreementReport) -> tuple[float, float]:
    """Agreement first; of equal agreements the smaller error (RMSE in tolerance units)."""
    err = math.hypot(rep.rmse_v / rep.tol_v, rep.rmse_w / rep.tol_w)
    return (rep.agreement, -err if math.isfinite(err) else -math.inf)


def session_latency(
    trace: TraceLike,
    *,
    robot: RobotSpecLike,
    params: DriveParams,
    engine: str = "reduced",
    odom_v_window_s: float = 0.0,
    tol_v: float,
    tol_w: float,
    params_file: str | None = None,
) -> SessionLatency:
    """The command latency that fits the checked log best, every other parameter kept.

    The latency is searched with the reduced model (the latency is the session's, not the
    engine's) on a 0.05 s grid over 0-0.6 s and the fitted delay, then on a 0.01 s grid
    around the best; the agreement at it is measured with ``engine``.

    Parameters
    ----------
    trace : Trace
        The checked log.
    robot : RobotSpec
        The robot.
    params : DriveParams
        The fitted drive parameters.
    engine : {"reduced", "pybullet"}
        Simulator of the reported agreement.
    odom_v_window_s : float
        Odometry window of v, s (as :func:`sim2real.agreement.replay.replay`).
    tol_v, tol_w : float
        Agreement tolerances, m/s and rad/s.
    params_file : str, optional
        Provenance copied into the report.

    Returns
    -------
    SessionLatency

    Examples
    --------
    >>> lat = session_latency(trace, robot=spec, params=p, tol_v=0.02, tol_w=0.1)  # doctest: +SKIP
    >>> lat.delay_s, lat.report.agreement  # doctest: +SKIP
    (0.23, 0.86)
    """

    def run(delay_s: float, eng: str) -> Any:
        sim = replay(
            trace,
            robot=robot,
            params=params.replace(delay_s=delay_s),
            engine=eng,
            odom_v_window_s=odom_v_window_s,
        )
        return measure_agreement(trace, sim, tol_v=tol_v, tol_w=tol_w, params_file=params_file)

    scores: dict[float, tuple[float, float]] = {}

    def search(grid: np.ndarray) -> float:
        for d in grid:
            key = round(float(d), 6)
            if key not in scores and 0.0 <= key <= LATENCY_MAX_S:
                scores[key] = _score(run(key, "reduced"))
        return max(scores, key=lambda k: scores[k])

    coarse = np.arange(0.0, LATENCY_MAX_S + 1e-9, LATENCY_COARSE_STEP_S)
    best = search(np.append(coarse, params.delay_s))
    span = LATENCY_COARSE_STEP_S - LATENCY_FINE_STEP_S
    best = search(np.arange(best - span, best + span + 1e-9, LATENCY_FINE_STEP_S))
    return SessionLatency(
        delay_s=best, fitted_delay_s=float(params.delay_s), report=run(best, engine)
    )
