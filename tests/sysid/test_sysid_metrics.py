"""Shared scores: FIT %, agreement and cross-correlation lag (golden numbers and properties)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid.errors import SysidValueError
from sysid.metrics import active_mask, agreement_fraction, fit_percent, rmse, xcorr_lag_s


def test_fit_percent_golden_numbers() -> None:
    assert fit_percent([0.0, 2.0], [0.0, 1.0]) == pytest.approx(100 * (1 - 1 / math.sqrt(2)))
    assert fit_percent([1.0, 2.0, 3.0], [2.0, 2.0, 2.0]) == pytest.approx(0.0)
    assert fit_percent([1.0, 2.0, 3.0], [1.0, 2.0, 3.0]) == 100.0


def test_fit_percent_of_a_constant_is_undefined_even_with_rounding() -> None:
    assert math.isnan(fit_percent(np.full(10, 0.1), np.zeros(10)))  # mean of 0.1s is inexact
    with pytest.raises(SysidValueError, match="differ in shape"):
        fit_percent([1.0, 2.0], [1.0])


def test_agreement_counts_only_active_samples() -> None:
    act = active_mask([0.0, 0.2, 0.0, 0.0], [0.0] * 4, [0.0, 0.2, 0.05, 0.0], [0.0] * 4)
    assert act.tolist() == [False, True, True, False]
    both, av, aw = agreement_fraction([1.0, 0.0, 0.03, 1.0], [0.0, 0.5, 0.0, 0.0], act)
    assert (both, av, aw) == (0.0, 0.5, 0.5)
    assert rmse([0.0, 0.0], [3.0, 4.0]) == pytest.approx(math.sqrt(12.5))


@settings(max_examples=20, deadline=None)
@given(shift_s=st.floats(-0.4, 0.4), seed=st.integers(0, 10_000))
def test_xcorr_lag_recovers_a_known_shift(shift_s: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 30.0, 0.02)
    knots = np.arange(0.0, 31.0, 0.5)
    levels = rng.uniform(-1.0, 1.0, knots.size)
    real = np.interp(t, knots, levels)
    sim = np.interp(t - shift_s, knots, levels)  # sim late by shift_s
    # sub-sample: the parabolic peak on the 10 ms grid lands within 3 ms
    assert xcorr_lag_s(t, real, sim) == pytest.approx(shift_s, abs=0.003)
