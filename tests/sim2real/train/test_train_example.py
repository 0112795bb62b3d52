"""Issue 15's target, run as a user types it: the shipped RandomMap config with a 2,000-step budget.

``sim2real train examples/randommap_ppo.yaml --timesteps 2000`` in a fresh process (imports,
the two subprocess envs, training, the final 10-episode evaluation) must finish in under
2 minutes on this 2-core machine (measured 19 s at load ~2), draw a progress bar on a terminal,
and its ``model.zip`` must evaluate with ``envs eval --policy``.
"""

from __future__ import annotations

import json
import os
import pty
import select
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

pytestmark = [pytest.mark.train, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[3]
_LIVE = "\x1b[?25l"  # a live rich progress display hides the cursor while it draws
BUDGET_S = 120.0  # issue 15: "finishes in < 2 min here"


def _on_a_terminal(argv: list[str], cwd: Path) -> tuple[int, str]:
    """Run ``argv`` with stdout and stderr on a pseudo-terminal; returns (exit code, output)."""
    env = {k: v for k, v in os.environ.items() if k not in ("NO_COLOR", "CI", "FORCE_COLOR")}
    env.update(TERM="xterm-256color", COLUMNS="120", LINES="40")
    master, slave = pty.openpty()
    proc = subprocess.Popen(
        argv, stdout=slave, stderr=slave, stdin=subprocess.DEVNULL, cwd=cwd, env=env
    )
    os.close(slave)
    chunks = []
    while True:
        ready, _, _ = select.select([master], [], [], 1.0)
        if ready:
            try:
                data = os.read(master, 65536)
            except OSError:  # the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
        elif proc.poll() is not None:
            break
    os.close(master)
    return proc.wait(timeout=600), b"".join(chunks).decode("utf-8", "replace")


def test_randommap_example_2000_steps_under_2_minutes_and_evaluates(tmp_path: Path) -> None:
    out = tmp_path / "smoke"
    argv = [
        sys.executable,
        "-m",
        "sim2real",
        "train",
        str(ROOT / "examples" / "randommap_ppo.yaml"),
    ]
    start = time.perf_counter()
    code, shown = _on_a_terminal([*argv, "--timesteps", "2000", "--out", str(out)], tmp_path)
    wall_s = time.perf_counter() - start
    assert code == 0, shown[-2000:]
    assert wall_s < BUDGET_S, f"{wall_s:.1f} s"
    assert _LIVE in shown and "training" in shown  # the bar of env steps
    assert "trained 2048 steps" in shown  # 2 envs x n_steps 256 per update: 4 updates
    for name in ("config.yaml", "model.zip", "evaluation.yaml", "episodes.csv"):
        assert (out / name).is_file(), name
    assert any((out / "tensorboard").rglob("events.out.tfevents.*"))
    assert yaml.safe_load((out / "config.yaml").read_text())["timesteps"] == 2000
    assert yaml.safe_load((out / "evaluation.yaml").read_text())["episodes"] == 10

    report = tmp_path / "eval.json"
    evaluate = [sys.executable, "-m", "sim2real", "envs", "eval", "RandomMap-v0"]
    evaluate += ["--policy", str(out / "model.zip"), "--preset", "TEST1", "--episodes", "2"]
    proc = subprocess.run(
        [*evaluate, "--json", str(report)], capture_output=True, text=True, check=False
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    doc = json.loads(report.read_text())
    assert doc["controller"] == "PPO policy model.zip" and len(doc["episodes"]) == 2
