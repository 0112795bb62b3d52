"""Gymnasium wrappers for domain randomisation (sensor noise, delays, camera pose, dynamics).

Each wrapper is one concept, works on any gymnasium env whose observation has the entry it
needs (a ``Box``, or a ``Dict`` entry chosen with ``key``, optionally an ``index`` range of the
last axis), draws from its own seeded generator, records what it drew in
``info["randomization"][name]`` and has a curriculum ``scale`` in [0, 1]:

- :class:`DepthNoise`, :class:`LidarNoise`, :class:`ObservationNoise`, :class:`GoalNoise`
  (observation level);
- :class:`OdometryDelay`, :class:`ActionDelay` (delays in seconds or steps);
- :class:`CameraPoseJitter`, :class:`DynamicsRandomizer` (physics level; they need the camera or
  drive protocol on ``env.unwrapped``, see docs/ARCHITECTURE.md);
- :class:`VectorObservationRandomizer` applies a stack of observation randomizers to every
  sub-env of a vector env (one stack and stream per sub-env, as N wrapped single envs).

Stacks are built from and saved to YAML with :func:`from_config` / :func:`save_config`, and
:class:`SuccessRateCurriculum` raises every scale as the policy improves.

Names are loaded on first use (PEP 562), so ``import randomizers.errors`` does not pull in
gymnasium or numba.

A floor above :mod:`robots`: randomizers imports robots (drive parameters, files), never
:mod:`sysid` or :mod:`sim2real`.

Examples
--------
>>> import gymnasium as gym
>>> import randomizers as dr
>>> env = dr.ActionDelay(dr.ObservationNoise(gym.make("CartPole-v1"), std=0.01), delay_steps=1)
>>> obs, info = env.reset(seed=0)
>>> sorted(info["randomization"])
['ActionDelay', 'ObservationNoise']
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from randomizers._base import Randomizer, iter_randomizers, set_scale
    from randomizers._camera import CameraPoseJitter
    from randomizers._config import (
        CONFIG_FORMAT,
        RANDOMIZERS,
        from_config,
        save_config,
        to_config,
    )
    from randomizers._curriculum import CurriculumUpdate, SuccessRateCurriculum
    from randomizers._delay import ActionDelay, OdometryDelay, steps_from_seconds
    from randomizers._dynamics import (
        DynamicsRandomizer,
        default_bounds,
        stream_generator,
    )
    from randomizers._gauss import fill_standard_normal
    from randomizers._goal import GoalNoise
    from randomizers._noise import DepthNoise, LidarNoise, ObservationNoise
    from randomizers._odometry_noise import VelocityObservationNoise
    from randomizers._vector import VectorObservationRandomizer

__all__ = [
    "CONFIG_FORMAT",
    "RANDOMIZERS",
    "ActionDelay",
    "CameraPoseJitter",
    "CurriculumUpdate",
    "DepthNoise",
    "DynamicsRandomizer",
    "GoalNoise",
    "LidarNoise",
    "ObservationNoise",
    "OdometryDelay",
    "Randomizer",
    "SuccessRateCurriculum",
    "VectorObservationRandomizer",
    "VelocityObservationNoise",
    "default_bounds",
    "fill_standard_normal",
    "from_config",
    "iter_randomizers",
    "save_config",
    "set_scale",
    "steps_from_seconds",
    "stream_generator",
    "to_config",
]

_MODULES = (
    "randomizers._base",
    "randomizers._camera",
    "randomizers._config",
    "randomizers._curriculum",
    "randomizers._delay",
    "randomizers._dynamics",
    "randomizers._gauss",
    "randomizers._goal",
    "randomizers._noise",
    "randomizers._odometry_noise",
    "randomizers._vector",
)


def _load() -> None:
    """Import every public name at once (on first access of any of them)."""
    namespace = globals()
    for module_name in _MODULES:
        module = importlib.import_module(module_name)
        for name in getattr(module, "__all__", ()):
            if name in __all__:
                namespace[name] = getattr(module, name)
    # Public entry points (env.spec, pickling for async vector envs): randomizers:<Class>.
    for cls in (
        *namespace["RANDOMIZERS"].values(),
        namespace["Randomizer"],
        namespace["SuccessRateCurriculum"],
        namespace["CurriculumUpdate"],
    ):
        cls.__module__ = __name__


def __getattr__(name: str) -> Any:
    if name in __all__:
        _load()
        return globals()[name]
    raise AttributeError(f"module 'randomizers' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
