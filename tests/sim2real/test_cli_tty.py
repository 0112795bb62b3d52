"""Long runs are observable on a terminal and quiet in a pipe; pybullet's banner never on stdout."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from hostile_logs import ROBOT, base_arrays, write_faulty

from tests.terminal import LIVE, on_a_terminal

_ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def _cli(*argv: str) -> list[str]:
    return [sys.executable, "-m", "sim2real", *argv]


def _piped(
    argv: list[str], cwd: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> tuple[int, str]:
    """Run ``argv`` in-process with stdout and stderr captured (not a terminal), from ``cwd``.

    In-process saves a Python start and the imports; the pybullet banner, written by C code
    to the descriptor, has its own subprocess test below.
    """
    from sim2real.cli import main

    for name in ("NO_COLOR", "CI", "FORCE_COLOR"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.chdir(cwd)
    capsys.readouterr()
    code = main(argv[3:])  # after "python -m sim2real"
    out, err = capsys.readouterr()
    return code, out + err


@pytest.fixture(scope="module")
def log_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("tty")
    write_faulty(folder / "run.mcap", [], base_arrays(duration_s=8.0, seed=2))
    return folder


@pytest.mark.slow
def test_sysid_fit_shows_a_bar_on_a_terminal_and_nothing_in_a_pipe(
    log_dir: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    argv = _cli("sysid", "fit", "run.mcap", "--robot", ROBOT, "-o", "p.yaml", "--free", "delay_s")
    code, shown = on_a_terminal(argv, log_dir)
    assert code == 0, shown
    assert LIVE in shown and "sysid" in shown
    code, piped = _piped(argv, log_dir, capsys, monkeypatch)
    assert code == 0, piped
    assert not _ANSI.search(piped)  # no bar, no colour, no cursor moves


@pytest.mark.slow
def test_envs_eval_shows_a_bar_on_a_terminal_and_nothing_in_a_pipe(
    log_dir: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    argv = _cli("envs", "eval", "RandomMap-v0", "--episodes", "1")
    code, shown = on_a_terminal(argv, log_dir)
    assert code == 0, shown
    assert LIVE in shown and "episodes" in shown
    code, piped = _piped(argv, log_dir, capsys, monkeypatch)
    assert code == 0, piped
    assert not _ANSI.search(piped)


def test_pybullet_banner_never_reaches_stdout(tmp_path: Path) -> None:
    code = "import robots.pybullet_robot, sim2real.envs._world; print('ok')"
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "ok\n"
    assert "pybullet build time" not in proc.stderr  # silenced at the descriptor level too


@pytest.mark.slow
def test_agree_ensemble_shows_a_bar_on_a_terminal_and_nothing_in_a_pipe(
    log_dir: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from sim2real.cli import main

    params = log_dir / "ens_params.yaml"
    fit = ["sysid", "fit", str(log_dir / "run.mcap"), "--robot", ROBOT, "-o", str(params)]
    assert main([*fit, "--free", "delay_s"]) == 0
    argv = _cli(
        "agree",
        "run.mcap",
        "--robot",
        ROBOT,
        "--params",
        params.name,
        "--engine",
        "reduced",
        "--ensemble",
        "4",
    )
    code, shown = on_a_terminal(argv, log_dir)
    assert code == 0, shown
    assert LIVE in shown and "ensemble" in shown
    code, piped = _piped(argv, log_dir, capsys, monkeypatch)
    assert code == 0, piped
    assert not _ANSI.search(piped)
