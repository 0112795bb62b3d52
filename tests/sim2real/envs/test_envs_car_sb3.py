"""The CarCrossing-v0 DQN/PPO script (benchmarks/carcrossing_sb3.py) runs with Table I settings."""

from __future__ import annotations

import importlib.util
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("torch")

pytestmark = pytest.mark.train


@pytest.fixture(autouse=True)
def one_torch_thread() -> Iterator[None]:
    """The script sets OMP_NUM_THREADS=1 before torch loads (small networks: one thread is
    fastest); here torch is loaded before the script, so its thread count is set as the
    script's run has it, and restored."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


def _script():  # type: ignore[no-untyped-def]
    path = Path(__file__).resolve().parents[3] / "benchmarks" / "carcrossing_sb3.py"
    spec = importlib.util.spec_from_file_location("carcrossing_sb3", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_table_one_hyperparameters() -> None:
    mod = _script()
    dqn = mod.table_one("DQN", eps_fraction=0.5)
    ppo = mod.table_one("PPO", eps_fraction=0.5)
    for kw in (dqn, ppo):
        assert (kw["gamma"], kw["batch_size"], kw["learning_rate"]) == (0.99, 256, 5e-5)
        assert kw["policy_kwargs"]["optimizer_kwargs"] == {"weight_decay": 1e-4}
    assert dqn["target_update_interval"] == 100 and dqn["exploration_final_eps"] == 0.01
    assert ppo["clip_range"] == 0.2 and ppo["n_epochs"] == 7


@pytest.mark.parametrize("algorithm", ["DQN", "PPO"])
def test_trains_and_evaluates(algorithm: str) -> None:
    mod = _script()
    r = mod.train_and_evaluate(algorithm, timesteps=600, episodes=2)
    assert 0.0 <= r["success_rate"] <= 1.0
    assert r["success_rate"] + r["collision_rate"] + r["off_road_rate"] + r["timeout_rate"] == 1.0
