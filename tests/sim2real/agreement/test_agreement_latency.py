"""The session's own latency and the noise ceiling (sim2real.agreement.latency, agree --json)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from _agreement_fixtures import HIDDEN, ROBOT, hidden_params, spec, write_log, write_params
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.randomization import ObservationNoise
from sim2real.agreement.figures import AGREEMENT_KEYS, agreement_from_arrays
from sim2real.agreement.latency import REFERENCE_KEYS, noise_ceiling, session_latency
from sim2real.agreement.study import fitted_noise
from sim2real.cli import main
from sim2real.logs import read_trace


def test_noise_ceiling_golden_numbers() -> None:
    c = noise_ceiling(ObservationNoise(std_v_mps=0.01, std_w_radps=0.05), tol_v=0.02, tol_w=0.1)
    # P(|N(0, 0.01)| <= 0.02) = erf(2 / sqrt 2) = 0.95450, the same for w
    assert c.agreement_v == pytest.approx(0.954500, abs=1e-6)
    assert c.agreement == pytest.approx(0.954500**2, abs=1e-6)
    assert c.band_width_v_mps == pytest.approx(2 * 1.644854 * 0.01, rel=1e-6)
    assert c.band_width_w_radps == pytest.approx(2 * 1.644854 * 0.05, rel=1e-6)
    exact = noise_ceiling(ObservationNoise(), tol_v=0.02, tol_w=0.1)
    assert exact.agreement == 1.0 and exact.band_width_v_mps == 0.0
    # quantisation q adds q^2 / 12 to the variance
    q = noise_ceiling(ObservationNoise(quantum_v_mps=0.012), tol_v=0.02, tol_w=0.1)
    assert q.band_width_v_mps == pytest.approx(2 * 1.644854 * 0.012 / math.sqrt(12), rel=1e-6)


@settings(max_examples=40, deadline=None)
@given(sd=st.floats(1e-4, 0.2), seed=st.integers(0, 2**31))
def test_noise_ceiling_is_the_agreement_of_a_perfect_model(sd: float, seed: int) -> None:
    """Noise alone on a perfect replay gives the ceiling's agreement (Monte Carlo, 20000)."""
    rng = np.random.default_rng(seed)
    n = 20000
    truth_v, truth_w = np.full(n, 0.2), np.full(n, 0.5)
    noise = ObservationNoise(std_v_mps=sd, std_w_radps=4 * sd)
    real_v, real_w = noise.apply(rng, truth_v, truth_w)
    rep = agreement_from_arrays(
        t_s=np.arange(n) * 0.05, cmd_v=truth_v, cmd_w=truth_w, real_v=real_v, real_w=real_w,
        sim_v=truth_v, sim_w=truth_w, tol_v=0.02, tol_w=0.1, robot="x", params_file=None,
        log_file=None, log_sha256=None,
    )  # fmt: skip
    c = noise_ceiling(noise, tol_v=0.02, tol_w=0.1)
    assert rep.agreement == pytest.approx(c.agreement, abs=0.015)
    inside = np.mean(np.abs(real_v - truth_v) <= c.band_width_v_mps / 2)
    assert inside == pytest.approx(0.9, abs=0.015)


def test_session_latency_finds_the_log_latency(tmp_path: Path) -> None:
    """A log recorded at 0.25 s latency, a fit that says 0.05 s: the best delay is the log's."""
    log = write_log(tmp_path / "late.mcap", params=hidden_params().replace(delay_s=0.25))
    trace = read_trace(log)
    lat = session_latency(
        trace, robot=spec(), params=hidden_params().replace(delay_s=0.05),
        tol_v=0.02, tol_w=0.1,
    )  # fmt: skip
    assert lat.fitted_delay_s == 0.05
    assert lat.delay_s == pytest.approx(0.25, abs=0.011)
    assert lat.report.agreement > 0.9
    same = session_latency(trace, robot=spec(), params=hidden_params(), tol_v=0.02, tol_w=0.1)
    assert same.delay_s == pytest.approx(0.25, abs=0.011)  # whatever the fitted delay


def test_agree_json_and_terminal_carry_the_reference_figures(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = write_log(tmp_path / "val.mcap", duration_s=12.0)
    params = write_params(tmp_path / "p.yaml", {**HIDDEN, "delay_s": 0.0})
    out = tmp_path / "a.json"
    argv = ["agree", str(log), "--robot", ROBOT, "--engine", "reduced", "--params", str(params)]
    assert main([*argv, "--json", str(out)]) == 0
    figures = json.loads(out.read_text())
    assert tuple(figures) == (*AGREEMENT_KEYS, *REFERENCE_KEYS, "notes")
    assert figures["fitted_delay_s"] == 0.0
    assert figures["best_delay_s"] == pytest.approx(HIDDEN["delay_s"], abs=0.011)
    assert figures["agreement_at_best_delay"] > figures["agreement"]
    assert 0.9 < figures["noise_ceiling"] <= 1.0
    text = capsys.readouterr().out
    assert "this log's best" in text and "noise ceiling" in text and "noise-only band" in text


def test_the_ceiling_uses_the_noise_the_fit_estimated() -> None:
    """A calibrated file's noise is the calibration's (tuned for coverage): its factors are
    undone, so the ceiling speaks of the measurement noise the fit estimated."""
    calibrated = ObservationNoise(std_v_mps=0.004, std_w_radps=0.3)
    calibration = {"noise_factor_v": 0.5, "noise_factor_w": 6.0}
    fit = fitted_noise(calibrated, calibration)
    assert fit.std_v_mps == pytest.approx(0.008) and fit.std_w_radps == pytest.approx(0.05)
    assert fitted_noise(calibrated, None) == calibrated  # not calibrated: the file's
    assert fitted_noise(calibrated, {"noise_factor_v": 0.0, "noise_factor_w": None}) == calibrated
    assert fitted_noise(calibrated, {"noise_factor_v": 1e-12}) == calibrated  # absurd quotient
