"""Smoke test of examples/train_sb3.py: a short PPO run with the randomizer stack.

Skipped when the ``[train]`` extra (stable-baselines3, torch) is not installed.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("torch")

ROOT = Path(__file__).resolve().parents[3]


@pytest.mark.slow
def test_train_sb3_smoke(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location("train_sb3", ROOT / "examples" / "train_sb3.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["train_sb3"] = module
    spec.loader.exec_module(module)
    rc = module.main(
        [
            "--algo",
            "ppo",
            "--steps",
            "2048",
            "--eval-every",
            "1024",
            "--eval-episodes",
            "1",
            "--eval-preset",
            "TEST1",
            "--max-episode-steps",
            "100",
            "--randomizers",
            str(ROOT / "examples" / "randommap_randomizers.yaml"),
            "--out",
            str(tmp_path),
            "--no-progress",
        ]
    )
    assert rc == 0
    assert (tmp_path / "ppo_final.zip").stat().st_size > 10_000
    assert (tmp_path / "evaluations.npz").is_file()
