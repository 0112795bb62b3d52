"""The report's verdict: the lag phrase and the choice of the next step."""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest

from sim2real.agreement.report._verdict import GOOD_AGREEMENT, lag_phrase, make_verdict


@dataclass
class _A:
    agreement: float
    lag_s_v: float = 0.0
    lag_s_w: float = 0.0
    tol_v: float = 0.02
    tol_w: float = 0.1
    log_file: str | None = "val.mcap"
    params_file: str | None = "params.yaml"


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
    v = make_verdict(_runs(0.944, lag_s_v=-0.038, lag_s_w=-0.040), _Ens(0.009), robot="r")
    assert [s.label for s in v.stats] == [
        "agreement, sysid params",
        "coverage of the 90 % band",
        "timing (sim - real)",
    ]
    assert [s.value for s in v.stats] == ["94.4 %", "0.9 %", "-39 ms"]
    assert "(spec defaults: 50.0 %)" in v.stats[0].sentence
    assert v.stats[2].sentence.startswith("sim leads real by 0.039 s")
    assert v.next_step.startswith("the 90 % band is too narrow") and not v.ok
    assert "sim2real sysid calibrate" in v.next_step


def test_next_step_order() -> None:
    no_params = [_Run("spec defaults", _A(0.6, params_file=None))]
    assert "sim2real sysid fit" in make_verdict(no_params, None, robot="r").next_step
    late = make_verdict(_runs(0.7, lag_s_v=0.12, lag_s_w=0.12), _Ens(0.9), robot="r")
    assert late.next_step.startswith("sim lags real by 0.120 s: the simulated command delay")
    assert "too long" in late.next_step
    early = make_verdict(_runs(0.9, lag_s_v=-0.1, lag_s_w=-0.1), _Ens(0.9), robot="r")
    assert "too short" in early.next_step
    poor = make_verdict(_runs(GOOD_AGREEMENT - 0.01), _Ens(0.9), robot="r")
    assert poor.next_step.startswith("the fit reaches 79.0 %")
    no_band = make_verdict(_runs(0.95), None, robot="r")
    assert "--ensemble 10" in no_band.next_step and no_band.stats[1].value == "no band"
    wide = make_verdict(_runs(0.95), _Ens(1.0), robot="r")
    assert wide.next_step.startswith("the 90 % band is too wide") and not wide.ok
    good = make_verdict(_runs(0.95), _Ens(0.88), robot="r")
    assert good.ok and "DynamicsRandomizer.from_sysid" in good.next_step


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
