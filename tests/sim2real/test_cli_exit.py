"""The console command's lean exit: ``sim2real.cli.run`` freezes the GC after ``main``."""

from __future__ import annotations

import gc
import subprocess
import sys
from importlib.metadata import entry_points

import pytest

from sim2real.cli import main, run


def test_console_script_and_module_run_the_lean_entry() -> None:
    (script,) = [ep for ep in entry_points(group="console_scripts") if ep.name == "sim2real"]
    assert script.value == "sim2real.cli:run"


def test_run_returns_mains_code_and_freezes_the_collector(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    gc.unfreeze()
    assert main(["robots", "list"]) == 0
    assert gc.get_freeze_count() == 0  # main() alone, as tests call it, leaves the GC alone
    monkeypatch.setattr(sys, "argv", ["sim2real", "robots", "show", "no_such_robot"])
    try:
        assert run() == 2
        assert gc.get_freeze_count() > 1000
    finally:
        gc.unfreeze()
    assert "sim2real: error:" in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "code"), [(["robots", "list"], 0), (["logs", "info"], 2)])
def test_python_m_sim2real_exit_codes(argv: list[str], code: int) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "sim2real", *argv], capture_output=True, text=True, check=False
    )
    assert proc.returncode == code, proc.stderr
    assert "Traceback" not in proc.stderr
    if code == 0:
        assert "turtlebot3_burger" in proc.stdout
