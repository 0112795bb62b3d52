"""Noise on the goal location the agent observes (Liang et al. 2020)."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from randomizers._base import check_choice, check_nonnegative
from randomizers._observation import ObservationRandomizer
from randomizers._select import select
from randomizers.errors import RandomizerValueError

__all__ = ["GoalNoise"]

_COORDS = ("cartesian", "polar")
_RESAMPLE = ("episode", "step")


class GoalNoise(ObservationRandomizer):
    r"""Offset the observed goal location by Gaussian noise, N(0, 0.2 m) per axis by default.

    Liang et al. (2020) add Gaussian noise to the robot's goal location in simulation. The offset
    :math:`\delta \sim \mathcal N(0, (c\,\sigma)^2 I)` is drawn once per episode (default:
    a consistently wrong goal, as from a poor localisation fix) or at every step
    (``resample="step"``: jittery goal).

    - ``coords="cartesian"``: the selected entries are goal coordinates in metres; the offset
      is added to each.
    - ``coords="polar"``: the selected 2 entries are (distance m, bearing rad). The goal point
      :math:`(d\cos\beta, d\sin\beta)` is offset, then converted back:
      :math:`d' = |p + \delta|`, :math:`\beta' = \mathrm{atan2}` in (-π, π].

    The offset lives in the frame the observation is expressed in: for a robot-relative goal a
    per-episode offset is fixed in the robot frame (it turns with the robot), not in the world.
    Results are clipped to the entry's Box bounds when ``clip`` is True.

    Parameters
    ----------
    env : gymnasium.Env
        Env with a float Box goal entry.
    std_m : float
        Standard deviation σ of each offset component, m (>= 0).
    key : str, optional
        Dict key of the goal (required for Dict spaces).
    index : int, slice or [start, stop], optional
        Range of the last axis holding the goal (2 entries for polar goals).
    coords : {"cartesian", "polar"}
        How the goal is written.
    resample : {"episode", "step"}
        Draw a new offset each episode or each step.
    clip : bool
        Clip to the entry's Box bounds.
    scale : float
        Curriculum scale c in [0, 1] multiplying σ.
    name : str, optional
        Unique name in the stack; default ``GoalNoise[<key>]``.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> from randomizers import GoalNoise
    >>> class Nav(gym.Env):
    ...     observation_space = gym.spaces.Dict(
    ...         {"goal": gym.spaces.Box(-10.0, 10.0, (2,), np.float32)})
    ...     action_space = gym.spaces.Discrete(1)
    ...     def reset(self, *, seed=None, options=None):
    ...         super().reset(seed=seed)
    ...         return {"goal": np.array([3.0, 4.0], np.float32)}, {}
    ...     def step(self, action):
    ...         return {"goal": np.array([3.0, 4.0], np.float32)}, 0.0, False, False, {}
    >>> env = GoalNoise(Nav(), std_m=0.2, key="goal")
    >>> obs, info = env.reset(seed=0)
    >>> offset = info["randomization"]["GoalNoise[goal]"]["offset_m"]
    >>> bool(np.allclose(obs["goal"], np.array([3.0, 4.0]) + offset, atol=1e-6))
    True
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        std_m: float = 0.2,
        *,
        key: str | None = None,
        index: Any = None,
        coords: str = "cartesian",
        resample: str = "episode",
        clip: bool = True,
        scale: float = 1.0,
        name: str | None = None,
    ) -> None:
        sel = select(env.observation_space, key=key, index=index, wrapper="GoalNoise")
        std_m = check_nonnegative(std_m, argument="std_m", unit="m")
        coords = check_choice(coords, argument="coords", choices=_COORDS)
        resample = check_choice(resample, argument="resample", choices=_RESAMPLE)
        width = sel.shape[-1] if sel.shape else 1
        if coords == "polar" and width != 2:
            raise RandomizerValueError(
                f"GoalNoise: coords='polar' needs exactly 2 entries (distance, bearing) on the "
                f"last axis, got {width}; select them with 'index'"
            )
        self._wrap_selection(
            env,
            sel,
            scale=scale,
            name=name,
            std_m=std_m,
            options={"coords": coords, "resample": resample, "clip": bool(clip)},
            dtype=np.float64,
        )
        self.std_m = std_m
        self.coords = coords
        self.resample = resample
        self._clip = bool(clip)
        self._width = 2 if coords == "polar" else width
        self.offset_m = np.zeros(self._width)
        self._offset_cast = self.offset_m.astype(sel.dtype)

    def _draw(self) -> None:
        self.offset_m = self.scale * self.std_m * self.rng.standard_normal(self._width)
        self._offset_cast = self.offset_m.astype(self._sel.dtype)

    def sample_episode(self) -> None:
        """Draw the episode's offset (also the first one in per-step mode)."""
        self._draw()

    def observation(self, observation: Any) -> Any:
        """Return ``observation`` with the offset goal (a new object)."""
        goal = self._sel.get(observation)
        if self.coords == "polar" and goal.ndim == 1:  # one goal: scalar maths is ~10x faster
            x = float(goal[0]) * math.cos(goal[1]) + self.offset_m[0]
            y = float(goal[0]) * math.sin(goal[1]) + self.offset_m[1]
            out = np.array([math.hypot(x, y), math.atan2(y, x)], dtype=self._sel.dtype)
        elif self.coords == "polar":
            goal = goal.astype(np.float64)
            x = goal[..., 0] * np.cos(goal[..., 1]) + self.offset_m[0]
            y = goal[..., 0] * np.sin(goal[..., 1]) + self.offset_m[1]
            out = np.stack([np.hypot(x, y), np.arctan2(y, x)], axis=-1).astype(self._sel.dtype)
        else:
            out = np.add(goal, self._offset_cast, dtype=self._sel.dtype)
        if self._clip:
            self._sel.clip(out)
        return self._sel.put(observation, out)

    def step(self, action: Any) -> Any:
        """Step the env; in per-step mode draw a new offset first."""
        if self.resample == "step":
            self._draw()
        return super().step(action)

    def episode_record(self) -> dict[str, Any]:
        """The offset (m), std and scale."""
        return {
            "offset_m": self.offset_m.tolist(),
            "std_m": self.scale * self.std_m,
            "scale": self.scale,
        }

    def step_record(self) -> dict[str, Any] | None:
        """The step's offset in per-step mode; nothing in per-episode mode."""
        return self.episode_record() if self.resample == "step" else None
