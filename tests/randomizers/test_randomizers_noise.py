"""DepthNoise, LidarNoise, ObservationNoise and GoalNoise: statistics, invalid values, clipping."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from randomizers_testenv import DEPTH_FAR_M, DEPTH_NEAR_M, GOAL_XY, NavDouble, depth_image

from randomizers import DepthNoise, GoalNoise, LidarNoise, ObservationNoise


def _depth_env(std_m: float = 0.2, scale: float = 1.0) -> DepthNoise:
    return DepthNoise(
        NavDouble(), std_m, near_m=DEPTH_NEAR_M, far_m=DEPTH_FAR_M, key="depth", scale=scale
    )


def _depth_residuals(env: DepthNoise, frames: int, seed: int = 11) -> np.ndarray:
    clean = depth_image()
    inner = (clean > 0.7) & (clean < 7.3)  # far from the clip limits: residual = raw noise
    obs, _ = env.reset(seed=seed)
    out = [obs["depth"][inner] - clean[inner]]
    for _ in range(frames - 1):
        out.append(env.step(np.zeros(2, np.float32))[0]["depth"][inner] - clean[inner])
    return np.concatenate(out).astype(np.float64)


def test_depth_noise_mean_and_std_default_0p2_m() -> None:
    res = _depth_residuals(_depth_env(), frames=30)
    n = res.size  # ~115k pixels
    assert n > 100_000
    assert abs(res.mean()) < 4 * 0.2 / math.sqrt(n)  # ~0.0024 m
    assert abs(res.std() - 0.2) < 4 * 0.2 / math.sqrt(2 * n)  # ~0.0017 m


def test_depth_noise_scale_multiplies_std() -> None:
    res = _depth_residuals(_depth_env(std_m=0.2, scale=0.25), frames=20)
    assert abs(res.std() - 0.05) < 4 * 0.05 / math.sqrt(2 * res.size)


def test_depth_noise_is_iid_across_pixels_and_frames() -> None:
    env = _depth_env()
    clean = depth_image()
    obs0, _ = env.reset(seed=1)
    obs1 = env.step(np.zeros(2, np.float32))[0]
    inner = (clean > 0.7) & (clean < 7.3)
    a = obs0["depth"][inner] - clean[inner]
    b = obs1["depth"][inner] - clean[inner]
    bound = 4 / math.sqrt(a.size)
    assert abs(np.corrcoef(a, b)[0, 1]) < bound
    assert abs(np.corrcoef(a[:-1], a[1:])[0, 1]) < bound


def test_depth_invalid_pixels_stay_invalid_and_valid_ones_are_clipped() -> None:
    env = _depth_env(std_m=5.0)  # huge noise: many valid pixels hit the clip limits
    obs, _ = env.reset(seed=2)
    depth = obs["depth"]
    assert depth.dtype == np.float32 and depth.shape == (64, 64)
    assert np.isnan(depth[0, 0]) and depth[0, 1] == 0.0
    assert depth[0, 2] == DEPTH_FAR_M and np.isposinf(depth[0, 3])
    valid = depth.copy()
    valid[0, :4] = DEPTH_NEAR_M
    assert valid.min() == pytest.approx(DEPTH_NEAR_M) and valid.max() == DEPTH_FAR_M
    assert np.count_nonzero(valid == DEPTH_NEAR_M) > 100


def test_depth_noise_does_not_touch_other_keys_or_the_env_arrays() -> None:
    env = _depth_env()
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(obs["lidar"], env.unwrapped._lidar)
    np.testing.assert_array_equal(env.unwrapped._depth, depth_image(), strict=True)


def test_depth_noise_scale_zero_passes_through() -> None:
    obs, info = _depth_env(scale=0.0).reset(seed=0)
    np.testing.assert_array_equal(obs["depth"], depth_image())
    assert info["randomization"]["DepthNoise[depth]"] == {"std_m": 0.0, "scale": 0.0}


def test_depth_noise_on_plain_box_observation() -> None:
    class Cam(gym.Env[np.ndarray, int]):
        observation_space = gym.spaces.Box(0.0, 8.0, (48, 64), np.float64)
        action_space = gym.spaces.Discrete(1)

        def reset(self, *, seed=None, options=None):  # type: ignore[no-untyped-def]
            super().reset(seed=seed)
            return np.full((48, 64), 4.0), {}

        def step(self, action):  # type: ignore[no-untyped-def]
            return np.full((48, 64), 4.0), 0.0, False, False, {}

    env = DepthNoise(Cam(), 0.2, near_m=0.05, far_m=8.0)
    obs, _ = env.reset(seed=0)
    assert obs.dtype == np.float64
    assert abs((obs - 4.0).std() - 0.2) < 4 * 0.2 / math.sqrt(2 * obs.size)


def test_lidar_noise_std_dropout_rate_and_invalid_beams() -> None:
    env = LidarNoise(NavDouble(), std_m=0.05, dropout=0.2, key="lidar")
    clean = env.unwrapped._lidar.copy()
    valid = clean < 3.5
    residuals, dropped, total = [], 0, 0
    obs, info = env.reset(seed=4)
    for _ in range(2000):
        scan = obs["lidar"]
        assert scan.dtype == np.float32
        assert np.all(scan[~valid] == 3.5)  # max-range beams untouched
        is_drop = valid & (scan == 3.5)
        assert info["randomization"]["LidarNoise[lidar]"]["dropped"] == is_drop.sum()
        dropped += int(is_drop.sum())
        total += int(valid.sum())
        residuals.append((scan - clean)[valid & ~is_drop])
        obs, _, _, _, info = env.step(np.zeros(2, np.float32))
    p_hat = dropped / total
    assert abs(p_hat - 0.2) < 4 * math.sqrt(0.2 * 0.8 / total)
    res = np.concatenate(residuals).astype(np.float64)
    assert abs(res.std() - 0.05) < 4 * 0.05 / math.sqrt(2 * res.size)
    assert abs(res.mean()) < 4 * 0.05 / math.sqrt(res.size)


def test_lidar_noise_clips_to_range_and_scale_scales_dropout() -> None:
    env = LidarNoise(NavDouble(), std_m=3.0, dropout=0.5, key="lidar", scale=0.0)
    obs, info = env.reset(seed=0)
    np.testing.assert_array_equal(obs["lidar"], env.unwrapped._lidar)
    assert info["randomization"]["LidarNoise[lidar]"]["dropped"] == 0
    env.set_scale(1.0)
    obs, _ = env.reset()
    assert obs["lidar"].min() >= 0.12 and obs["lidar"].max() <= 3.5


def test_observation_noise_on_cartpole_index_range() -> None:
    env = ObservationNoise(gym.make("CartPole-v1"), std=0.1, index=[2, 4], clip=False)
    bare = gym.make("CartPole-v1")
    diffs = []
    obs, _ = env.reset(seed=5)
    ref, _ = bare.reset(seed=5)
    for _ in range(200):
        np.testing.assert_array_equal(obs[:2], ref[:2])
        diffs.append(obs[2:] - ref[2:])
        obs, _, term, trunc, _ = env.step(0)
        ref, _, _rterm, _rtrunc, _ = bare.step(0)
        if term or trunc:
            obs, _ = env.reset(seed=6)
            ref, _ = bare.reset(seed=6)
    d = np.asarray(diffs, dtype=np.float64).ravel()
    assert abs(d.std() - 0.1) < 4 * 0.1 / math.sqrt(2 * d.size)


def test_observation_noise_per_element_std_and_clip_to_bounds() -> None:
    env = ObservationNoise(gym.make("Pendulum-v1"), std=[0.0, 0.0, 50.0])
    obs, _ = env.reset(seed=0)
    ref, _ = gym.make("Pendulum-v1").reset(seed=0)
    np.testing.assert_array_equal(obs[:2], ref[:2])
    at_limit = 0
    for _ in range(40):
        obs = env.step(np.zeros(1, np.float32))[0]
        assert env.observation_space.contains(obs)  # clipped to +-8 rad/s
        at_limit += int(abs(obs[2]) == np.float32(8.0))
    assert at_limit > 25  # P(|w + N(0, 50^2)| <= 8) is ~0.13-0.25: ~32 expected


def test_goal_noise_per_episode_offset_is_constant_and_recorded() -> None:
    env = GoalNoise(NavDouble(), std_m=0.2, key="goal")
    base = env.unwrapped
    obs, info = env.reset(seed=3)
    offset = np.array(info["randomization"]["GoalNoise[goal]"]["offset_m"])
    for _ in range(5):
        clean = base._obs()["goal"]
        np.testing.assert_allclose(obs["goal"], clean + offset, atol=1e-5)
        obs, _, _, _, info = env.step(np.array([0.5, 0.1], np.float32))
        assert "randomization" not in info
    offsets = []
    for seed in range(400):
        _, info = env.reset(seed=seed)
        offsets.append(info["randomization"]["GoalNoise[goal]"]["offset_m"])
    o = np.asarray(offsets)
    assert np.all(np.abs(o.std(axis=0) - 0.2) < 4 * 0.2 / math.sqrt(2 * 400))


def test_goal_noise_per_step_changes_every_step() -> None:
    env = GoalNoise(NavDouble(), std_m=0.2, key="goal", resample="step")
    _, info = env.reset(seed=0)
    seen = [tuple(info["randomization"]["GoalNoise[goal]"]["offset_m"])]
    for _ in range(5):
        info = env.step(np.zeros(2, np.float32))[4]
        seen.append(tuple(info["randomization"]["GoalNoise[goal]"]["offset_m"]))
    assert len(set(seen)) == 6


def test_goal_noise_polar_goal_moves_the_point_then_converts_back() -> None:
    env = GoalNoise(NavDouble(polar_goal=True), std_m=0.3, key="goal", coords="polar")
    obs, info = env.reset(seed=9)
    start = env.unwrapped.pose
    d, b = obs["goal"]
    offset = np.array(info["randomization"]["GoalNoise[goal]"]["offset_m"])
    truth = GOAL_XY - start[:2]  # yaw is 0 at reset
    np.testing.assert_allclose([d * math.cos(b), d * math.sin(b)], truth + offset, atol=1e-5)


def test_goal_noise_polar_bearing_wraps() -> None:
    class Behind(gym.Env[np.ndarray, int]):
        observation_space = gym.spaces.Box(
            np.array([0.0, -math.pi], np.float32), np.array([50.0, math.pi], np.float32)
        )
        action_space = gym.spaces.Discrete(1)

        def reset(self, *, seed=None, options=None):  # type: ignore[no-untyped-def]
            super().reset(seed=seed)
            return np.array([2.0, math.pi - 1e-3], np.float32), {}

        def step(self, action):  # type: ignore[no-untyped-def]
            return np.array([2.0, math.pi - 1e-3], np.float32), 0.0, False, False, {}

    env = GoalNoise(Behind(), std_m=0.5, coords="polar")
    bearings = [env.reset(seed=s)[0][1] for s in range(200)]
    assert min(bearings) < -2.5 and max(bearings) > 2.5  # both sides of the +-pi cut
    assert all(-math.pi <= b <= math.pi for b in bearings)
