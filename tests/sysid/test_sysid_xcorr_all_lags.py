"""The all-lags cross-correlation of ``xcorr_lag_s`` (FFT + cumulative sums, issue 16) equals the
per-lag Pearson correlation of the overlapping parts."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid.metrics import _overlap_corr, _overlap_corr_all


@settings(max_examples=60)
@given(n=st.integers(5, 3000), shift=st.integers(-40, 40), seed=st.integers(0, 2**32 - 1))
def test_all_lags_equal_the_per_lag_correlation(n: int, shift: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    a = rng.normal(size=n)
    b = np.roll(a, shift) + 0.3 * rng.normal(size=n)
    a -= a.mean()
    b -= b.mean()
    max_k = min(100, n - 2)
    ref = [
        _overlap_corr(a[max(0, -k) : n - max(0, k)], b[max(0, k) : n - max(0, -k)])
        for k in range(-max_k, max_k + 1)
    ]
    np.testing.assert_allclose(_overlap_corr_all(a, b, max_k), ref, atol=1e-9)


def test_constant_overlap_gives_zero() -> None:
    a = np.array([1.0, -1.0, 0.0, 0.0, 0.0, 0.0])
    b = np.zeros(6)
    assert np.all(_overlap_corr_all(a, b, 4) == 0.0)
