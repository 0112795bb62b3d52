"""The model's time-step bias widens the posterior as a bounded inflation: never past the prior."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid._map import bounded_bias


def _widest(bias: np.ndarray, info: np.ndarray, prior_prec: np.ndarray) -> float:
    """Largest eigenvalue of Q^(1/2) (Pi^-1 + b b^T) Q^(1/2): <= 1 when within the prior."""
    cov = np.linalg.inv(info + prior_prec) + np.outer(bias, bias)
    root = np.diag(np.sqrt(np.diag(prior_prec)))
    return float(np.linalg.eigvalsh(root @ cov @ root).max())


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), bias_sd=st.floats(0.01, 100.0))
def test_the_bounded_bias_keeps_the_posterior_within_the_prior(seed: int, bias_sd: float) -> None:
    # any size, any rank of the data information (0 to full), scales over six decades
    rng = np.random.default_rng(seed)
    p = int(rng.integers(1, 7))
    a = rng.normal(size=(int(rng.integers(0, p + 1)), p)) * 10.0 ** rng.uniform(-3, 3, size=p)
    info = a.T @ a
    prior_prec = np.diag(10.0 ** rng.uniform(-2, 2, size=p))
    bias = rng.normal(size=p) * bias_sd / np.sqrt(np.diag(prior_prec))
    out = bounded_bias(bias, info, prior_prec)
    assert _widest(out, info, prior_prec) <= 1.0 + 1e-6
    # it only shrinks, along the same direction
    scale = float(out @ bias) / float(bias @ bias)
    assert 0.0 <= scale <= 1.0 + 1e-12
    np.testing.assert_allclose(out, scale * bias, atol=1e-12 * float(np.abs(bias).max()))


def test_a_bias_within_the_prior_is_kept_whole() -> None:
    # one coordinate, data as informative as the prior: posterior variance 1/2, room for 1/2
    one = np.eye(1)
    np.testing.assert_array_equal(bounded_bias(np.array([0.7]), one, one), [0.7])
    # a shift of 3 prior sd is cut to the prior: 1/2 + 1/2
    np.testing.assert_allclose(bounded_bias(np.array([3.0]), one, one) ** 2, [0.5], rtol=1e-12)
    # a shift along a direction the data say nothing about (the prior is the posterior there)
    # leaves no room at all
    out = bounded_bias(np.array([0.1, 0.5]), np.diag([1.0, 0.0]), np.eye(2))
    np.testing.assert_allclose(out, [0.0, 0.0], atol=1e-6)


def test_the_cap_of_the_burger_seed_3_case() -> None:
    # the numbers of the case that broke: a 3.8 prior-sd shift of the torque cap through its
    # coupling to the other coordinates, where the data barely inform the cap
    info = np.array([[4.0, 3.9], [3.9, 4.0]])  # two coordinates the data tie together
    prior = np.eye(2)
    bias = np.array([0.4, -3.8])
    out = bounded_bias(bias, info, prior)
    cov = np.linalg.inv(info + prior) + np.outer(out, out)
    assert np.all(np.sqrt(np.diag(cov)) <= 1.0 + 1e-9)
    assert np.sqrt(np.diag(np.linalg.inv(info + prior) + np.outer(bias, bias)))[1] > 3.0
