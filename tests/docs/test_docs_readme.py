"""The README's Python tour runs as written (on the bundled data)."""

from __future__ import annotations

import json
import os
import runpy
import shlex
from pathlib import Path

import pytest
import yaml

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


def _sh_commands(text: str) -> list[list[str]]:
    """The ``sim2real ...`` command lines of the README's sh blocks (continuations joined)."""
    out = []
    rest = text
    while "```sh\n" in rest:
        start = rest.index("```sh\n") + len("```sh\n")
        end = rest.index("```", start)
        block = rest[start:end].replace("\\\n", " ")
        for line in block.splitlines():
            line = line.split("#", 1)[0].strip()
            if line.startswith("sim2real "):
                out.append(shlex.split(line)[1:])
        rest = rest[end + 3 :]
    return out


@pytest.mark.slow
def test_readme_cli_tour_gives_the_demos_figures(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The tour's fit and agree commands, run as written, give the demo's numbers."""
    from sim2real.cli import main
    from sim2real.cli._demo import run_demo, tour_commands

    commands = _sh_commands((ROOT / "README.md").read_text(encoding="utf-8"))
    fit = next(c for c in commands if c[:2] == ["sysid", "fit"])
    agree = next(c for c in commands if c[0] == "agree" and "--ensemble" in c)
    # the demo runs exactly the tour's commands (its own output folder aside)
    demo_fit, demo_agree = tour_commands(".", "data")
    norm = lambda argv: [Path(a).name if "/" in a else a for a in argv]  # noqa: E731
    assert norm(fit) == norm(demo_fit) and norm(agree) == norm(demo_agree)
    (tmp_path / "data").symlink_to(ROOT / "data")
    cwd = os.getcwd()
    try:
        os.chdir(tmp_path)
        assert main(fit) == 0
        assert main([*agree, "--engine", "reduced"]) == 0  # the reduced engine keeps it quick
    finally:
        os.chdir(cwd)
    tour = json.loads((tmp_path / "agreement.json").read_text())
    summary = run_demo(tmp_path / "demo", engine="reduced")
    capsys.readouterr()
    for key in ("agreement", "agreement_v", "fit_percent_v", "fit_percent_w", "lag_s_w"):
        assert summary["sysid"][key] == tour[key], key
    assert summary["coverage"] == tour["coverage"]
    a = yaml.safe_load((tmp_path / "params.yaml").read_text())["parameters"]
    b = yaml.safe_load((tmp_path / "demo" / "params.yaml").read_text())["parameters"]
    assert {k: v["value"] for k, v in a.items()} == {k: v["value"] for k, v in b.items()}
    # the robot-dependent default: v of an encoder base is averaged over one odometry period
    assert summary["odom_v_window_s"] == pytest.approx(1.0 / 30.0)
