"""The DWA baseline reaches goals, avoids obstacles, and evaluate() aggregates honestly."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs.baselines import DWAController, evaluate
from sim2real.envs.maps import MapConfig


def test_dwa_action_is_in_the_action_space() -> None:
    env = gym.make("sim2real/CrowdNav-v0")
    ctrl = DWAController.for_env(env)
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        a = ctrl.act(obs)
        assert env.action_space.contains(a)
        obs, *_ = env.step(a)
    env.close()


def test_dwa_stops_before_a_wall_dead_ahead() -> None:
    ctrl = DWAController(
        beam_angles_rad=np.linspace(-math.pi, math.pi, 72, endpoint=False),
        lidar_xy_m=(0.0, 0.0),
        range_max_m=3.5,
        robot_radius_m=0.12,
        action_low=np.array([0.0, -1.0]),
        action_high=np.array([0.21, 1.0]),
        control_dt=0.1,
    )
    angles = ctrl.beam_angles_rad
    ranges = np.where(np.abs(np.cos(angles)) > 1e-9, 0.2 / np.maximum(np.cos(angles), 1e-9), 3.5)
    ranges = np.where(np.cos(angles) > 0, np.minimum(ranges, 3.5), 3.5)
    obs = np.concatenate([ranges, [5.0, 0.0, 0.2, 0.0]])  # goal behind the wall
    v, w = ctrl.act(obs)
    assert v == 0.0 and abs(w) == pytest.approx(1.0)  # no admissible arc: turn in place


@pytest.mark.slow
def test_evaluate_on_two_test1_episodes() -> None:
    env = gym.make("sim2real/RandomMap-v0", preset="TEST1")
    seen = []
    summary = evaluate(
        env, DWAController.for_env(env), episodes=2, seed=0, on_episode=lambda i, r: seen.append(i)
    )
    assert seen == [0, 1] and summary.episodes == 2
    rates = summary.success_rate + summary.collision_rate + summary.timeout_rate
    assert rates == pytest.approx(1.0)
    assert summary.success_rate == 1.0  # measured: DWA solves TEST1 maps 0 and 1
    m = summary.means
    assert 8.0 - 0.3 <= m["path_length_m"] < 10.0
    assert m["time_to_goal_s"] == pytest.approx(
        np.mean([r["time_to_goal_s"] for r in summary.per_episode])
    )
    assert [r["seed"] for r in summary.per_episode] == [0, 1]
    env.close()


def test_dwa_reaches_a_near_goal_on_an_empty_map() -> None:
    env = gym.make(
        "sim2real/RandomMap-v0", map_config=MapConfig(n_min=0, n_max=0, r_wall=0.0, d_target_m=2.0)
    )
    summary = evaluate(env, DWAController.for_env(env), episodes=1, seed=5)
    assert summary.success_rate == 1.0
    assert summary.means["time_to_goal_s"] < 2.0 / 0.2 + 6.0  # straight line plus turning
    env.close()
