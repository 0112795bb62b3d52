"""Errors raised by :mod:`robots` on bad specs, parameter files and robot names."""

from __future__ import annotations

__all__ = [
    "ParamsFileError",
    "RobotsError",
    "RobotsValueError",
    "SpecError",
    "UnknownRobotError",
]


class RobotsError(Exception):
    """Base class of every error raised on bad input by the :mod:`robots` package."""


class RobotsValueError(RobotsError, ValueError):
    """An argument or parameter has a non-physical value (negative mass, delay < 0, ...)."""


class UnknownRobotError(RobotsError, KeyError):
    """A robot name is not one of the shipped specs; the message lists the known names."""

    def __str__(self) -> str:  # KeyError would otherwise quote the message
        return str(self.args[0]) if self.args else ""


class SpecError(RobotsError, ValueError):
    """A robot spec file has a missing, unknown or non-physical key."""


class ParamsFileError(RobotsError, ValueError):
    """A drive-parameter file (sysid result) is unreadable, for another robot, or invalid."""
