"""sysid.odometry: the exact window mean of a piecewise-linear signal (odometry v model)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid.errors import SysidValueError
from sysid.odometry import running_integral, window_mean


@settings(max_examples=50, deadline=None)
@given(
    a=st.floats(-2.0, 2.0),
    b=st.floats(-2.0, 2.0),
    window=st.floats(1e-3, 0.5),
    seed=st.integers(0, 2**32 - 1),
)
def test_mean_of_a_line_is_its_value_half_a_window_earlier(
    a: float, b: float, window: float, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.0, 5.0, 40))
    t[0], t[-1] = 0.0, 5.0
    x = rng.uniform(window, 5.0, 20)
    got = window_mean(t, a + b * t, x, window)
    np.testing.assert_allclose(got, a + b * (x - 0.5 * window), rtol=0, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), window=st.floats(0.01, 0.3))
def test_matches_a_brute_force_average_of_a_random_polyline(seed: int, window: float) -> None:
    rng = np.random.default_rng(seed)
    t = np.concatenate(([0.0], np.cumsum(rng.uniform(0.02, 0.1, 30))))  # knots >= 20 ms apart
    y = rng.normal(0.0, 1.0, t.size)
    x = rng.uniform(-0.2, t[-1] + 0.2, 10)
    q = x[:, None] + np.linspace(-window, 0.0, 20001)[None, :]
    brute = np.trapezoid(np.interp(q, t, y), q, axis=1) / window  # interp holds the ends
    np.testing.assert_allclose(window_mean(t, y, x, window), brute, rtol=0, atol=1e-6)


def test_step_and_held_ends() -> None:
    t, y = np.array([0.0, 1.0, 1.0, 2.0]), np.array([0.0, 0.0, 1.0, 1.0])
    np.testing.assert_allclose(window_mean(t, y, [1.05, 1.5, 3.0, -1.0], 0.2), [0.25, 1, 1, 0])
    np.testing.assert_allclose(running_integral(t, y, [2.0, 3.0, -1.0]), [1.0, 2.0, 0.0])
    np.testing.assert_allclose(window_mean(t, y, [0.5, 1.5], 0.0), [0.0, 1.0])


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf"), True])
def test_bad_window_is_refused(bad: float) -> None:
    with pytest.raises(SysidValueError, match="window_s must be a finite number >= 0"):
        window_mean([0.0, 1.0], [0.0, 1.0], [0.5], bad)


def test_bad_signal_is_refused() -> None:
    with pytest.raises(SysidValueError, match="sorted"):
        window_mean([1.0, 0.0], [0.0, 1.0], [0.5], 0.1)
    with pytest.raises(SysidValueError, match="one length"):
        window_mean([0.0, 1.0], [0.0], [0.5], 0.1)
    with pytest.raises(SysidValueError, match="finite"):
        window_mean([0.0, np.nan], [0.0, 1.0], [0.5], 0.1)
