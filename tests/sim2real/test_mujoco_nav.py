"""sim2real/MujocoNav-v0: the exported robot in a Gymnasium env; DynamicsRandomizer draws each
episode's robot from a sysid result into its MjModel, the robots of agree --ensemble."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim2real.envs  # noqa: F401 - registers the envs
from randomizers import DynamicsRandomizer
from robots.randomization import DriveDistribution
from robots.spec import lumped_base_mass_kg
from sim2real.agreement.figures import DYNAMICS_STREAM, _stream
from tests.sim2real.agreement._agreement_fixtures import write_params

pytestmark = pytest.mark.mujoco


def test_env_passes_the_checker_and_reaches_a_goal() -> None:
    env = gym.make("sim2real/MujocoNav-v0", robot="turtlebot3_burger", goal_distance_m=(0.5, 0.5))
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=3)
    assert obs.shape == (5,) and np.linalg.norm(info["goal_m"]) == pytest.approx(0.5)
    done, steps, total = False, 0, 0.0
    while not done and steps < 200:  # steer at the goal: turn by the bearing, drive when facing
        sin_b, cos_b = float(obs[1]), float(obs[2])
        action = np.array([max(cos_b, 0.0), np.clip(2.0 * np.arctan2(sin_b, cos_b), -1, 1)])
        obs, reward, done, truncated, info = env.step(action.astype(np.float32))
        total += reward
        steps += 1
        done = done or truncated
    assert info["distance_m"] <= 0.2 and steps < 200
    assert total == pytest.approx(0.5 - info["distance_m"] + 1.0 - 0.01 * steps, abs=1e-6)


def test_dynamics_randomizer_draws_the_ensemble_robots(tmp_path: Path) -> None:
    values = {"added_mass_kg": 0.3, "motor_gain_nms_per_rad": 0.015}
    params = write_params(tmp_path / "p.yaml", values, robot="turtlebot3_burger")
    base = gym.make("sim2real/MujocoNav-v0", robot="turtlebot3_burger")
    env = DynamicsRandomizer.from_sysid(params, env=base)
    dist = DriveDistribution.from_params_file(params, robot="turtlebot3_burger")
    expected = dist.sample(_stream(7, DYNAMICS_STREAM), 3, spread=1.0)
    sim = env.unwrapped.sim  # type: ignore[attr-defined]
    model = sim.model
    env.reset(seed=7)
    for k in range(3):
        if k:
            env.reset()
        assert sim.params == expected[k]
        assert sim.model is model  # the draw is a field edit
        spec = env.unwrapped.robot_spec  # type: ignore[attr-defined]
        mass = lumped_base_mass_kg(spec) + expected[k].added_mass_kg
        assert model.body("base_link").mass[0] == pytest.approx(mass)


@pytest.mark.train
@pytest.mark.slow
def test_trains_with_sim2real_train_for_a_smoke_budget(tmp_path: Path) -> None:
    import yaml

    from sim2real.cli import main

    pytest.importorskip("stable_baselines3")
    root = Path(__file__).resolve().parents[2]
    config = yaml.safe_load((root / "examples" / "mujoco_nav_ppo_smoke.yaml").read_text())
    params = write_params(tmp_path / "p.yaml", {"added_mass_kg": 0.2}, robot="turtlebot3_burger")
    config["randomizers"]["randomizers"][0]["sysid"] = str(params)
    config["out"] = str(tmp_path / "run")
    path = tmp_path / "smoke.yaml"
    path.write_text(yaml.safe_dump(config), encoding="utf-8")
    assert main(["train", str(path)]) == 0
    evaluation = yaml.safe_load((tmp_path / "run" / "evaluation.yaml").read_text())
    assert (tmp_path / "run" / "model.zip").is_file()
    assert evaluation["episodes"] == 2 and evaluation["env_id"] == "sim2real/MujocoNav-v0"
