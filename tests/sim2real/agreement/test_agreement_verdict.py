"""The one verdict of an agreement run: its headline, reasons and next step."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sim2real.agreement.report._verdict import GOOD_AGREEMENT, lag_phrase, make_verdict
from sim2real.agreement.verdict import (
    MIN_ACTIVE,
    SessionFigures,
    band_miss_reason,
    decide,
    speed_shortfall,
)


@dataclass
class _A:
    agreement: float
    lag_s_v: float = 0.0
    lag_s_w: float = 0.0
    tol_v: float = 0.02
    tol_w: float = 0.1
    log_file: str | None = "val.mcap"
    params_file: str | None = "params.yaml"
    n_active: int = 500


@dataclass
class _Run:
    label: str
    agreement: _A


@dataclass
class _Ens:
    coverage: float
    n: int = 10
    band_level: float = 0.9
    band_width_v_mps: float = 0.01
    band_width_w_radps: float = 0.1

    @property
    def coverage_v(self) -> float:
        return self.coverage

    @property
    def coverage_w(self) -> float:
        return self.coverage


def _runs(after: float, **kw: object) -> list[_Run]:
    return [
        _Run("spec defaults", _A(0.5, params_file=None)),
        _Run("sysid params", _A(after, **kw)),  # type: ignore[arg-type]
    ]


def _decide(after: float, ens: _Ens | None = None, *, before: float = 0.5, **kw: object):  # type: ignore[no-untyped-def]
    session = kw.pop("session", None)
    return decide(
        defaults=_A(before, params_file=None),
        fitted=_A(after, **kw),  # type: ignore[arg-type]
        robot="r",
        ensemble=ens,
        session=session,  # type: ignore[arg-type]
    )


@pytest.mark.parametrize(
    ("lag", "text"),
    [
        (0.12, "sim lags real by 0.120 s"),
        (-0.0381, "sim leads real by 0.038 s"),
        (0.004, "sim and real in step (< 5 ms)"),
        (math.nan, "lag unknown (a constant signal)"),
    ],
)
def test_lag_phrase_says_who_is_late(lag: float, text: str) -> None:
    assert lag_phrase(lag) == text


def test_the_verdict_has_three_figures_with_a_sentence_each() -> None:
    v = make_verdict(_runs(0.944, lag_s_v=-0.008, lag_s_w=-0.010), _Ens(0.009), robot="r")
    assert [s.label for s in v.stats] == [
        "agreement, sysid params",
        "coverage of the 90 % band",
        "timing (sim - real)",
    ]
    assert [s.value for s in v.stats] == ["94.4 %", "0.9 %", "-9 ms"]
    assert "(spec defaults: 50.0 %)" in v.stats[0].sentence
    assert v.stats[2].sentence.startswith("sim leads real by 0.009 s")
    assert v.headline.startswith("The 90 % band is too narrow") and not v.ok
    assert "sim2real sysid calibrate" in v.next_step


def test_headline_order() -> None:
    no_fit = decide(defaults=_A(0.6, params_file=None), fitted=None, robot="neato.yaml")
    assert no_fit.kind == "no_fit" and "--robot neato.yaml" in no_fit.next_step
    assert "sim2real sysid fit" in no_fit.next_step
    late = _decide(0.7, _Ens(0.9), lag_s_v=0.12, lag_s_w=0.12)
    assert late.kind == "latency" and "sim lags real by 0.120 s" in late.headline
    poor = _decide(GOOD_AGREEMENT - 0.01, _Ens(0.9))
    assert poor.kind == "poor_fit" and poor.headline.startswith("The fit reaches 79.0 %")
    no_band = _decide(0.95)
    assert no_band.kind == "no_band" and "--ensemble 30" in no_band.next_step
    wide = _decide(0.95, _Ens(1.0))
    assert wide.kind == "band_wide" and wide.headline.startswith("The 90 % band is too wide")
    good = _decide(0.95, _Ens(0.88))
    assert good.kind == "calibrated" and good.ok
    assert "DynamicsRandomizer.from_sysid" in good.next_step
    few = _decide(0.95, _Ens(0.88), n_active=MIN_ACTIVE - 1)
    assert few.kind == "too_little_data" and str(MIN_ACTIVE - 1) in few.headline


def test_a_fit_worse_than_the_defaults_is_the_headline_with_its_cause() -> None:
    """Worse than the defaults outranks a calibrated band; the likely cause is named."""
    plain = _decide(0.353, _Ens(0.88), before=0.641)
    assert plain.kind == "fit_worse" and not plain.ok
    assert "35.3 % against 64.1 %" in plain.headline
    assert any(r.startswith("The 90 % band is calibrated") for r in plain.reasons)
    slow = _decide(0.353, before=0.641, session=SessionFigures(speed_shortfall=("v", 0.30, 0.27)))
    assert "tops out at 0.27 m/s in v where the robot holds 0.3 m/s" in slow.headline
    no_delay = _decide(0.353, before=0.641, session=SessionFigures(fitted_delay_s=4e-12))
    assert "fitted command delay is 4e-12 s" in no_delay.headline
    latency = _decide(
        0.353,
        before=0.641,
        session=SessionFigures(fitted_delay_s=0.0, best_delay_s=0.11, agreement_at_best_delay=0.7),
    )
    assert "own best command latency is 0.110 s where the fit has 0.000 s" in latency.headline
    assert "(agreement there 70.0 %)" in latency.headline
    assert latency.headline.count("the latency of this session differs") == 1
    # a latency that lifts the fit only to 40.1 % of the defaults' 79.6 % is not the cause
    part = _decide(
        0.369,
        before=0.796,
        session=SessionFigures(
            fitted_delay_s=0.214, best_delay_s=0.03, agreement_at_best_delay=0.401,
            speed_shortfall=("v", 0.30, 0.27),
        ),
    )  # fmt: skip
    cause = part.headline.split("likely cause: ", 1)[1]
    assert cause.startswith("the fitted model tops out at 0.27 m/s in v")
    assert "own latency explains only part of the gap" in cause
    assert "0.030 s where the fit has 0.214 s (agreement there 40.1 %)" in cause
    none = SessionFigures(fitted_delay_s=0.164, best_delay_s=0.05, agreement_at_best_delay=0.479)
    unmoved = _decide(0.479, session=none)  # the latency changes nothing: not a cause
    assert "latency" not in unmoved.headline
    assert any("latency accounts for 0.0 points" in r for r in unmoved.reasons)
    late = _decide(0.7, session=SessionFigures(fitted_delay_s=0.214, best_delay_s=0.28))
    assert late.kind == "latency"
    # a steady spin recorded from its middle: any delay gives 100 %, so no latency finding
    steady = SessionFigures(fitted_delay_s=0.214, best_delay_s=0.03, agreement_at_best_delay=1.0)
    flat = _decide(1.0, session=steady)
    assert flat.kind == "no_band" and "accounts for 0.0 points" in " ".join(flat.reasons)
    assert late.headline.count("latency") == 2  # "The latency ...: ... best command latency"
    # within the margin it is not "worse"
    assert _decide(0.49, _Ens(0.88), before=0.5).kind == "poor_fit"


def test_a_unit_slower_than_the_fits_is_the_headline_even_within_the_margin() -> None:
    """Under the defaults by less than the margin, a robot that holds less than the fitted
    model at its top speed is still the headline's cause, ahead of an extrapolation; a robot
    faster than the fit is not a slower unit, and within the margin it is no headline."""
    from types import SimpleNamespace

    ext = SimpleNamespace(known=True, share_outside=0.139, sentence="this log leaves it")
    slower = SessionFigures(speed_shortfall=("v", 0.276, 0.302), extrapolation=ext)
    v = _decide(0.468, before=0.481, session=slower)
    assert v.kind == "fit_worse" and "46.8 % against 48.1 %" in v.headline
    cause = v.headline.split("likely cause: ", 1)[1]
    assert cause.startswith(
        "this robot holds 0.276 m/s in v where the fitted model holds 0.302 m/s at its top "
        "speed: this unit is slower than the fit log's (another unit's top speed"
    )
    assert "this log leaves it" in v.reasons
    assert v.next_step.startswith("fit on a log of this unit, or on logs of several units")
    spin = SessionFigures(speed_shortfall=("w", 0.9, 1.01))
    assert "1.01 rad/s at its top yaw rate" in _decide(0.468, before=0.481, session=spin).headline
    faster = SessionFigures(speed_shortfall=("v", 0.30, 0.27), extrapolation=ext)
    assert _decide(0.468, before=0.481, session=faster).kind == "extrapolates"
    above = _decide(0.49, before=0.48, session=slower)  # not under the defaults
    assert above.kind == "extrapolates"
    assert sum("this unit is slower than the fit log's" in r for r in above.reasons) == 1
    assert not any("this unit is slower" in r for r in v.reasons)  # the headline says it
    # a latency that explains part of the gap is said after the unit's top speed: the next
    # step stays the unit's
    partial = SessionFigures(
        speed_shortfall=("v", 0.276, 0.302), fitted_delay_s=0.214, best_delay_s=0.03,
        agreement_at_best_delay=0.401,
    )  # fmt: skip
    both = _decide(0.369, before=0.481, session=partial)
    cause = both.headline.split("likely cause: ", 1)[1]
    assert cause.startswith("this robot holds 0.276 m/s") and "explains only part" in cause
    assert both.next_step.startswith("fit on a log of this unit, or on logs of several units")


@given(
    held=st.floats(0.1, 0.5),
    slower_by=st.floats(-0.1, 0.1),
    n_top=st.integers(0, 40),
)
def test_the_held_top_speed_is_read_where_the_simulation_runs_at_its_top(
    held: float, slower_by: float, n_top: int
) -> None:
    """Samples at the simulation's top (>= 95 % of it) compare the held speeds; samples under
    it never count; fewer than ten at the top say nothing."""
    sim = np.r_[np.full(n_top, held), np.linspace(0.0, 0.5 * held, 40)]
    real = np.r_[np.full(n_top, held - slower_by), np.linspace(0.0, 0.5 * held, 40)]
    out = speed_shortfall(real, np.zeros_like(real), sim, np.zeros_like(sim),
                          np.ones(real.size, bool), tol_v=0.02, tol_w=0.1)  # fmt: skip
    if n_top >= 10 and slower_by > 0.02 + 1e-9:
        assert out == ("v", round(held - slower_by, 4), round(held, 4))
    elif n_top >= 10 and -slower_by > 0.02 + 1e-9:
        assert out is not None and out[1] > out[2]  # the robot is the faster: the first check
    elif abs(slower_by) < 0.02 - 1e-9 or n_top < 10:
        assert out is None or out[1] > out[2]


def test_the_share_of_latency_is_said_in_one_sentence() -> None:
    """The session's own latency close to the fitted one: a reason says how much of the
    shortfall it accounts for (a latency that differs is the headline's instead)."""
    close = SessionFigures(fitted_delay_s=0.086, best_delay_s=0.066, agreement_at_best_delay=0.396)
    v = _decide(0.391, session=close)
    said = [r for r in v.reasons if r.startswith("at this session's own best command latency")]
    assert len(said) == 1
    assert "0.066 s (the fit has 0.086 s), the fit reaches 39.6 % against 39.1 %" in said[0]
    assert "latency accounts for 0.5 points and the dynamics for the other 60.4 points" in said[0]
    far = SessionFigures(fitted_delay_s=0.214, best_delay_s=0.28, agreement_at_best_delay=0.74)
    v = _decide(0.7, session=far)
    assert v.kind == "latency" and not any("accounts for" in r for r in v.reasons)


def test_a_calibrated_band_on_a_log_the_fit_never_saw_is_not_trained_with() -> None:
    """A fit on a spin in place checked on driving (half its samples outside the envelope):
    the headline says it extrapolates, the next step is no invitation to train."""
    from types import SimpleNamespace

    ext = SimpleNamespace(known=True, share_outside=0.496, sentence="this log leaves it")
    far = _decide(0.978, _Ens(0.88), session=SessionFigures(extrapolation=ext))
    assert far.kind == "extrapolates" and not far.ok
    assert "outside the envelope the fit saw for 49.6 % of its active samples" in far.headline
    assert "this log leaves it" in far.reasons
    assert any(r.startswith("The 90 % band is calibrated") for r in far.reasons)
    assert "train with" not in far.next_step and "refit on logs" in far.next_step
    near = SimpleNamespace(known=True, share_outside=0.05, sentence="this log leaves it")
    ok_band = _decide(0.978, _Ens(0.88), session=SessionFigures(extrapolation=near))
    assert ok_band.kind == "calibrated" and "this log leaves it" in ok_band.reasons


def test_a_band_calibrated_by_being_wide_is_said() -> None:
    top = SessionFigures(top_v_mps=0.3, top_w_radps=2.0)
    wide = _decide(0.95, _Ens(0.9, band_width_v_mps=0.16), session=top)
    assert wide.kind == "calibrated" and not wide.ok
    assert any(
        "holds the robot by being wide" in r and "53 % of the top speed" in r for r in wide.reasons
    )
    narrow_w = _decide(0.95, _Ens(0.5, band_width_v_mps=0.16, band_width_w_radps=1.0), session=top)
    assert not any("by being wide" in r for r in narrow_w.reasons)  # covers too little
    noisy = SessionFigures(top_v_mps=0.3, top_w_radps=2.0, noise_band_width_v_mps=0.14)
    assert _decide(0.95, _Ens(0.9, band_width_v_mps=0.16), session=noisy).ok
    ceiling = SessionFigures(noise_ceiling=0.6)
    assert any("caps the agreement" in r for r in _decide(0.58, _Ens(0.9), session=ceiling).reasons)
    # 0.56 is within 5 points of a 0.60 ceiling: the fit is as good as the noise allows
    assert _decide(0.56, _Ens(0.9), before=0.4, session=ceiling).kind == "calibrated"
    short = _decide(0.54, _Ens(0.9), before=0.4, session=ceiling)
    assert short.kind == "poor_fit" and "short of 55.0 % (the noise ceiling less" in short.headline


def test_a_ceiling_the_fit_beats_is_not_used_to_judge_it() -> None:
    """A replay cannot beat a true noise ceiling: beaten, the noise estimate overstates."""
    ceiling = SessionFigures(noise_ceiling=0.766, agreement_at_best_delay=0.853)
    beaten = _decide(0.833, _Ens(0.9), session=ceiling)
    [reason] = [r for r in beaten.reasons if "noise ceiling" in r]
    assert "reaches 85.3 %, above the 76.6 %" in reason and "overstates" in reason
    assert not any("caps the agreement" in r for r in beaten.reasons)
    # within 2 points of the ceiling is sampling, not evidence against the noise estimate
    close = _decide(0.78, _Ens(0.9), session=SessionFigures(noise_ceiling=0.766))
    assert any(
        "caps the agreement a perfect model could reach at 76.6 %" in r for r in close.reasons
    )
    # the defaults alone (no fit) are judged by their own agreement
    no_fit = decide(
        defaults=_A(0.9, params_file=None), fitted=None, robot="r",
        session=SessionFigures(noise_ceiling=0.6, agreement_at_best_delay=0.95),
    )  # fmt: skip
    assert any("reaches 90.0 %" in r for r in no_fit.reasons)


def test_coverage_counts_a_sample_on_a_quantised_band_edge() -> None:
    """Encoder odometry and a band rounded with the params file's quantum share a lattice."""
    import numpy as np

    from sim2real.agreement.figures import band_coverage

    q_real = 0.5 * 0.033 * (2 * np.pi / 4096) * 30.0  # one encoder quantum of v at 30 Hz
    q_file = float(f"{q_real:.8g}")  # as a YAML file keeps it
    k = np.arange(-5, 6)
    real = k * q_real
    edge = np.round(real / q_file) * q_file
    assert np.any(real > edge) and np.any(real < edge)  # round-off puts some just outside
    active = np.ones(k.size, bool)
    assert band_coverage(real, edge, edge, active) == 1.0
    assert band_coverage(real + 1e-6, edge, edge, active) == 0.0  # a real miss still misses


def test_the_cli_table_words_the_lag_like_the_report() -> None:
    """``agree``'s table says "sim lags/leads real by X s", not a signed number."""
    from types import SimpleNamespace

    from sim2real.agreement.study import summary_table

    def run(label: str, lag_v: float, lag_w: float) -> SimpleNamespace:
        figures = dict.fromkeys(
            ("agreement", "agreement_v", "agreement_w", "fit_percent_v", "fit_percent_w"), 0.9
        )
        figures |= {"rmse_v": 0.01, "rmse_w": 0.1, "n_active": 5, "n_samples": 9}
        return SimpleNamespace(
            label=label, agreement=SimpleNamespace(**figures, lag_s_v=lag_v, lag_s_w=lag_w)
        )

    table = summary_table([run("spec defaults", 0.12, -0.0381), run("sysid", 0.001, math.nan)])
    rows = {line.split("  ")[0]: line for line in table.splitlines()}
    assert "sim lags real by 0.120 s" in rows["timing v"]
    assert "sim and real in step (< 5 ms)" in rows["timing v"]
    assert "sim leads real by 0.038 s" in rows["timing w"]
    assert lag_phrase(math.nan) in rows["timing w"]
    assert "lag v" not in table and "+0.120" not in table


@pytest.mark.parametrize("with_params", [False, True])
def test_terminal_and_report_print_the_same_verdict(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], with_params: bool
) -> None:
    """`agree` in-process: every verdict sentence printed is in the report's HTML, verbatim."""
    import html

    from _agreement_fixtures import HIDDEN, ROBOT, write_log, write_params

    from sim2real.cli import main

    log = write_log(tmp_path / "val.mcap", duration_s=20.0)
    report = tmp_path / "report.html"
    args = ["agree", str(log), "--robot", ROBOT, "--engine", "reduced", "--report", str(report)]
    if with_params:
        args += ["--params", str(write_params(tmp_path / "p.yaml", HIDDEN)), "--ensemble", "4"]
    assert main(args) == 0
    out = capsys.readouterr().out
    lines = [ln for ln in out.splitlines() if ln.startswith(("verdict: ", "  - ", "next step: "))]
    assert lines[0].startswith("verdict: ") and lines[-1].startswith("next step: ")
    page = html.unescape(report.read_text(encoding="utf-8"))
    for line in lines:
        sentence = line.split(": ", 1)[1] if not line.startswith("  - ") else line[4:]
        assert sentence in page
    head = "verdict: The 90 % band is" if with_params else "verdict: The spec defaults reach"
    assert lines[0].startswith(head)
    for line in lines:  # each sentence said once: the cards give figures, not the verdict again
        sentence = line.split(": ", 1)[1] if not line.startswith("  - ") else line[4:]
        assert page.count(sentence) == 1, sentence
    if with_params:  # the band's card: its coverage per axis and its median widths
        card = re.search(r"coverage of the 90 % band \(N=4\).*?</div></div>", page, re.S)
        assert card and re.search(r"median width [\d.e-]+ m/s, [\d.e-]+ rad/s", card.group(0))


def _band(cov_v: float, n: int = 100):  # type: ignore[no-untyped-def]
    from types import SimpleNamespace

    return SimpleNamespace(
        band_level=0.9, coverage_v=cov_v, coverage_w=0.9, lo_v=np.zeros(n),
        hi_v=np.full(n, 0.1), lo_w=np.zeros(n), hi_w=np.ones(n), active=np.ones(n, bool),
    )  # fmt: skip


def test_band_miss_reason_tells_timing_bias_and_scatter_apart() -> None:
    inside, w = np.full(100, 0.05), np.full(100, 0.5)
    since = np.tile(np.linspace(0.0, 3.0, 20), 5)  # 35 of 100 samples within 1 s of a step
    # misses only near steps, on both sides: timing
    real = inside.copy()
    near = np.flatnonzero(since <= 1.0)
    real[near[::2]], real[near[1::2]] = 0.3, -0.2
    why = band_miss_reason(_band(0.65), real, w, since)
    assert why is not None and why.startswith("the band covers too little v because of timing")
    assert "35 % of its active samples fall outside" in why and "100 % within 1 s" in why
    # misses away from steps, all above: a bias (the robot faster than every member)
    real = inside.copy()
    far = np.flatnonzero(since > 1.0)[:30]
    real[far] = 0.2
    why = band_miss_reason(_band(0.7), real, w, since)
    assert why is not None and "a bias: the robot runs faster" in why and "0 % within" in why
    assert "median 0.1 m/s out" in why
    # away from steps, on both sides: a steady scatter
    real[far[::2]] = -0.1
    why = band_miss_reason(_band(0.7), real, w, since)
    assert why is not None and "steady scatter wider than the band" in why
    # a calibrated band needs no reason
    assert band_miss_reason(_band(0.85), real, w, since) is None


def test_checking_the_fit_on_its_own_log_is_said_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`agree` on a log the params file was fitted on: the headline says its figures measure
    the fit, and the next step names another recording (not training)."""
    from _agreement_fixtures import ROBOT, write_log

    from sim2real.cli import main

    fit_log = write_log(tmp_path / "fit.mcap", duration_s=15.0)
    other = write_log(tmp_path / "other.mcap", duration_s=15.0, seed=4)
    params = tmp_path / "p.yaml"
    assert main(["sysid", "fit", str(fit_log), "--robot", ROBOT, "-o", str(params)]) == 0
    capsys.readouterr()
    argv = ["--robot", ROBOT, "--engine", "reduced", "--params", str(params)]
    assert main(["agree", str(fit_log), *argv]) == 0
    out = capsys.readouterr().out
    assert "verdict: This log is one the params file was fitted on (as fit.mcap): its " in out
    assert "next step: compare on a recording the fit never used" in out
    assert main(["agree", str(other), *argv]) == 0
    assert "fitted on" not in capsys.readouterr().out
    v = _decide(0.95, _Ens(0.88), session=SessionFigures(fit_log="a.mcap"))
    assert v.kind == "fit_log" and not v.ok and "train" not in v.next_step
    assert any(r.startswith("The 90 % band is calibrated") for r in v.reasons)
