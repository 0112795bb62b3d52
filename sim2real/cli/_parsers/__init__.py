"""The argument parsers of the ``sim2real`` commands, one module per command group.

These modules import only :mod:`argparse` and light helpers, so ``sim2real --help`` and the
parsing of any command stay fast. Each command names its handler as ``"GROUP:function"``
(``set_defaults(handler=...)``); :func:`sim2real.cli.main` imports the group's handler module
(:data:`sim2real.cli.HANDLER_MODULES`) only for the command that runs.
"""

from __future__ import annotations

from sim2real.cli._parsers import agree, demo, envs, logs, robots, sysid, train

__all__ = ["GROUPS"]

#: The command groups in the order ``sim2real --help`` lists them.
GROUPS = (logs, robots, sysid, agree, envs, train, demo)
