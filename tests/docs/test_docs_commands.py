"""Every ``sim2real`` command line in the docs pages parses with the CLI as written."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

from sim2real.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]


def _command_lines() -> list[tuple[str, str]]:
    """(page, line) of each ``sim2real ...`` line in the sh blocks of docs/*.md."""
    out = []
    for page in sorted((ROOT / "docs").glob("*.md")):
        rest = page.read_text(encoding="utf-8")
        while "```sh\n" in rest:
            start = rest.index("```sh\n") + len("```sh\n")
            end = rest.index("```", start)
            for line in rest[start:end].replace("\\\n", " ").splitlines():
                line = line.split(" #", 1)[0].strip()
                if line.startswith(("sim2real ", ".venv-rllib/bin/sim2real ")):
                    out.append((page.name, line))
            rest = rest[end + 3 :]
    return out


LINES = _command_lines()


def test_the_pages_have_commands() -> None:
    pages = {page for page, _ in LINES}
    assert {"index.md", "training.md", "cluster.md", "agreement.md"} <= pages


@pytest.mark.parametrize(
    ("page", "line"), LINES, ids=[f"{p}:{i}" for i, (p, _) in enumerate(LINES)]
)
def test_command_parses(page: str, line: str) -> None:
    argv = shlex.split(line)[1:]
    try:
        build_parser().parse_args(argv)
    except SystemExit as exc:  # argparse exits 2 on an unknown option or a bad value
        if exc.code != 0:  # --help exits 0
            pytest.fail(f"{page}: `{line}` does not parse (exit {exc.code})")
