"""The documentation site: its generated pages, and a strict MkDocs build with no warning.

Needs the ``[docs]`` extra (``make docs`` installs it); skipped without it.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mkdocs")
pytest.importorskip("material")
pytest.importorskip("mkdocstrings_handlers.python")

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
import mkdocs_hooks  # noqa: E402

sys.path.remove(str(ROOT / "scripts"))


def _commands() -> list[str]:
    from sim2real.cli import build_parser

    return [" ".join(p) for p, _ in mkdocs_hooks._commands(build_parser(), ("sim2real",))]


def test_cli_page_has_every_command_and_its_help() -> None:
    page = mkdocs_hooks.cli_page()
    commands = _commands()
    assert {"sim2real sysid fit", "sim2real agree", "sim2real envs eval"} <= set(commands)
    for command in commands:
        assert f"`{command}`" in page, command
    assert page.count("```text") == len(commands)
    assert "usage: sim2real sysid calibrate" in page
    assert "examples:" in page


def test_api_pages_list_the_public_modules_only() -> None:
    names = mkdocs_hooks.public_modules("sim2real")
    assert "sim2real.agreement.calibration" in names and "sim2real.cluster" in names
    assert not [n for n in names if any(part.startswith("_") for part in n.split("."))]
    assert not [n for n in names if n.startswith("sim2real.cli")]
    assert names[0] == "sim2real"
    pages = mkdocs_hooks.api_pages()
    assert sorted(m for ms in pages.values() for m in ms if m.startswith("sim2real")) == sorted(
        names
    )
    assert pages["sim2real.agreement"][0] == "sim2real.agreement"
    assert "sim2real.cluster" in pages["sim2real"] and "sim2real.logs" not in pages["sim2real"]
    page = mkdocs_hooks.api_page("sysid", pages["sysid"])
    assert page.count("::: sysid") == len(mkdocs_hooks.public_modules("sysid"))


def test_sphinx_roles_read_as_code() -> None:
    text = "See :class:`~robots.params.DriveParams`, :func:`sysid.fit_drive` and :math:`k_v`."
    assert mkdocs_hooks.plain_roles(text) == (
        "See `robots.params.DriveParams`, `sysid.fit_drive` and `k_v`."
    )


@pytest.mark.slow
def test_site_builds_strict_without_a_warning(tmp_path: Path) -> None:
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)]
    run = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    out = run.stdout + run.stderr
    assert run.returncode == 0, out
    assert "WARNING" not in out, out
    cli = (tmp_path / "cli" / "index.html").read_text(encoding="utf-8")
    assert "usage: sim2real sysid fit" in cli
    sysid_page = (tmp_path / "api" / "sysid" / "index.html").read_text(encoding="utf-8")
    assert 'id="sysid.fit_drive"' in sysid_page and ":class:" not in sysid_page
    for page in ("index", "agreement", "training", "cluster", "spec-format", "benchmarks"):
        assert (tmp_path / ("" if page == "index" else page) / "index.html").is_file(), page
    # every API page is in the nav
    index = (tmp_path / "index.html").read_text(encoding="utf-8")
    for page in mkdocs_hooks.api_pages():
        assert f'href="api/{page}/"' in index, page
