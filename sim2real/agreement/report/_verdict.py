"""The verdict at the top of the agreement report: what the figures mean and what to do next.

Three figures matter: the agreement of the main simulation (the last run: the sysid fit when
there is one), the coverage of the randomised band (when an ensemble was run) and the timing
(cross-correlation lag). Each gets one sentence saying what it means. The headline, its
reasons and the next step are the words of the one verdict,
:func:`sim2real.agreement.verdict.decide`, which ``sim2real agree`` prints too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from sim2real.agreement.figures import lag_phrase  # the one wording of a lag (also the CLI table)
from sim2real.agreement.report._html import Stat, Verdict
from sim2real.agreement.verdict import (
    GOOD_AGREEMENT,
    LAG_LIMIT_S,
    AgreementVerdict,
    decide,
    mean_lag_s,
    percent,
)

__all__ = ["GOOD_AGREEMENT", "LAG_LIMIT_S", "lag_phrase", "make_verdict"]


def _agreement_stat(runs: Sequence[Any]) -> Stat:
    a = runs[-1].agreement
    sentence = (
        f"of the active time the simulated base ({runs[-1].label}) is within "
        f"{a.tol_v:g} m/s and {a.tol_w:g} rad/s of the real one"
    )
    if len(runs) >= 2:
        sentence += f" ({runs[0].label}: {percent(runs[0].agreement.agreement)})"
    return Stat(
        label=f"agreement, {runs[-1].label}",
        value=percent(a.agreement),
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
        value=percent(cov),
        fraction=grade,
        sentence=sentence,
    )


def _lag_stat(runs: Sequence[Any]) -> Stat:
    lag = mean_lag_s(runs[-1].agreement)
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


def make_verdict(
    runs: Sequence[Any],
    ensemble: Any | None,
    *,
    robot: str,
    verdict: AgreementVerdict | None = None,
    notes: Sequence[str] = (),
) -> Verdict:
    """The report's verdict section: three figures and the words of the one verdict.

    ``notes`` (segments left out, figures left undefined) are shown under it. ``verdict`` is :func:`sim2real.agreement.verdict.decide`'s outcome for this run (what
    ``sim2real agree`` printed); without it, it is decided here from ``runs`` (spec defaults
    first, the params file's replay last) and ``ensemble``.
    """
    if verdict is None:
        verdict = decide(
            defaults=runs[0].agreement,
            fitted=runs[-1].agreement if len(runs) >= 2 else None,
            robot=robot,
            ensemble=ensemble,
        )
    stats = [_agreement_stat(runs), _coverage_stat(ensemble), _lag_stat(runs)]
    return Verdict(
        stats=stats,
        headline=verdict.headline,
        reasons=verdict.reasons,
        next_step=verdict.next_step,
        ok=verdict.ok,
        notes=tuple(notes),
    )
