"""The verdict at the top of the agreement report: what the figures mean and what to do next.

Three figures matter: the agreement of the main simulation (the last run: the sysid fit when
there is one), the coverage of the randomised band (when an ensemble was run) and the timing
(cross-correlation lag). Each gets one sentence saying what it means; then one next step,
chosen in this order: fit the model (no params), fix the timing (a lag over
:data:`LAG_LIMIT_S`), improve the fit (agreement under :data:`GOOD_AGREEMENT`), add a band (no
ensemble), then :func:`sim2real.agreement.figures.band_verdict` (the band too narrow or too wide, with
the command that calibrates it, or calibrated: "train with it").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from sim2real.agreement.figures import lag_phrase  # the one wording of a lag (also the CLI table)
from sim2real.agreement.report._html import Stat, Verdict

__all__ = ["GOOD_AGREEMENT", "LAG_LIMIT_S", "lag_phrase", "make_verdict"]

#: Agreement from which the model is good enough to train with (seed paper 000: "over 80 %").
GOOD_AGREEMENT = 0.8
#: A lag beyond this is a timing error worth fixing before anything else, s.
LAG_LIMIT_S = 0.05


def _lag(agreement: Any) -> float:
    lags = [x for x in (agreement.lag_s_v, agreement.lag_s_w) if math.isfinite(x)]
    return sum(lags) / len(lags) if lags else math.nan


def _pct(x: float) -> str:
    return f"{100 * x:.1f} %" if math.isfinite(x) else "n/a"


def _agreement_stat(runs: Sequence[Any]) -> Stat:
    a = runs[-1].agreement
    sentence = (
        f"of the active time the simulated base ({runs[-1].label}) is within "
        f"{a.tol_v:g} m/s and {a.tol_w:g} rad/s of the real one"
    )
    if len(runs) >= 2:
        sentence += f" ({runs[0].label}: {_pct(runs[0].agreement.agreement)})"
    return Stat(
        label=f"agreement, {runs[-1].label}",
        value=_pct(a.agreement),
        fraction=a.agreement,
        sentence=sentence + ".",
    )


def _band_level(ensemble: Any) -> float:
    return float(getattr(ensemble, "band_level", 0.9))


def _coverage_stat(ensemble: Any | None) -> Stat:
    if ensemble is None:
        return Stat(
            label="band coverage",
            value="no band",
            fraction=math.nan,
            sentence="no randomised ensemble was run, so nothing says how far sim may stray "
            "from real (add --ensemble 10).",
        )
    level = _band_level(ensemble)
    cov = ensemble.coverage
    sentence = (
        f"of the real samples lie inside the {100 * level:g} % band of {ensemble.n} randomised "
        f"robots; a calibrated band covers about {100 * level:g} %."
    )
    # the ratio to the nominal level grades it: near the level is good
    grade = min(cov / level, 1.0) if math.isfinite(cov) else math.nan
    return Stat(
        label=f"coverage of the {100 * level:g} % band",
        value=_pct(cov),
        fraction=grade,
        sentence=sentence,
    )


def _lag_stat(runs: Sequence[Any]) -> Stat:
    lag = _lag(runs[-1].agreement)
    if math.isfinite(lag) and abs(lag) >= 0.005:
        when = "after" if lag > 0 else "before"
        sentence = (
            f"{lag_phrase(lag)}: the simulated base responds {abs(lag):.3f} s {when} the real "
            "one (cross-correlation of v and w)."
        )
    else:
        sentence = f"{lag_phrase(lag)}: the simulated delay matches the real one."
    # graded against the limit: in step is good, LAG_LIMIT_S is amber, twice that red
    grade = 1.0 - abs(lag) / (4 * LAG_LIMIT_S) if math.isfinite(lag) else math.nan
    value = f"{1000 * lag:+.0f} ms" if math.isfinite(lag) else "n/a"
    return Stat(label="timing (sim - real)", value=value, fraction=grade, sentence=sentence)


def _next_step(runs: Sequence[Any], ensemble: Any | None, robot: str) -> tuple[str, bool]:
    main = runs[-1].agreement
    log = main.log_file or "LOG.mcap"
    params = main.params_file
    lag = _lag(main)
    if params is None:
        return (
            f"the spec defaults reach {_pct(main.agreement)}: fit the drive model to a log of "
            f"this robot, 'sim2real sysid fit TRAIN.mcap --robot {robot} -o params.yaml', then "
            f"compare again with 'sim2real agree {log} --robot {robot} --params params.yaml "
            "--ensemble 10'.",
            False,
        )
    if math.isfinite(lag) and abs(lag) > LAG_LIMIT_S:
        direction = "long" if lag > 0 else "short"
        return (
            f"{lag_phrase(lag)}: the simulated command delay (delay_s) is {abs(lag):.2f} s too "
            f"{direction} for this log; refit on a log with sharp command steps, or widen the "
            "delay's randomisation if the delay varies between sessions.",
            False,
        )
    if not main.agreement >= GOOD_AGREEMENT:
        return (
            f"the fit reaches {_pct(main.agreement)} (< {_pct(GOOD_AGREEMENT)}): see in the "
            "rolling agreement where it fails, and refit on a longer log with varied driving "
            "(steps, turns, reversals, the speeds you use).",
            False,
        )
    if ensemble is None:
        return (
            f"see how far sim may stray from real: 'sim2real agree {log} --robot {robot} "
            f"--params {params} --ensemble 10'.",
            False,
        )
    from sim2real.agreement.figures import band_verdict

    sentence = band_verdict(
        coverage_v=ensemble.coverage_v,
        coverage_w=ensemble.coverage_w,
        band_level=ensemble.band_level,
        band_width_v_mps=ensemble.band_width_v_mps,
        band_width_w_radps=ensemble.band_width_w_radps,
    )
    return sentence[0].lower() + sentence[1:], " band is calibrated" in sentence


def make_verdict(runs: Sequence[Any], ensemble: Any | None, *, robot: str) -> Verdict:
    """The verdict of a report's runs (last = main simulation) and optional ensemble."""
    stats = [_agreement_stat(runs), _coverage_stat(ensemble), _lag_stat(runs)]
    step, ok = _next_step(runs, ensemble, robot)
    return Verdict(stats=stats, next_step=step, ok=ok)
