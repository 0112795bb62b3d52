"""benchmarks/bench_transfer.py --smoke: the whole transfer loop end to end, twice the same table."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

# `make test-train` selects by marker: the smoke loop needs the [train] extra
pytestmark = pytest.mark.train

ROOT = Path(__file__).resolve().parents[3]


#: What the loop is asked for: the table's rows, not what a policy learns, are what this checks;
#: 512 env steps are two PPO updates of the smoke hyper-parameters (4 envs x 64 steps each), and
#: two evaluation episodes per model and world fill every cell.
SMALL = ("--timesteps", "512", "--episodes", "2")
#: The conditions the --jobs 2 run trains again: one nominal, one with a randomizer stack (what a
#: worker process must rebuild from the config it is handed).
AGAIN = ("spec", "calibrated DR")


def _smoke(out: Path, *extra: str) -> str:
    cmd = [sys.executable, str(ROOT / "benchmarks" / "bench_transfer.py"), "--smoke", *SMALL]
    run = subprocess.run(
        [*cmd, *extra, "--out", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=900
    )
    assert run.returncode == 0, run.stderr[-3000:]
    assert "wall time" in run.stdout
    return (out / "results.md").read_text(encoding="utf-8")


def _weights(model_zip: Path) -> bytes:
    """The policy's saved parameters in an SB3 ``model.zip``."""
    with zipfile.ZipFile(model_zip) as archive:
        return archive.read("policy.pth")


def _rows(table: str, names: tuple[str, ...]) -> list[str]:
    """The table's rows of the conditions ``names``."""
    return [line for line in table.splitlines() if line.split(" | ")[0][2:] in names]


@pytest.mark.slow
def test_smoke_runs_the_loop_and_repeats_its_table(tmp_path: Path) -> None:
    first = _smoke(tmp_path / "a")
    for name in ("spec", "fitted", "calibrated DR", "blind DR"):
        for world in ("sim", "plant"):
            assert f"| {name} | {world} |" in first
    assert "512 env steps per run" in first and "2 evaluation episodes" in first
    # what each condition trains with, against the sessions' true latency
    delays = first.split("delay_s trained with (5/50/95 %): ")[1]
    assert "fitted point 0." in delays and "calibrated DR 0." in delays
    assert "evaluation sessions 0.06-0.16 s" in delays
    assert (tmp_path / "a" / "excite.mcap").is_file()
    assert (tmp_path / "a" / "calibrated.yaml").is_file()
    # the same rows when two runs train and evaluate in two worker processes; the fit and the
    # calibration are not what --jobs changes: the second run resumes from the first's files
    # (the script skips a fit or a calibration whose file exists; it records the sessions,
    # trains and evaluates again)
    (tmp_path / "b").mkdir()
    for name in ("fitted.yaml", "calibrated.yaml"):
        shutil.copy(tmp_path / "a" / name, tmp_path / "b" / name)
    second = _smoke(tmp_path / "b", "--jobs", "2", "--conditions", *AGAIN)
    assert len(_rows(second, AGAIN)) == 4
    assert _rows(second, AGAIN) == _rows(first, AGAIN)
    assert second.splitlines()[0] == first.splitlines()[0]  # the budget and the task
    assert second.split("\n\n")[-1] == first.split("\n\n")[-1]  # the delays line
    # at this budget every episode times out, so the rows alone could hide a different policy:
    # the trained weights are the same bytes (and differ between the two conditions)
    weights = {
        (run, name): _weights(tmp_path / run / f"{name.replace(' ', '_')}_seed0" / "model.zip")
        for run in ("a", "b")
        for name in AGAIN
    }
    for name in AGAIN:
        assert weights["a", name] == weights["b", name], name
    assert weights["a", AGAIN[0]] != weights["a", AGAIN[1]]


@pytest.mark.slow
def test_gap_probe_evaluates_the_spec_policy_in_its_sim_and_on_each_session_distribution(
    tmp_path: Path,
) -> None:
    cmd = [sys.executable, str(ROOT / "benchmarks" / "bench_transfer.py"), "--smoke"]
    cmd += ["--gap", "kobuki", "--episodes", "2", "--out", str(tmp_path)]
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    table = (tmp_path / "gap_kobuki.md").read_text(encoding="utf-8")
    worlds = (
        "sim",
        "plant",
        "plant, latency 0.10-0.23 s",
        "plant, latency 0.15-0.25 s",
        "plant, latency 0.2-0.3 s",
    )
    for world in (*worlds, "plant, payload 1-2x"):
        assert f"| spec | {world} | " in table
    assert "'robot': 'turtlebot2'" in table and "1024 env steps" in table
    assert "training success (stochastic actions) per env steps: " in table
    # the open-loop response: the spec's model is one robot; the plant's sessions vary, and a
    # longer latency rolls further after the stop command
    response = {
        line.split(" | ")[0][2:]: line.split(" | ")[1:]
        for line in table.split("open-loop response")[1].splitlines()
        if line.startswith("| ") and not line.startswith("| world")
    }
    assert set(response) == {*worlds, "plant, payload 1-2x"}
    assert all("-" in cell for cell in response["plant"])
    sim_stop = float(response["sim"][1].split(" (")[0])
    lo, hi = response["sim"][1].split(" (")[1].rstrip(")").split("-")
    assert float(lo) == float(hi) == sim_stop
    stop = {w: float(response[w][1].split(" (")[0]) for w in worlds[1:]}
    assert stop["plant"] < stop["plant, latency 0.15-0.25 s"] < stop["plant, latency 0.2-0.3 s"]
    assert not (tmp_path / "results.md").exists()  # the probe trains no other condition
