"""One-sided limits: a lower bound the logs prove, honoured by the one sampler."""

from __future__ import annotations

import dataclasses
import math
from statistics import NormalDist

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from robots.errors import ParamsFileError, RobotsError
from robots.randomization import DriveDistribution
from robots.spec import load_spec

FIELD = "wheel_torque_max_nm"


def _dist(**lower: float) -> DriveDistribution:
    spec = load_spec("turtlebot2")
    base = DriveDistribution.from_priors(spec.name, spec.geometry, spec.priors)
    return dataclasses.replace(base, lower=lower)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), shift_sd=st.floats(-3.0, 2.0), spread=st.floats(0.2, 2.0))
@example(seed=0, shift_sd=2.0, spread=0.25)  # the bound 8 sd of the narrowed spread out
def test_truncated_marginal_same_draws_for_same_seed(
    seed: int, shift_sd: float, spread: float
) -> None:
    free = _dist()
    j = free.names.index(FIELD)
    mu, sd = free.mean[j], free.std()[FIELD]
    bound = math.exp(mu + shift_sd * sd)
    dist = dataclasses.replace(free, lower={FIELD: bound})
    a = dist.sample_coords(np.random.default_rng(seed), 64, spread=spread)
    b = dist.sample_coords(np.random.default_rng(seed), 64, spread=spread)
    plain = free.sample_coords(np.random.default_rng(seed), 64, spread=spread)
    assert np.array_equal(a, b)  # same seed, same robots
    assert np.all(a[:, j] >= math.log(bound) - 1e-12)  # never below what the log needed
    others = [k for k in range(len(free.names)) if k != j]
    assert np.array_equal(a[:, others], plain[:, others])  # the other fields untouched
    order = np.argsort(plain[:, j], kind="stable")
    assert np.all(np.diff(a[order, j]) >= -1e-12)  # monotone: ranks (and pairings) kept
    draws = dist.sample(np.random.default_rng(seed), 3, spread=spread)
    assert all(getattr(p, FIELD) >= bound * (1 - 1e-9) for p in draws)


@pytest.mark.parametrize("beta", [6.0, 9.0, 20.0])
def test_a_bound_deep_in_the_upper_tail_draws_just_above_it(beta: float) -> None:
    # far out, a normal truncated at mu + beta sd has its mass within ~1/beta sd of the bound:
    # mean mu + sd (beta + 1/beta - 2/beta^3 + ...), the Mills-ratio expansion
    free = _dist()
    j = free.names.index(FIELD)
    mu, sd = free.mean[j], free.std()[FIELD]
    dist = dataclasses.replace(free, lower={FIELD: math.exp(mu + beta * sd)})
    z = (dist.sample_coords(np.random.default_rng(3), 4000)[:, j] - mu) / sd
    assert np.all(np.isfinite(z)) and z.min() >= beta - 1e-9
    mills = NormalDist().pdf(beta) / (0.5 * math.erfc(beta / math.sqrt(2)))  # E[Z | Z > beta]
    assert z.mean() == pytest.approx(mills, abs=0.05 / beta)
    assert len(np.unique(z)) > 3900  # spread over the tail, not piled on the bound


def test_truncated_marginal_has_the_truncated_normal_mean() -> None:
    free = _dist()
    j = free.names.index(FIELD)
    mu, sd = free.mean[j], free.std()[FIELD]
    dist = dataclasses.replace(free, lower={FIELD: math.exp(mu)})  # truncated at the mean
    z = dist.sample_coords(np.random.default_rng(7), 20000)[:, j]
    # a normal truncated at its mean: mean mu + sd sqrt(2 / pi), all draws above mu
    assert z.mean() == pytest.approx(mu + sd * math.sqrt(2 / math.pi), abs=0.02 * sd)
    assert z.min() >= mu
    # a bound far below the mass changes nothing
    far = dataclasses.replace(free, lower={FIELD: math.exp(mu - 8 * sd)})
    same = far.sample_coords(np.random.default_rng(7), 200)
    assert np.allclose(same, free.sample_coords(np.random.default_rng(7), 200), atol=1e-9)
    assert NormalDist().cdf(-8) < 1e-14


def test_lower_bounds_round_trip_and_bad_values() -> None:
    dist = _dist(**{FIELD: 0.5})
    block = dist.to_dict()
    assert block["lower"] == {FIELD: 0.5}
    assert DriveDistribution.from_dict(block).lower == {FIELD: 0.5}
    assert "lower" not in _dist().to_dict()  # no bounds, no key: files stay as they were
    assert dist.scaled(2.0).lower == {FIELD: 0.5}
    with pytest.raises(ParamsFileError, match=r"lower\.delay_s"):
        DriveDistribution.from_dict({**block, "lower": {"delay_s": 0.1}})
    with pytest.raises(ParamsFileError, match="finite number > 0"):
        DriveDistribution.from_dict({**block, "lower": {FIELD: -1.0}})
    with pytest.raises(RobotsError):
        _dist(no_such_field=1.0)
