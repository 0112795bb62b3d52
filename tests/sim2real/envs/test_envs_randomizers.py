"""Every randomizer applies to the envs (camera and drive protocols, Dict and Box keys)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import randomizers as dr
import sim2real.envs  # noqa: F401  (registers the ids)


def test_crowdnav_takes_the_full_randomizer_stack() -> None:
    base = gym.make("sim2real/CrowdNav-v0")
    nominal_cam = base.unwrapped.get_camera_pose()[0].copy()
    cfg = {
        "format": "sim2real.randomizers/1",
        "randomizers": [
            {"type": "DynamicsRandomizer", "uniform": {"delay_s": [0.25, 0.3]}},
            {"type": "CameraPoseJitter", "position_std_m": 0.05},
            {"type": "DepthNoise", "key": "depth", "std_m": 0.2, "near_m": 0.05, "far_m": 8.0},
            {"type": "GoalNoise", "key": "goal", "coords": "polar", "std_m": 0.1},
            {"type": "OdometryDelay", "key": "velocity", "delay_s": [0.1, 0.2]},
            {"type": "LidarNoise", "key": "lidar", "std_m": 0.01},
        ],
    }
    env = dr.from_config(base, cfg)
    obs, info = env.reset(seed=0)
    assert len(info["randomization"]) == 6
    assert 0.25 <= env.unwrapped.get_drive_params().delay_s <= 0.3
    assert not np.allclose(env.unwrapped.get_camera_pose()[0], nominal_cam)
    for _ in range(3):
        obs, *_ = env.step(env.action_space.sample())
    assert obs["depth"].shape == (48, 64)
    env.close()


def test_randommap_takes_the_example_stack() -> None:
    from pathlib import Path

    yaml_path = Path(__file__).resolve().parents[3] / "examples" / "randommap_randomizers.yaml"
    env = dr.from_config(gym.make("sim2real/RandomMap-v0"), yaml_path)
    obs, info = env.reset(seed=1)
    assert obs.shape == (40,)
    assert {"DynamicsRandomizer", "LidarNoise[0:36]"} <= set(info["randomization"])
    obs, *_ = env.step(np.array([0.1, 0.0], dtype=np.float32))
    assert env.observation_space.contains(obs)
    env.close()
