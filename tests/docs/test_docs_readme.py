"""The README's Python tour runs as written (on the bundled data)."""

from __future__ import annotations

import os
import runpy
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _python_blocks(text: str) -> list[str]:
    blocks, rest = [], text
    while "```python\n" in rest:
        start = rest.index("```python\n") + len("```python\n")
        end = rest.index("```", start)
        blocks.append(rest[start:end])
        rest = rest[end + 3 :]
    return blocks


@pytest.mark.slow
def test_readme_python_tour_runs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocks = _python_blocks((ROOT / "README.md").read_text(encoding="utf-8"))
    assert blocks, "README.md has no python example"
    (tmp_path / "data").symlink_to(ROOT / "data")
    script = tmp_path / "tour.py"
    script.write_text("\n".join(blocks), encoding="utf-8")
    cwd = os.getcwd()
    try:
        os.chdir(tmp_path)
        runpy.run_path(str(script), run_name="__main__")
    finally:
        os.chdir(cwd)
    assert (tmp_path / "params.yaml").is_file()
    assert "DynamicsRandomizer" in capsys.readouterr().out
