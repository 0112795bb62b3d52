"""The report's verdict: the lag phrase and the choice of the next step."""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest

from sim2real.report._verdict import GOOD_AGREEMENT, lag_phrase, make_verdict


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
    assert v.next_step.startswith("the band is too narrow") and not v.ok


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
    assert wide.next_step.startswith("the band is wider than the real spread")
    good = make_verdict(_runs(0.95), _Ens(0.88), robot="r")
    assert good.ok and "DynamicsRandomizer.from_sysid('params.yaml')" in good.next_step
