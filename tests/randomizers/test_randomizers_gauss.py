"""The ziggurat normal generator: exact N(0, 1) statistics, reproducibility, tables."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from randomizers._gauss import ZIGGURAT_LAYERS, NormalPool, fill_standard_normal, ziggurat_tables


@pytest.fixture(scope="module")
def draws() -> np.ndarray:
    return fill_standard_normal(np.random.default_rng(20260), np.empty(4_000_000))


def test_tables_close_at_the_top() -> None:
    _, _, fx, edge = ziggurat_tables()
    area = edge[0] * fx[0]  # base strip: width v / f(r) times height f(r)
    # The top layer (right edge x_255, from f(x_255) up to f(0) = 1) must also have area v.
    assert edge[ZIGGURAT_LAYERS - 1] * (1.0 - fx[ZIGGURAT_LAYERS - 1]) == pytest.approx(
        area, rel=1e-6
    )
    assert np.all(np.diff(edge[1:]) < 0)


def test_moments_match_standard_normal(draws: np.ndarray) -> None:
    n = draws.size
    assert abs(draws.mean()) < 4 / math.sqrt(n)
    assert abs(draws.std() - 1.0) < 4 / math.sqrt(2 * n)
    assert abs(stats.skew(draws)) < 4 * math.sqrt(6 / n)
    assert abs(stats.kurtosis(draws)) < 4 * math.sqrt(24 / n)


@pytest.mark.parametrize("threshold", [0.5, 1.0, 2.0, 3.0, 3.6541528853610088, 4.0])
def test_tail_frequencies(draws: np.ndarray, threshold: float) -> None:
    """Counts beyond |x| > t within 4.5 sigma of the binomial expectation (checks the tail path)."""
    p = 2 * stats.norm.sf(threshold)
    expected = p * draws.size
    observed = np.count_nonzero(np.abs(draws) > threshold)
    assert abs(observed - expected) < 4.5 * math.sqrt(expected * (1 - p))


def test_kolmogorov_smirnov(draws: np.ndarray) -> None:
    assert stats.kstest(draws[:500_000], "norm").pvalue > 1e-3


def test_same_seed_same_samples_float32_and_float64() -> None:
    a = fill_standard_normal(np.random.default_rng(7), np.empty((64, 64), np.float32))
    b = fill_standard_normal(np.random.default_rng(7), np.empty((64, 64), np.float32))
    c = fill_standard_normal(np.random.default_rng(7), np.empty((64, 64), np.float64))
    assert a.dtype == np.float32 and np.array_equal(a, b)
    np.testing.assert_allclose(a, c, rtol=1e-6, atol=1e-6)
    d = fill_standard_normal(np.random.default_rng(8), np.empty((64, 64), np.float32))
    assert not np.array_equal(a, d)


def test_successive_calls_are_uncorrelated() -> None:
    rng = np.random.default_rng(3)
    a = fill_standard_normal(rng, np.empty(200_000))
    b = fill_standard_normal(rng, np.empty(200_000))
    assert abs(np.corrcoef(a, b)[0, 1]) < 4 / math.sqrt(a.size)
    assert abs(np.corrcoef(a[:-1], a[1:])[0, 1]) < 4 / math.sqrt(a.size)


def test_empty_and_odd_sizes() -> None:
    rng = np.random.default_rng(0)
    assert fill_standard_normal(rng, np.empty(0)).size == 0
    out = fill_standard_normal(rng, np.full(7, np.nan))
    assert np.all(np.isfinite(out))


def test_pool_hands_out_consecutive_slices_of_the_stream() -> None:
    pool = NormalPool(np.float64)
    rng = np.random.default_rng(4)
    taken = np.concatenate([pool.take(rng, 8).copy() for _ in range(256)])  # two 1024 blocks
    direct = np.random.default_rng(4)
    expected = np.concatenate([fill_standard_normal(direct, np.empty(1024)) for _ in range(2)])
    np.testing.assert_array_equal(taken, expected)


def test_pool_grows_for_large_requests_and_clear_restarts() -> None:
    pool = NormalPool(np.float32)
    pool.take(np.random.default_rng(1), 2)
    big = pool.take(np.random.default_rng(1), 100_000).copy()  # needs a new, larger block
    assert big.size == 100_000 and big.dtype == np.float32
    pool.clear()  # as on reset(seed=...): the same seed gives the same samples again
    np.testing.assert_array_equal(pool.take(np.random.default_rng(1), 100_000), big)


@pytest.mark.parametrize("bit_generator", ["MT19937", "Philox", "SFC64", "PCG64DXSM", "PCG64"])
def test_every_numpy_bit_generator_gives_standard_normal_samples(bit_generator: str) -> None:
    n = 400_000
    z = fill_standard_normal(np.random.Generator(getattr(np.random, bit_generator)(3)), np.empty(n))
    assert abs(z.mean()) < 4 / math.sqrt(n)
    assert abs(z.std() - 1.0) < 4 / math.sqrt(2 * n)


def test_raw_words_count_and_a_bit_generator_of_unknown_width() -> None:
    from randomizers._gauss import raw_words
    from randomizers.errors import RandomizerTypeError

    pcg = raw_words(np.random.PCG64(1), 5)
    assert pcg.dtype == np.uint32 and pcg.size == 6
    assert np.array_equal(pcg, np.random.PCG64(1).random_raw(3).view(np.uint32))
    mt = raw_words(np.random.MT19937(1), 5)
    assert np.array_equal(mt, np.random.MT19937(1).random_raw(5).astype(np.uint32))
    with pytest.raises(RandomizerTypeError, match="raw output width is not known"):
        raw_words(object(), 4)  # type: ignore[arg-type]
