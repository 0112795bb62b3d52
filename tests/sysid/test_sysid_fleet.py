"""Several sessions of one robot: per-log estimates, a random-effects population, the file."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.spec import load_spec
from sysid import SysidResult, fit_drive
from sysid._fleet import SessionInfo, population
from sysid.synthetic import step_commands, synthetic_log

SPEC = load_spec("turtlebot3_burger")
GEO = SPEC.geometry
#: session-to-session truth: latency and payload differ per day
DELAYS = (0.08, 0.10, 0.12, 0.14, 0.16)
PAYLOADS = (0.0, 0.1, 0.2, 0.3, 0.4)


@settings(max_examples=20)
@given(
    values=st.lists(st.floats(-2.0, 2.0), min_size=2, max_size=8),
    noise=st.floats(1e-4, 1.0),
)
def test_population_mean_is_precision_weighted_and_between_is_psd(
    values: list[float], noise: float
) -> None:
    sessions = [SessionInfo(z=np.array([x]), info=np.array([[1.0 / noise**2]])) for x in values]
    pop = population(
        sessions, prior_mu=np.zeros(1), prior_prec=np.zeros(1), session_cov=np.eye(1) * 0.01
    )
    w = 1.0 / (noise**2 + pop.between[0, 0])
    assert pop.mean[0] == pytest.approx(np.mean(values), abs=1e-9 + 1e-6 * abs(np.mean(values)))
    assert pop.mean_cov[0, 0] == pytest.approx(1.0 / (w * len(values)), rel=1e-6)
    assert pop.between[0, 0] >= 0


def test_population_shrinks_toward_the_default_spread_with_few_sessions() -> None:
    s0 = np.diag([0.04, 0.01])
    # two sessions that agree exactly: the data say "no spread", the shrinkage keeps some
    sessions = [SessionInfo(z=np.array([1.0, 2.0]), info=np.eye(2) * 1e8) for _ in range(2)]
    pop = population(sessions, prior_mu=np.zeros(2), prior_prec=np.zeros(2), session_cov=s0)
    assert np.allclose(pop.between, 3.0 / 5.0 * s0, rtol=1e-3)
    # a field no session informs: its mean is the prior, its spread the default one
    blind = [SessionInfo(z=np.array([0.0]), info=np.zeros((1, 1))) for _ in range(4)]
    pop = population(
        blind, prior_mu=np.array([0.3]), prior_prec=np.array([4.0]), session_cov=s0[:1, :1]
    )
    assert pop.mean[0] == pytest.approx(0.3)
    assert pop.mean_cov[0, 0] == pytest.approx(0.25)  # the prior, counted once
    assert pop.between[0, 0] == pytest.approx(0.04, rel=1e-3)


def test_a_session_blind_in_a_direction_says_nothing_there() -> None:
    """A short log's MAP point off the prior where its data carry ~no information (a bound,
    an unconverged step) must not be read as a data estimate astronomically far away: that
    made the EM spread grow without bound (motor gain exp(-1392) = 0 on a paused log)."""
    prior_mu, prior_prec = np.array([0.0, 0.0]), np.array([100.0, 100.0])
    s0 = np.diag([0.01, 0.01])
    sessions = [
        SessionInfo(z=np.array([0.05, 0.1]), info=np.diag([1e4, 1e-27])),  # 1 prior sd off
        SessionInfo(z=np.array([0.07, 0.0]), info=np.diag([1e4, 0.0])),
    ]
    pop = population(sessions, prior_mu=prior_mu, prior_prec=prior_prec, session_cov=s0)
    assert pop.mean[1] == pytest.approx(0.0, abs=1e-12)  # the prior: no session informs it
    assert pop.mean_cov[1, 1] == pytest.approx(0.01, rel=1e-6)
    assert pop.between[1, 1] == pytest.approx(0.01, rel=1e-3)  # the default spread
    assert 0.03 < pop.mean[0] < 0.07 and pop.between[0, 0] < 0.01
    # informed well (eigenvalue >= MIN_INFO_RATIO of the prior), the pull is undone as before
    informed = [SessionInfo(z=np.array([x, 0.0]), info=np.diag([1e4, 0.0])) for x in (0.05, 0.07)]
    ref = population(informed, prior_mu=prior_mu, prior_prec=prior_prec, session_cov=s0)
    assert ref.mean[0] == pytest.approx(pop.mean[0], rel=1e-9)


@pytest.fixture(scope="module")
def fleet() -> SysidResult:
    logs = []
    for i, (delay, payload) in enumerate(zip(DELAYS, PAYLOADS, strict=True)):
        truth = SPEC.drive.replace(delay_s=delay, added_mass_kg=payload)
        t, v, w = step_commands(25.0, seed=40 + i, v_max_mps=0.15, w_max_radps=1.2)
        logs.append(
            synthetic_log(
                truth, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=40 + i, spike_mps=None, name=f"s{i}"
            )
        )
    return fit_drive(
        logs,
        geometry=GEO,
        base_params=SPEC.drive,
        priors=SPEC.priors,
        robot=SPEC.name,
        odom_v_window_s=0.02,
    )


def test_fleet_gives_per_log_estimates_and_a_population(fleet: SysidResult, tmp_path: Path) -> None:
    assert [s["log"] for s in fleet.sessions] == ["s0", "s1", "s2", "s3", "s4"]
    delays = [s["parameters"]["delay_s"]["value"] for s in fleet.sessions]
    assert np.allclose(delays, DELAYS, atol=0.01)
    dist = fleet.randomization
    assert dist is not None
    # population mean and between-session spread of the delay (coordinates: seconds)
    i = dist.names.index("delay_s")
    assert dist.mean[i] == pytest.approx(np.mean(DELAYS), abs=0.01)
    sd = math.sqrt(dist.covariance_array[i, i])
    # the five truths spread with sd 0.028 s; three pseudo-sessions of the spec's default
    # 0.02 s shrink it a little; the uncertainty of the mean adds a little
    assert 0.015 < sd < 0.04
    assert fleet.params.delay_s == pytest.approx(np.mean(DELAYS), abs=0.01)
    back = SysidResult.load(fleet.save(tmp_path / "fleet.yaml"))
    assert back.sessions == fleet.sessions
    assert back.randomization == dist
    assert all(s.n_samples > 0 for s in fleet.scores_fit) and len(fleet.scores_fit) == 5


def test_fleet_draws_cover_the_sessions(fleet: SysidResult) -> None:
    dist = fleet.randomization
    assert dist is not None
    draws = dist.sample(np.random.default_rng(0), 400)
    delays = np.array([p.delay_s for p in draws])
    lo, hi = np.percentile(delays, [2.5, 97.5])
    assert lo < min(DELAYS) and hi > max(DELAYS)
    assert all(p.total_mass_kg(GEO) > 0 for p in draws)


def test_new_session_widening_falls_to_one_as_sessions_accumulate() -> None:
    from scipy.stats import norm, t

    from sysid._fleet import PRIOR_SESSIONS, new_session_factor

    factors = [new_session_factor(n) for n in (1, 2, 3, 5, 10, 100, 10_000)]
    assert all(a > b for a, b in itertools.pairwise(factors))
    assert factors[-1] == pytest.approx(1.0, abs=1e-3)
    # the Gaussian with this variance has the Student-t predictive's central 90 % interval
    for n in (1, 3, 8):
        dof = n - 1 + PRIOR_SESSIONS
        assert math.sqrt(new_session_factor(n)) * norm.ppf(0.95) == pytest.approx(
            t.ppf(0.95, dof), rel=1e-9
        )
