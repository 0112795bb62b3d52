"""benchmarks/bench_mujoco_sysid.py --quick: both fitters' rows, with finite numbers."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.mujoco, pytest.mark.realdata, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]


def test_quick_mode_tables_both_fitters_on_the_neato(realdata_dir: Path) -> None:
    pytest.importorskip("mujoco.sysid")
    cmd = [sys.executable, str(ROOT / "benchmarks" / "bench_mujoco_sysid.py"), "--quick"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=900, env=env)
    assert run.returncode == 0, run.stderr[-3000:]
    summary = run.stdout.split("## Summary")[1]
    rows = {}
    for line in summary.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) == 7 and cells[0] == "neato":
            rows[cells[1]] = cells
    assert set(rows) == {"ours", "mujoco.sysid"}
    for cells in rows.values():
        agreement, coverage, wall, cpu = cells[3], cells[4], cells[5], cells[6]
        numbers = [float(agreement), *map(float, coverage.split(" / ")), float(wall), float(cpu)]
        assert all(math.isfinite(x) for x in numbers)
        assert 0.0 <= float(agreement) <= 100.0 and float(cpu) > 0.0
    assert "target held (ours >= theirs at no more fit CPU): " in run.stdout
