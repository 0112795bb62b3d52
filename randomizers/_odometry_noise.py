r"""Odometry noise on the measured (v, w) of an observation, as a sysid result's noise model says.

The noise model (:class:`robots.randomization.ObservationNoise`: white noise of std
:math:`\sigma_v, \sigma_\omega`, then quantisation to :math:`q_v, q_\omega`) is estimated by
``sim2real sysid fit`` from the fit residuals and stored in the ``noise`` entry of the params
file's ``randomization`` block. :class:`VelocityObservationNoise` adds it to the velocity entry
of an env's observation at every step with :meth:`ObservationNoise.apply` -- the same rule
``sim2real agree --ensemble`` uses to build its predictive band, so the band and the policy's
training see the same odometry.
"""

from __future__ import annotations

import functools
from dataclasses import asdict
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from randomizers._base import check_nonnegative
from randomizers._dynamics import env_robot, load_distribution
from randomizers._observation import ObservationRandomizer
from randomizers._select import select
from randomizers.errors import RandomizerValueError
from robots.randomization import ObservationNoise as NoiseModel

__all__ = ["VelocityObservationNoise"]


class VelocityObservationNoise(ObservationRandomizer):
    r"""Add odometry noise (white noise, then quantisation) to the (v, w) entry of observations.

    The selected entry must hold exactly two values, forward velocity v (m/s) and yaw rate w
    (rad/s), e.g. ``key="velocity"`` of ``sim2real/CrowdNav-v0`` or ``index=[-2, None]`` ...
    the last two entries of ``sim2real/RandomMap-v0``'s Box. Each step draws
    :math:`v + c\,\sigma_v z_v` and :math:`w + c\,\sigma_\omega z_\omega` (v first, then w),
    rounds them to the quantum when it is > 0 and clips them to the space
    (:meth:`robots.randomization.ObservationNoise.apply`; c is the curriculum scale).

    Parameters
    ----------
    env : gymnasium.Env
        Env whose observation holds (v, w).
    std_v_mps, std_w_radps : float
        Noise standard deviations, m/s and rad/s (>= 0).
    quantum_v_mps, quantum_w_radps : float
        Resolution of the reported values (0 = none).
    key : str, optional
        Dict key of the entry (required for Dict spaces).
    index : int, slice or [start, stop], optional
        The two entries of the last axis holding (v, w) (default: the whole entry).
    clip : bool
        Clip to the entry's bounds after adding the noise.
    scale : float
        Curriculum scale c in [0, 1] multiplying both standard deviations.
    name : str, optional
        Unique name in the stack; default ``VelocityObservationNoise`` plus the key/index.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> from randomizers import VelocityObservationNoise
    >>> class Odo(gym.Env):
    ...     observation_space = gym.spaces.Box(-2.0, 2.0, (2,))
    ...     action_space = gym.spaces.Discrete(1)
    ...     def reset(self, *, seed=None, options=None):
    ...         return np.array([0.2, 0.5], np.float32), {}
    ...     def step(self, action):
    ...         return np.array([0.2, 0.5], np.float32), 0.0, False, False, {}
    >>> env = VelocityObservationNoise(Odo(), std_v_mps=0.01, std_w_radps=0.05)
    >>> obs, info = env.reset(seed=0)
    >>> bool(abs(obs[0] - 0.2) < 0.05), info["randomization"]["VelocityObservationNoise"]["scale"]
    (True, 1.0)
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        *,
        std_v_mps: float,
        std_w_radps: float,
        quantum_v_mps: float = 0.0,
        quantum_w_radps: float = 0.0,
        key: str | None = None,
        index: Any = None,
        clip: bool = True,
        scale: float = 1.0,
        name: str | None = None,
    ) -> None:
        wrapper = "VelocityObservationNoise"
        sel = select(env.observation_space, key=key, index=index, wrapper=wrapper)
        if sel.shape[-1:] != (2,):
            raise RandomizerValueError(
                f"{wrapper}: the selected observation entry must hold the two values (v, w) on "
                f"its last axis, got shape {sel.shape}; choose them with 'key' and/or 'index', "
                "e.g. index=[-2, None] for the last two entries"
            )
        values = {
            "std_v_mps": std_v_mps,
            "std_w_radps": std_w_radps,
            "quantum_v_mps": quantum_v_mps,
            "quantum_w_radps": quantum_w_radps,
        }
        checked = {k: check_nonnegative(v, argument=k) for k, v in values.items()}
        try:
            model = NoiseModel(**checked)
        except ValueError as exc:
            raise RandomizerValueError(f"{wrapper}: {exc}") from None
        self._wrap_selection(
            env,
            sel,
            scale=scale,
            name=name,
            options={"clip": bool(clip)},
            **checked,
        )
        self._clip = bool(clip)
        #: The noise model applied at scale 1.
        self.noise = model

    @classmethod
    def from_sysid(
        cls,
        path: str | Path,
        *,
        env: gym.Env[Any, Any] | None = None,
        key: str | None = None,
        index: Any = None,
        robot: str | None = None,
        scale: float = 1.0,
        name: str | None = None,
    ) -> Any:
        """The odometry noise of a params file's ``randomization.noise`` entry.

        The file must be for the env's robot (``robot``, else ``env.unwrapped.robot_spec.name``
        when the env has one, else any). Without ``env`` it returns a picklable
        ``env -> wrapper`` callable (for ``gymnasium.make_vec(..., wrappers=[...])``).

        Examples
        --------
        >>> make = VelocityObservationNoise.from_sysid("params.yaml", key="velocity")
        ... # doctest: +SKIP
        >>> env = make(gym.make("sim2real/CrowdNav-v0"))  # doctest: +SKIP
        """
        owner = "VelocityObservationNoise.from_sysid"
        if env is not None and robot is None:
            robot = env_robot(env)
        noise = load_distribution(path, robot=robot, owner=owner).noise
        make: Any = functools.partial(
            cls, **asdict(noise), key=key, index=index, scale=scale, name=name
        )
        if env is None:
            return _RobotChecked(factory=make, path=str(path), robot=robot)
        return make(env)

    def observation(self, observation: Any) -> Any:
        """Return ``observation`` with odometry noise on (v, w) (a new object)."""
        part = self._sel.get(observation)
        v, w = self.noise.apply(self.rng, part[..., 0], part[..., 1], spread=self.scale)
        out = np.empty(part.shape, dtype=self._sel.dtype)
        out[..., 0] = v
        out[..., 1] = w
        if self._clip:
            self._sel.clip(out)
        return self._sel.put(observation, out)

    def episode_record(self) -> dict[str, Any]:
        """Effective standard deviations and scale."""
        return {
            "std_v_mps": self.scale * self.noise.std_v_mps,
            "std_w_radps": self.scale * self.noise.std_w_radps,
            "scale": self.scale,
        }


class _RobotChecked:
    """A picklable ``env -> wrapper`` factory that checks the env's robot against the file."""

    def __init__(self, *, factory: Any, path: str, robot: str | None) -> None:
        self.factory = factory
        self.path = path
        self.robot = robot

    def __call__(self, env: gym.Env[Any, Any]) -> Any:
        name = env_robot(env)
        if self.robot is None and name is not None:
            load_distribution(self.path, robot=name, owner="VelocityObservationNoise.from_sysid")
        return self.factory(env)
