"""docs/benchmarks.md is written by benchmarks/results_page.py from recorded figures."""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "benchmarks"


def _row(script: str, figure: str, value: str, met: bool | None) -> str:
    return json.dumps(
        {
            "bench": "b",
            "figure": figure,
            "value": value,
            "target": "t",
            "met": met,
            "script": script,
        }
    )


def _write_page(tmp_path: Path, rows: list[str], *args: str) -> str:
    results = tmp_path / "results.jsonl"
    results.write_text("\n".join(rows) + "\n", encoding="utf-8")
    page = tmp_path / "benchmarks.md"
    env = {**os.environ, "BENCH_QUICK": ""}
    cmd = [sys.executable, "results_page.py", "--results", str(results), "--page", str(page)]
    subprocess.run([*cmd, *args], cwd=BENCH, check=True, capture_output=True, env=env)
    return page.read_text(encoding="utf-8")


def _section(page: str, name: str) -> str:
    return page.split(f"<!-- bench:{name} -->", 1)[1].split(f"<!-- /bench:{name} -->", 1)[0]


def test_a_run_writes_its_sections_and_keeps_the_others(tmp_path: Path) -> None:
    # a hand-run study first, then a make bench run of two scripts, one failing
    _write_page(tmp_path, [_row("bench_novel_robots.py", "coverage", "97.5 %", True)])
    page = _write_page(
        tmp_path,
        [
            _row("bench_perf.py", "start-up", "1.15x", True),
            _row("bench_sysid.py", "fit", "3 s", False),
        ],
        "--ran",
        "bench_perf.py bench_sysid.py bench_calibration.py",
        "--failed",
        "bench_calibration.py",
        "--elapsed-s",
        "606",
    )
    assert page.startswith("# Benchmarks\n")
    assert "| b | coverage | 97.5 % | t | yes |" in _section(page, "bench_novel_robots.py")
    assert "| b | start-up | 1.15x | t | yes |" in _section(page, "bench_perf.py")
    assert "| b | fit | 3 s | t | **no** |" in _section(page, "bench_sysid.py")
    assert "took 10.1 min" in _section(page, "bench_sysid.py")
    failed = _section(page, "bench_calibration.py")
    assert "the script failed" in failed and "No figures were recorded." in failed
    # sections in name order, each once
    names = [ln.split(":", 1)[1][:-4] for ln in page.splitlines() if ln.startswith("<!-- bench:")]
    assert names == sorted(set(names)) and len(names) == 4
    # the study run again replaces its own section only
    again = _write_page(tmp_path, [_row("bench_novel_robots.py", "coverage", "91.0 %", True)])
    assert "91.0 %" in again and "97.5 %" not in again
    assert _section(again, "bench_perf.py") == _section(page, "bench_perf.py")


def test_the_repo_page_is_the_generated_kind() -> None:
    page = (ROOT / "docs" / "benchmarks.md").read_text(encoding="utf-8")
    sys.path.insert(0, str(BENCH))
    try:
        from results_page import INTRO
    finally:
        sys.path.remove(str(BENCH))
    assert page.startswith(INTRO)
    assert "perf-table" not in (ROOT / "README.md").read_text(encoding="utf-8")


def test_benchmark_docstrings_say_what_and_how_in_at_most_40_lines() -> None:
    long = {}
    for path in sorted(BENCH.glob("*.py")):
        doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")), clean=False)
        assert doc, f"{path.name} has no module docstring"
        if len(doc.splitlines()) > 40:
            long[path.name] = len(doc.splitlines())
    assert not long, f"benchmark docstrings over 40 lines (results go to docs/): {long}"


def test_bench_real_names_a_bad_split_and_exits_2() -> None:
    cmd = [sys.executable, "bench_real.py", "--neato-split", "nope.mcap"]
    done = subprocess.run(cmd, cwd=BENCH, capture_output=True, text=True, check=False)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    last = done.stderr.strip().splitlines()[-1]
    assert "'nope.mcap' is not a Neato recording; give one of neato_" in last


def test_bench_real_refuses_a_folder_without_recordings(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("no recording here", encoding="utf-8")
    cmd = [sys.executable, "bench_real.py", "--more-neato", str(tmp_path)]
    done = subprocess.run(cmd, cwd=BENCH, capture_output=True, text=True, check=False)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert f"'{tmp_path}' holds no .bag or .mcap file" in done.stderr.strip().splitlines()[-1]
