"""The one verdict of an agreement run: what its figures mean and what to do next.

:func:`decide` reads the figures of a run (the spec defaults' replay, the fitted replay, the
band, and the optional figures of the checked session) and returns one
:class:`AgreementVerdict`: a headline, the reasons behind it and one next step. ``sim2real
agree`` prints its words and the HTML report shows the same words, so the terminal and the page
never disagree.

The headline is the first of these that holds:

1. **too little data**: fewer than :data:`MIN_ACTIVE` active samples;
2. **no fit**: only the spec defaults were replayed (next: fit the drive model);
3. **the log is one the fit used**: its figures measure the fit, not a new session;
4. **fit worse than the spec defaults**: the fitted agreement is more than
   :data:`WORSE_MARGIN` under the defaults' (or under them at all when the robot holds less
   than the fitted model at its top speed), with its likely cause (this session's latency, a
   unit slower than the fit's, commands outside the fitted envelope, a top speed under what
   the robot holds, a delay driven to zero);
5. **latency of this session differs**: the fitted replay lags or leads the real robot by
   more than :data:`LAG_LIMIT_S`, or the session's own best latency is that far from the
   fitted delay;
6. **the fit extrapolates**: the log drives outside the envelope the fit saw (speeds, turns
   while driving, accelerations) for at least :data:`EXTRAPOLATES_SHARE` of its active
   samples, so its figures and its band judge the model where no fitting log informed it;
7. **the fit is short of** :data:`GOOD_AGREEMENT` (or of the noise ceiling less
   :data:`CEILING_SLACK`, when the measurement noise allows no more);
8. **the band**: none run, too narrow, too wide or calibrated
   (:func:`sim2real.agreement.figures.band_verdict`).

Every other finding that holds (commands outside the fitted envelope, a band calibrated by
being wide, a noise ceiling under the target) is a reason.

Examples
--------
>>> from sim2real.agreement.figures import agreement_from_arrays
>>> import numpy as np
>>> t = np.arange(100) * 0.1
>>> rep = agreement_from_arrays(t_s=t, cmd_v=np.full(100, 0.2), cmd_w=np.zeros(100),
...     real_v=np.full(100, 0.2), real_w=np.zeros(100), sim_v=np.full(100, 0.2),
...     sim_w=np.zeros(100), robot="r")
>>> decide(defaults=rep, fitted=None, robot="r").headline.split(":")[0]
'The spec defaults reach 100.0 % (no fit)'
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from sim2real.agreement.figures import band_verdict, calibrated_range, lag_phrase

__all__ = [
    "CEILING_SLACK",
    "EXTRAPOLATES_SHARE",
    "GOOD_AGREEMENT",
    "LAG_LIMIT_S",
    "LATENCY_GAIN",
    "MIN_ACTIVE",
    "OUTSIDE_SHARE",
    "WIDE_SHARE",
    "WORSE_MARGIN",
    "AgreementVerdict",
    "SessionFigures",
    "band_miss_reason",
    "decide",
    "mean_lag_s",
    "percent",
    "speed_shortfall",
    "verdict_text",
]

#: A session's own latency that lifts the agreement by no more than this is no finding.
LATENCY_GAIN = 0.005
#: Agreement from which the model is good enough to train with ("over 80 %", Liang et al. 2020).
GOOD_AGREEMENT = 0.8
#: A lag (or a latency difference) beyond this is a timing error worth fixing first, s.
LAG_LIMIT_S = 0.05
#: A fit within this much of the noise ceiling is as good as the measurement noise allows.
CEILING_SLACK = 0.05
#: A replay that beats the noise ceiling by more than this shows the noise estimate overstates.
CEILING_BEATEN = 0.02
#: Fewer active samples than this make the figures too uncertain to judge.
MIN_ACTIVE = 50
#: The fit counts as worse than the spec defaults when its agreement is this much lower.
WORSE_MARGIN = 0.02
#: Commands outside the fitted envelope for at least this share of the time are a reason.
OUTSIDE_SHARE = 0.01
#: ... and for at least this share, the headline (the figures judge an extrapolation).
EXTRAPOLATES_SHARE = 0.1
#: A calibrated band wider than this share of the top speed (yaw rate) is "wide".
WIDE_SHARE = 0.2
#: A calibrated band is only as narrow as the measurement noise allows: up to this many times
#: the noise-only band counts as narrow enough.
NOISE_BAND_SLACK = 1.25
#: The simulation runs at its top where it reaches this share of its top speed (yaw rate).
HELD_TOP_SHARE = 0.95
#: A held top speed is read on at least this many samples at the top.
HELD_TOP_MIN = 10


#: Misses of a band within this long after a command step count as at the step, s.
STEP_WINDOW_S = 1.0
#: A band that misses mostly near command steps (at least this share) misses timing.
TIMING_SHARE = 0.6
#: A band that misses mostly on one side (at least this share) misses a bias.
BIAS_SHARE = 0.8


class _Agreement(Protocol):
    agreement: float
    lag_s_v: float
    lag_s_w: float
    n_active: int
    log_file: str | None
    params_file: str | None


@dataclass(frozen=True, kw_only=True)
class SessionFigures:
    """Optional figures of the checked session; None where they were not measured.

    Attributes
    ----------
    best_delay_s : float or None
        The command latency that fits this session best, s.
    agreement_at_best_delay : float or None
        The fitted model's agreement at that latency (0..1).
    fitted_delay_s : float or None
        The fitted model's command delay (``delay_s`` of the params), s.
    noise_ceiling : float or None
        The agreement a perfect model would reach given the measurement noise (0..1).
    noise_band_width_v_mps, noise_band_width_w_radps : float or None
        Width of the 90 % band that the measurement noise alone forces.
    top_v_mps, top_w_radps : float or None
        The robot's top speed and yaw rate (the spec's), to judge the band's width.
    speed_shortfall : tuple of str or None
        ``(axis, real, sim)`` when the fitted model's top speed differs from what the robot
        holds (:func:`speed_shortfall`; ``real < sim``: the robot is the slower).
    extrapolation : object or None
        The checked log against the fit's envelope (:class:`sysid.envelope.EnvelopeCheck`):
        ``known``, ``share_outside`` and ``sentence``.
    noise_note : str or None
        Whose odometry noise the noise ceiling and band assume (this log's own or the fit's),
        one sentence (:func:`sim2real.agreement.latency.noise_note`).
    band_misses : str or None
        Why the band covers too little, where it does (:func:`band_miss_reason`).
    fit_log : str or None
        The checked log as the params file names it when the file was fitted on it
        (``a.mcap[0:16]`` for a fitted part).
    """

    best_delay_s: float | None = None
    agreement_at_best_delay: float | None = None
    fitted_delay_s: float | None = None
    noise_ceiling: float | None = None
    noise_band_width_v_mps: float | None = None
    noise_band_width_w_radps: float | None = None
    top_v_mps: float | None = None
    top_w_radps: float | None = None
    speed_shortfall: tuple[str, float, float] | None = None
    extrapolation: Any = None
    noise_note: str | None = None
    band_misses: str | None = None
    fit_log: str | None = None


@dataclass(frozen=True, kw_only=True)
class AgreementVerdict:
    """The verdict of one agreement run.

    Attributes
    ----------
    kind : str
        What the headline is about: ``"too_little_data"``, ``"no_fit"``, ``"fit_log"``,
        ``"fit_worse"``,
        ``"latency"``, ``"extrapolates"``, ``"poor_fit"``, ``"no_band"``, ``"band_narrow"``,
        ``"band_wide"``, ``"band_mixed"``, ``"band_unknown"`` or ``"calibrated"``.
    headline : str
        One sentence: the verdict.
    reasons : tuple of str
        Further findings, one sentence each.
    next_step : str
        One sentence: what to do next.
    ok : bool
        True when nothing needs fixing (a calibrated band on a good fit).
    """

    kind: str
    headline: str
    reasons: tuple[str, ...]
    next_step: str
    ok: bool

    def lines(self, *, about: str = "") -> tuple[str, ...]:
        """The verdict as the terminal prints it: headline, reasons, next step; ``about``
        (a log's name, in a fleet) is put in the first line: ``verdict (a.mcap): ...``."""
        return (
            f"verdict{f' ({about})' if about else ''}: {self.headline}",
            *(f"  - {r}" for r in self.reasons),
            f"next step: {self.next_step}",
        )

    def to_dict(self) -> dict[str, Any]:
        """The ``verdict`` entry of a log's JSON figures (plain JSON types).

        Examples
        --------
        >>> v = AgreementVerdict(kind="no_fit", headline="H.", reasons=("r.",),
        ...                      next_step="s.", ok=False)
        >>> AgreementVerdict.from_dict(v.to_dict()) == v
        True
        """
        return {
            "kind": self.kind,
            "headline": self.headline,
            "reasons": list(self.reasons),
            "next_step": self.next_step,
            "ok": bool(self.ok),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> AgreementVerdict:
        """Inverse of :meth:`to_dict` (a fleet's per-log verdicts come back as JSON)."""
        return cls(
            kind=str(data["kind"]),
            headline=str(data["headline"]),
            reasons=tuple(str(r) for r in data["reasons"]),
            next_step=str(data["next_step"]),
            ok=bool(data["ok"]),
        )


def verdict_text(verdict: AgreementVerdict) -> str:
    """:meth:`AgreementVerdict.lines` joined by newlines (what ``sim2real agree`` prints)."""
    return "\n".join(verdict.lines())


def percent(x: float | None) -> str:
    """A share as the verdict prints it: one decimal, or ``n/a`` when it is not known.

    Examples
    --------
    >>> percent(0.9551), percent(None)
    ('95.5 %', 'n/a')
    """
    return f"{100 * x:.1f} %" if x is not None and math.isfinite(x) else "n/a"


def mean_lag_s(a: _Agreement) -> float:
    """The mean of an agreement's finite lags on v and w, s (NaN when neither is known)."""
    lags = [x for x in (a.lag_s_v, a.lag_s_w) if math.isfinite(x)]
    return sum(lags) / len(lags) if lags else math.nan


def _finite(x: float | None) -> bool:
    return x is not None and math.isfinite(x)


def speed_shortfall(
    real_v: Any, real_w: Any, sim_v: Any, sim_w: Any, active: Any, *, tol_v: float, tol_w: float
) -> tuple[str, float, float] | None:
    """``(axis, real, sim)`` when the simulation's top speed differs from the robot's.

    Two checks per axis, in order: the simulation tops out under the robot (the 95th
    percentile of |velocity| over the active samples, so that a spike makes no top speed);
    then the robot holds less than the simulation at the simulation's top (the medians of
    |velocity| over the active samples where the simulation runs at
    :data:`HELD_TOP_SHARE` of its top or more, at least :data:`HELD_TOP_MIN` of them: a unit,
    battery or load slower than the fit's). Either counts when it exceeds the tolerance of
    that axis; ``real < sim`` in the result tells the second.

    Examples
    --------
    >>> import numpy as np
    >>> speed_shortfall(np.full(50, 0.3), np.zeros(50), np.full(50, 0.27), np.zeros(50),
    ...                 np.ones(50, bool), tol_v=0.02, tol_w=0.1)
    ('v', 0.3, 0.27)
    >>> speed_shortfall(np.full(50, 0.276), np.zeros(50), np.full(50, 0.302), np.zeros(50),
    ...                 np.ones(50, bool), tol_v=0.02, tol_w=0.1)
    ('v', 0.276, 0.302)
    """
    act = np.asarray(active, dtype=bool)
    if not act.any():
        return None
    axes = (("v", real_v, sim_v, tol_v), ("w", real_w, sim_w, tol_w))
    for axis, real, sim, tol in axes:
        top_real = float(np.percentile(np.abs(np.asarray(real, dtype=float)[act]), 95))
        top_sim = float(np.percentile(np.abs(np.asarray(sim, dtype=float)[act]), 95))
        if top_real - top_sim > tol:
            return axis, round(top_real, 4), round(top_sim, 4)
    for axis, real, sim, tol in axes:
        r = np.abs(np.asarray(real, dtype=float)[act])
        s = np.abs(np.asarray(sim, dtype=float)[act])
        at_top = s >= HELD_TOP_SHARE * float(np.percentile(s, 99))
        if at_top.sum() < HELD_TOP_MIN:
            continue
        held_real, held_sim = float(np.median(r[at_top])), float(np.median(s[at_top]))
        if held_sim - held_real > tol:
            return axis, round(held_real, 4), round(held_sim, 4)
    return None


def _latency_reason(fitted: _Agreement, s: SessionFigures) -> str | None:
    """One sentence when this session's latency differs from the fitted one (else None)."""
    best, fitted_delay = s.best_delay_s, s.fitted_delay_s
    if best is not None and fitted_delay is not None and _finite(best) and _finite(fitted_delay):
        gap = best - fitted_delay
        at_best = s.agreement_at_best_delay
        if at_best is not None and _finite(at_best) and at_best <= fitted.agreement + LATENCY_GAIN:
            return None  # the delay changes nothing here (no command step to time)
        if abs(gap) > LAG_LIMIT_S:
            at = (
                f" (agreement there {percent(s.agreement_at_best_delay)})"
                if _finite(s.agreement_at_best_delay)
                else ""
            )
            return (
                f"this session's own best command latency is {best:.3f} s where the "
                f"fit has {fitted_delay:.3f} s{at}"
            )
        return None
    lag = mean_lag_s(fitted)
    if math.isfinite(lag) and abs(lag) > LAG_LIMIT_S:
        return f"{lag_phrase(lag)} (cross-correlation of v and w)"
    return None


def _latency_share(fitted: _Agreement, s: SessionFigures) -> str | None:
    """How much of the fit's shortfall this session's own latency accounts for, one sentence
    (None when it is not measured, or when the latency differs: the headline says it then)."""
    best, delay, at = s.best_delay_s, s.fitted_delay_s, s.agreement_at_best_delay
    if best is None or delay is None or at is None or _latency_reason(fitted, s):
        return None
    if not all(math.isfinite(x) for x in (best, delay, at)):
        return None
    gained = max(0.0, at - fitted.agreement)
    return (
        f"at this session's own best command latency, {best:.3f} s (the fit has {delay:.3f} "
        f"s), the fit reaches {percent(at)} against {percent(fitted.agreement)}: latency accounts "
        f"for {100 * gained:.1f} points and the dynamics for the other "
        f"{100 * max(0.0, 1.0 - fitted.agreement - gained):.1f} points short of 100 %"
    )


def _extrapolation_reason(s: SessionFigures) -> str | None:
    ext = s.extrapolation
    if ext is None:
        return None
    if not getattr(ext, "known", False) or getattr(ext, "share_outside", 0.0) >= OUTSIDE_SHARE:
        return str(ext.sentence)
    return None


def _likely_cause(defaults: _Agreement, fitted: _Agreement, s: SessionFigures) -> str:
    """The likely cause of a fit that does worse than the spec defaults, one clause.

    This session's own latency is the cause when the fit at that latency comes within
    :data:`WORSE_MARGIN` of the defaults (or when that agreement is unknown); when it stays
    further under, the latency explains only part of the gap, which is said after the cause
    found among the others.
    """
    latency = _latency_reason(fitted, s)
    at_best = s.agreement_at_best_delay
    if latency is None:
        return _other_cause(s)
    if at_best is None or not _finite(at_best) or at_best >= defaults.agreement - WORSE_MARGIN:
        return f"{latency}: the latency of this session differs"
    part = "this session's own latency explains only part of the gap"
    return f"{_other_cause(s)}; {part}: {latency}"


def _other_cause(s: SessionFigures) -> str:
    """The likely cause of a fit worse than the defaults, latency aside, one clause: a robot
    that holds less than the fitted model at its top speed first (a property of this unit no
    fit log of another could show), then commands outside the fitted envelope, a fitted top
    speed under the robot's, a delay driven to zero."""
    slower = _slower_unit(s)
    if slower is not None:
        return slower
    ext = s.extrapolation
    if ext is not None and getattr(ext, "known", False) and ext.share_outside >= EXTRAPOLATES_SHARE:
        return (
            f"this log drives outside what the fit log saw for {percent(ext.share_outside)} of "
            "its active time"
        )
    if s.speed_shortfall is not None and s.speed_shortfall[1] > s.speed_shortfall[2]:
        axis, real, sim = s.speed_shortfall
        unit = "m/s" if axis == "v" else "rad/s"
        return (
            f"the fitted model tops out at {sim:.3g} {unit} in {axis} where the robot holds "
            f"{real:.3g} {unit} (a top speed fitted under a spiky or pose-derived velocity)"
        )
    if _finite(s.fitted_delay_s) and s.fitted_delay_s is not None and s.fitted_delay_s < 0.005:
        return (
            f"the fitted command delay is {s.fitted_delay_s:.3g} s (driven to zero: the fit "
            "log's timing did not identify it)"
        )
    return "the fit log does not excite what this log does (other speeds, turns or a session)"


def _slower_unit(s: SessionFigures) -> str | None:
    """One clause when the robot holds less than the fitted model at its top (else None)."""
    if s.speed_shortfall is None or s.speed_shortfall[1] >= s.speed_shortfall[2]:
        return None
    axis, real, sim = s.speed_shortfall
    unit, top = ("m/s", "top speed") if axis == "v" else ("rad/s", "top yaw rate")
    return (
        f"this robot holds {real:.3g} {unit} in {axis} where the fitted model holds {sim:.3g} "
        f"{unit} at its {top}: this unit is slower than the fit log's (another unit's "
        f"{top}, or its battery, load or floor)"
    )


def band_miss_reason(ensemble: Any, real_v: Any, real_w: Any, since_step_s: Any) -> str | None:
    """One sentence on why the band covers too little, where it does (else None).

    For each axis under :func:`sim2real.agreement.figures.calibrated_range`, the misses
    (active real samples outside the band) are read: mostly within :data:`STEP_WINDOW_S` of a
    command step (:data:`TIMING_SHARE`), this session's timing or transients differ; mostly on
    one side (:data:`BIAS_SHARE`), a bias (the robot runs faster or slower than every member:
    another unit, load or floor); else a steady scatter wider than the band. ``since_step_s``
    is :func:`sim2real.agreement.figures.since_command_step_s` at the measurements.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> ens = SimpleNamespace(band_level=0.9, coverage_v=0.5, coverage_w=0.9,
    ...     lo_v=np.zeros(4), hi_v=np.full(4, 0.1), lo_w=np.zeros(4), hi_w=np.ones(4),
    ...     active=np.ones(4, bool))
    >>> why = band_miss_reason(ens, np.array([0.05, 0.05, 0.3, 0.3]), np.zeros(4), np.full(4, 5))
    >>> why.split(" (")[0]
    'the band covers too little v because of a bias: the robot runs faster than every simulated member'
    """
    low = calibrated_range(ensemble.band_level)[0]
    parts = []
    for axis, real, lo, hi, cov, unit in (
        ("v", real_v, ensemble.lo_v, ensemble.hi_v, ensemble.coverage_v, "m/s"),
        ("w", real_w, ensemble.lo_w, ensemble.hi_w, ensemble.coverage_w, "rad/s"),
    ):
        act = np.asarray(ensemble.active, dtype=bool)
        arrays = [np.asarray(x, dtype=float) for x in (real, lo, hi, since_step_s)]
        if not (_finite(cov) and cov < low) or any(a.shape != act.shape for a in arrays):
            continue
        r, lo_, hi_, since = (a[act] for a in arrays)
        below, above = r < lo_, r > hi_
        n_miss = int((below | above).sum())
        if n_miss == 0:
            continue
        near = float(((below | above) & (since <= STEP_WINDOW_S)).sum()) / n_miss
        side = "above" if above.sum() > below.sum() else "below"
        one_side = float(max(above.sum(), below.sum())) / n_miss
        gap = float(np.median(np.where(above, r - hi_, lo_ - r)[below | above]))
        where = (
            f"{100 * n_miss / r.size:.0f} % of its active samples fall outside, "
            f"{100 * one_side:.0f} % of them {side} it (median {gap:.3g} {unit} out) and "
            f"{100 * near:.0f} % within {STEP_WINDOW_S:g} s of a command step"
        )
        if near >= TIMING_SHARE:
            why = "timing: this session's latency or transients differ from the spread's"
        elif one_side >= BIAS_SHARE:
            pace = "faster" if side == "above" else "slower"
            why = (
                f"a bias: the robot runs {pace} than every simulated member (another unit, "
                "load or floor than the fit's)"
            )
        else:
            why = "steady scatter wider than the band (this log's odometry is noisier)"
        parts.append(f"{axis} because of {why}: {where}")
    if not parts:
        return None
    return "the band covers too little " + "; and too little ".join(parts)


def _band_words(ensemble: Any) -> str:
    return band_verdict(
        coverage_v=ensemble.coverage_v,
        coverage_w=ensemble.coverage_w,
        band_level=ensemble.band_level,
        band_width_v_mps=ensemble.band_width_v_mps,
        band_width_w_radps=ensemble.band_width_w_radps,
    )


def _band_state(ensemble: Any) -> tuple[str, bool]:
    head = _band_words(ensemble).split(":")[0]
    if "calibrated" in head:
        return "calibrated", True
    if "narrow" in head and "wide" in head:
        return "band_mixed", False
    if "narrow" in head:
        return "band_narrow", False
    if "wide" in head:
        return "band_wide", False
    return "band_unknown", False


def _wide_reason(ensemble: Any, s: SessionFigures) -> str | None:
    """A band that covers by being wide: one sentence (else None); an axis it covers too
    little is not wide enough to say so."""
    wide = []
    low = calibrated_range(ensemble.band_level)[0]
    for axis, width, top, noise, unit, cov in (
        ("v", ensemble.band_width_v_mps, s.top_v_mps, s.noise_band_width_v_mps, "m/s",
         ensemble.coverage_v),
        ("w", ensemble.band_width_w_radps, s.top_w_radps, s.noise_band_width_w_radps, "rad/s",
         ensemble.coverage_w),
    ):  # fmt: skip
        if not (_finite(width) and _finite(top)) or top is None or top <= 0 or cov < low:
            continue
        if width <= WIDE_SHARE * top:
            continue
        if _finite(noise) and noise is not None and width <= NOISE_BAND_SLACK * noise:
            continue
        share = f"{100 * width / top:.0f} % of the top {'speed' if axis == 'v' else 'yaw rate'}"
        floor = f", {width / noise:.2g}x the noise-only band" if _finite(noise) and noise else ""
        wide.append(f"{axis} {width:.3g} {unit} ({share}{floor})")
    if not wide:
        return None
    return (
        f"the band holds the robot by being wide: median width {' and '.join(wide)}; "
        f"a useful band is at most {100 * WIDE_SHARE:.0f} % of the top speed or "
        f"{NOISE_BAND_SLACK:g}x what the measurement noise forces"
    )


def _good_agreement(s: SessionFigures) -> float:
    """The agreement a fit must reach: :data:`GOOD_AGREEMENT`, or within
    :data:`CEILING_SLACK` of the noise ceiling when the measurement noise allows no more."""
    ceiling = s.noise_ceiling
    if ceiling is not None and _finite(ceiling):
        return min(GOOD_AGREEMENT, ceiling - CEILING_SLACK)
    return GOOD_AGREEMENT


def _ceiling_reason(s: SessionFigures, reached: float) -> str | None:
    """Why the noise ceiling matters, or why it does not describe this log.

    ``reached`` is the best agreement a replay reached on this log (fitted, or at this log's
    own best latency). A replay cannot beat a ceiling that its noise model states truly; when
    it does by more than :data:`CEILING_BEATEN`, the noise assumed overstates this log's
    odometry noise, and the verdict says so instead of judging the fit against it. Each
    reason ends with whose noise it is (``s.noise_note``)."""
    ceiling = s.noise_ceiling
    if ceiling is None or not _finite(ceiling) or ceiling >= GOOD_AGREEMENT:
        return s.noise_note or None  # whose noise the band's floor assumes, still said
    if _finite(reached) and reached > ceiling + CEILING_BEATEN:
        return (
            f"the fit reaches {percent(reached)}, above the {percent(ceiling)} that the odometry "
            "noise assumed would allow (noise ceiling): that estimate overstates this "
            "log's noise, so the ceiling is not used to judge it" + _said(s.noise_note)
        )
    return (
        f"the measurement noise caps the agreement a perfect model could reach at "
        f"{percent(ceiling)} (noise ceiling): judge the fit against that" + _said(s.noise_note)
    )


def _said(note: str | None) -> str:
    """``note`` appended to a reason ("" without one)."""
    return f"; {note}" if note else ""


def _fit_step(robot: str, log: str) -> str:
    return (
        f"fit the drive model to a log of this robot, 'sim2real sysid fit TRAIN.mcap --robot "
        f"{robot} -o params.yaml', then compare again with 'sim2real agree {log} --robot "
        f"{robot} --params params.yaml --ensemble 30'"
    )


def _band_next(kind: str, ensemble: Any, params: str) -> str:
    calibrate = (
        f"'sim2real sysid calibrate {params} VALIDATION.mcap -o calibrated.yaml' on a log "
        "the fit did not use"
    )
    if kind == "calibrated":
        return (
            "train with this randomisation (randomizers.DynamicsRandomizer.from_sysid and "
            "VelocityObservationNoise.from_sysid of the same params file)"
        )
    if kind == "band_narrow":
        return (
            f"widen the band with {calibrate}, or fit several sessions at once "
            "(sysid fit a.mcap b.mcap ...) so the between-session spread is estimated"
        )
    if kind == "band_unknown":
        return "record a log in which the robot moves and turns, and compare on it"
    return f"fit the band's spread with {calibrate}"


def decide(
    *,
    defaults: _Agreement,
    fitted: _Agreement | None,
    robot: str,
    ensemble: Any = None,
    session: SessionFigures | None = None,
) -> AgreementVerdict:
    """The verdict of an agreement run.

    Parameters
    ----------
    defaults : AgreementReport
        The spec defaults' replay of the checked log.
    fitted : AgreementReport, optional
        The replay with the params file; None when only the defaults were run.
    robot : str
        The robot as the user named it (a spec name or a spec file path), for the advice.
    ensemble : EnsembleResult, optional
        The band (``coverage_v``, ``coverage_w``, ``band_level``, median widths).
    session : SessionFigures, optional
        Optional figures of the checked session (latency, noise, envelope, top speeds).

    Returns
    -------
    AgreementVerdict
    """
    s = session or SessionFigures()
    main = fitted if fitted is not None else defaults
    log = main.log_file or "LOG.mcap"
    params = (fitted.params_file if fitted is not None else None) or "params.yaml"
    reasons: list[str] = []
    reached = max(
        main.agreement,
        s.agreement_at_best_delay
        if fitted is not None and s.agreement_at_best_delay is not None
        else -math.inf,
    )
    latency = _latency_share(fitted, s) if fitted is not None else None
    for reason in (_extrapolation_reason(s), latency, _ceiling_reason(s, reached)):
        if reason is not None:
            reasons.append(reason)
    if main.n_active < MIN_ACTIVE:
        return AgreementVerdict(
            kind="too_little_data",
            headline=(
                f"Too little data to judge: {log} has {main.n_active} active samples (at least "
                f"{MIN_ACTIVE} are needed for figures worth a verdict)."
            ),
            reasons=tuple(reasons),
            next_step="record a longer log in which the robot drives and turns under command.",
            ok=False,
        )
    if fitted is None:
        return AgreementVerdict(
            kind="no_fit",
            headline=f"The spec defaults reach {percent(defaults.agreement)} (no fit): nothing "
            "was fitted to this robot yet.",
            reasons=tuple(reasons),
            next_step=_fit_step(robot, log) + ".",
            ok=False,
        )
    where = {"log": log, "robot": robot, "params": params}
    return _fitted_verdict(defaults, fitted, ensemble, s, reasons, where)


#: Next steps of the headlines before the band's.
_WORSE_STEP = (
    "refit on a log that drives like this one (its speeds, turns while driving and stops), or "
    "several sessions at once (sysid fit a.mcap b.mcap ...); until then the spec defaults "
    "simulate this robot better than {params}."
)
_SLOWER_UNIT_STEP = (
    "fit on a log of this unit, or on logs of several units at once (sysid fit a.mcap b.mcap "
    "...) so that the spread spans their top speeds; until then the spec defaults simulate "
    "this robot better than {params}."
)
_LATENCY_STEP = (
    "randomise the command delay (delay_s) across sessions, or refit on a log with sharp "
    "command steps recorded like this one (same driver, same clock)."
)
_FIT_LOG_STEP = (
    "compare on a recording the fit never used: 'sim2real agree OTHER.mcap --robot {robot} "
    "--params {params} --ensemble 30'."
)
_EXTRAPOLATES_STEP = (
    "refit on logs that also drive like this one (sysid fit a.mcap b.mcap ... with its "
    "speeds, turns and accelerations), then compare again before training with {params}."
)
_POOR_STEP = (
    "see in the rolling agreement where it fails, and refit on a longer log with varied "
    "driving (steps, turns, reversals, the speeds you use)."
)
_BAND_STEP = (
    "see how far sim may stray from real: 'sim2real agree {log} --robot {robot} --params "
    "{params} --ensemble 30'."
)


def _problem(
    defaults: _Agreement, fitted: _Agreement, ensemble: Any, s: SessionFigures
) -> tuple[str, str, str] | None:
    """``(kind, headline, next step template)`` of the first finding before the band's."""
    after, before = percent(fitted.agreement), percent(defaults.agreement)
    if s.fit_log:
        return (
            "fit_log",
            f"This log is one the params file was fitted on (as {s.fit_log}): its figures "
            f"(fit {after}, spec defaults {before}) say how well the model fits it, not how "
            "it holds on a session it never saw.",
            _FIT_LOG_STEP,
        )
    worse = fitted.agreement < defaults.agreement - WORSE_MARGIN
    if worse or (fitted.agreement < defaults.agreement and _slower_unit(s) is not None):
        cause = _likely_cause(defaults, fitted, s)
        slower = _slower_unit(s)  # the first cause when it holds, latency's part said after it
        return (
            "fit_worse",
            f"The fit does worse than the spec defaults on this log: {after} against {before}; "
            f"likely cause: {cause}.",
            _SLOWER_UNIT_STEP if slower is not None and cause.startswith(slower) else _WORSE_STEP,
        )
    latency = _latency_reason(fitted, s)
    if latency is not None:
        return "latency", f"The latency of this session differs: {latency}.", _LATENCY_STEP
    ext = s.extrapolation
    if getattr(ext, "known", False) and ext.share_outside >= EXTRAPOLATES_SHARE:
        return (
            "extrapolates",
            f"The fit extrapolates on this log: it drives outside the envelope the fit saw for "
            f"{percent(ext.share_outside)} of its active samples, so its figures (fit {after}, "
            f"spec defaults {before}) judge the model where no log informed it.",
            _EXTRAPOLATES_STEP,
        )
    good = _good_agreement(s)
    if not fitted.agreement >= good:
        return (
            "poor_fit",
            f"The fit reaches {after} (spec defaults {before}), short of {percent(good)}"
            + (" (the noise ceiling less 5 points)." if good < GOOD_AGREEMENT else "."),
            _POOR_STEP,
        )
    if ensemble is None:
        return (
            "no_band",
            f"The fit reaches {after} (spec defaults {before}); no band was run, so nothing "
            "says how far sim may stray from real.",
            _BAND_STEP,
        )
    return None


def _fitted_verdict(
    defaults: _Agreement,
    fitted: _Agreement,
    ensemble: Any,
    s: SessionFigures,
    reasons: list[str],
    where: dict[str, str],
) -> AgreementVerdict:
    """The verdict of a fitted run; ``where`` holds the ``log``, ``robot`` and ``params``."""
    band_reasons = [] if ensemble is None else [_band_sentence(ensemble)]
    if ensemble is not None and (wide := _wide_reason(ensemble, s)) is not None:
        band_reasons.append(wide)
    if ensemble is not None and s.band_misses:
        band_reasons.append(s.band_misses)
    problem = _problem(defaults, fitted, ensemble, s)
    slower = _slower_unit(s)
    if slower is not None and (problem is None or slower not in problem[1]):
        reasons = [*reasons, slower]  # said once: here unless the headline names it
    if problem is not None:
        kind, headline, step = problem
        return AgreementVerdict(
            kind=kind,
            headline=headline,
            reasons=tuple(reasons + band_reasons),
            next_step=step.format(**where),
            ok=False,
        )
    kind, ok = _band_state(ensemble)
    ext = s.extrapolation
    outside = getattr(ext, "known", False) and ext.share_outside >= OUTSIDE_SHARE
    return AgreementVerdict(
        kind=kind,
        headline=band_reasons[0],
        reasons=tuple(reasons + band_reasons[1:]),
        next_step=_band_next(kind, ensemble, where["params"]) + ".",
        ok=ok and len(band_reasons) == 1 and not outside,
    )


def _band_sentence(ensemble: Any) -> str:
    """The band's sentence without its advice (the verdict gives one next step)."""
    head = _band_words(ensemble).split("; ")[0].split(", so ")[0]
    return head.rstrip(".") + "."
