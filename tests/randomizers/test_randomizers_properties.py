"""Hypothesis properties: shapes, dtypes, scales, seeds, delays on envs built from the inputs."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from randomizers import DepthNoise, ObservationNoise, OdometryDelay, fill_standard_normal

SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


class ReplayEnv(gym.Env[np.ndarray, int]):
    """Returns the given frames one after another (frame 0 at reset)."""

    action_space = gym.spaces.Discrete(1)

    def __init__(self, frames: np.ndarray, low: float, high: float) -> None:
        self.frames = frames
        self.observation_space = gym.spaces.Box(low, high, frames.shape[1:], frames.dtype)
        self.t = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        super().reset(seed=seed)
        self.t = 0
        return self.frames[0].copy(), {}

    def step(self, action: int) -> Any:
        self.t = min(self.t + 1, len(self.frames) - 1)
        return self.frames[self.t].copy(), 0.0, False, False, {}


shapes = hnp.array_shapes(min_dims=1, max_dims=3, min_side=1, max_side=9)
dtypes = st.sampled_from([np.float32, np.float64])
scales = st.floats(0.0, 1.0)
seeds = st.integers(0, 2**63 - 1)


@SETTINGS
@given(shape=shapes, dtype=dtypes, std=st.floats(0.0, 5.0), scale=scales, seed=seeds)
def test_observation_noise_keeps_shape_dtype_and_bounds(shape, dtype, std, scale, seed) -> None:  # type: ignore[no-untyped-def]
    frames = np.zeros((2, *shape), dtype)
    env = ObservationNoise(ReplayEnv(frames, -1.0, 1.0), std=std, scale=scale)
    obs, info = env.reset(seed=seed)
    assert obs.shape == shape and obs.dtype == dtype
    assert env.observation_space.contains(obs)
    assert info["randomization"]["ObservationNoise"]["std"] == scale * std
    again, _ = env.reset(seed=seed)
    np.testing.assert_array_equal(obs, again)
    if scale == 0.0 or std == 0.0:
        np.testing.assert_array_equal(obs, frames[0])


@SETTINGS
@given(
    image=hnp.arrays(
        st.sampled_from([np.float32, np.float64]),
        hnp.array_shapes(min_dims=2, max_dims=2, min_side=1, max_side=24),
        elements=st.one_of(
            st.floats(0.015625, 9.0, width=32),
            st.sampled_from([0.0, -1.0, 8.0, 10.0, float("nan"), float("inf")]),
        ),
    ),
    std=st.floats(0.0, 3.0),
    scale=scales,
    seed=seeds,
)
def test_depth_noise_invalid_stay_valid_are_clipped(image, std, scale, seed) -> None:  # type: ignore[no-untyped-def]
    near, far = 0.05, 8.0
    env = DepthNoise(ReplayEnv(image[None], 0.0, far), std, near_m=near, far_m=far, scale=scale)
    obs, _ = env.reset(seed=seed)
    assert obs.shape == image.shape and obs.dtype == image.dtype
    invalid = ~((image > 0) & (image < far))
    np.testing.assert_array_equal(obs[invalid], image[invalid])
    valid = obs[~invalid]
    assert np.all((valid >= near) & (valid <= far)) or std * scale == 0.0


@SETTINGS
@given(
    k=st.integers(0, 6),
    length=st.integers(1, 12),
    width=st.integers(1, 5),
    start=st.integers(0, 4),
    fill=st.sampled_from(["first", "zeros"]),
)
def test_odometry_delay_is_exact_for_any_delay_and_range(k, length, width, start, fill) -> None:  # type: ignore[no-untyped-def]
    start = min(start, width - 1)
    frames = np.arange(1, (length + 1) * width + 1, dtype=np.float32).reshape(length + 1, width)
    env = OdometryDelay(
        ReplayEnv(frames, -np.inf, np.inf), delay_steps=k, index=[start, width], fill=fill
    )
    seen = [env.reset(seed=0)[0]]
    seen.extend(env.step(0)[0] for _ in range(length))
    for t, obs in enumerate(seen):
        src = t - k
        expect = frames[max(src, 0), start:] if (src >= 0 or fill == "first") else 0.0
        np.testing.assert_array_equal(obs[start:], np.broadcast_to(expect, obs[start:].shape))
        np.testing.assert_array_equal(obs[:start], frames[t, :start])


@SETTINGS
@given(size=st.integers(0, 3000), dtype=dtypes, seed=seeds)
def test_fill_standard_normal_any_size_is_finite_and_seeded(size, dtype, seed) -> None:  # type: ignore[no-untyped-def]
    a = fill_standard_normal(np.random.default_rng(seed), np.empty(size, dtype))
    b = fill_standard_normal(np.random.default_rng(seed), np.empty(size, dtype))
    assert a.dtype == dtype and np.all(np.isfinite(a)) and np.array_equal(a, b)
    assert np.all(np.abs(a) < 12.0)
