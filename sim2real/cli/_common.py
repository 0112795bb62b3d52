"""Shared helpers of the CLI modules: help formatting, argument types, the gate's line."""

from __future__ import annotations

import argparse
import math
from dataclasses import fields
from typing import NoReturn

from sim2real.logs import ReadOptions

__all__ = [
    "EPILOG_MAIN",
    "HelpFormatter",
    "OneLineErrorParser",
    "add_command",
    "add_group",
    "add_logs_argument",
    "add_odom_v_window_argument",
    "add_ray_argument",
    "add_read_arguments",
    "gate_line",
    "read_options",
]

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


class OneLineErrorParser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line, like every other error, exit 2.

    Subcommand parsers inherit the class, so ``sim2real agree LOG --tol-v abc`` prints
    ``sim2real: error: sim2real agree: argument --tol-v: invalid float value: 'abc'; see
    'sim2real agree --help'``.
    """

    def error(self, message: str) -> NoReturn:
        """Print ``message`` as one line with a pointer to ``--help`` and exit with code 2."""
        text = " ".join(message.split())
        self.exit(2, f"sim2real: error: {self.prog}: {text}; see '{self.prog} --help'\n")


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


def add_group(
    sub: argparse._SubParsersAction,  # type: ignore[type-arg]
    name: str,
    *,
    help: str,
    description: str,
    examples: str,
) -> argparse._SubParsersAction:  # type: ignore[type-arg]
    """Add a command group (``sim2real NAME SUBCOMMAND``); returns its subcommands' parsers."""
    group = add_command(sub, name, help=help, description=description, examples=examples)
    group_sub = group.add_subparsers(dest=f"{name}_command", metavar="SUBCOMMAND")
    group_sub.required = True
    return group_sub


def add_logs_argument(
    parser: argparse.ArgumentParser, dest: str, *, what: str, several: str
) -> None:
    """The positional logs (``LOG...``): files or folders of any readable format, or globs.

    ``what`` names the logs and ``several`` says what several of them mean, e.g. "fitting
    log(s)" and "several logs are several sessions (a population)".
    """
    parser.add_argument(
        dest,
        nargs="+",
        metavar="LOG",
        help=(
            f"{what}: .mcap files, ROS 1 .bag, rosbag2 folders or .csv; paths or quoted "
            f"globs ('fleet/*.mcap'); {several}"
        ),
    )


def add_ray_argument(parser: argparse.ArgumentParser, *, several: str) -> None:
    """``--ray auto|ADDRESS``: run the work of several logs as Ray tasks; ``several`` says
    what the tasks are (e.g. "with several logs, run one Ray task per log")."""
    parser.add_argument(
        "--ray",
        metavar="auto|ADDRESS",
        help=(
            f"{several}: 'auto' joins the running cluster or starts a local one, ADDRESS is a "
            "head node (needs the [cluster] extra)"
        ),
    )


def add_odom_v_window_argument(
    parser: argparse.ArgumentParser, *, compared: str, averaged: str = "", like: str = ""
) -> None:
    """``--odom-v-window S|auto`` (default ``auto``): the window of the odometry's v.

    ``compared`` names the v compared without a window ("model", "simulated"); ``averaged``
    and ``like`` are inserted before and inside the default's parentheses.
    """
    parser.add_argument(
        "--odom-v-window",
        default="auto",
        metavar="S|auto",
        help=(
            f"odometry v is a wheel-encoder tick difference over this window, s{averaged} "
            "(default 'auto': from the spec's odometry, one period for an encoder base, e.g. "
            f"1/30 s on a TurtleBot3, 0 otherwise{like}); 0 = compare the instantaneous "
            f"{compared} v"
        ),
    )


def add_read_arguments(parser: argparse.ArgumentParser, *, time_source_note: str = "") -> None:
    """The options of every command that reads velocity logs: which topics, which clock, and
    where the measured velocities come from (the keywords of :func:`sim2real.logs.read_trace`).

    Adds ``--cmd-topic``, ``--odom-topic``, ``--time-source {auto,header,log}`` (``auto``
    default), ``--odom-velocity {auto,twist,pose}`` and ``--keep-all``; ``time_source_note``
    ends the ``--time-source`` help (e.g. how a validation log must be read).
    """
    parser.add_argument("--cmd-topic", help="command topic (default: auto-detect)")
    parser.add_argument("--odom-topic", help="odometry topic (default: auto-detect)")
    time_source = (
        "message timing: header stamps, recorder log times, or 'auto' (default: header stamps "
        "unless they run on another clock than the log times, which it says)"
        + (f"; {time_source_note}" if time_source_note else "")
    )
    odom_velocity = (
        "measured velocities from the Odometry twist, from its pose (smoothed differentiation), "
        "or 'auto' (default: the pose when the twist is zero or spiky while the pose moves, "
        "which it says)"
    )
    # the choices of sim2real.logs.read_trace, each with 'auto' (the reader chooses) as default
    for flag, choices, text in (
        ("--time-source", ("header", "log"), time_source),
        ("--odom-velocity", ("twist", "pose"), odom_velocity),
    ):
        parser.add_argument(flag, choices=("auto", *choices), default="auto", help=text)
    parser.add_argument(
        "--keep-all",
        action="store_true",
        help=(
            "keep the unattended samples: the robot moving with no command in force, or a "
            "command held while the wheels stay stopped (default: left out, with a note)"
        ),
    )


def gate_line(agreement: float | None, gate: float, *, what: str = "agreement") -> tuple[str, int]:
    """The ``--min-agreement`` verdict as one line and the exit code (0 passed, 1 failed).

    Examples
    --------
    >>> gate_line(0.93, 0.9)
    ('agreement 93.0 % is at or above --min-agreement 90.0 %: passed', 0)
    >>> gate_line(0.5, 0.9, what="pooled agreement")[1]
    1
    """
    value = (
        "n/a" if agreement is None or not math.isfinite(agreement) else f"{100 * agreement:.1f} %"
    )
    if agreement is not None and math.isfinite(agreement) and agreement >= gate:
        return f"{what} {value} is at or above --min-agreement {100 * gate:.1f} %: passed", 0
    return f"{what} {value} is below --min-agreement {100 * gate:.1f} %", 1


def read_options(args: argparse.Namespace) -> ReadOptions:
    """The parsed options of :func:`add_read_arguments` (their destinations are the fields'
    names), as the library's :class:`sim2real.logs.ReadOptions`.

    Examples
    --------
    >>> p = argparse.ArgumentParser()
    >>> add_read_arguments(p)
    >>> read_options(p.parse_args(["--time-source", "log"])).time_source
    'log'
    """
    return ReadOptions(**{f.name: getattr(args, f.name) for f in fields(ReadOptions)})
