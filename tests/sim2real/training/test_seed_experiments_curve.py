"""benchmarks/seed_experiments.py curve: each env's outcome words land in the right column."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def test_curve_counts_random_map_crashes_and_traps(tmp_path: Path) -> None:
    csv = tmp_path / "episodes.csv"
    rows = ["step,outcome,return,length"]
    # RandomMap-v0 (Yang et al.'s words): crash = collision, trap = timeout
    rows += [
        f"{100 * (i + 1)},{o},-1.0,100" for i, o in enumerate(["crash", "trap", "trap", "success"])
    ]
    # CrowdNav-v0 / Race-v0 words in the second block
    rows += [
        f"{1100 + 100 * i},{o},2.0,100" for i, o in enumerate(["collision", "timeout", "overshoot"])
    ]
    csv.write_text("\n".join(rows) + "\n", encoding="utf-8")
    script = ROOT / "benchmarks" / "seed_experiments.py"
    run = subprocess.run(
        [sys.executable, str(script), "curve", str(csv), "--block", "1000"],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    lines = [line for line in run.stdout.splitlines() if line.startswith(f"| {csv} |")]
    assert lines[0].endswith("| 0-1000 | 4 | 0.25 | 0.25 | 0.50 | 0.00 | -1.00 |")
    assert lines[1].endswith("| 1000-2000 | 3 | 0.00 | 0.33 | 0.33 | 0.33 | 2.00 |")
