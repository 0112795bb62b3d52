"""Issue 15's target, run as a user types it: the shipped RandomMap config with a 2,000-step budget.

``sim2real train examples/randommap_ppo.yaml --timesteps 2000`` in a fresh process (imports,
the two subprocess envs, training, the final 10-episode evaluation) must finish in under
2 minutes on this 2-core machine (measured 19 s at load ~2), draw a progress bar on a terminal,
and its ``model.zip`` must evaluate with ``envs eval --policy``. The process tree's CPU time is
held to the same budget always; the wall clock where the load average does not exceed the
cores (at load 4.6 it took 90 s: a failure there would measure the machine, not the code).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
import yaml

from sim2real.cli import main
from tests.sim2real.training.budget import within_budget
from tests.terminal import LIVE, on_a_terminal

pytestmark = [pytest.mark.train, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[3]
BUDGET_S = 120.0  # issue 15: "finishes in < 2 min here"


def test_randommap_example_2000_steps_under_2_minutes_and_evaluates(tmp_path: Path) -> None:
    out = tmp_path / "smoke"
    argv = [
        sys.executable,
        "-m",
        "sim2real",
        "train",
        str(ROOT / "examples" / "randommap_ppo.yaml"),
    ]
    # CPU seconds of the command and its reaped children always (what the run costs whatever
    # else the machine does); the wall clock, the issue's own measure, where the machine is not
    # busier than its cores (a failure there would measure the machine, not the code)
    with within_budget(BUDGET_S):
        code, shown = on_a_terminal([*argv, "--timesteps", "2000", "--out", str(out)], tmp_path)
    assert code == 0, shown[-2000:]
    assert LIVE in shown and "training" in shown  # the bar of env steps
    assert "trained 2048 steps" in shown  # 2 envs x n_steps 256 per update: 4 updates
    for name in ("config.yaml", "model.zip", "evaluation.yaml", "episodes.csv"):
        assert (out / name).is_file(), name
    assert any((out / "tensorboard").rglob("events.out.tfevents.*"))
    assert yaml.safe_load((out / "config.yaml").read_text())["timesteps"] == 2000
    assert yaml.safe_load((out / "evaluation.yaml").read_text())["episodes"] == 10

    # the command's own entry point in this process: a second fresh interpreter would import
    # torch and SB3 again for two episodes (the training run above is the fresh-process part)
    report = tmp_path / "eval.json"
    evaluate = ["envs", "eval", "RandomMap-v0", "--policy", str(out / "model.zip")]
    evaluate += ["--preset", "TEST1", "--episodes", "2", "--json", str(report)]
    assert main(evaluate) == 0
    doc = json.loads(report.read_text())
    assert doc["controller"] == "PPO policy model.zip" and len(doc["episodes"]) == 2
