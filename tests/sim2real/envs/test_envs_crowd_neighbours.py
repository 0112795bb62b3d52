"""CrowdNav-v0's ``neighbours=K`` entry: the K nearest pedestrians in the robot's frame."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs.vector import CrowdNavVectorEnv
from sim2real.errors import Sim2RealValueError


def test_neighbours_are_the_nearest_pedestrians_in_the_robot_frame() -> None:
    env = gym.make("sim2real/CrowdNav-v0", neighbours=4, depth_width=8, depth_height=6)
    obs, _ = env.reset(seed=3, options={"num_pedestrians": 6})
    for _ in range(5):
        obs, *_ = env.step(np.array([0.3, 0.4], dtype=np.float32))
    assert env.observation_space.contains(obs)
    base = env.unwrapped
    x, y, yaw = base._backend.pose
    v, _ = base._backend.velocity
    rel = base.crowd.position_m - np.array([x, y])
    order = np.argsort(np.hypot(rel[:, 0], rel[:, 1]))[:4]
    c, s = math.cos(yaw), math.sin(yaw)
    local = rel[order] @ np.array([[c, -s], [s, c]])  # rotate by -yaw
    rel_v = base.crowd.velocity_mps[order] - np.array([v * c, v * s])
    local_v = rel_v @ np.array([[c, -s], [s, c]])
    rows = obs["neighbours"].reshape(4, 4)
    np.testing.assert_allclose(rows[:, :2], local, atol=1e-5)
    np.testing.assert_allclose(rows[:, 2:], local_v, atol=1e-5)
    assert np.all(np.diff(np.hypot(rows[:, 0], rows[:, 1])) >= 0)  # nearest first


def test_fewer_pedestrians_than_slots_leave_zero_rows_and_default_has_no_entry() -> None:
    env = gym.make("sim2real/CrowdNav-v0", neighbours=5, depth_width=8, depth_height=6)
    obs, _ = env.reset(seed=0, options={"num_pedestrians": 2})
    rows = obs["neighbours"].reshape(5, 4)
    assert np.all(np.abs(rows[:2]).sum(axis=1) > 0) and np.all(rows[2:] == 0)
    plain, _ = gym.make("sim2real/CrowdNav-v0", depth_width=8, depth_height=6).reset(seed=0)
    assert "neighbours" not in plain


@pytest.mark.parametrize("bad", [-1, 2.5, True, "5"])
def test_bad_neighbour_count_is_one_sentence(bad: object) -> None:
    with pytest.raises(Sim2RealValueError, match="neighbours must be an integer >= 0"):
        gym.make("sim2real/CrowdNav-v0", neighbours=bad)


def test_vector_env_refuses_neighbours() -> None:
    with pytest.raises(Sim2RealValueError, match="does not observe neighbours"):
        CrowdNavVectorEnv(2, neighbours=3, depth_width=8, depth_height=6)
