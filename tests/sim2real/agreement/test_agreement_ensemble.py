"""The ensemble: robots drawn from the one distribution, the predictive band and its coverage."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from _agreement_fixtures import HIDDEN, ROBOT, hidden_params, spec, write_log
from hypothesis import given, settings
from hypothesis import strategies as st

from randomizers import DynamicsRandomizer
from robots.randomization import DriveDistribution, ObservationNoise
from sim2real.agreement.figures import (
    band_coverage,
    band_verdict,
    calibrated_range,
    ensemble_members,
    predictive_band,
    run_ensemble,
)
from sim2real.errors import Sim2RealValueError
from sim2real.logs import read_trace
from tests.randomization_block import distribution_around, write_params_file


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return read_trace(write_log(tmp_path_factory.mktemp("ens") / "log.mcap", duration_s=20.0))


def _dist(rel: float = 0.3, **noise: float) -> DriveDistribution:
    return distribution_around(hidden_params(), ROBOT, rel=rel, **noise)


class _DriveEnv(gym.Env[np.ndarray, int]):
    """The smallest env with the drive protocol, claiming to simulate ``robot``."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (1,))
    action_space = gym.spaces.Discrete(1)

    def __init__(self, robot: str = ROBOT) -> None:
        self.robot_spec = spec() if robot == ROBOT else dataclasses.replace(spec(), name=robot)
        self.params = spec().drive

    def get_drive_params(self) -> Any:
        return self.params

    def set_drive_params(self, params: Any) -> None:
        self.params = params

    def reset(self, *, seed: int | None = None, options: Any = None) -> Any:
        super().reset(seed=seed)
        return np.zeros(1, np.float32), {}

    def step(self, action: int) -> Any:
        return np.zeros(1, np.float32), 0.0, False, False, {}


def test_same_seed_same_robots_in_agree_and_in_training(trace, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    path = write_params_file(tmp_path / "p.yaml", hidden_params(), ROBOT)
    dist = DriveDistribution.from_params_file(path, robot=ROBOT)
    ens = run_ensemble(trace, robot=ROBOT, distribution=dist, n=5, seed=42, engine="reduced")
    env = DynamicsRandomizer.from_sysid(path, env=_DriveEnv())
    episodes = []
    for k in range(5):
        env.reset(seed=42 if k == 0 else None)  # seeded once, like a training run
        episodes.append(env.unwrapped.params)
    assert list(ens.params) == episodes
    assert len(set(ens.params)) == 5  # really drawn, not five copies
    other = run_ensemble(trace, robot=ROBOT, distribution=dist, n=5, seed=43, engine="reduced")
    assert other.params != ens.params


def test_ensemble_is_reproducible(trace) -> None:  # type: ignore[no-untyped-def]
    kw: dict[str, Any] = {"robot": ROBOT, "distribution": _dist(), "n": 4, "engine": "reduced"}
    a = run_ensemble(trace, seed=9, **kw)
    b = run_ensemble(trace, seed=9, **kw)
    np.testing.assert_array_equal(a.lo_v, b.lo_v)
    np.testing.assert_array_equal(a.hi_w, b.hi_w)
    assert a.params == b.params and a.coverage == b.coverage


def test_members_are_replays_of_the_drawn_robots(trace) -> None:  # type: ignore[no-untyped-def]
    from sim2real.agreement.replay import replay

    drawn, mv, mw = ensemble_members(
        trace, robot=ROBOT, distribution=_dist(), n=3, seed=1, engine="reduced"
    )
    assert mv.shape == (3, trace.meas_v.size) == mw.shape
    sim = replay(trace, robot=ROBOT, params=drawn[2], engine="reduced")
    np.testing.assert_array_equal(mv[2], sim.v)
    np.testing.assert_array_equal(mw[2], sim.w)


def test_noise_only_band_of_the_true_robot_covers_its_level(trace) -> None:  # type: ignore[no-untyped-def]
    # The log is the true robot plus N(0, 0.003) / N(0, 0.02) noise (write_log); a band of the
    # true robot (spread 0) with that noise model must cover about its level, at every level.
    dist = _dist(rel=1e-9, noise_v=0.003, noise_w=0.02)  # every robot is the true one
    ens = run_ensemble(trace, robot=ROBOT, distribution=dist, n=10, seed=0, engine="reduced")
    for level, cov_v, cov_w in ens.coverage_by_level:
        assert abs(cov_v - level) < 0.06, (level, cov_v)
        assert abs(cov_w - level) < 0.06, (level, cov_w)
    assert ens.band_width_v_mps == pytest.approx(2 * 1.645 * 0.003, rel=0.15)
    assert ens.band_width_w_radps == pytest.approx(2 * 1.645 * 0.02, rel=0.15)
    assert "calibrated" in band_verdict(coverage_v=ens.coverage_v, coverage_w=ens.coverage_w)


def test_without_noise_a_point_band_misses_the_noisy_log(trace) -> None:  # type: ignore[no-untyped-def]
    dist = _dist(rel=1e-9, noise_v=0.0, noise_w=0.0)
    ens = run_ensemble(trace, robot=ROBOT, distribution=dist, n=4, seed=0, engine="reduced")
    assert ens.coverage_v < 0.1 and ens.coverage_w < 0.1
    assert band_verdict(coverage_v=ens.coverage_v, coverage_w=ens.coverage_w).startswith(
        "The 90 % band is too narrow on v and w"
    )


def test_wider_spread_raises_coverage_and_width(trace) -> None:  # type: ignore[no-untyped-def]
    # centre off the truth and no noise model: only the dynamics spread can reach the real log
    off = hidden_params().replace(delay_s=0.1, added_mass_kg=0.0)
    dist = distribution_around(off, ROBOT, rel=0.3, noise_v=0.0, noise_w=0.0)
    runs = [
        run_ensemble(
            trace, robot=ROBOT, distribution=dist, n=12, seed=5, spread=s, engine="reduced"
        )
        for s in (0.1, 1.0, 3.0)
    ]
    cov = [r.coverage for r in runs]
    width = [r.band_width_v_mps for r in runs]
    assert cov[0] < cov[1] < cov[2] and width[0] < width[1] < width[2]
    for r in runs:
        assert np.all(r.lo_v <= r.hi_v) and r.lo_v.shape == trace.meas_v.shape
        assert 0.0 <= r.coverage <= min(r.coverage_v, r.coverage_w) <= 1.0


@pytest.mark.parametrize(("n", "spread"), [(1, 1.0), (0, 1.0), (3, -1.0), (3, math.nan)])
def test_bad_ensemble_arguments_are_refused(trace, n: int, spread: float) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(Sim2RealValueError, match=r"--ensemble|--spread"):
        run_ensemble(trace, robot=ROBOT, distribution=_dist(), n=n, seed=0, spread=spread)


def test_predictive_band_is_the_weibull_interval() -> None:
    draws = np.arange(1.0, 20.0)[:, None]  # 19 draws: p (m + 1) = 1 and 19 exactly
    lo, hi = predictive_band(draws, 0.9)
    assert (lo[0], hi[0]) == (1.0, 19.0)
    with pytest.raises(Sim2RealValueError, match="--band-level"):
        predictive_band(draws, 1.0)


@settings(max_examples=20)
@given(st.integers(5, 60), st.sampled_from([0.5, 0.8, 0.9]), st.integers(0, 2**31))
def test_weibull_band_contains_a_new_draw_with_its_level(m: int, level: float, seed: int) -> None:
    # exchangeable draws: P(new draw inside the band of m draws) = level (order statistics),
    # up to the interpolation between order statistics (at most 1 / (m + 1))
    rng = np.random.default_rng(seed)
    draws = rng.standard_normal((m, 20000))
    lo, hi = predictive_band(draws, level)
    new = rng.standard_normal(20000)
    cov = band_coverage(new, lo, hi, np.ones(20000, bool))
    reachable = min(level, (m - 1) / (m + 1))  # [min, max] is the widest band of m draws
    assert abs(cov - reachable) < 1.0 / (m + 1) + 0.02


def test_calibrated_range_and_verdicts() -> None:
    lo, hi = calibrated_range(0.9)
    assert (round(lo, 6), round(hi, 6)) == (0.8, 0.99)
    assert "too wide on v and w" in band_verdict(coverage_v=0.999, coverage_w=1.0)
    assert "too narrow on w and too wide on v" in band_verdict(coverage_v=1.0, coverage_w=0.3)
    assert "cannot be judged" in band_verdict(coverage_v=math.nan, coverage_w=0.9)
    calibrated = band_verdict(
        coverage_v=0.85, coverage_w=0.95, band_width_v_mps=0.05, band_width_w_radps=0.2
    )
    assert calibrated.startswith("The 90 % band is calibrated") and "0.05 m/s" in calibrated
    assert band_verdict(coverage_v=0.45, coverage_w=0.5, band_level=0.5).startswith(
        "The 50 % band is calibrated"
    )
    for text in (calibrated, band_verdict(coverage_v=0.2, coverage_w=0.9)):
        assert text.count(". ") == 0 and text.endswith(".")  # one sentence


def test_another_robots_file_is_refused_everywhere(tmp_path: Path) -> None:
    from randomizers import VelocityObservationNoise
    from randomizers.errors import RandomizerValueError
    from robots.errors import ParamsFileError

    other = write_params_file(tmp_path / "kobuki.yaml", load_kobuki(), "turtlebot2")
    with pytest.raises(ParamsFileError, match="turtlebot2"):
        DriveDistribution.from_params_file(other, robot=ROBOT)
    with pytest.raises(RandomizerValueError, match=r"turtlebot2.*turtlebot3_burger|burger"):
        DynamicsRandomizer.from_sysid(other, env=_DriveEnv())
    with pytest.raises(RandomizerValueError, match="turtlebot2"):
        DynamicsRandomizer.from_sysid(other)(_DriveEnv())  # the factory checks the env too
    with pytest.raises(RandomizerValueError, match="turtlebot2"):
        VelocityObservationNoise.from_sysid(other, env=_VelEnv(), index=[0, 2])


def load_kobuki() -> Any:
    from robots.spec import load_spec

    return load_spec("turtlebot2").drive


class _VelEnv(_DriveEnv):
    observation_space = gym.spaces.Box(-2.0, 2.0, (2,))

    def reset(self, *, seed: int | None = None, options: Any = None) -> Any:
        return np.zeros(2, np.float32), {}

    def step(self, action: int) -> Any:
        return np.zeros(2, np.float32), 0.0, False, False, {}


def test_observation_noise_randomizer_draws_with_the_band_rule(tmp_path: Path) -> None:
    from randomizers import VelocityObservationNoise

    path = write_params_file(
        tmp_path / "p.yaml", hidden_params(), ROBOT, fitted=HIDDEN, noise_v=0.01, noise_w=0.05
    )
    env = VelocityObservationNoise.from_sysid(path, env=_VelEnv(), index=[0, 2])
    assert env.noise == ObservationNoise(std_v_mps=0.01, std_w_radps=0.05)
    obs = np.array([env.reset(seed=s)[0] for s in range(2000)])
    assert obs[:, 0].std() == pytest.approx(0.01, rel=0.08)
    assert obs[:, 1].std() == pytest.approx(0.05, rel=0.08)
    # the same rule as the band: ObservationNoise.apply on the wrapper's stream
    env.reset(seed=7)
    again = VelocityObservationNoise.from_sysid(path, env=_VelEnv(), index=[0, 2])
    first = again.reset(seed=7)[0]
    from randomizers import stream_generator

    v, w = env.noise.apply(stream_generator(7, again.name), np.zeros(1), np.zeros(1))
    np.testing.assert_allclose(first, np.array([v[0], w[0]], np.float32), rtol=1e-6)


def test_a_band_of_given_members_is_the_ensembles_band(trace) -> None:  # type: ignore[no-untyped-def]
    from sim2real.agreement.figures import ensemble_of_members

    dist = _dist(noise_v=0.003, noise_w=0.02)
    ens = run_ensemble(trace, robot=ROBOT, distribution=dist, n=8, seed=4, engine="reduced")
    again = ensemble_of_members(
        trace, (ens.members_v, ens.members_w), noise=dist.noise, seed=4, params=ens.params
    )
    assert (again.coverage_v, again.coverage_w) == (ens.coverage_v, ens.coverage_w)
    np.testing.assert_array_equal(again.lo_v, ens.lo_v)
    assert again.n == 8 and again.params == ens.params and again.sampled == ()
    point = ensemble_of_members(
        trace, (ens.members_v[:2] * 0.0, ens.members_w[:2] * 0.0), noise=ObservationNoise(), seed=0
    )
    assert point.coverage_v < ens.coverage_v  # a band of standing robots misses the drive
