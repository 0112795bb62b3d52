"""robots.files: the one atomic write (temp file beside the target, umask, killed writers' leftovers)."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from robots.files import (
    atomic_write,
    clean_orphans,
    output_problem,
    process_alive,
    write_text_atomic,
)


@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_a_written_file_gets_the_users_umask(
    tmp_path: Path, umask: None, mask: int, mode: int
) -> None:
    os.umask(mask)
    path = write_text_atomic(tmp_path / "a.yaml", "x: 1\n")
    assert stat.S_IMODE(path.stat().st_mode) == mode
    assert path.read_text(encoding="utf-8") == "x: 1\n"


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temp(tmp_path: Path) -> None:
    target = tmp_path / "a.bin"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError, match="boom"), atomic_write(target) as fh:
        fh.write(b"new")
        raise RuntimeError("boom")
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["a.bin"]


def test_the_temp_file_carries_the_writers_pid(tmp_path: Path) -> None:
    with atomic_write(tmp_path / "a.txt", "w", encoding="utf-8") as fh:
        names = [p.name for p in tmp_path.iterdir()]
        fh.write("x")
    assert len(names) == 1
    assert names[0].startswith(f".a.txt.{os.getpid()}.") and names[0].endswith(".tmp")


def test_clean_orphans_removes_only_the_temp_files_of_dead_writers(tmp_path: Path) -> None:
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        check=True,
        capture_output=True,
        text=True,
    )
    dead_pid = int(dead.stdout)
    assert not process_alive(dead_pid)
    orphan = tmp_path / f".a.txt.{dead_pid}.k3j2.tmp"
    live = tmp_path / f".b.txt.{os.getpid()}.x9q1.tmp"
    other = tmp_path / ".hidden.tmp"
    for path in (orphan, live, other):
        path.write_text("half")
    clean_orphans(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([live.name, other.name])


def test_a_missing_folder_is_refused(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        write_text_atomic(tmp_path / "nope" / "a.txt", "x")


def test_output_problem_names_a_missing_folder_or_a_folder(tmp_path: Path) -> None:
    assert output_problem(tmp_path / "a.yaml") is None
    missing = output_problem(tmp_path / "nope" / "a.yaml", what="params file")
    assert missing == (
        f"params file '{tmp_path / 'nope' / 'a.yaml'}' is in folder '{tmp_path / 'nope'}', which "
        "does not exist; create it first or choose another path"
    )
    assert output_problem(tmp_path) == f"output file '{tmp_path}' is a folder; give a file name"
