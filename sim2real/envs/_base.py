"""What the single-robot envs share (:class:`~sim2real.envs._nav.NavEnvBase`, CarCrossing-v0):
the constructor's common arguments, checked and kept, and the pybullet world closed with the
env."""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from robots.params import DriveParams
from sim2real.envs._robot import check_env_arguments
from sim2real.envs._world import PybulletWorld

__all__ = ["WorldEnv"]


class WorldEnv(gym.Env):  # type: ignore[type-arg]
    """A gymnasium env with a back-end (``dynamics``), a control period and an episode limit,
    which may own a :class:`~sim2real.envs._world.PybulletWorld` (closed by :meth:`close`).

    ``checks`` go to :func:`~sim2real.envs._robot.check_env_arguments` (``pybullet_body``,
    ``choices``).
    """

    metadata: dict[str, Any] = {"render_modes": []}  # noqa: RUF012

    def __init__(
        self,
        dynamics: str,
        control_dt: float,
        max_episode_steps: int,
        drive_params: DriveParams | None,
        **checks: Any,
    ) -> None:
        super().__init__()
        check_env_arguments(
            dynamics=dynamics,
            control_dt=control_dt,
            max_episode_steps=max_episode_steps,
            drive_params=drive_params,
            **checks,
        )
        self.dynamics = dynamics
        #: Control period, s (the randomizers read ``env.unwrapped.control_dt``).
        self.control_dt = float(control_dt)
        self.max_episode_steps = int(max_episode_steps)
        self._world: PybulletWorld | None = None

    def close(self) -> None:
        if self._world is not None:
            self._world.close()
            self._world = None
        super().close()
