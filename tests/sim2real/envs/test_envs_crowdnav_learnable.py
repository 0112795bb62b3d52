"""What a learner sees and is paid in CrowdNav-v0's empty room, through the training stack."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.training.environment import build_env

EMPTY_ROOM = {
    "scenario": "static",
    "complexity": 0.0,
    "depth_width": 8,
    "depth_height": 6,
    "max_episode_steps": 400,
}


@pytest.fixture
def env() -> Any:
    """The empty room with observations and actions scaled to [-1, 1], as the configs train."""
    return build_env(
        "sim2real/CrowdNav-v0", EMPTY_ROOM, normalize={"observations": True, "actions": True}
    )


def _goal(obs: dict[str, np.ndarray]) -> tuple[float, float]:
    """Goal distance (m) and bearing (rad) back from the [-1, 1] scaling (bounds 0-20, +-pi)."""
    d, b = (float(x) for x in obs["goal"])
    return 10.0 * (d + 1.0), math.pi * b


@pytest.mark.parametrize("seed", range(6))
def test_a_proportional_controller_on_the_observation_alone_reaches_the_goal(
    env: Any, seed: int
) -> None:
    obs, _ = env.reset(seed=seed)
    total, steps = 0.0, 0
    while True:
        _, bearing = _goal(obs)
        v_frac, w_frac = max(0.0, math.cos(bearing)), float(np.clip(2.0 * bearing / math.pi, -1, 1))
        obs, reward, terminated, truncated, info = env.step(
            np.array([2.0 * v_frac - 1.0, w_frac], np.float32)
        )
        total += reward
        steps += 1
        if terminated or truncated:
            break
    assert info["outcome"] == "success"
    assert (terminated, truncated) == (True, False)
    assert steps < 120  # 6-7 m at 0.7 m/s is 9-10 s: 90-100 steps of 0.1 s
    assert total > 20.0  # +10 reach, about +15 progress, minus the small step and smoothness costs


def test_turning_left_moves_the_goal_bearing_right_by_the_angle_turned(env: Any) -> None:
    obs, _ = env.reset(seed=0)
    d0, b0 = _goal(obs)
    yaw0 = env.unwrapped._backend.pose[2]
    for _ in range(10):
        obs, *_ = env.step(np.array([-1.0, 0.5], np.float32))  # v = 0, w = +pi/2 rad/s
    d1, b1 = _goal(obs)
    turned = env.unwrapped._backend.pose[2] - yaw0
    assert turned > 0.3  # left, after the base's latency and acceleration limit
    assert d1 == pytest.approx(d0, abs=1e-3)
    assert b1 - b0 == pytest.approx(-turned, abs=1e-3)


def test_driving_at_the_goal_pays_and_standing_still_costs(env: Any) -> None:
    env.reset(seed=5)  # goal nearly straight ahead (bearing -0.02 rad)
    paid = [env.step(np.array([1.0, 0.0], np.float32))[1] for _ in range(30)]
    # k_prog 2.5 /m x (0.066-0.07 m per step at the base's top speed) - the 0.01 step cost
    assert 2.5 * 0.066 - 0.01 < paid[-1] < 2.5 * 0.07 - 0.01
    env.reset(seed=5)
    still = [env.step(np.array([-1.0, 0.0], np.float32))[1] for _ in range(30)]
    assert still[-1] == pytest.approx(-0.01)


def test_a_timeout_is_a_truncation_not_a_termination() -> None:
    env = build_env(
        "sim2real/CrowdNav-v0", {**EMPTY_ROOM, "max_episode_steps": 20}, normalize={"actions": True}
    )
    env.reset(seed=0)
    flags = [env.step(np.array([-1.0, 0.0], np.float32))[2:4] for _ in range(20)]
    assert flags[:-1] == [(False, False)] * 19
    assert flags[-1] == (False, True)
