"""The full randomizer stack on the project's own navigation envs (sim2real.envs, pybullet)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import randomizers
import sim2real.envs  # noqa: F401  (registers the env ids; installed with the package)


def _stack(env: gym.Env[Any, Any]) -> dict[str, Any]:
    space = env.observation_space
    depth = space["depth"]
    entries: list[dict[str, Any]] = [
        {
            "type": "DynamicsRandomizer",
            "uniform": {"coulomb_v_fwd_n": [0.1, 0.5]},
            "normal": {"added_mass_kg": [0.5, 0.2]},
        },
        {"type": "ActionDelay", "delay_s": [0.0, 0.3]},
        {"type": "OdometryDelay", "key": "velocity", "delay_steps": [1, 3]},
        {"type": "LidarNoise", "key": "lidar", "std_m": 0.01, "dropout": 0.05},
        {"type": "GoalNoise", "key": "goal", "coords": "polar"},
    ]
    if hasattr(env.unwrapped, "set_camera_pose"):
        entries.insert(1, {"type": "CameraPoseJitter"})
        entries.append(
            {
                "type": "DepthNoise",
                "key": "depth",
                "near_m": float(depth.low.min()),
                "far_m": float(depth.high.max()),
            }
        )
    return {"randomizers": entries}


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("sim2real/CrowdNav-v0", {"dynamics": "pybullet"}),
        ("sim2real/CrowdNav-v0", {"dynamics": "reduced"}),
    ],
)
def test_full_stack_on_crowdnav(env_id: str, kwargs: dict[str, Any]) -> None:
    def rollout() -> tuple[list[np.ndarray], dict[str, Any]]:
        base = gym.make(env_id, **kwargs)
        env = randomizers.from_config(base, _stack(base))
        obs, info = env.reset(seed=3)
        depth = [obs["depth"]]
        for _ in range(15):
            obs, _, term, trunc, _ = env.step(np.array([0.3, 0.1], np.float32))
            depth.append(obs["depth"])
            if term or trunc:
                break
        params = env.unwrapped.get_drive_params()
        assert (
            params.coulomb_v_fwd_n == info["randomization"]["DynamicsRandomizer"]["coulomb_v_fwd_n"]
        )
        xyz, _ = env.unwrapped.get_camera_pose()
        np.testing.assert_allclose(xyz, info["randomization"]["CameraPoseJitter"]["xyz_m"])
        env.close()
        return depth, info

    a, info_a = rollout()
    b, info_b = rollout()
    assert info_a["randomization"] == info_b["randomization"]
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    assert set(info_a["randomization"]) >= {"CameraPoseJitter", "DepthNoise[depth]"}


def test_index_selected_stack_on_randommap_box_observation() -> None:
    """RandomMap-v0 observes one Box: 36 ranges, goal (distance, bearing), velocity (v, w)."""
    config = {
        "randomizers": [
            {"type": "DynamicsRandomizer", "uniform": {"coulomb_w_nm": [0.0, 0.05]}},
            {"type": "ActionDelay", "delay_steps": 1},
            {"type": "OdometryDelay", "index": [38, 40], "delay_steps": 2},
            {"type": "LidarNoise", "index": [0, 36], "std_m": 0.01, "dropout": 0.1},
            {"type": "GoalNoise", "index": [36, 38], "coords": "polar"},
        ]
    }

    def rollout() -> list[np.ndarray]:
        base = gym.make("sim2real/RandomMap-v0", preset="TEST2", dynamics="pybullet")
        env = randomizers.from_config(base, config)
        obs, info = env.reset(seed=5)
        assert obs.shape == (40,) and obs.dtype == np.float32
        assert env.observation_space.contains(obs)
        assert info["randomization"]["OdometryDelay[38:40]"]["delay_s"] == pytest.approx(0.2)
        seen = [obs]
        for _ in range(10):
            obs, _, term, trunc, _ = env.step(np.array([0.1, 0.2], np.float32))
            seen.append(obs)
            if term or trunc:
                break
        env.close()
        return seen

    a, b = rollout(), rollout()
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    velocity = np.array([o[38:40] for o in a])
    np.testing.assert_array_equal(velocity[1], velocity[0])  # delayed: still the first value


def test_sysid_randomisation_on_crowdnav_from_a_config(tmp_path) -> None:  # type: ignore[no-untyped-def]
    # the training stack a sysid result prescribes: its robots and its odometry noise, built
    # from the params file through a randomizer config (what `envs eval --randomize` reads)
    from robots.randomization import DriveDistribution
    from tests.randomization_block import write_params_file

    base = gym.make("sim2real/CrowdNav-v0", dynamics="reduced")
    robot = base.unwrapped.robot_spec
    path = write_params_file(tmp_path / "p.yaml", robot.drive, robot.name, noise_v=0.02)
    dist = DriveDistribution.from_params_file(path, robot=robot.name)
    config = {
        "randomizers": [
            {"type": "DynamicsRandomizer", "sysid": str(path)},
            {"type": "VelocityObservationNoise", "key": "velocity", "std_v_mps": 0.02,
             "std_w_radps": 0.02},
        ]
    }  # fmt: skip
    env = randomizers.from_config(base, config)
    env.reset(seed=5)
    assert (
        env.unwrapped.get_drive_params()
        == dist.sample(randomizers.stream_generator(5, "DynamicsRandomizer"), 1)[0]
    )
    vel = []
    for _ in range(30):
        obs, *_ = env.step(np.array([0.0, 0.0], np.float32))
        vel.append(obs["velocity"])
    assert 0.01 < float(np.std(np.array(vel)[:, 0])) < 0.03  # standing still: noise only
    saved = randomizers.to_config(env)["randomizers"]
    assert saved[0]["sysid"] == str(path) and saved[0]["robot"] == robot.name
    other = "turtlebot2" if robot.name != "turtlebot2" else "turtlebot3_burger"
    from robots.spec import load_spec

    wrong = write_params_file(tmp_path / "w.yaml", load_spec(other).drive, other)
    with pytest.raises(randomizers.errors.RandomizerValueError, match=other):
        randomizers.DynamicsRandomizer.from_sysid(wrong, env=gym.make("sim2real/CrowdNav-v0"))
