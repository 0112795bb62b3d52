"""A log's own odometry noise where it runs steady (no model), and its pooling over logs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid.steady import MIN_STEADY_SAMPLES, SteadyNoise, pooled_steady_noise, steady_noise


def _log(std_v: float, std_w: float, seed: int) -> tuple[np.ndarray, ...]:
    """20 Hz odometry under commands held 3 s each (levels differ), white noise added."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 60.0, 0.05)
    level = np.floor(t / 3.0)
    cmd_v, cmd_w = 0.05 + 0.01 * (level % 5), 0.2 * (level % 3 - 1)
    return (
        t,
        cmd_v,
        cmd_w,
        cmd_v + rng.normal(0.0, std_v, t.size),
        cmd_w + rng.normal(0.0, std_w, t.size),
    )


@settings(max_examples=25, deadline=None)
@given(std_v=st.floats(0.001, 0.05), std_w=st.floats(0.005, 0.2), seed=st.integers(0, 1000))
def test_steady_noise_recovers_the_white_noise(std_v: float, std_w: float, seed: int) -> None:
    own = steady_noise(*_log(std_v, std_w, seed))
    assert own.measured and own.n_samples > 600
    # the MAD of ~800 samples: within 15 % of the truth
    assert own.std_v_mps == pytest.approx(std_v, rel=0.15)
    assert own.std_w_radps == pytest.approx(std_w, rel=0.15)


def test_a_log_that_never_holds_a_command_cannot_tell_its_noise() -> None:
    t, _, _, v, w = _log(0.01, 0.05, 0)
    changing = np.linspace(0.0, 0.3, t.size)  # a new command at every sample
    own = steady_noise(t, changing, np.zeros(t.size), v, w)
    assert not own.measured and own.n_samples < MIN_STEADY_SAMPLES
    assert math.isnan(own.std_v_mps) and math.isnan(own.std_w_radps)


@settings(max_examples=100, deadline=None)
@given(
    stds=st.lists(
        st.tuples(st.floats(0.0, 0.1), st.floats(0.0, 0.5), st.integers(0, 500)),
        min_size=1,
        max_size=5,
    )
)
def test_pooled_noise_lies_within_the_measured_logs(stds: list[tuple[float, float, int]]) -> None:
    logs = [SteadyNoise(std_v_mps=v, std_w_radps=w, n_samples=n) for v, w, n in stds]
    pooled = pooled_steady_noise(logs)
    measured = [lg for lg in logs if lg.measured]
    if not measured:
        assert not pooled.measured and math.isnan(pooled.std_v_mps)
        return
    assert pooled.n_samples == sum(lg.n_samples for lg in measured)
    for axis in ("std_v_mps", "std_w_radps"):
        values = [getattr(lg, axis) for lg in measured]
        assert min(values) - 1e-12 <= getattr(pooled, axis) <= max(values) + 1e-12
