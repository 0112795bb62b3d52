"""Shared helpers of the CLI modules: help formatting and argument types."""

from __future__ import annotations

import argparse

__all__ = ["EPILOG_MAIN", "HelpFormatter", "add_command"]

EPILOG_MAIN = """\
examples:
  sim2real logs info run.mcap                     # topics, rates, chosen cmd/odom topics
  sim2real robots list                            # the robots with shipped specs
  sim2real sysid fit train.mcap --robot turtlebot3_burger -o params.yaml
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --report report.html
  sim2real demo --out sim2real-demo               # what `make demo` runs
"""


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the examples' line breaks and shows defaults."""


def add_command(
    sub: argparse._SubParsersAction,  # type: ignore[type-arg]
    name: str,
    *,
    help: str,
    description: str,
    examples: str,
) -> argparse.ArgumentParser:
    """Add a subcommand whose ``--help`` ends with an ``examples:`` block."""
    parser: argparse.ArgumentParser = sub.add_parser(
        name,
        help=help,
        description=description,
        epilog="examples:\n" + examples.rstrip() + "\n",
        formatter_class=HelpFormatter,
    )
    return parser
