"""benchmarks/bench_transfer.py --smoke: the whole transfer loop end to end, twice the same table."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

ROOT = Path(__file__).resolve().parents[3]


def _smoke(out: Path) -> str:
    cmd = [sys.executable, str(ROOT / "benchmarks" / "bench_transfer.py"), "--smoke"]
    run = subprocess.run(
        [*cmd, "--out", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=900
    )
    assert run.returncode == 0, run.stderr[-3000:]
    assert "wall time" in run.stdout
    return (out / "results.md").read_text(encoding="utf-8")


@pytest.mark.slow
def test_smoke_runs_the_loop_and_repeats_its_table(tmp_path: Path) -> None:
    first = _smoke(tmp_path / "a")
    for name in ("spec", "fitted", "calibrated DR", "blind DR"):
        for world in ("sim", "plant"):
            assert f"| {name} | {world} |" in first
    assert (tmp_path / "a" / "excite.mcap").is_file()
    assert (tmp_path / "a" / "calibrated.yaml").is_file()
    assert _smoke(tmp_path / "b") == first
