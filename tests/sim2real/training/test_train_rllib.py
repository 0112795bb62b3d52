"""`algorithm: rllib-ppo`: RLlib's PPO on the env `sim2real train` builds (needs ray[rllib]).

ray[rllib] 2.60 pins gymnasium 1.2.2, so these run in the separate venv of `make rllib-extra`
(`make test-train` runs them there); elsewhere only the one-sentence refusal is checked.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest
import yaml

from sim2real.cli import main
from sim2real.errors import Sim2RealValueError
from sim2real.training.config import config_from_dict

ROOT = Path(__file__).resolve().parents[3]


def _have_rllib() -> bool:
    if importlib.util.find_spec("ray") is None:
        return False
    try:  # the ray wheel ships rllib's code; its own dependencies come with ray[rllib]
        import ray.rllib  # noqa: F401
    except ImportError:
        return False
    return True


HAVE_RLLIB = _have_rllib()


def _config(tmp_path: Path, **change: object) -> Path:
    doc = {
        "format": "sim2real.train/1",
        "env": {"id": "RandomMap-v0", "kwargs": {"preset": "TEST1", "max_episode_steps": 40}},
        "randomizers": str(ROOT / "examples" / "randommap_randomizers.yaml"),
        "algorithm": "rllib-ppo",
        "normalize": {"observations": True, "actions": True},
        "hyperparameters": {
            "train_batch_size_per_learner": 200,
            "minibatch_size": 100,
            "num_epochs": 1,
            "fcnet_hiddens": [16, 16],
        },
        "rllib": {"num_env_runners": 1},
        "timesteps": 400,
        "seed": 0,
        "out": str(tmp_path / "run"),
        "checkpoint_every": 200,
        "evaluation": {"episodes": 2, "seed": 100},
        **change,
    }
    path = tmp_path / "train.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


def test_rllib_config_keys_are_checked() -> None:
    cfg = config_from_dict({"env": {"id": "RandomMap-v0"}, "algorithm": "RLlib-PPO"})
    assert cfg.algorithm == "rllib-ppo"
    assert cfg.rllib == {"address": "auto", "num_env_runners": 1, "num_envs_per_env_runner": 1}
    with pytest.raises(Sim2RealValueError, match=r"key 'rllib.num_env_runners' must be an integer"):
        config_from_dict({"env": {"id": "RandomMap-v0"}, "rllib": {"num_env_runners": -1}})
    with pytest.raises(Sim2RealValueError, match=r"key 'rllib' must be a mapping of address"):
        config_from_dict({"env": {"id": "RandomMap-v0"}, "rllib": {"workers": 2}})


@pytest.mark.skipif(HAVE_RLLIB, reason="checks the refusal without ray[rllib]")
def test_without_rllib_one_sentence_names_the_pin(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["train", str(_config(tmp_path))]) == 2
    err = capsys.readouterr().err
    assert "needs Ray RLlib" in err and "gymnasium==1.2.2" in err and err.count("\n") == 1


@pytest.mark.train
@pytest.mark.cluster
@pytest.mark.slow
@pytest.mark.skipif(not HAVE_RLLIB, reason="needs ray[rllib] (make rllib-extra)")
def test_rllib_ppo_trains_checkpoints_and_evaluates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import ray

    ray.init(num_cpus=2, include_dashboard=False, logging_level="ERROR")
    try:
        assert main(["train", str(_config(tmp_path))]) == 0
    finally:
        ray.shutdown()
    out = tmp_path / "run"
    assert "trained 400 steps" in capsys.readouterr().out
    resolved = yaml.safe_load((out / "config.yaml").read_text())
    assert resolved["algorithm"] == "rllib-ppo" and resolved["rllib"]["num_env_runners"] == 1
    assert resolved["randomizers"]["randomizers"][0]["name"] == "DynamicsRandomizer"
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == ["step_200", "step_400"]
    progress = (out / "progress.csv").read_text().splitlines()
    assert progress[0] == "iteration,env_steps,episode_return_mean"
    assert [int(line.split(",")[1]) for line in progress[1:]] == [200, 400]
    meta = yaml.safe_load((out / "model" / "sim2real.yaml").read_text())
    assert meta["algorithm"] == "rllib-ppo" and meta["normalize"]["actions"] is True
    ev = yaml.safe_load((out / "evaluation.yaml").read_text())
    assert ev["episodes"] == 2
    assert ev["success_rate"] + ev["collision_rate"] + ev["timeout_rate"] == pytest.approx(1.0)
    # the saved policy evaluates through envs eval like an SB3 model.zip, deterministically
    reports = []
    for name in ("a", "b"):
        report = tmp_path / f"{name}.json"
        argv = ["envs", "eval", "RandomMap-v0", "--policy", str(out / "model"), "--episodes", "2"]
        assert main([*argv, "--json", str(report)]) == 0
        reports.append(json.loads(report.read_text()))
    assert reports[0]["episodes"] == reports[1]["episodes"]
    assert reports[0]["controller"] == "rllib-ppo policy model"
