"""Errors raised by :mod:`sysid` on data that cannot be fitted."""

from __future__ import annotations

__all__ = [
    "ExcitationError",
    "ResultFileError",
    "SysidError",
    "SysidFileError",
    "SysidValueError",
]


class SysidError(Exception):
    """Base class of every error raised on bad input by the :mod:`sysid` package."""


class SysidValueError(SysidError, ValueError):
    """An argument or a log's values break a rule (NaN, too short, bad window, ...)."""


class ExcitationError(SysidError, ValueError):
    """The log does not excite the model enough to identify anything (no motion, flat command)."""


class SysidFileError(SysidError, FileNotFoundError):
    """An output file cannot be written where asked (missing folder, path is a folder)."""


class ResultFileError(SysidError, ValueError):
    """A sysid result file is missing, not YAML, or not in the ``sim2real.sysid/1`` format."""
