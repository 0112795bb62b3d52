"""``sim2real demo`` writes its outputs as one set: a failed or killed run keeps the old set."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sim2real._io import clean_orphans
from sim2real.cli import main

OUTPUTS = ("params.yaml", "calibrated.yaml", "report.html", "agreement.json", "summary.json")


@pytest.fixture(scope="module")
def demo_data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three short sessions of the foreign plant under the demo's file names."""
    from sim2real.plants.diff_drive import write_fleet

    folder = tmp_path_factory.mktemp("demo_data")
    paths = write_fleet(folder, "turtlebot3_burger", 3, seed=5, duration_s=15.0)
    for path, name in zip(paths, ("demo_train", "demo_calibrate", "demo_validate"), strict=True):
        path.rename(folder / f"{name}.mcap")
    return folder


def _argv(data: Path, out: Path, seed: int) -> list[str]:
    options = ["--engine", "reduced", "--ensemble", "2", "--seed", str(seed)]
    return ["demo", "--data", str(data), "--out", str(out), *options]


@pytest.fixture(scope="module")
def old_set(demo_run: Path) -> Path:
    """A complete demo folder (the bundled logs, the reduced engine, seed 0): the run the README
    tests check too, read only (the tests copy it)."""
    return demo_run / "out"


def _copy(old: Path, dst: Path) -> dict[str, tuple[int, bytes]]:
    """Copy the old set to ``dst``; returns each file's (inode, bytes) there."""
    shutil.copytree(old, dst)
    return {p.name: (p.stat().st_ino, p.read_bytes()) for p in dst.iterdir()}


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.mark.slow
def test_a_demo_writes_every_output_and_nothing_else(old_set: Path) -> None:
    names = {p.name for p in old_set.iterdir()}
    assert set(OUTPUTS) <= names and "report_timeseries.png" in names
    assert _leftovers(old_set) == []
    for name in ("agreement.json", "report.html", "summary.json"):  # no staging path leaks
        assert ".sim2real-out-" not in (old_set / name).read_text(), name
    assert (
        f'"params_file": "{old_set / "calibrated.yaml"}"'
        in (old_set / "agreement.json").read_text()
    )


@pytest.mark.slow
def test_a_failing_demo_keeps_the_old_set(
    demo_data: Path, old_set: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    from sim2real.errors import Sim2RealValueError

    out = tmp_path / "out"
    before = _copy(old_set, out)

    def fail(config: object) -> None:  # the third step fails after the first two wrote
        assert any(p.name == "calibrated.yaml" for p in out.glob(".sim2real-out-*/*"))
        raise Sim2RealValueError("agree failed")

    monkeypatch.setattr("sim2real.cli._demo.run_study", fail)
    assert main(_argv(demo_data, out, seed=2)) == 2
    assert "agree failed" in capsys.readouterr().err
    after = {p.name: (p.stat().st_ino, p.read_bytes()) for p in out.iterdir()}
    assert after == before  # the same files, untouched, and no staging folder


@pytest.mark.slow
def test_a_killed_demo_keeps_the_old_set_and_the_next_run_cleans_up(
    demo_data: Path, old_set: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    before = _copy(old_set, out)
    proc = subprocess.Popen(
        [sys.executable, "-m", "sim2real", *_argv(demo_data, out, seed=3)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 300
    try:  # killed once the fit and the calibration are written (staged), before agree ends
        while not list(out.glob(".sim2real-out-*/calibrated.yaml")):
            assert proc.poll() is None and time.monotonic() < deadline, "demo ended before"
            time.sleep(0.05)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert _leftovers(out)  # the killed run's staging folder
    assert {
        p.name: (p.stat().st_ino, p.read_bytes()) for p in out.iterdir() if p.name[0] != "."
    } == before
    clean_orphans(out)  # what the next run does first
    assert _leftovers(out) == []
    assert {p.name: (p.stat().st_ino, p.read_bytes()) for p in out.iterdir()} == before
