"""Pick the part of an observation a wrapper acts on: a Dict key and/or an index range.

``key`` names an entry of a ``Dict`` observation space (one level); ``index`` picks a range of
the *last* axis of a ``Box`` (an int, a ``slice`` with step 1, or ``[start, stop)``), e.g.
``index=[2, 4]`` is CartPole's pole angle and angular velocity. Both may be combined. The
selected part is always a ``Box``; the wrapper returns a new observation and never writes into
the arrays the env returned.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from randomizers.errors import MissingObservationKeyError, RandomizerTypeError, RandomizerValueError

__all__ = ["Selection", "normalize_index", "select"]


def normalize_index(index: Any, length: int, *, wrapper: str) -> tuple[int, int] | None:
    """Turn ``index`` (int, slice, range or ``[start, stop]``) into ``(start, stop)``."""
    if index is None:
        return None
    if isinstance(index, bool):
        raise RandomizerTypeError(
            f"{wrapper}: argument 'index' must be an int, a slice or [start, stop], got {index!r}"
        )
    if isinstance(index, int | np.integer):
        start = int(index) + length if index < 0 else int(index)
        bounds: tuple[int, int] = (start, start + 1)
    elif isinstance(index, slice | range):
        if index.step not in (None, 1):
            raise RandomizerValueError(
                f"{wrapper}: argument 'index' must have step 1, got {index!r}; select a "
                "contiguous range"
            )
        start, stop, _ = slice(index.start, index.stop).indices(length)
        bounds = (start, stop)
    elif (
        isinstance(index, Sequence)
        and len(index) == 2
        and all(isinstance(i, int | np.integer) and not isinstance(i, bool) for i in index)
    ):
        start, stop, _ = slice(int(index[0]), int(index[1])).indices(length)
        bounds = (start, stop)
    else:
        raise RandomizerTypeError(
            f"{wrapper}: argument 'index' must be an int, a slice or [start, stop], got {index!r}"
        )
    if not 0 <= bounds[0] < bounds[1] <= length:
        raise RandomizerValueError(
            f"{wrapper}: argument 'index' must select at least one of the {length} entries of "
            f"the last axis, got {index!r}; pick indices in [0, {length})"
        )
    return bounds


@dataclass(frozen=True, kw_only=True)
class Selection:
    """The resolved target of an observation-level wrapper.

    Attributes
    ----------
    key : str or None
        Dict key, or None for a Box observation.
    index : tuple of int or None
        ``(start, stop)`` on the last axis, or None for the whole entry.
    space : gymnasium.spaces.Box
        The Box of the selected entry (before ``index``).
    low, high : ndarray
        Bounds of the selected part (after ``index``), in the space's dtype.
    bounded : bool
        True when any bound is finite (clipping may change values).
    wrapper : str
        The wrapper that selected it (its messages and default name start with it).
    """

    key: str | None
    index: tuple[int, int] | None
    space: spaces.Box
    low: np.ndarray
    high: np.ndarray
    bounded: bool
    wrapper: str

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of the selected part."""
        return tuple(self.low.shape)

    @property
    def dtype(self) -> np.dtype[Any]:
        """dtype of the selected part (the space's)."""
        return np.dtype(self.space.dtype)

    def get(self, obs: Any) -> np.ndarray:
        """Return the selected part of ``obs`` (a view; do not write into it)."""
        arr = np.asarray(obs[self.key] if self.key is not None else obs)
        if self.index is not None:
            return arr[..., self.index[0] : self.index[1]]
        return arr

    def put(self, obs: Any, part: np.ndarray) -> Any:
        """Return a copy of ``obs`` whose selected part is ``part`` (``obs`` is untouched)."""
        if self.index is not None:
            whole = np.array(obs[self.key] if self.key is not None else obs, copy=True)
            whole[..., self.index[0] : self.index[1]] = part
        else:
            whole = part
        if self.key is None:
            return whole
        out = dict(obs)
        out[self.key] = whole
        return out

    def clip(self, part: np.ndarray) -> np.ndarray:
        """Clip ``part`` in place to the space's bounds (no-op for an unbounded Box)."""
        if self.bounded:  # maximum/minimum: much cheaper than np.clip on small arrays
            np.maximum(part, self.low, out=part)
            np.minimum(part, self.high, out=part)
        return part


def select(
    observation_space: spaces.Space[Any],
    *,
    key: str | None,
    index: Any,
    wrapper: str,
    float_only: bool = True,
) -> Selection:
    """Resolve ``key``/``index`` against ``observation_space`` (clear errors otherwise)."""
    sub, where = _entry(observation_space, key, wrapper)
    if not isinstance(sub, spaces.Box):
        raise RandomizerTypeError(
            f"{wrapper}: {where} must be a gymnasium Box, got {type(sub).__name__} ({sub}); "
            "apply the wrapper to a Box entry"
        )
    if float_only and not np.issubdtype(sub.dtype, np.floating):
        raise RandomizerTypeError(
            f"{wrapper}: {where} must have a floating dtype, got {sub.dtype}; convert it "
            "with gymnasium.wrappers.DtypeObservation first"
        )
    if index is not None and len(sub.shape) == 0:
        raise RandomizerTypeError(f"{wrapper}: argument 'index' needs a Box with at least 1 axis")
    bounds = normalize_index(index, sub.shape[-1], wrapper=wrapper) if sub.shape else None
    low, high = sub.low, sub.high
    if bounds is not None:
        low = low[..., bounds[0] : bounds[1]]
        high = high[..., bounds[0] : bounds[1]]
    bounded = bool(np.isfinite(low).any() or np.isfinite(high).any())
    return Selection(
        key=key,
        index=bounds,
        space=sub,
        low=np.ascontiguousarray(low),
        high=np.ascontiguousarray(high),
        bounded=bounded,
        wrapper=wrapper,
    )


def _entry(
    observation_space: spaces.Space[Any], key: str | None, wrapper: str
) -> tuple[spaces.Space[Any], str]:
    """The space ``key`` names (the whole space without a key) and how errors call it."""
    if not isinstance(observation_space, spaces.Dict):
        if key is not None:
            raise RandomizerTypeError(
                f"{wrapper}: argument 'key'={key!r} needs a Dict observation space, but it is "
                f"{type(observation_space).__name__}; drop 'key' (use 'index' for a Box)"
            )
        return observation_space, "the observation space"
    keys = list(observation_space.spaces)
    if key is None:
        raise RandomizerValueError(
            f"{wrapper}: argument 'key' is required for a Dict observation space; "
            f"keys present: {keys}"
        )
    if key not in observation_space.spaces:
        raise MissingObservationKeyError(
            f"{wrapper}: argument 'key'={key!r} is not in the observation space; keys "
            f"present: {keys}"
        )
    return observation_space.spaces[key], f"observation entry '{key}'"


def index_label(key: str | None, index: tuple[int, int] | None) -> str:
    """Short text for names: ``[depth]``, ``[2:4]``, ``[goal][0:2]`` or ``''``."""
    text = f"[{key}]" if key is not None else ""
    if index is not None:
        text += f"[{index[0]}:{index[1]}]"
    return text


def index_kwarg(index: tuple[int, int] | None) -> list[int] | None:
    """``(start, stop)`` as the YAML-friendly list recorded in the wrapper's kwargs."""
    return None if index is None else [index[0], index[1]]
