"""Odometry noise that grows with speed: sd^2 = floor^2 + (fraction x |speed|)^2 per axis.

Synthetic logs of known law: commands held 4 s each (drive at two speeds, spin at two rates,
an arc), 10 Hz, white Gaussian noise of the law added to each axis. Tolerances: ~150-300
steady samples per axis recover each part within 25 % (the robust sd of 30 samples a bin has
a ~28 % error in variance); the mean over 100 logs within 4 %.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.agreement.latency import fit_speed_noise
from sim2real.logs import Trace
from sysid._logs import as_log_arrays
from sysid.fit import _measurement_noise
from sysid.steady import (
    MIN_STEADY_SAMPLES,
    SpeedNoise,
    speed_bins,
    speed_noise,
    steady_noise,
    variance_law,
)

MOTIONS = ((0.3, 0.0), (0.0, 2.0), (0.15, 0.0), (0.0, -1.0), (0.2, 0.8))


def _log(
    floor_v: float, frac_v: float, floor_w: float, frac_w: float, seed: int, motions=MOTIONS
) -> tuple[np.ndarray, ...]:
    """120 s at 10 Hz under ``motions`` held 4 s each, in turn; the law's noise added."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 120.0, 0.1)
    k = (t // 4.0).astype(int) % len(motions)
    cmd_v = np.array([motions[i][0] for i in k])
    cmd_w = np.array([motions[i][1] for i in k])
    meas_v = cmd_v + rng.normal(0.0, np.hypot(floor_v, frac_v * cmd_v))
    meas_w = cmd_w + rng.normal(0.0, np.hypot(floor_w, frac_w * cmd_w))
    return t, cmd_v, cmd_w, meas_v, meas_w


@settings(max_examples=25, deadline=None)
@given(
    floor_v=st.floats(0.0005, 0.005),
    frac_v=st.floats(0.03, 0.1),
    floor_w=st.floats(0.002, 0.02),
    frac_w=st.floats(0.03, 0.1),
    seed=st.integers(0, 1000),
)
def test_the_law_is_recovered(
    floor_v: float, frac_v: float, floor_w: float, frac_w: float, seed: int
) -> None:
    law = speed_noise([_log(floor_v, frac_v, floor_w, frac_w, seed)])
    assert set(law.told) == {"floor_v_mps", "fraction_v", "floor_w_radps", "fraction_w"}
    assert law.n_v >= 500 and law.n_w >= 500
    assert law.fraction_v == pytest.approx(frac_v, rel=0.25)
    assert law.fraction_w == pytest.approx(frac_w, rel=0.25)
    assert law.floor_v_mps == pytest.approx(floor_v, rel=0.25)
    assert law.floor_w_radps == pytest.approx(floor_w, rel=0.25)


def test_the_refined_law_is_unbiased_where_the_bins_own_weights_are_not() -> None:
    """Mean over 100 logs: within 4 % of the truth (weights from each bin's own variance
    read the fraction ~10-15 % low)."""
    laws = [speed_noise([_log(0.002, 0.06, 0.005, 0.06, seed)]) for seed in range(100)]
    assert np.mean([x.fraction_w for x in laws]) == pytest.approx(0.06, rel=0.04)
    assert np.mean([x.fraction_v for x in laws]) == pytest.approx(0.06, rel=0.04)
    plain = []
    for seed in range(100):
        *_, cmd_w, _, meas_w = _log(0.002, 0.06, 0.005, 0.06, seed)
        dev = meas_w - cmd_w  # the law's noise at the commanded rate
        _, c1 = variance_law(dev, np.abs(cmd_w), bin_samples=MIN_STEADY_SAMPLES)
        plain.append(math.sqrt(c1))
    assert np.mean(plain) < 0.06 * 0.95


def test_one_noise_per_axis_misreads_a_noise_that_grows_with_speed() -> None:
    """The pooled steady noise of a log that spins at 2 rad/s and drives straight is far below
    its spinning noise: what the law is for."""
    log = _log(0.001, 0.06, 0.005, 0.06, 0)
    pooled = steady_noise(*log)
    law = speed_noise([log])
    spinning = float(law.std_at(0.0, 2.0)[1])
    assert spinning == pytest.approx(0.12, rel=0.2)
    assert pooled.std_w_radps < 0.5 * spinning


def test_a_log_held_at_zero_takes_the_fallbacks_fraction() -> None:
    """Drives straight only: w is held at zero, so w tells its floor and not its fraction."""
    log = _log(0.001, 0.05, 0.005, 0.06, 1, motions=((0.3, 0.0), (0.15, 0.0)))
    fit = SpeedNoise(floor_v_mps=0.002, fraction_v=0.07, floor_w_radps=0.004, fraction_w=0.08)
    law = speed_noise([log], fallback=fit)
    assert law.fraction_w == 0.08 and "fraction_w" not in law.told
    assert law.floor_w_radps == pytest.approx(0.005, rel=0.2) and "floor_w_radps" in law.told
    alone = speed_noise([log])
    assert math.isnan(alone.fraction_w)  # no fallback: unknown (counts as 0 in std_at)
    assert float(alone.std_at(0.0, 2.0)[1]) == alone.floor_w_radps


def test_one_speed_takes_the_fallbacks_floor_and_keeps_its_own_noise_there() -> None:
    """Drives at 0.3 m/s only (v at one speed): the floor is the fallback's, the fraction the
    rest, so the noise at 0.3 m/s stays the log's own; with no fallback, a constant."""
    log = _log(0.001, 0.05, 0.005, 0.06, 2, motions=((0.3, 0.0), (0.3, 1.0)))
    fit = SpeedNoise(floor_v_mps=0.004, fraction_v=0.01, floor_w_radps=0.004, fraction_w=0.08)
    law = speed_noise([log], fallback=fit)
    own = float(speed_noise([log]).std_at(0.3, 0.0)[0])
    assert law.floor_v_mps == 0.004 and "fraction_v" in law.told
    assert float(law.std_at(0.3, 0.0)[0]) == pytest.approx(own, rel=0.01)  # at its rms speed
    alone = speed_noise([log])
    assert alone.fraction_v == 0.0 and alone.floor_v_mps == pytest.approx(0.015, rel=0.2)
    assert "floor_v_mps" not in alone.told


def test_a_log_without_steady_samples_is_the_fallback() -> None:
    t, _, _, v, w = _log(0.001, 0.05, 0.005, 0.06, 3)
    changing = np.linspace(0.0, 0.3, t.size)
    fit = SpeedNoise(floor_v_mps=0.004, fraction_v=0.01, floor_w_radps=0.004, fraction_w=0.08)
    law = speed_noise([(t, changing, 0 * t, v, w)], fallback=fit)
    assert law.told == () and (law.n_v, law.n_w) == (0, 0)
    assert law.fraction_w == 0.08 and law.floor_v_mps == 0.004
    assert math.isnan(speed_noise([(t, changing, 0 * t, v, w)]).floor_v_mps)


def test_logs_pool() -> None:
    """Two logs of one source: the law of both, from the samples of both."""
    a = _log(0.001, 0.05, 0.005, 0.06, 4, motions=((0.3, 0.0), (0.0, 0.0)))
    b = _log(0.001, 0.05, 0.005, 0.06, 5, motions=((0.0, 2.0), (0.15, 0.0)))
    law = speed_noise([a, b])
    assert law.n_v == speed_noise([a]).n_v + speed_noise([b]).n_v
    assert law.fraction_w == pytest.approx(0.06, rel=0.25)


@settings(max_examples=50, deadline=None)
@given(
    speeds=st.lists(st.floats(0.0, 3.0), min_size=1, max_size=200),
    size=st.integers(1, 40),
    seed=st.integers(0, 100),
)
def test_bins_partition_and_never_mix_classes(speeds: list[float], size: int, seed: int) -> None:
    classes = np.random.default_rng(seed).integers(0, 2, len(speeds))
    bins = speed_bins(speeds, size, classes=classes)
    joined = np.sort(np.concatenate(bins))
    assert joined.tolist() == list(range(len(speeds)))
    a = np.asarray(speeds)
    for b in bins:
        assert b.size >= min(size, int(np.sum(classes == classes[b[0]])))
        assert np.unique(classes[b]).size == 1
        assert np.all(np.diff(a[b]) >= 0)  # consecutive speeds


def test_the_fit_records_the_parts_its_logs_tell_and_agree_reads_them() -> None:
    """``settings.measurement_noise`` of a fit holds the law's told parts; ``agree`` reads
    them back as the fallback of a checked log (sim2real.agreement.latency.fit_speed_noise)."""
    t, cmd_v, cmd_w, meas_v, meas_w = _log(0.001, 0.05, 0.005, 0.06, 6)
    stamps = 1_700_000_000_000_000_000 + np.rint(t * 1e9).astype(np.int64)
    trace = Trace(cmd_t_ns=stamps, cmd_v=cmd_v, cmd_w=cmd_w, meas_t_ns=stamps, meas_v=meas_v,
                  meas_w=meas_w)  # fmt: skip
    block = _measurement_noise([as_log_arrays(trace)])
    law = speed_noise([(t, cmd_v, cmd_w, meas_v, meas_w)])
    recorded = block["measurement_noise"]
    assert {k: recorded[k] for k in law.told} == {k: getattr(law, k) for k in law.told}
    back = fit_speed_noise(block)
    assert back is not None and back.fraction_w == law.fraction_w
    assert fit_speed_noise({"measurement_noise": {"std_v_mps": 0.01}}) is None
