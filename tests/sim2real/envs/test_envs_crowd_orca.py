"""CrowdNav-v0 with ORCA pedestrians: they avoid each other and a standing robot."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs.orca import OrcaCrowd
from sim2real.errors import Sim2RealValueError


def test_orca_pedestrians_avoid_each_other_and_the_standing_robot() -> None:
    env = gym.make("sim2real/CrowdNav-v0", pedestrians="orca", scenario="dynamic", complexity=1.0)
    _, info = env.reset(seed=3)
    crowd = env.unwrapped.crowd
    assert isinstance(crowd, OrcaCrowd) and info["pedestrians"] == "orca"
    start = crowd.position_m.copy()
    r = crowd.radius_m
    for _ in range(150):
        _, _, term, trunc, info = env.step(np.zeros(2, dtype=np.float32))
        assert not term and not trunc  # no pedestrian walks into the robot
        d = np.linalg.norm(crowd.position_m[:, None] - crowd.position_m[None], axis=2)
        np.fill_diagonal(d, np.inf)
        assert np.min(d - (r[:, None] + r[None, :])) > -0.02  # within rounding of ORCA's LP
    walked = np.linalg.norm(crowd.position_m - start, axis=1)
    assert np.sum(walked > 1.0) >= 0.5 * np.sum(crowd.pref_speed_mps > 0)
    env.close()


def test_orca_option_per_episode_and_determinism() -> None:
    env = gym.make("sim2real/CrowdNav-v0")
    runs = []
    for _ in range(2):
        env.reset(seed=5, options={"pedestrians": "orca"})
        for _ in range(20):
            env.step(np.array([0.3, 0.1], dtype=np.float32))
        runs.append(env.unwrapped.crowd.position_m.copy())
    assert np.array_equal(runs[0], runs[1])
    _, info = env.reset(seed=5)
    assert info["pedestrians"] == "eq1"
    with pytest.raises(Sim2RealValueError, match="pedestrians must be one of eq1, orca"):
        env.reset(seed=5, options={"pedestrians": "sfm"})
    env.close()
