"""pybullet, imported without its "pybullet build time" banner (private).

pybullet's C module prints a build-time banner from C when it is first imported (to stdout in
some builds, stderr in others), which would corrupt piped output such as ``--json`` on stdout.
:func:`quiet_import` points file descriptors 1 and 2 at ``os.devnull`` around the first import
and flushes C's stdio buffers before restoring them. Every module of the project imports
pybullet through ``from robots._pybullet import pybullet``.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from types import ModuleType

__all__ = ["pybullet", "quiet_import"]


def _flush_c_stdio() -> None:
    with contextlib.suppress(OSError, AttributeError):  # no POSIX libc to flush
        ctypes.CDLL(None).fflush(None)


def quiet_import() -> ModuleType:
    """Import pybullet with stdout and stderr silenced at the file-descriptor level."""
    if "pybullet" in sys.modules:
        return sys.modules["pybullet"]
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        import pybullet as module
    finally:
        _flush_c_stdio()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)
    return module


pybullet = quiet_import()
