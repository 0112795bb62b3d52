"""Reward constants given as a dataclass or as a mapping of its fields (env kwargs from YAML)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from typing import Any, TypeVar

from sim2real.errors import Sim2RealValueError

__all__ = ["reward_constants"]

R = TypeVar("R")


def reward_constants(cls: type[R], value: R | Mapping[str, Any] | None, example: str) -> R:
    """``value`` as ``cls``: as it is, the defaults for None, or a mapping's fields as floats.

    ``example`` is one valid field (``"stop"``) for the message of a wrong key or value.

    Examples
    --------
    >>> from sim2real.envs.race import RaceReward
    >>> reward_constants(RaceReward, {"stop": 0.1}, "stop").stop
    0.1
    """
    if value is None:
        return cls()
    if isinstance(value, cls):
        return value
    names = [f.name for f in fields(cls)]  # type: ignore[arg-type]
    if not isinstance(value, Mapping) or set(value) - set(names):
        extra = sorted(set(value) - set(names)) if isinstance(value, Mapping) else value
        raise Sim2RealValueError(
            f"reward must be a {cls.__name__} or a mapping of its fields ({', '.join(names)}), "
            f"got {extra!r}; e.g. reward: {{{example}: 0.1}}"
        )
    for key, number in value.items():
        if isinstance(number, bool) or not isinstance(number, int | float):
            raise Sim2RealValueError(
                f"reward.{key} must be a number, got {number!r}; e.g. reward: {{{key}: 0.1}}"
            )
    return cls(**{key: float(number) for key, number in value.items()})
