"""Test helper: run a command on a pseudo-terminal, as a user at a terminal would see it."""

from __future__ import annotations

import os
import pty
import select
import subprocess
from pathlib import Path

__all__ = ["LIVE", "on_a_terminal", "terminal_env"]

#: A live rich progress display hides the cursor while it draws.
LIVE = "\x1b[?25l"


def terminal_env() -> dict[str, str]:
    """This process's environment as a colour terminal of 120 x 40 would have it."""
    env = {k: v for k, v in os.environ.items() if k not in ("NO_COLOR", "CI", "FORCE_COLOR")}
    env.update(TERM="xterm-256color", COLUMNS="120", LINES="40")
    return env


def on_a_terminal(argv: list[str], cwd: Path) -> tuple[int, str]:
    """Run ``argv`` with stdout and stderr on a pseudo-terminal; returns (exit code, output)."""
    master, slave = pty.openpty()
    proc = subprocess.Popen(
        argv, stdout=slave, stderr=slave, stdin=subprocess.DEVNULL, cwd=cwd, env=terminal_env()
    )
    os.close(slave)
    chunks = []
    while True:
        ready, _, _ = select.select([master], [], [], 1.0)
        if ready:
            try:
                data = os.read(master, 65536)
            except OSError:  # the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
        elif proc.poll() is not None:
            break
    os.close(master)
    return proc.wait(timeout=600), b"".join(chunks).decode("utf-8", "replace")
