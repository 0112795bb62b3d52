"""The CLI's one dispatcher: every command names a handler that exists, and building the
parser imports no handler module (they load only for the command that runs)."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

from sim2real.cli import HANDLER_MODULES, build_parser, handler


def _handlers(parser: argparse.ArgumentParser, path: str = "sim2real") -> dict[str, str]:
    """``{"sim2real sysid fit": "sysid:handle_fit", ...}`` over every (sub)command."""
    found: dict[str, str] = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found.update(_handlers(sub, f"{path} {name}"))
    if parser.get_default("handler") is not None:
        found[path] = parser.get_default("handler")
    return found


def test_every_command_names_a_handler_function_of_the_table() -> None:
    names = _handlers(build_parser())
    assert len(names) >= 15 and "sim2real sysid fit" in names and "sim2real agree" in names
    for command, name in names.items():
        group = name.split(":")[0]
        assert group in HANDLER_MODULES, command
        assert callable(handler(name)), command
        assert handler(name).__module__ == HANDLER_MODULES[group], command
    assert {n.split(":")[0] for n in names.values()} == set(HANDLER_MODULES)  # none unused


def test_parsing_imports_no_handler_module() -> None:
    code = (
        "import json, sys\n"
        "from sim2real.cli import HANDLER_MODULES, build_parser\n"
        "build_parser().parse_args(['sysid', 'fit', 'x.mcap', '--robot', 'r', '-o', 'p.yaml'])\n"
        "print(json.dumps(sorted(m for m in HANDLER_MODULES.values() if m in sys.modules)))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(proc.stdout) == []
