"""Errors raised by :mod:`sim2real` (log I/O, replay, agreement, report, CLI).

Every message is one plain sentence that names the file, topic or argument, the rule, the
value received and the fix. The CLI prints it and exits with code 2.
"""

from __future__ import annotations

__all__ = [
    "ClusterLostWarning",
    "LogFormatError",
    "LogValueError",
    "MissingTopicError",
    "Sim2RealError",
    "Sim2RealFileNotFoundError",
    "Sim2RealValueError",
    "Sim2RealWarning",
]


class Sim2RealWarning(UserWarning):
    """Base class of the warnings of the :mod:`sim2real` package (the CLI prints them)."""


class ClusterLostWarning(Sim2RealWarning, RuntimeWarning):
    """Ray failed during a run (its node or worker died); the work it held ran here instead."""


class Sim2RealError(Exception):
    """Base class of every error raised on bad input by the :mod:`sim2real` package."""


class Sim2RealValueError(Sim2RealError, ValueError):
    """An argument has a value outside its rule (tolerance <= 0, window out of range, ...)."""


class Sim2RealFileNotFoundError(Sim2RealError, FileNotFoundError):
    """A named input file or output folder does not exist."""


class LogFormatError(Sim2RealError, ValueError):
    """A log file is not a readable MCAP file (empty, truncated, corrupt, unknown encoding)."""


class MissingTopicError(Sim2RealError, LookupError):
    """A log has no topic usable for the requested role (command or measurement)."""


class LogValueError(Sim2RealError, ValueError):
    """A log's values cannot be used (NaN/inf, non-monotonic time that cannot be repaired)."""
