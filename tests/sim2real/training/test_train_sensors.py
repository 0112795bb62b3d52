"""``policy: sensors``: a small encoder per sensor entry, the goal passed through; trained and
reloaded from a config, and refused on a Box observation in one sentence."""

from __future__ import annotations

import doctest
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

from sim2real.cli import main
from sim2real.training.config import load_config
from sim2real.training.evaluation import load_policy
from sim2real.training.train import train

pytestmark = pytest.mark.train
torch = pytest.importorskip("torch")

import sim2real.training._sensors  # noqa: E402  (needs torch)
from sim2real.training._sensors import SensorEncoderExtractor  # noqa: E402

_DOC = {
    "format": "sim2real.train/1",
    "env": {
        "id": "sim2real/CrowdNav-v0",
        "kwargs": {"scenario": "static", "complexity": 0.0, "depth_width": 8, "depth_height": 6},
    },
    "randomizers": None,
    "algorithm": "PPO",
    "policy": "sensors",
    "hyperparameters": {"n_steps": 128, "batch_size": 64},
    "normalize": {"observations": True, "actions": True},
    "timesteps": 256,
    "n_envs": 1,
    "seed": 0,
    "evaluation": {"episodes": 1, "seed": 10000},
}


def _config(tmp_path: Path, **change: object) -> Path:
    path = tmp_path / "sensors.yaml"
    path.write_text(yaml.safe_dump({**_DOC, **change, "out": str(tmp_path / "run")}), "utf-8")
    return path


def test_small_entries_pass_through_and_each_sensor_gets_its_own_encoder() -> None:
    space = gym.spaces.Dict(
        {
            "depth": gym.spaces.Box(-1, 1, (6, 8), np.float32),
            "goal": gym.spaces.Box(-1, 1, (2,), np.float32),
            "lidar": gym.spaces.Box(-1, 1, (640,), np.float32),
        }
    )
    net = SensorEncoderExtractor(space, width=4)
    assert (net.small, net.large, net.features_dim) == (["goal"], ["depth", "lidar"], 10)
    goal = torch.tensor([[0.3, -0.7]])
    lidar = torch.rand(1, 640)
    with torch.no_grad():
        out = net({"depth": torch.zeros(1, 6, 8), "goal": goal, "lidar": lidar}).numpy()
        moved = net({"depth": torch.zeros(1, 6, 8), "goal": goal, "lidar": lidar + 0.5}).numpy()
    np.testing.assert_array_equal(out[:, :2], goal.numpy())
    np.testing.assert_array_equal(moved[:, :6], out[:, :6])  # goal and depth's own features
    assert not np.allclose(moved[:, 6:], out[:, 6:])
    assert float(np.abs(out[:, 2:]).max()) <= 1.0


def test_a_sensors_config_trains_and_reloads_with_its_encoders(tmp_path: Path) -> None:
    result = train(load_config(_config(tmp_path)))
    assert result.timesteps == 256 and result.evaluation["episodes"] == 1
    extractor = load_policy(result.model_path).model.policy.features_extractor
    assert isinstance(extractor, SensorEncoderExtractor)
    assert extractor.large == ["depth", "lidar"]


def test_sensors_on_a_box_observation_is_one_sentence_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _config(tmp_path, env={"id": "sim2real/RandomMap-v0", "kwargs": {"preset": "TEST1"}})
    assert main(["train", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "policy 'sensors'" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "run" / "model.zip").exists()


def test_docstring_example() -> None:
    assert doctest.testmod(sim2real.training._sensors).failed == 0
