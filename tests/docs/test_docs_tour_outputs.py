"""The files the README's commands write in the repository root are ignored by git."""

from __future__ import annotations

import itertools
import shlex
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: The options of `sysid` and `agree` that name a file to write.
OUTPUT_OPTIONS = ("-o", "--out", "--json", "--report", "--sim-out")


def _written_in_root(readme: str) -> set[str]:
    """The root-level files (no folder in the path) the README's sysid/agree commands write."""
    out: set[str] = set()
    for block in readme.split("```sh\n")[1:]:
        for line in block.split("```", 1)[0].replace("\\\n", " ").splitlines():
            argv = shlex.split(line.split("#", 1)[0])
            if argv[:1] != ["sim2real"] or argv[1:2] not in (["sysid"], ["agree"]):
                continue
            for flag, value in itertools.pairwise(argv):
                if flag in OUTPUT_OPTIONS and "/" not in value:
                    out.add(value)
                    if flag == "--report":  # the plots beside it: <stem>_<name>.png
                        out.add(f"{Path(value).stem}_timeseries.png")
    return out


def _ignored(paths: list[str]) -> set[str]:
    proc = subprocess.run(
        ["git", "-C", str(ROOT), "check-ignore", "--no-index", *paths],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode in (0, 1), proc.stderr
    return set(proc.stdout.split())


@pytest.mark.skipif(
    shutil.which("git") is None or not (ROOT / ".git").exists(), reason="not a git checkout"
)
def test_the_tours_outputs_in_the_root_are_ignored_and_only_there() -> None:
    written = _written_in_root((ROOT / "README.md").read_text(encoding="utf-8"))
    assert {
        "params.yaml",
        "calibrated.yaml",
        "report.html",
        "agreement.json",
        "sim.mcap",
    } <= written
    assert _ignored(sorted(written)) == written
    deeper = [f"examples/{name}" for name in sorted(written)]  # a folder's files stay visible
    assert _ignored(deeper) == set()
