"""Wrapper arguments are bounded by what can run: a clear error before any allocation."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from randomizers_testenv import DEPTH_FAR_M, DEPTH_NEAR_M, NavDouble

from randomizers import ActionDelay, DepthNoise, LidarNoise, ObservationNoise, OdometryDelay
from randomizers.errors import RandomizerValueError


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"delay_s": 1e9}, r"'delay_s' = 1000000000.0 \(1e\+10 steps of 0.1 s\) exceeds 1000000"),
        ({"delay_s": [0.0, 2e5]}, r"'delay_s' = \[0.0, 200000.0\] \(2e\+06 steps"),
        ({"delay_steps": 10**9}, r"'delay_steps' = 1000000000 exceeds 1000000 control steps"),
    ],
)
def test_a_delay_longer_than_any_episode_is_refused(kwargs: dict, needle: str) -> None:
    for wrapper in (OdometryDelay, ActionDelay):
        extra = {"key": "velocity"} if wrapper is OdometryDelay else {}
        with pytest.raises(RandomizerValueError, match=needle):
            wrapper(NavDouble(), **kwargs, **extra)
    OdometryDelay(NavDouble(), delay_steps=10**6, key="velocity")  # the bound itself is fine


@pytest.mark.parametrize(
    ("make", "needle"),
    [
        (lambda e: ObservationNoise(e, std=1e308, key="velocity"), r"'std' = 1e\+308 .* \(4, "),
        (lambda e: ObservationNoise(e, std=[0.1, 5e3], key="velocity"), r"element 1"),
        (
            lambda e: DepthNoise(e, std_m=1e5, key="depth", near_m=DEPTH_NEAR_M, far_m=DEPTH_FAR_M),
            r"DepthNoise: argument 'std_m' = 1e\+05",
        ),
        (lambda e: LidarNoise(e, std_m=1e7, key="lidar"), r"LidarNoise: argument 'std_m' = 1e\+07"),
    ],
)
def test_a_std_orders_beyond_the_observation_range_is_refused(make, needle: str) -> None:
    with pytest.raises(RandomizerValueError, match=needle):
        make(NavDouble())


def test_unbounded_entries_still_refuse_a_std_the_dtype_cannot_hold() -> None:
    env = gym.make("CartPole-v1")  # element 1 is unbounded (float32 max)
    ObservationNoise(env, std=[0.1, 1e6, 0.1, 0.1])  # large but representable: accepted
    with pytest.raises(RandomizerValueError, match=r"element 1\) or too large for float32"):
        ObservationNoise(env, std=[0.1, 1e35, 0.1, 0.1])


@pytest.mark.parametrize("fill", ["first", "zeros"])
def test_odometry_delay_on_a_dict_env_hands_out_distinct_arrays(fill: str) -> None:
    env = OdometryDelay(NavDouble(invalid_pixels=False), delay_steps=3, key="velocity", fill=fill)
    check_env(env, skip_render_check=True)
    env.reset(seed=0)
    seen = [env.step(np.array([0.5, 0.1], np.float32))[0]["velocity"] for _ in range(3)]
    assert len({id(v) for v in seen}) == 3  # the padding is not one shared object
    seen[0][:] = 99.0  # a caller writing into one observation changes no other
    assert np.all(seen[1] != 99.0) and np.all(seen[2] != 99.0)


def test_action_delay_padding_is_not_shared() -> None:
    env = ActionDelay(NavDouble(invalid_pixels=False), delay_steps=2)
    env.reset(seed=0)
    a = np.array([0.3, 0.0], np.float32)
    first, second = env.action(a), env.action(np.zeros(2, np.float32))
    assert first is not second and np.array_equal(first, second)
