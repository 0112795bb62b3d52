"""The seed papers' experiment configs in ``examples/``: each one's protocol keys, and a smoke
variant of each (the same file, a few hundred steps, two evaluation episodes) that trains and
evaluates in under 60 s."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest
import yaml

from sim2real.training.config import config_from_dict
from sim2real.training.train import train

pytestmark = pytest.mark.train
pytest.importorskip("stable_baselines3")

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples"

#: config -> (algorithm, smoke steps, smoke hyper-parameters)
SMOKE: dict[str, tuple[str, int, dict[str, Any]]] = {
    "randommap_td3": ("TD3", 300, {"learning_starts": 100, "batch_size": 32}),
    "randommap_sac": ("SAC", 300, {"learning_starts": 100, "batch_size": 32}),
    "carcrossing_dqn": ("DQN", 400, {"learning_starts": 100}),
    "carcrossing_ppo": ("PPO", 256, {"n_steps": 128, "batch_size": 64, "n_epochs": 1}),
    "carcrossing_ppo_entropy": ("PPO", 256, {"n_steps": 128, "batch_size": 64, "n_epochs": 1}),
    "crowdnav_card": ("PPO", 128, {"n_steps": 64, "batch_size": 32, "n_epochs": 1}),
    "crowdnav_nominal": ("PPO", 128, {"n_steps": 64, "batch_size": 32, "n_epochs": 1}),
    "race_sarl": ("DQN", 400, {"learning_starts": 100, "buffer_size": 2000}),
}


def _doc(name: str) -> dict[str, Any]:
    return dict(yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text(encoding="utf-8")))


def test_random_map_configs_follow_table_iii() -> None:
    for name in ("randommap_td3", "randommap_sac"):
        cfg = config_from_dict(_doc(name), folder=EXAMPLES)
        assert cfg.env_kwargs["preset"] == "TRAIN" and cfg.eval_kwargs["preset"] == "TEST1"
        assert cfg.hyperparameters["learning_rate"] == 3e-4
        assert cfg.hyperparameters["policy_kwargs"]["net_arch"] == [256, 256]
    td3 = config_from_dict(_doc("randommap_td3"), folder=EXAMPLES)
    assert td3.action_noise == {"type": "normal", "sigma": 0.1}  # TD3 explores by it


def test_crowdnav_pair_differs_only_in_the_card_stack() -> None:
    card, nominal = _doc("crowdnav_card"), _doc("crowdnav_nominal")
    assert nominal["randomizers"] is None
    stack = config_from_dict(card, folder=EXAMPLES).randomizers
    assert stack is not None
    types = [entry["type"] for entry in stack["randomizers"]]
    assert types == ["DepthNoise", "GoalNoise", "OdometryDelay", "CameraPoseJitter"]
    assert stack["randomizers"][0]["std_m"] == 0.2  # Liang et al.: N(0, 0.2) on depth
    for key in (
        "env",
        "algorithm",
        "policy",
        "hyperparameters",
        "normalize",
        "curriculum",
        "timesteps",
        "evaluation",
    ):
        assert card[key] == nominal[key], key


@pytest.mark.parametrize("name", sorted(SMOKE))
def test_smoke_variant_trains_and_evaluates_under_60_s(name: str, tmp_path: Path) -> None:
    algorithm, steps, hyper = SMOKE[name]
    doc = _doc(name)
    doc["hyperparameters"] = {**doc.get("hyperparameters", {}), **hyper}
    doc["evaluation"] = {**doc.get("evaluation", {}), "episodes": 2}
    doc["env"]["kwargs"] = {**doc["env"].get("kwargs", {}), "max_episode_steps": 100}
    doc.update(timesteps=steps, checkpoint_every=0, out=str(tmp_path / "run"))
    start = time.perf_counter()
    result = train(config_from_dict(doc, folder=EXAMPLES))
    elapsed_s = time.perf_counter() - start
    assert elapsed_s < 60.0, f"{name}: {elapsed_s:.1f} s"
    assert config_from_dict(_doc(name), folder=EXAMPLES).algorithm == algorithm
    assert result.timesteps >= steps and result.evaluation["episodes"] == 2
    assert (tmp_path / "run" / "model.zip").is_file()
    assert (tmp_path / "run" / "episodes.csv").read_text().startswith("step,outcome")
