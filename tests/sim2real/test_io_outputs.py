"""Outputs: the user's umask, output sets that move in together, leftovers of killed runs."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from sim2real._io import atomic_write, clean_orphans, output_set
from sim2real.errors import Sim2RealValueError


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_atomic_write_gives_the_users_umask(tmp_path: Path, umask: None, mask: int, mode: int):
    os.umask(mask)
    with atomic_write(tmp_path / "params.yaml", "w") as fh:
        fh.write("x: 1\n")
    assert _mode(tmp_path / "params.yaml") == mode
    with output_set([tmp_path / "a.json"]) as out:
        out.staged(tmp_path / "a.json").write_text("{}")
    assert _mode(tmp_path / "a.json") == mode


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_output_set_moves_every_file_in_at_the_end(tmp_path: Path) -> None:
    (tmp_path / "sub").mkdir()
    dests = [tmp_path / "a.json", tmp_path / "report.html", tmp_path / "sub" / "sim.mcap"]
    with output_set([*dests, None]) as out:
        for d in dests:
            out.staged(d).write_text(d.name)
            assert not d.exists()  # nothing appears before the end
        out.staged(dests[1]).with_name("report_plot.png").write_text("png")  # an extra file
    assert [d.read_text() for d in dests] == ["a.json", "report.html", "sim.mcap"]
    assert (tmp_path / "report_plot.png").read_text() == "png"
    assert _leftovers(tmp_path) == [] and _leftovers(tmp_path / "sub") == []


def test_a_failed_output_set_keeps_the_old_outputs(tmp_path: Path) -> None:
    a, b = tmp_path / "a.json", tmp_path / "b.html"
    a.write_text("old a")
    b.write_text("old b")
    with pytest.raises(RuntimeError), output_set([a, b]) as out:
        out.staged(a).write_text("new a")
        raise RuntimeError("killed by a bug")
    assert (a.read_text(), b.read_text()) == ("old a", "old b")
    assert _leftovers(tmp_path) == []


def test_the_same_output_twice_is_refused(tmp_path: Path) -> None:
    with (
        pytest.raises(Sim2RealValueError, match=r"is given twice"),
        output_set([tmp_path / "x.json", tmp_path / "x.json"]),
    ):
        pass


_KILLED_RUN = """
import os, signal, sys
from pathlib import Path
import sim2real._io as io
folder, stage = Path(sys.argv[1]), sys.argv[2]
dests = [folder / "a.json", folder / "b.html", folder / "c.mcap"]
real_finish = io._finish_set
def finish_then_die(staging):
    first = sorted(p for p in staging.iterdir() if p.name != ".commit")[0]
    os.replace(first, staging.parent / first.name)  # one file moved in, then killed
    os.kill(os.getpid(), signal.SIGKILL)
io._finish_set = finish_then_die
with io.output_set(dests) as out:
    for d in dests:
        with io.atomic_write(out.staged(d), "w") as fh:
            fh.write("new")
    if stage == "writing":
        with io.atomic_write(folder / "lone.txt", "w") as fh:
            fh.write("half")
            fh.flush()
            os.kill(os.getpid(), signal.SIGKILL)
"""


@pytest.mark.parametrize("stage", ["writing", "moving"])
def test_a_killed_run_leaves_old_or_new_set_and_the_next_run_cleans_up(
    tmp_path: Path, stage: str
) -> None:
    names = ("a.json", "b.html", "c.mcap")
    for name in names:
        (tmp_path / name).write_text("old")
    proc = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(_KILLED_RUN), str(tmp_path), stage],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    assert _leftovers(tmp_path)  # the killed run left its staging folder / temp file
    if stage == "writing":  # killed before the end: the old set is intact
        assert {(tmp_path / n).read_text() for n in names} == {"old"}
    clean_orphans(tmp_path)  # what the next run does first
    assert _leftovers(tmp_path) == []
    expected = "old" if stage == "writing" else "new"  # a committed set is finished
    assert [(tmp_path / n).read_text() for n in names] == [expected] * 3
    assert not (tmp_path / "lone.txt").exists()
