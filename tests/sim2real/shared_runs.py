"""Expensive runs that several test modules check, computed once per test run.

A session fixture runs once per pytest process; under pytest-xdist every worker is a process,
so each would redo the run. :func:`run_once` computes it once for all of them: the first
worker to take the lock fills the folder and marks it done, the others wait and read it (the
pytest-xdist documentation's recipe, a :class:`filelock.FileLock` in the run's shared base
temporary folder). The fixtures hand out folders to read; a test that changes files copies
them first.
"""

from __future__ import annotations

import contextlib
import io
import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from filelock import FileLock

__all__ = ["demo_run", "run_once"]


def run_once(
    tmp_path_factory: pytest.TempPathFactory, name: str, compute: Callable[[Path], None]
) -> Path:
    """The folder ``name`` that ``compute(folder)`` fills, filled once per test run.

    Under xdist the workers' base temporary folders share a parent that is new for each run;
    without xdist the base folder itself is new for each run (its parent holds earlier runs).
    A failed ``compute`` leaves no mark: the next caller tries again from an empty folder.
    """
    base = tmp_path_factory.getbasetemp()
    root = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    folder, done = root / name, root / f"{name}.done"
    with FileLock(str(root / f"{name}.lock")):
        if not done.is_file():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            compute(folder)
            done.touch()
    return folder


def _demo(folder: Path) -> None:
    """``sim2real demo --engine reduced --out folder/out``; what it prints in ``stdout.txt``."""
    from sim2real.cli._demo import run_demo

    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        run_demo(folder / "out", engine="reduced")
    (folder / "stdout.txt").write_text(printed.getvalue(), encoding="utf-8")


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The demo on the bundled logs with the reduced engine (the README tour's figures):
    a folder of ``out/`` (its outputs) and ``stdout.txt`` (what it printed). Read only."""
    return run_once(tmp_path_factory, "demo_reduced", _demo)
