"""SARL* (``policy: sarl``): the attention extractor's properties, the race smoke config trained
and evaluated in under 60 s, CrowdNav-v0 with neighbours, and the bad-input sentences."""

from __future__ import annotations

import doctest
import importlib
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.cli import main
from sim2real.training.config import load_config
from sim2real.training.evaluation import check_spaces, load_policy
from sim2real.training.train import train
from tests.sim2real.training.budget import within_budget

pytestmark = pytest.mark.train
torch = pytest.importorskip("torch")

from sim2real.training._sarl import SarlExtractor  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
_SPACE = gym.spaces.Dict(
    {
        "goal": gym.spaces.Box(-10.0, 10.0, (2,), np.float32),
        "neighbours": gym.spaces.Box(-20.0, 20.0, (6 * 4,), np.float32),
    }
)


def _features(net: SarlExtractor, goal: np.ndarray, rows: np.ndarray) -> np.ndarray:
    obs = {
        "goal": torch.as_tensor(goal, dtype=torch.float32)[None],
        "neighbours": torch.as_tensor(rows.reshape(-1), dtype=torch.float32)[None],
    }
    with torch.no_grad():
        return np.asarray(net(obs)[0].numpy())


@settings(max_examples=25, deadline=None)
@given(present=st.integers(0, 6), seed=st.integers(0, 2**16))
def test_attention_ignores_order_and_empty_slots(present: int, seed: int) -> None:
    torch.manual_seed(0)
    net = SarlExtractor(_SPACE, neighbours=6, neighbour_features=4)
    rng = np.random.default_rng(seed)
    goal = rng.uniform(-3, 3, 2)
    rows = np.zeros((6, 4))
    rows[:present] = rng.uniform(0.2, 3.0, (present, 4)) * rng.choice([-1, 1], (present, 4))
    base = _features(net, goal, rows)
    shuffled = _features(net, goal, rows[rng.permutation(6)])
    np.testing.assert_allclose(shuffled, base, atol=1e-5)
    # the same weights on 9 slots (3 more empty ones) give the same features
    wide_space = gym.spaces.Dict(
        {"goal": _SPACE["goal"], "neighbours": gym.spaces.Box(-20.0, 20.0, (9 * 4,), np.float32)}
    )
    wide = SarlExtractor(wide_space, neighbours=9, neighbour_features=4)
    wide.load_state_dict(net.state_dict())
    np.testing.assert_allclose(
        _features(wide, goal, np.vstack([rows, np.zeros((3, 4))])), base, atol=1e-6
    )
    pooled = base[64:]
    assert (np.abs(pooled).max() == 0.0) == (present == 0)  # no neighbour: nothing pooled


def test_attention_weights_follow_the_neighbours() -> None:
    torch.manual_seed(1)
    net = SarlExtractor(_SPACE, neighbours=6, neighbour_features=4)
    goal = np.array([2.0, 0.1])
    near = np.zeros((6, 4))
    near[0] = [0.5, 0.0, -0.3, 0.0]
    far = near.copy()
    far[0] = [2.5, 1.0, 0.0, 0.2]
    assert np.abs(_features(net, goal, near) - _features(net, goal, far))[64:].max() > 1e-3


def _smoke_doc(tmp_path: Path, name: str) -> Path:
    doc = yaml.safe_load((ROOT / "examples" / name).read_text(encoding="utf-8"))
    doc["out"] = str(tmp_path / "run")
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


def test_race_smoke_trains_and_evaluates_under_60_s(tmp_path: Path) -> None:
    with within_budget(60.0):
        result = train(load_config(_smoke_doc(tmp_path, "race_sarl_smoke.yaml")))
    assert result.timesteps >= 1000 and result.evaluation["episodes"] == 4
    rates = [result.evaluation[k] for k in ("success_rate", "collision_rate", "timeout_rate")]
    assert all(0.0 <= r <= 1.0 for r in rates)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        policy = load_policy(result.model_path)
    assert not [w for w in caught if "is ignored" in str(w.message)]
    assert isinstance(policy.model.policy.q_net.features_extractor, SarlExtractor)
    buffer = policy.model.replay_buffer  # the config's 3-step returns, as trained
    assert type(buffer).__name__ == "NStepReplayBuffer" and buffer.n_steps == 3
    env = policy.wrap(gym.make("sim2real/Race-v0", track="open", num_opponents=3))
    check_spaces(policy, env, "Race-v0")
    obs, _ = env.reset(seed=3)
    assert env.action_space.contains(policy.controller().act(obs))


def test_crowdnav_with_neighbours_trains(tmp_path: Path) -> None:
    result = train(load_config(_smoke_doc(tmp_path, "crowdnav_sarl_smoke.yaml")))
    assert result.evaluation["episodes"] == 2
    model = load_policy(result.model_path).model
    assert isinstance(model.policy.q_net.features_extractor, SarlExtractor)


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"env": {"id": "RandomMap-v0", "kwargs": {"preset": "TEST1"}}}, "observes none"),
        ({"env": {"id": "CrowdNav-v0"}}, "observes none"),
        ({"policy": "sarl-star"}, "not a known policy preset"),
        ({"env": {"id": "RandomMap-v0", "kwargs": {"preset": "TEST9"}}}, "unknown map preset"),
        (
            {"policy": "sarl-lookahead", "env": {"id": "RandomMap-v0", "kwargs": {}}},
            "predicts the next Race-v0 observation",
        ),
        (
            {"policy": "sarl-lookahead", "env": {"id": "CrowdNav-v0", "kwargs": {"neighbours": 5}}},
            "use sim2real/Race-v0",
        ),
        ({"policy": "sarl-lookahead", "algorithm": "PPO"}, "use algorithm DQN"),
        (
            {
                "policy": "sarl-lookahead",
                "hyperparameters": {"policy_kwargs": {"lookahead": {"motion": "drive"}}},
            },
            "which the look-ahead does not take",
        ),
        (
            {
                "policy": "sarl-lookahead",
                "hyperparameters": {"policy_kwargs": {"lookahead": {"motion_model": "exact"}}},
            },
            "is 'exact', which is not one of command, drive",
        ),
    ],
)
def test_bad_sarl_configs_one_sentence_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: dict[str, object], words: str
) -> None:
    doc = yaml.safe_load((ROOT / "examples" / "race_sarl_smoke.yaml").read_text("utf-8"))
    doc.update(change, out=str(tmp_path / "run"))
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    assert main(["train", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "run" / "model.zip").exists()


@pytest.mark.parametrize("module", ["_sarl", "_lookahead"])
def test_docstring_example(module: str) -> None:
    result = doctest.testmod(importlib.import_module(f"sim2real.training.{module}"))
    assert result.attempted > 0 and result.failed == 0


def test_race_smoke_uses_the_full_configs_action_grid() -> None:
    full, smoke = (
        yaml.safe_load((ROOT / "examples" / name).read_text("utf-8"))
        for name in ("race_sarl.yaml", "race_sarl_smoke.yaml")
    )
    assert smoke["discrete_actions"] == full["discrete_actions"]
    assert smoke["hyperparameters"]["n_steps"] == full["hyperparameters"]["n_steps"]
    assert 0.2 in full["discrete_actions"]["w_radps"]  # gentle turns at top speed
