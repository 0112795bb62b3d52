"""Shared reset/step plumbing of the observation-level randomizers."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, SupportsFloat

import gymnasium as gym

from randomizers._base import Randomizer, check_name, check_scale
from randomizers._select import Selection, index_kwarg, index_label

__all__ = ["ObservationRandomizer"]


class ObservationRandomizer(
    gym.ObservationWrapper[Any, Any, Any], Randomizer, gym.utils.RecordConstructorArgs
):
    """Base of the observation-level randomizers (not used directly).

    ``reset`` reseeds, calls :meth:`sample_episode`, resets the env, transforms the first
    observation and records :meth:`episode_record`; ``step`` transforms each observation and
    records :meth:`step_record` when it is not None.
    """

    _sel: Selection

    def _wrap_selection(
        self,
        env: gym.Env[Any, Any],
        sel: Selection,
        *,
        scale: Any,
        name: Any,
        options: Mapping[str, Any] | None = None,
        dtype: Any = None,
        **model: Any,
    ) -> None:
        """:meth:`_wrap` around the observation part ``sel``: check ``scale`` and ``name``
        (default ``Wrapper[key][start:stop]``, after the wrapper that selected ``sel``), record the ``model`` arguments, the selection
        (``key``, ``index``) and the ``options``, draw in ``dtype`` (default the part's) and
        keep ``sel``."""
        scale = check_scale(scale)
        name = check_name(name, env, sel.wrapper + index_label(sel.key, sel.index))
        self._wrap(
            env,
            **model,
            key=sel.key,
            index=index_kwarg(sel.index),
            **(options or {}),
            scale=scale,
            name=name,
            dtype=sel.dtype if dtype is None else dtype,
        )
        self._sel = sel

    def sample_episode(self) -> None:
        """Draw the per-episode values (after reseeding, before the env's reset)."""

    def start_episode(self, observation: Any) -> None:
        """Look at the env's first observation before it is transformed (e.g. fill buffers)."""

    def episode_record(self) -> dict[str, Any]:
        """What goes into ``info['randomization'][name]`` at reset."""
        return {"scale": self.scale}

    def step_record(self) -> dict[str, Any] | None:
        """What goes into ``info['randomization'][name]`` at each step (None: nothing)."""
        return None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the env; reseed this wrapper's generator when ``seed`` is given."""
        self._begin_episode(seed)
        self.sample_episode()
        obs, info = self.env.reset(seed=seed, options=options)
        self.start_episode(obs)
        return self.observation(obs), self._record(info, self.episode_record())

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the env and randomise the observation it returns."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        obs = self.observation(obs)
        record = self.step_record()
        if record is not None:
            self._record(info, record)
        return obs, reward, terminated, truncated, info
