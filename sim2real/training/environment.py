"""The env a policy trains and is evaluated on: a registered sim2real env, its randomizer stack,
a discrete action grid and the space scaling, built in one place (:func:`build_env`) for SB3,
RLlib and the evaluation.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import randomizers as dr
import sim2real.envs  # noqa: F401  (registers the ids)
from robots.params import load_drive_params
from sim2real.envs.maps import MapConfig
from sim2real.errors import Sim2RealValueError

__all__ = [
    "DiscreteActions",
    "RescaleDictObservation",
    "build_env",
    "default_action_grid",
    "describe_space",
    "neighbour_slots",
    "normalize_spaces",
    "set_params_file",
]


class DiscreteActions(gym.ActionWrapper):  # type: ignore[type-arg]
    """A ``Discrete`` action space over a grid of (v, w) commands, for DQN.

    Action ``k`` is ``(v_mps[k // len(w_radps)], w_radps[k % len(w_radps)])``.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import sim2real.envs
    >>> env = DiscreteActions(gym.make("sim2real/RandomMap-v0"), v_mps=[0.0, 0.25],
    ...                       w_radps=[-1.0, 0.0, 1.0])
    >>> int(env.action_space.n), env.action(4).tolist()
    (6, [0.25, 0.0])
    """

    def __init__(self, env: gym.Env[Any, Any], *, v_mps: list[float], w_radps: list[float]):
        super().__init__(env)
        self.grid = np.array([(v, w) for v in v_mps for w in w_radps], dtype=np.float32)
        self.action_space = gym.spaces.Discrete(len(self.grid))

    def action(self, action: Any) -> np.ndarray:
        """The (v, w) command of grid index ``action``."""
        return self.grid[int(np.asarray(action).reshape(-1)[0])]


class RescaleDictObservation(gym.ObservationWrapper):  # type: ignore[type-arg]
    """Every Box entry of a ``Dict`` observation rescaled to [-1, 1] from its bounds.

    The Dict counterpart of ``gymnasium.wrappers.RescaleObservation`` (which takes a Box only):
    one fixed affine map per entry, so a lidar scan and a depth image in metres sit on the same
    scale as a goal bearing in radians.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import sim2real.envs
    >>> env = RescaleDictObservation(gym.make("sim2real/CrowdNav-v0", depth_width=8,
    ...                                       depth_height=6))
    >>> obs, _ = env.reset(seed=0)
    >>> all(float(abs(x).max()) <= 1.0 for x in obs.values())
    True
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        super().__init__(env)
        space = env.observation_space
        assert isinstance(space, gym.spaces.Dict)
        self._affine = {
            key: (0.5 * (box.high + box.low), 0.5 * (box.high - box.low))  # type: ignore[attr-defined]
            for key, box in space.spaces.items()
        }
        self.observation_space = gym.spaces.Dict(
            {
                key: gym.spaces.Box(-1.0, 1.0, box.shape, np.float32)
                for key, box in space.spaces.items()
            }
        )

    def observation(self, observation: Any) -> dict[str, np.ndarray]:
        """The observation with each entry mapped to [-1, 1] (clipped at the bounds)."""
        return {
            key: np.clip((np.asarray(value) - mid) / half, -1.0, 1.0).astype(np.float32)
            for (key, value), (mid, half) in zip(
                observation.items(), (self._affine[k] for k in observation), strict=True
            )
        }


def _finite_boxes(space: Any) -> bool:
    """Whether ``space`` is a Box, or a Dict of Boxes, with finite bounds throughout."""
    if isinstance(space, gym.spaces.Dict):
        return len(space.spaces) > 0 and all(_finite_boxes(s) for s in space.spaces.values())
    return (
        isinstance(space, gym.spaces.Box)
        and bool(np.all(np.isfinite(space.low)))
        and bool(np.all(np.isfinite(space.high)))
        and bool(np.all(space.high > space.low))
    )


def default_action_grid(env: gym.Env[Any, Any]) -> dict[str, list[float]]:
    """3 forward speeds x 5 turn rates spanning the env's Box action space."""
    space = env.action_space
    low = np.asarray(space.low, dtype=np.float64)  # type: ignore[attr-defined]
    high = np.asarray(space.high, dtype=np.float64)  # type: ignore[attr-defined]
    return {
        "v_mps": [float(x) for x in np.linspace(max(low[0], 0.0), high[0], 3)],
        "w_radps": [float(x) for x in np.linspace(low[1], high[1], 5)],
    }


def build_env(
    env_id: str,
    env_kwargs: Mapping[str, Any],
    *,
    randomizers: Mapping[str, Any] | None = None,
    discrete_actions: Mapping[str, list[float]] | None = None,
    normalize: Mapping[str, bool] | None = None,
    where: str = "env",
) -> Any:
    """``gymnasium.make(env_id, **env_kwargs)`` wrapped in the randomizer stack (innermost first),
    for a discrete-action algorithm :class:`DiscreteActions`, and the ``observations`` /
    ``actions`` entries of ``normalize`` (:func:`normalize_spaces`, outermost).

    Examples
    --------
    >>> env = build_env("sim2real/RandomMap-v0", {"preset": "TEST1"})
    >>> env.observation_space.shape
    (40,)
    """
    kwargs = dict(env_kwargs)
    params = kwargs.pop("params", None)
    if isinstance(kwargs.get("map_config"), Mapping):
        try:
            kwargs["map_config"] = MapConfig(**kwargs["map_config"])
        except TypeError as exc:
            raise Sim2RealValueError(
                f"{where}: env kwargs 'map_config' {kwargs['map_config']} is not a MapConfig "
                f"({exc}); use its fields d_target_m, r_wall, n_min, n_max, area_m, ..."
            ) from None
    # through the spec, so that max_episode_steps reaches the env (the envs end episodes
    # themselves); gym.make(id, max_episode_steps=...) would add a TimeLimit wrapper instead
    spec = gym.spec(env_id)
    try:
        env: Any = gym.make(dataclasses.replace(spec, kwargs={**spec.kwargs, **kwargs}))
    except TypeError as exc:
        raise Sim2RealValueError(
            f"{where}: env kwargs {dict(env_kwargs)} are not accepted by {env_id} ({exc}); "
            "see `sim2real envs list` for its options"
        ) from None
    if params is not None:
        set_params_file(env, params)
    if randomizers is not None:
        env = dr.from_config(env, randomizers)
    if discrete_actions is not None:
        env = DiscreteActions(env, **discrete_actions)
    if normalize is not None:
        env = normalize_spaces(env, normalize, where=where)
    return env


def normalize_spaces(env: Any, normalize: Mapping[str, bool], *, where: str = "env") -> Any:
    """``env`` with its Box observation / action space rescaled to [-1, 1] from their bounds.

    ``normalize["observations"]`` adds ``gymnasium.wrappers.RescaleObservation`` (a Dict of
    Boxes: :class:`RescaleDictObservation`),
    ``normalize["actions"]`` ``gymnasium.wrappers.RescaleAction`` (a Box action space only; a
    discrete one is left alone). Both are fixed affine maps, so a saved policy evaluates with
    exactly its training scaling.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import sim2real.envs
    >>> env = normalize_spaces(gym.make("sim2real/RandomMap-v0"),
    ...                        {"observations": True, "actions": True})
    >>> float(env.observation_space.low.min()), env.action_space.high.tolist()
    (-1.0, [1.0, 1.0])
    """
    if normalize.get("observations"):
        space = env.observation_space
        if not _finite_boxes(space):
            raise Sim2RealValueError(
                f"{where}: normalize 'observations' needs a Box (or a Dict of Boxes) observation "
                f"space with finite bounds, got {describe_space(space)}; set "
                "normalize.observations: false"
            )
        if isinstance(space, gym.spaces.Dict):
            env = RescaleDictObservation(env)
        else:
            env = gym.wrappers.RescaleObservation(env, np.float32(-1.0), np.float32(1.0))
    if normalize.get("actions") and isinstance(env.action_space, gym.spaces.Box):
        env = gym.wrappers.RescaleAction(env, np.float32(-1.0), np.float32(1.0))
    return env


def neighbour_slots(env: Any, *, where: str = "env") -> tuple[int, int]:
    """(slots, values per slot) of the neighbours ``env`` observes, for SARL* (``policy: sarl``).

    Raises one sentence for an env without them (RandomMap-v0, CarCrossing-v0, CrowdNav-v0
    without ``neighbours``).

    Examples
    --------
    >>> import gymnasium as gym
    >>> import sim2real.envs
    >>> neighbour_slots(gym.make("sim2real/Race-v0", track="open"))
    (5, 4)
    """
    slots = getattr(env.unwrapped, "neighbour_slots", None)
    if slots is None or slots[0] < 1:
        name = env.unwrapped.spec.id if env.unwrapped.spec is not None else type(env).__name__
        raise Sim2RealValueError(
            f"{where}: policy 'sarl' attends over the neighbours an env observes, but {name} "
            "observes none; use sim2real/Race-v0, or sim2real/CrowdNav-v0 with env.kwargs "
            "neighbours: 5, or another policy"
        )
    return int(slots[0]), int(slots[1])


def set_params_file(env: Any, path: str | Path) -> None:
    """Give ``env`` the drive parameters of a sysid result (refused for another robot)."""
    base = env.unwrapped
    spec = getattr(base, "robot_spec", None)
    if spec is None or not hasattr(base, "set_drive_params"):
        raise Sim2RealValueError(
            f"params file '{path}' cannot be applied: {type(base).__name__} has no robot drive "
            "model (params apply to CrowdNav-v0 and RandomMap-v0)"
        )
    base.set_drive_params(load_drive_params(path, robot=spec.name, base=base.get_drive_params()))


def describe_space(space: Any) -> str:
    """Short text of a space: ``Box(40,)``, ``Dict(lidar: Box(36,), ...)``, ``Discrete(15)``."""
    if isinstance(space, gym.spaces.Box):
        return f"Box{space.shape}"
    if isinstance(space, gym.spaces.Dict):
        inner = ", ".join(f"{k}: {describe_space(v)}" for k, v in space.spaces.items())
        return f"Dict({inner})"
    return str(space)
