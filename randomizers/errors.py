"""Errors raised by :mod:`randomizers` on bad wrapper arguments and envs that lack a protocol.

The classes also inherit the matching builtin (``ValueError``, ``TypeError``, ``KeyError``,
``AttributeError``) so ``except ValueError`` in user code keeps working.
"""

from __future__ import annotations

__all__ = [
    "MissingObservationKeyError",
    "MissingProtocolError",
    "RandomizationNotAppliedError",
    "RandomizerConfigError",
    "RandomizerError",
    "RandomizerTypeError",
    "RandomizerValueError",
]


class RandomizerError(Exception):
    """Base class of every error raised on bad input by the :mod:`randomizers` package."""


class RandomizerValueError(RandomizerError, ValueError):
    """A wrapper argument breaks its rule (negative std, delay < 0, scale outside [0, 1], ...)."""


class RandomizerTypeError(RandomizerError, TypeError):
    """A wrapped env's space has the wrong type for the wrapper (e.g. Discrete where Box needed)."""


class MissingObservationKeyError(RandomizerError, KeyError):
    """A wrapper names an observation key the env's Dict space does not have."""

    def __str__(self) -> str:  # KeyError would otherwise quote the message
        return str(self.args[0]) if self.args else ""


class MissingProtocolError(RandomizerError, AttributeError):
    """A physics-level wrapper needs a method (e.g. ``set_drive_params``) the env lacks."""


class RandomizationNotAppliedError(RandomizerError, RuntimeError):
    """The env accepted a protocol call (``set_camera_pose``, ``set_drive_params``) without effect."""


class RandomizerConfigError(RandomizerValueError):
    """A randomizer config (YAML file or dict) is missing, malformed or names an unknown wrapper."""
