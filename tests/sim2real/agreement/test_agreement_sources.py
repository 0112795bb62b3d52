"""Where a band's width and misses come from: noise, latency, each parameter; and steps of
the command as clipped to the robot's limits."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from _agreement_fixtures import ROBOT, hidden_params, spec, write_log

from sim2real.agreement.calibration import _validation_logs
from sim2real.agreement.latency import SampleNoise
from sim2real.agreement.sources import band_sources, marginal
from sim2real.logs import read_trace
from tests.randomization_block import distribution_around


@pytest.fixture(scope="module")
def plant_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_log(tmp_path_factory.mktemp("sources") / "a.mcap", duration_s=24.0, seed=4)


def test_noise_alone_makes_a_band_of_noise(plant_log: Path) -> None:
    dist = distribution_around(hidden_params(), ROBOT, rel=0.0, noise_v=0.01, noise_w=0.05)
    why = band_sources(read_trace(plant_log), robot=ROBOT, distribution=dist, n=8)
    assert why.names[0] == "noise" and why.share_v[0] == 1.0 and why.share_w[0] == 1.0
    assert why.width_v_mps[0] == pytest.approx(3.29 * 0.01, rel=1e-3)
    assert why.width_w_radps[0] == pytest.approx(3.29 * 0.05, rel=1e-3)
    assert why.largest("v", 1)[0][0] == "noise"


def test_a_noise_per_sample_counts_by_its_mean_variance(plant_log: Path) -> None:
    """The band's noise as agree draws it (an sd per sample): half the samples at 0.01 m/s,
    half at 0.03, is the noise-only band of sqrt((0.01^2 + 0.03^2) / 2) = 0.0224 m/s; a
    constant one is the distribution's own."""
    trace = read_trace(plant_log)
    dist = distribution_around(hidden_params(), ROBOT, rel=0.0, noise_v=0.01, noise_w=0.05)
    size = trace.meas_v.size
    same = SampleNoise(std_v_mps=np.full(size, 0.01), std_w_radps=np.full(size, 0.05))
    assert band_sources(trace, robot=ROBOT, distribution=dist, n=4, noise=same) == band_sources(
        trace, robot=ROBOT, distribution=dist, n=4
    )
    mixed = dataclasses.replace(same, std_v_mps=np.where(np.arange(size) % 2 == 0, 0.01, 0.03))
    why = band_sources(trace, robot=ROBOT, distribution=dist, n=4, noise=mixed)
    assert why.width_v_mps[0] == pytest.approx(3.29 * 0.0224, rel=0.02)
    assert why.band_width_v_mps > 3.29 * 0.01


def test_a_wide_latency_spread_makes_the_width_and_the_own_latency_the_misses(
    plant_log: Path,
) -> None:
    base = distribution_around(hidden_params(), ROBOT, rel=0.05)
    j = base.names.index("delay_s")
    cov = base.covariance_array
    cov[j, j] = 0.05**2  # 50 ms between sessions, every other spread 5 % of its prior's
    wide = dataclasses.replace(base, covariance=tuple(map(tuple, cov.tolist())))
    why = band_sources(read_trace(plant_log), robot=ROBOT, distribution=wide, n=12)
    assert all(abs(sum(s) - 1.0) < 1e-9 for s in (why.share_v, why.share_w))
    assert why.largest("w", 1)[0][0] == "delay_s"
    # mean latency 0.25 s where the plant's is 0.15: misses at the steps, which the band at
    # the session's own latency (found within 0.03 s) covers more of
    mean = list(base.mean)
    mean[j] = 0.25
    late = dataclasses.replace(base, mean=tuple(mean))
    why = band_sources(read_trace(plant_log), robot=ROBOT, distribution=late, n=12)
    assert why.own_delay_s == pytest.approx(0.15, abs=0.03)
    assert why.coverage_w < 0.85 and why.near_step_w > 0.6  # measured 0.83 and 0.70
    assert why.coverage_own_latency_w > why.coverage_w + 0.05  # measured 0.91
    assert marginal(late, "delay_s").std()["added_mass_kg"] == 0.0


def test_steps_are_read_on_the_command_clipped_to_the_robots_limits(plant_log: Path) -> None:
    # the same log commanding 10-15x the burger's top speed, a new value every 0.1 s: the
    # raw command steps at every message, the clipped one only where w or v's sign changes
    trace = read_trace(plant_log)
    rng = np.random.default_rng(0)
    over = dataclasses.replace(
        trace, cmd_v=np.sign(trace.cmd_v) * rng.uniform(2.2, 3.3, trace.cmd_v.size)
    )
    (log,) = _validation_logs([over], spec(), 0.02, 0.1)
    steady = float(np.mean(log.since_step_s >= 1.0))
    assert steady > 0.3  # 2 s holds: about half the samples are 1 s past a step
    unclipped = dataclasses.replace(spec(), max_v_mps=np.inf)
    (raw,) = _validation_logs([over], unclipped, 0.02, 0.1)
    assert float(np.mean(raw.since_step_s >= 1.0)) == 0.0
