"""Timing misses at command steps do not blow the calibrated noise up; a noise std too weak to
move the band's coverage keeps its estimate."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from _agreement_fixtures import ROBOT, hidden_params, write_log

from sim2real.agreement.calibration import (
    CHI2_1_MEDIAN,
    _AxisNoise,
    calibrate_traces,
    robust_noise_std,
)
from sim2real.logs import read_trace
from tests.randomization_block import distribution_around

TRUE_W = 0.02  # rad/s, the noise write_log adds to w
TRUE_V = 0.003  # m/s


def _with_turn_misses(trace, every: int, amplitude: float, late_s: float, seed: int):  # type: ignore[no-untyped-def]
    """The log with its measured w off by +-``amplitude`` for ``late_s`` after every
    ``every``-th turn command step: misses at the turns, not white noise."""
    rng = np.random.default_rng(seed)
    t, w = np.asarray(trace.meas_t_ns), np.array(trace.meas_w, dtype=float)
    turns = np.asarray(trace.cmd_t_ns)[1:][np.abs(np.diff(trace.cmd_w)) > 0.1]
    for step in turns[::every]:
        w[(t >= step) & (t < step + int(late_s * 1e9))] += rng.choice([-1.0, 1.0]) * amplitude
    return dataclasses.replace(trace, meas_w=w)


@pytest.fixture(scope="module")
def plant_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """40 s of steps every 2 s (17 turns), noise 0.003 m/s and 0.02 rad/s."""
    return write_log(tmp_path_factory.mktemp("misses") / "a.mcap", duration_s=40.0, seed=3)


@pytest.mark.parametrize("every", [1, 3])
def test_turn_misses_leave_the_noise_at_the_truth(plant_log: Path, every: int) -> None:
    # +-0.6 rad/s for 0.3 s after the turns: 13 % of the samples (every turn) or 5 % (every
    # third). The Gaussian likelihood and a coverage matching on every sample put the w noise
    # at 0.32 rad/s (x16 the truth) and 0.040 (x2); the steady samples' robust scale keeps it
    # at 0.020 and 0.020, and the between-session spread covers the misses instead
    trace = _with_turn_misses(read_trace(plant_log), every, 0.6, 0.3, seed=0)
    dist = distribution_around(hidden_params(), ROBOT, rel=0.02, noise_v=TRUE_V, noise_w=TRUE_W)
    res = calibrate_traces([trace], robot=ROBOT, distribution=dist, n=16, seed=0)
    assert TRUE_W / 1.25 <= res.noise_std_w_radps <= 1.25 * TRUE_W  # within 25 % of the truth
    assert TRUE_V / 1.5 <= res.noise_std_v_mps <= 1.5 * TRUE_V
    assert 0.9 <= res.coverage_w <= 0.99 and 0.9 <= res.coverage_v <= 0.99
    # the between-session spread covers them (measured b 2.08 and 1.06; 0.19 on the clean log)
    assert res.session_factor >= 0.8
    assert res.steady_w == pytest.approx(0.5, abs=0.05)  # the samples 1 s after a step or more
    assert any("at least 1 s after a command step" in note for note in res.notes)


def test_a_clean_log_gives_the_truth_too(plant_log: Path) -> None:
    dist = distribution_around(hidden_params(), ROBOT, rel=0.02, noise_v=0.03, noise_w=0.2)
    res = calibrate_traces([read_trace(plant_log)], robot=ROBOT, distribution=dist, n=16)
    # the file's noise is 10x the log's: the steady samples identify the truth (v measured
    # 0.0036: the spread holds part of the information, so a little of the file's 0.03 stays)
    assert res.noise_std_w_radps == pytest.approx(TRUE_W, rel=0.15)
    assert res.noise_std_v_mps == pytest.approx(TRUE_V, rel=0.25)


def test_a_noise_std_with_no_effect_on_the_coverage_keeps_its_estimate() -> None:
    # members spread 100x the real scatter: the band covers every sample with the noise at x1
    # and at x0.1 (the search's bound) alike; the search ran to that bound before
    rng = np.random.default_rng(0)
    real, wide = 0.01 * rng.standard_normal(2000), rng.normal(0.0, 1.0, size=(40, 2000))
    steady = np.ones(2000, dtype=bool)
    kept = _AxisNoise.matched(
        "v", real, wide, identified=(0.05, 1e-5), quantum=0.0, seed=0, steady=steady
    )
    assert (kept.scale, kept.std, kept.coverage) == (1.0, 0.05, kept.coverage_identified)
    assert kept.coverage == 1.0
    assert "has no effect on the 90 % band's coverage" in kept.note
    assert "identified std is kept" in kept.note
    # noise alone makes the band: x1 over-covers and the matching narrows it to 95 %, as far
    # as the log's own scatter about its steady levels (0.1) allows
    noisy = 0.1 * rng.standard_normal(2000)
    narrow = _AxisNoise.matched(
        "v", noisy, np.zeros((40, 2000)), identified=(0.3, 1e-5), quantum=0.0, seed=0,
        steady=steady, own_std=0.1,
    )  # fmt: skip
    assert narrow.scale < 0.5 and narrow.coverage == pytest.approx(0.95, abs=0.005)
    assert narrow.note == ""
    # but no further than the samples' own robust std (0.2 here: x0.67 of 0.3) or the log's
    # own scatter, whichever is larger
    for identified, own in (((0.3, 0.2), 0.1), ((0.3, 1e-5), 0.2)):
        floor = _AxisNoise.matched(
            "v", 0.1 * rng.standard_normal(2000), np.zeros((40, 2000)), identified=identified,
            quantum=0.0, seed=0,
            steady=steady, own_std=own,
        )  # fmt: skip
        assert floor.scale == pytest.approx(2.0 / 3.0) and floor.coverage > 0.95
    # a log without steady stretches cannot tell its noise from the spread: not narrowed
    kept = _AxisNoise.matched(
        "v", noisy, np.zeros((40, 2000)), identified=(0.3, 1e-5), quantum=0.0, seed=0,
        steady=steady,
    )  # fmt: skip
    assert (kept.scale, kept.std) == (1.0, 0.3) and kept.coverage == 1.0


def test_robust_scale_golden_and_unmoved_by_a_minority_of_misses() -> None:
    rng = np.random.default_rng(0)
    real = 0.1 * rng.standard_normal(4000)
    members = np.zeros((8, real.size))
    clean = robust_noise_std(real, members, 0.0)
    assert clean == pytest.approx(0.1, rel=0.05)
    real[:800] += 3.0  # one sample in five a large miss
    assert robust_noise_std(real, members, 0.0) == pytest.approx(0.1, rel=0.4)
    # the defining equation: the median squared standardised residual is chi2(1)'s median
    std = robust_noise_std(real, members, 0.0)
    assert float(np.median(real**2 / std**2)) == pytest.approx(CHI2_1_MEDIAN, rel=1e-3)
    # members that span the residuals alone: the floor of the search
    assert robust_noise_std(0.01 * real, rng.normal(size=(40, 4000)), 0.0) == 1e-5
