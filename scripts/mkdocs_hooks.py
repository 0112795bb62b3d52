"""MkDocs hooks: the CLI reference and the API reference pages, generated at build time.

``cli.md`` holds the ``--help`` of every ``sim2real`` command, taken from the argument parsers
themselves (:func:`sim2real.cli.build_parser`), so it cannot drift from the code. ``api/*.md``
hold one mkdocstrings section per public module of each package (modules and packages whose
names start with ``_`` are private and left out), found on disk, so a moved module moves in
the reference too; ``sim2real``'s subpackages get a page each, listed in the nav here. ``mkdocs.yml`` names this file under ``hooks:``, and :class:`SphinxRoles`
as a griffe extension of the python handler.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path
from typing import Any

import griffe
from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[1]
#: The API reference: one page per package, with what the package is for.
PACKAGES = {
    "sysid": "System identification of the drive model from velocity logs.",
    "robots": "Robot specs, the drive model (reduced and pybullet), sensors.",
    "randomizers": "Gymnasium wrappers for domain randomisation.",
    "sim2real": "Logs, agreement, training, foreign plants, envs, clusters.",
}
#: Width of the ``--help`` text (argparse reads it from ``COLUMNS``).
HELP_COLUMNS = 80
#: A Sphinx role in a docstring: ``:class:`robots.DriveParams```, ``:math:`x```, ...
_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|attr|data|exc|obj|const|math):`~?([^`]+)`")


def plain_roles(text: str) -> str:
    """Sphinx roles as markdown code spans (the docstrings are written for both).

    >>> plain_roles("Fit :class:`robots.params.DriveParams` with :func:`~sysid.fit_drive`.")
    'Fit `robots.params.DriveParams` with `sysid.fit_drive`.'
    """
    return _ROLE.sub(lambda m: f"`{m.group(1)}`", text)


class SphinxRoles(griffe.Extension):
    """A griffe extension: every docstring's Sphinx roles read as code spans."""

    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = plain_roles(obj.docstring.value)


def public_modules(package: str) -> list[str]:
    """Dotted names of ``package``'s public modules and subpackages, in path order.

    >>> public_modules("randomizers")[:2]
    ['randomizers', 'randomizers.errors']
    """
    base = ROOT / package
    names = []
    for path in sorted(base.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if any(p.startswith("_") for p in parts) or "cli" in parts:
            continue
        names.append(".".join(parts))
    return sorted(names, key=lambda n: (n.count(".") > 0, n))


def api_pages() -> dict[str, list[str]]:
    """The API reference's pages: page name -> the modules it documents.

    One page per package, and one per subpackage of ``sim2real`` (its rooms: ``agreement``,
    ``logs``, ...), whose modules would otherwise make one page of thousands of lines.

    >>> api_pages()["sysid"][:2]
    ['sysid', 'sysid.errors']
    """
    pages: dict[str, list[str]] = {}
    for package in PACKAGES:
        for name in public_modules(package):
            parts = name.split(".")
            room = package
            if package == "sim2real" and len(parts) > 1 and (ROOT / parts[0] / parts[1]).is_dir():
                room = ".".join(parts[:2])
            pages.setdefault(room, []).append(name)
    return pages


def api_page(page: str, modules: list[str]) -> str:
    """The markdown of one API page: a mkdocstrings section per module."""
    lines = [f"# `{page}`", ""]
    if page in PACKAGES:
        lines += [PACKAGES[page], ""]
    for name in modules:
        lines += [f"::: {name}", ""]
    return "\n".join(lines)


def _commands(
    parser: argparse.ArgumentParser, path: tuple[str, ...]
) -> list[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    out = [(path, parser)]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                out += _commands(sub, (*path, name))
    return out


def cli_page() -> str:
    """The markdown of the CLI reference: every command's ``--help``, in the parser's order."""
    os.environ["COLUMNS"] = str(HELP_COLUMNS)
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))  # this checkout's commands, whatever the venv installed
    from sim2real.cli import build_parser

    lines = [
        "# CLI reference",
        "",
        "Every command of `sim2real`, with the `--help` it prints. Bad input prints one sentence",
        "on stderr and exits with code 2; `agree --min-agreement` exits with 1 when the gate",
        "fails.",
        "",
    ]
    for path, parser in _commands(build_parser(), ("sim2real",)):
        level = "#" * min(len(path) + 1, 4)
        lines += [f"{level} `{' '.join(path)}`", "", "```text", parser.format_help().rstrip()]
        lines += ["```", ""]
    return "\n".join(lines)


def on_config(config: Any) -> Any:
    """List the API pages under the nav's "API reference" entry."""
    for entry in config["nav"]:
        if isinstance(entry, dict) and "API reference" in entry:
            entry["API reference"] = [{page: f"api/{page}.md"} for page in api_pages()]
    return config


def on_files(files: Files, config: Any) -> Files:
    """Add the generated pages to the site's files."""
    files.append(File.generated(config, "cli.md", content=cli_page()))
    for page, modules in api_pages().items():
        files.append(File.generated(config, f"api/{page}.md", content=api_page(page, modules)))
    return files
