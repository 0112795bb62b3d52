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


@pytest.mark.slow
def test_pybullet_pedestrians_are_bodies_the_lidar_hits() -> None:
    import pybullet as p

    env = gym.make("sim2real/CrowdNav-v0", dynamics="pybullet", scenario="dynamic")
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.zeros(2, dtype=np.float32))
    base = env.unwrapped
    world, crowd = base._world, base.crowd
    ids = world.pedestrian_ids
    assert len(ids) == len(crowd) > 0
    for k in range(len(crowd)):
        x, y = crowd.position_m[k]
        z = 0.3
        hit = p.rayTest([x - 2.0, y, z], [x + 2.0, y, z], physicsClientId=world.client)[0]
        # the ray from 2 m west hits this pedestrian (or another body in front of it)
        assert hit[0] >= 0
        if hit[0] == ids[k]:
            assert hit[3][0] == pytest.approx(x - crowd.radius_m[k], abs=0.02)
    hits = sum(
        p.rayTest(
            [*crowd.position_m[k], 3.0], [*crowd.position_m[k], 0.05], physicsClientId=world.client
        )[0][0]
        == ids[k]
        for k in range(len(crowd))
    )
    assert hits == len(crowd)  # straight down onto each pedestrian's top
    env.close()
