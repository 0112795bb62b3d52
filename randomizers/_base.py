"""What every randomizer shares: its own seeded generator, a curriculum scale, info records.

Seeding
-------
Each randomizer owns a :class:`numpy.random.Generator` built from the seed given to ``reset``
and a stream key derived from the randomizer's *name* (class name plus the observation key or
index it acts on, or the ``name`` argument)::

    SeedSequence(entropy=seed, spawn_key=blake2b(name) as two uint32 words)

The key depends on nothing else in the stack, so adding, removing or reordering other wrappers
never changes this wrapper's draws, and two randomizers in one stack may not share a name.
``reset(seed=s)`` rebuilds the generator (same episode again); ``reset()`` without a seed keeps
drawing from the current one (fresh OS entropy if the env was never seeded), as gymnasium's
``np_random`` does.

Scale
-----
``scale`` in [0, 1] multiplies the wrapper's noise, jitter, delay or range (the
complexity factor c of Liang et al. 2020, generalised). :meth:`Randomizer.set_scale` takes effect at the next
``reset`` so an episode never changes its randomisation half-way.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterator, Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from randomizers._gauss import NormalPool
from randomizers.errors import RandomizerTypeError, RandomizerValueError

__all__ = [
    "Randomizer",
    "iter_randomizers",
    "set_scale",
    "stream_key",
]

INFO_KEY = "randomization"


def stream_key(name: str) -> tuple[int, int]:
    """Stable 2 x uint32 spawn key of a randomizer name (blake2b; same on every platform)."""
    digest = hashlib.blake2b(name.encode("utf-8"), digest_size=8).digest()
    return int.from_bytes(digest[:4], "little"), int.from_bytes(digest[4:], "little")


def check_scale(scale: Any, *, argument: str = "scale") -> float:
    """Return ``scale`` as a float after checking it is a number in [0, 1]."""
    value = check_number(scale, argument=argument)
    if not 0.0 <= value <= 1.0:
        raise RandomizerValueError(
            f"argument '{argument}' must be in [0, 1] (0 = no randomisation, 1 = full), "
            f"got {scale!r}; pass a value between 0 and 1"
        )
    return value


def check_number(value: Any, *, argument: str) -> float:
    """Return ``value`` as a finite float or raise a :class:`RandomizerTypeError`/ValueError."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise RandomizerTypeError(
            f"argument '{argument}' must be a number, got {value!r} "
            f"({type(value).__name__}); pass a float"
        )
    out = float(value)
    if not math.isfinite(out):
        raise RandomizerValueError(
            f"argument '{argument}' must be finite, got {value!r}; pass a finite number"
        )
    return out


def check_nonnegative(value: Any, *, argument: str, unit: str = "") -> float:
    """Return ``value`` as a float after checking it is finite and >= 0."""
    out = check_number(value, argument=argument)
    if out < 0:
        unit_text = f" {unit}" if unit else ""
        raise RandomizerValueError(
            f"argument '{argument}' must be >= 0{unit_text}, got {value!r}; "
            "pass a non-negative value (0 disables it)"
        )
    return out


def check_choice(value: Any, *, argument: str, choices: tuple[str, ...]) -> str:
    """Return ``value`` after checking it is one of ``choices``."""
    if value not in choices:
        raise RandomizerValueError(
            f"argument '{argument}' must be one of {list(choices)}, got {value!r}"
        )
    return str(value)


def check_name(name: Any, env: gym.Env[Any, Any], default: str) -> str:
    """Return the randomizer's name; refuse one already used by a randomizer below ``env``."""
    if name is None:
        name = default
    if not isinstance(name, str) or not name:
        raise RandomizerTypeError(
            f"argument 'name' must be a non-empty string, got {name!r}; pass e.g. name='{default}'"
        )
    taken = [r.name for r in iter_randomizers(env)]
    if name in taken:
        raise RandomizerValueError(
            f"argument 'name': a randomizer named '{name}' is already in this stack (names in "
            f"use: {taken}); names key the random streams, so give this one another name, "
            f"e.g. name='{name}#2'"
        )
    return name


class Randomizer:
    """Mixin of every randomizer wrapper: generator, curriculum scale and info records.

    Subclasses call :meth:`_wrap` (or :meth:`_init_randomizer`) in ``__init__`` and :meth:`_begin_episode` at the
    start of ``reset`` (before drawing anything), and put their samples in
    ``info["randomization"][self.name]`` with :meth:`_record`.

    Attributes
    ----------
    name : str
        Unique name in the stack; keys the random stream and the info record.
    rng : numpy.random.Generator
        This randomizer's own generator (see the module docstring for how it is seeded).
    """

    name: str
    rng: np.random.Generator
    _scale: float
    _next_scale: float
    _normals: NormalPool
    _saved_kwargs: dict[str, Any]

    def _init_randomizer(self, name: str, scale: float, dtype: Any = np.float64) -> None:
        self.name = name
        self._scale = scale
        self._next_scale = scale
        self.rng = np.random.Generator(np.random.PCG64(self._seed_sequence(None)))
        self._normals = NormalPool(dtype)

    def _wrap(
        self,
        env: gym.Env[Any, Any],
        *,
        name: str,
        scale: float,
        dtype: Any = np.float64,
        **arguments: Any,
    ) -> None:
        """Wrap ``env``: record the constructor ``arguments``, then ``scale`` and ``name`` (what
        ``env.spec`` and a saved config show), and :meth:`_init_randomizer`."""
        gym.utils.RecordConstructorArgs.__init__(self, **arguments, scale=scale, name=name)  # type: ignore[arg-type]
        gym.Wrapper.__init__(self, env)  # type: ignore[arg-type]
        self._init_randomizer(name, scale, dtype)

    def _standard_normal(self, n: int) -> np.ndarray:
        """``n`` i.i.d. N(0, 1) samples from this randomizer's stream (a short-lived view)."""
        return self._normals.take(self.rng, n)

    def _seed_sequence(self, seed: int | None) -> np.random.SeedSequence:
        return np.random.SeedSequence(entropy=seed, spawn_key=stream_key(self.name))

    @property
    def scale(self) -> float:
        """Curriculum scale in effect for the current episode, in [0, 1]."""
        return self._scale

    def set_scale(self, scale: float) -> None:
        """Set the scale in [0, 1] used from the next ``reset`` on (also recorded for ``spec``).

        Examples
        --------
        >>> import gymnasium as gym
        >>> from randomizers import ObservationNoise
        >>> env = ObservationNoise(gym.make("CartPole-v1"), std=0.1)
        >>> env.set_scale(0.5)
        >>> _ = env.reset(seed=0)
        >>> env.scale
        0.5
        """
        self._next_scale = check_scale(scale)
        self._saved_kwargs["scale"] = self._next_scale
        if isinstance(self, gym.Wrapper):
            self.__dict__["_cached_spec"] = None  # env.spec must show the new scale

    def set_randomization_scale(self, scale: float) -> int:
        """Set ``scale`` on this randomizer and every randomizer below it; return how many.

        Vector envs reach it with ``envs.call("set_randomization_scale", s)``.
        """
        return _set_stack_scale(self, check_scale(scale))

    def _begin_episode(self, seed: int | None) -> None:
        """Reseed (when ``seed`` is given) and apply a pending :meth:`set_scale`."""
        if seed is not None:
            self.rng = np.random.Generator(np.random.PCG64(self._seed_sequence(seed)))
            self._normals.clear()
        self._scale = self._next_scale

    def _record(self, info: dict[str, Any], values: Mapping[str, Any]) -> dict[str, Any]:
        """Put ``values`` into ``info["randomization"][self.name]`` and return ``info``."""
        record = info.get(INFO_KEY)
        if not isinstance(record, dict):
            record = {}
            info[INFO_KEY] = record
        record[self.name] = dict(values)
        return info


def iter_randomizers(env: Any) -> Iterator[Randomizer]:
    """Yield the randomizers of a wrapper stack, outermost first.

    Examples
    --------
    >>> import gymnasium as gym
    >>> from randomizers import ActionDelay, ObservationNoise
    >>> env = ObservationNoise(ActionDelay(gym.make("CartPole-v1"), delay_steps=1), std=0.1)
    >>> [r.name for r in iter_randomizers(env)]
    ['ObservationNoise', 'ActionDelay']
    """
    current = env
    while isinstance(current, gym.Wrapper):
        if isinstance(current, Randomizer):
            yield current
        current = current.env


def set_scale(env: Any, scale: float) -> int:
    """Set the curriculum scale of every randomizer in a stack (from the next reset on).

    Works on a single env and on a gymnasium ``VectorEnv`` (through ``call``). Returns the
    number of randomizers changed (per sub-env for vector envs).

    Examples
    --------
    >>> import gymnasium as gym
    >>> from randomizers import ObservationNoise
    >>> set_scale(ObservationNoise(gym.make("CartPole-v1"), std=0.1), 0.25)
    1
    """
    value = check_scale(scale)
    if isinstance(env, gym.vector.VectorEnv):
        vector: Any = env
        counts = vector.call("set_randomization_scale", value)
        return int(counts[0]) if len(counts) else 0
    return _set_stack_scale(env, value)


def _set_stack_scale(env: Any, scale: float) -> int:
    count = 0
    for randomizer in iter_randomizers(env):
        randomizer.set_scale(scale)
        count += 1
    current = env
    while isinstance(current, gym.Wrapper):  # outer wrappers cache specs with inner kwargs
        current.__dict__["_cached_spec"] = None
        current = current.env
    return count
