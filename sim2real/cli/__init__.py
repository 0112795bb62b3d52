"""The ``sim2real`` command line: a thin layer over the library functions.

Each command group's arguments are defined in a light module of :mod:`sim2real.cli._parsers`
(``register(subparsers)``), which names the command's handler as ``"GROUP:function"``. The
handlers live in the private modules of :data:`HANDLER_MODULES` (``_logs``, ``_robots``,
``_sysid``, ...), which import what they need at their top; :func:`main` imports the one the
command needs, so ``--help`` and light commands never load the heavy libraries. Handlers
return an exit code. Bad input raises one of the packages' error types; :func:`main` prints
its one-line message to stderr and returns 2 (``--debug`` shows the traceback instead).

Examples
--------
>>> from sim2real.cli import main
>>> main(["robots", "list"])  # doctest: +SKIP
0
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import importlib
import os
import select
import sys
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import sim2real
from randomizers.errors import RandomizerError
from robots.errors import RobotsError
from sim2real.cli._common import EPILOG_MAIN, HelpFormatter, OneLineErrorParser
from sim2real.cli._parsers import GROUPS
from sim2real.errors import Sim2RealError, Sim2RealWarning
from sysid.errors import SysidError

__all__ = ["HANDLER_MODULES", "USER_ERRORS", "build_parser", "handler", "main", "run"]

#: The module of each command group's handlers (``set_defaults(handler="GROUP:function")``):
#: the CLI's deferred imports, in one place. :func:`main` imports only the module of the
#: command that runs, which keeps the start-up budget of ``--help`` and the light commands
#: (``tests/sim2real/test_import_budget.py``).
HANDLER_MODULES: dict[str, str] = {
    "logs": "sim2real.cli._logs",
    "robots": "sim2real.cli._robots",
    "sysid": "sim2real.cli._sysid",
    "sensors": "sim2real.cli._sensors",
    "result": "sim2real.cli._result",
    "calibrate": "sim2real.cli._calibrate",
    "agree": "sim2real.cli._agree",
    "envs": "sim2real.cli._envs",
    "train": "sim2real.cli._train",
    "demo": "sim2real.cli._demo",
}

#: Exceptions that mean "bad input": printed as one sentence, exit code 2.
USER_ERRORS: tuple[type[BaseException], ...] = (
    Sim2RealError,
    RobotsError,
    SysidError,
    RandomizerError,
)


class _VersionAction(argparse.Action):
    """``--version``: looks the version up only when asked (importlib.metadata is slow)."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        print(f"sim2real {sim2real.__version__}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``sim2real`` command with every subcommand registered."""
    parser = OneLineErrorParser(
        prog="sim2real",
        description="Close the sim-to-real gap of mobile-robot navigation policies.",
        epilog=EPILOG_MAIN,
        formatter_class=HelpFormatter,
    )
    parser.add_argument(
        "--version", action=_VersionAction, nargs=0, help="show the version number and exit"
    )
    parser.add_argument("--debug", action="store_true", help="show the full traceback on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for group in GROUPS:
        group.register(sub)
    return parser


def handler(name: str) -> Callable[[argparse.Namespace], int]:
    """The handler function a parser names as ``"GROUP:function"`` (its module imported now).

    Examples
    --------
    >>> handler("robots:handle_list").__name__
    'handle_list'
    """
    group, _, function = name.partition(":")
    module = importlib.import_module(HANDLER_MODULES[group])
    run_command: Callable[[argparse.Namespace], int] = getattr(module, function)
    return run_command


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (0 ok, 1 gate failed, 2 bad input, 141 stdout closed)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with _warnings_as_lines():
            return int(handler(args.handler)(args))
    except USER_ERRORS as exc:
        if args.debug:
            raise
        message = " ".join(str(exc).split())  # one line even if a message embeds newlines
        print(f"sim2real: error: {message}", file=sys.stderr)
        return 2
    except (FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError) as exc:
        if args.debug:
            raise
        name = getattr(exc, "filename", None)
        where = f" '{name}'" if name else ""
        print(
            f"sim2real: error: cannot use path{where}: {exc.strerror or exc}; "
            "check that it exists and is writable",
            file=sys.stderr,
        )
        return 2
    except BrokenPipeError:
        if not _stdout_closed():
            raise  # another pipe (a training env's worker process that died): not to hide
        # whoever read stdout has gone (`sim2real logs info run.bag | head -3`): stop quietly,
        # with stdout on /dev/null so the interpreter's last flush cannot fail again
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141  # 128 + SIGPIPE, the shell's status of a process a closed pipe stopped
    except KeyboardInterrupt:
        print("sim2real: interrupted", file=sys.stderr)
        return 130


@contextlib.contextmanager
def _warnings_as_lines() -> Iterator[None]:
    """Print the package's warnings (:class:`~sim2real.errors.Sim2RealWarning`) as one line
    each, ``sim2real: warning: ...``, every time; other warnings as Python shows them."""
    original = warnings.showwarning

    def show(message: Warning | str, category: type[Warning], *args: Any, **kwargs: Any) -> None:
        if issubclass(category, Sim2RealWarning):
            print(f"sim2real: warning: {' '.join(str(message).split())}", file=sys.stderr)
        else:
            original(message, category, *args, **kwargs)

    with warnings.catch_warnings():
        warnings.simplefilter("always", Sim2RealWarning)
        warnings.showwarning = show
        yield


def run() -> int:
    """The ``sim2real`` console command: :func:`main` on ``sys.argv``, then a lean exit.

    Once the command is done, the garbage collector is frozen (:func:`gc.freeze`) so that the
    interpreter's teardown frees the remaining objects by reference counting only, without
    the cyclic collections it would otherwise run over them (after an ``agree`` with numba,
    pybullet and Ray loaded, over a hundred thousand tracked objects); the same trick as
    Instagram's exit without a final collection ("Dismissing Python Garbage Collection at
    Instagram", 2017). Files, subprocesses and ``atexit`` handlers are closed as before (they
    do not depend on the cyclic collector), and objects kept alive only by a reference cycle
    are not finalised at exit, which CPython never promised anyway. :func:`main` itself,
    which tests call in-process, leaves the collector alone.
    """
    code = main()
    gc.freeze()
    return code


def _stdout_closed() -> bool:
    """Whether stdout is a pipe whose reader has gone (``poll`` flags an error on it).

    A BrokenPipeError can also come from a pipe to a child process (SB3's ``SubprocVecEnv``
    workers, Ray); only a closed stdout is the quiet exit 141.
    """
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # replaced by an object without a descriptor
        return False
    if not hasattr(select, "poll"):  # pragma: no cover - not on Linux or macOS
        return True
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    return any(events & select.POLLERR for _, events in poller.poll(0))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
