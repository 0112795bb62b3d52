"""Observation randomizers on a gymnasium vector env: one wrapper stack per sub-env.

A native vector env (``gym.make_vec(..., vectorization_mode="vector_entry_point")``) takes no
single-env wrappers, and gymnasium's own vector observation wrappers share one function (one
generator) between all sub-envs, which would draw other noise than N wrapped single envs.
:class:`VectorObservationRandomizer` instead builds the given stack of observation randomizers
once per sub-env, around a stand-in env that hands the stack sub-env *i*'s observation. Each
stack is reset with sub-env *i*'s seed (``seed + i``, gymnasium's rule), keeps its own stream
across autoresets, and so draws exactly what the same stack around the single env would in a
``SyncVectorEnv``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv, VectorWrapper
from gymnasium.vector.utils import concatenate, create_empty_array, iterate

from randomizers._base import INFO_KEY, Randomizer, check_scale
from randomizers._observation import ObservationRandomizer
from randomizers.errors import RandomizerTypeError, RandomizerValueError

__all__ = ["VectorObservationRandomizer"]


class _SubEnv(gym.Env[Any, Any]):
    """Stand-in single env: returns the observation it was handed (sub-env *i*'s)."""

    def __init__(self, observation_space: gym.Space[Any], action_space: gym.Space[Any]) -> None:
        self.observation_space = observation_space
        self.action_space = action_space
        self.next_obs: Any = None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        return self.next_obs, {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        return self.next_obs, 0.0, False, False, {}


def _check_stack(stack: Any, stub: _SubEnv) -> None:
    """Refuse a stack that is not made of observation randomizers only."""
    layer = stack
    while layer is not stub:
        if not isinstance(layer, ObservationRandomizer):
            raise RandomizerTypeError(
                "VectorObservationRandomizer: argument 'wrap' must build observation "
                f"randomizers only (DepthNoise, LidarNoise, ...), got {type(layer).__name__}; "
                "apply action, delay or dynamics randomizers to the single env "
                "(vectorization_mode='sync') or through the env's own arguments"
            )
        layer = layer.env


class VectorObservationRandomizer(VectorWrapper):
    """Apply a stack of observation randomizers to every sub-env of a vector env.

    Parameters
    ----------
    env : gymnasium.vector.VectorEnv
        The vector env (``NEXT_STEP`` autoreset, gymnasium's default).
    wrap : callable
        Builds the stack on a single env, e.g.
        ``lambda e: LidarNoise(e, std_m=0.02, dropout=0.05)``; called once per sub-env.

    Notes
    -----
    Sub-env *i* gets the noise the same stack would add around the single env in gymnasium's
    ``SyncVectorEnv`` with the same seeds (tested). ``info["randomization"]`` holds the
    stacks' records with gymnasium's per-key masks. :func:`randomizers.set_scale` works on it.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> from randomizers import ObservationNoise, VectorObservationRandomizer
    >>> envs = gym.make_vec("CartPole-v1", num_envs=2, vectorization_mode="sync")
    >>> noisy = VectorObservationRandomizer(envs, lambda e: ObservationNoise(e, std=0.1))
    >>> obs, info = noisy.reset(seed=0)
    >>> obs.shape, sorted(info["randomization"])
    ((2, 4), ['ObservationNoise', '_ObservationNoise'])
    """

    def __init__(
        self, env: VectorEnv, wrap: Callable[[gym.Env[Any, Any]], gym.Env[Any, Any]]
    ) -> None:  # type: ignore[type-arg]
        super().__init__(env)
        mode = env.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP)
        if mode != AutoresetMode.NEXT_STEP:
            raise RandomizerValueError(
                f"VectorObservationRandomizer needs a vector env with NEXT_STEP autoreset "
                f"(gymnasium's default), got {mode}; create it with the default autoreset_mode"
            )
        if not callable(wrap):
            raise RandomizerTypeError(
                f"VectorObservationRandomizer: argument 'wrap' must be a callable building the "
                f"stack on a single env, got {wrap!r}"
            )
        self._stubs = [
            _SubEnv(env.single_observation_space, env.single_action_space)
            for _ in range(env.num_envs)
        ]
        control_dt = getattr(env.unwrapped, "control_dt", None)
        for stub in self._stubs:
            if control_dt is not None:
                stub.control_dt = control_dt  # type: ignore[attr-defined]
        #: The per-sub-env stacks (stack ``i`` randomises sub-env ``i``).
        self.stacks = [wrap(stub) for stub in self._stubs]
        for stack, stub in zip(self.stacks, self._stubs, strict=True):
            _check_stack(stack, stub)
        self.single_observation_space = self.stacks[0].observation_space
        self._autoreset = np.zeros(env.num_envs, dtype=np.bool_)

    def _seeds(self, seed: int | Sequence[int | None] | None) -> list[int | None]:
        n = self.num_envs
        if seed is None:
            return [None] * n
        if isinstance(seed, int | np.integer) and not isinstance(seed, bool):
            return [int(seed) + i for i in range(n)]
        return list(seed)  # type: ignore[arg-type]

    def _merge(self, infos: dict[str, Any], info: dict[str, Any], i: int) -> dict[str, Any]:
        record = info.get(INFO_KEY)
        if record:
            infos = VectorEnv._add_info(self, infos, {INFO_KEY: record}, i)  # type: ignore[arg-type]
        return infos

    def _apply(self, obs: Any, rows: list[Any], indices: Sequence[int]) -> Any:
        """The batch ``obs`` with the randomised ``rows`` of sub-envs ``indices``."""
        items = list(iterate(self.env.observation_space, obs))
        for i, row in zip(indices, rows, strict=True):
            items[i] = row
        out: Any = create_empty_array(self.single_observation_space, self.num_envs)
        return concatenate(self.single_observation_space, items, out)

    def reset(
        self,
        *,
        seed: int | list[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the vector env and the stacks of the sub-envs it reset (stack i: seed + i)."""
        mask = None if options is None else options.get("reset_mask")
        obs, infos = self.env.reset(seed=seed, options=options)  # type: ignore[arg-type]
        seeds = self._seeds(seed)
        if len(seeds) != self.num_envs:
            raise RandomizerValueError(
                f"reset(seed=...) needs an int, None or {self.num_envs} seeds, got {len(seeds)}"
            )
        indices = range(self.num_envs) if mask is None else np.flatnonzero(mask).tolist()
        rows = list(iterate(self.env.observation_space, obs))
        out_rows = []
        for i in indices:
            self._stubs[i].next_obs = rows[i]
            row, info = self.stacks[i].reset(seed=seeds[i])
            out_rows.append(row)
            infos = self._merge(infos, info, i)
            self._autoreset[i] = False
        return self._apply(obs, out_rows, list(indices)), infos

    def step(self, actions: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        """Step the vector env; each stack randomises its sub-env's observation (a stack
        whose sub-env resets in this step starts its next episode, without reseeding)."""
        obs, rewards, terminated, truncated, infos = self.env.step(actions)
        rows = list(iterate(self.env.observation_space, obs))
        out_rows = []
        for i, stack in enumerate(self.stacks):
            self._stubs[i].next_obs = rows[i]
            if self._autoreset[i]:
                row, info = stack.reset()
            else:
                row, _, _, _, info = stack.step(None)
            out_rows.append(row)
            infos = self._merge(infos, info, i)
        self._autoreset = np.logical_or(terminated, truncated)
        return (
            self._apply(obs, out_rows, range(self.num_envs)),
            rewards,
            terminated,
            truncated,
            infos,
        )

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """``set_randomization_scale`` reaches every stack; other names go to the env."""
        if name == "set_randomization_scale":
            scale = check_scale(args[0] if args else kwargs["scale"])
            counts = []
            for stack in self.stacks:
                assert isinstance(stack, Randomizer)
                counts.append(stack.set_randomization_scale(scale))
            return tuple(counts)
        inner: Any = self.env
        return tuple(inner.call(name, *args, **kwargs))
