r"""``sim2real/MujocoNav-v0``: drive the exported MuJoCo robot to a goal (the [mujoco] extra).

A small differential-drive navigation env on the MJCF model of ``sim2real robots export``
(:class:`sim2real.mujoco.MujocoRobot`, its drive by :class:`sim2real.mujoco.MujocoDrive`):
each episode puts a goal at a random bearing, 1-3 m away; the action is a (v, w) command in
[-1, 1] times the robot's top speed and yaw rate, held for ``control_dt_s``; the observation is
the goal's distance (over the farthest start distance) and bearing (sin, cos) and the base's
(v, w) over the top speed and yaw rate. The reward is the progress towards the goal (per metre)
less 0.01 a step, plus 1 on reaching it (within ``goal_tolerance_m``); ``info["metrics"]``
holds the episode's metrics at its end (:class:`sim2real.envs.EpisodeMetrics`).

The env implements the drive protocol (``get_drive_params`` / ``set_drive_params``), so a
:class:`randomizers.DynamicsRandomizer` ``from_sysid`` draws each episode's robot from a sysid
result and writes it into the compiled ``MjModel`` in place, with the same seeding rules (and
the same robots) as ``agree --ensemble``.

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs  # registers the envs
>>> env = gym.make("sim2real/MujocoNav-v0", robot="turtlebot3_burger")  # doctest: +SKIP
>>> obs, info = env.reset(seed=0)  # doctest: +SKIP
>>> obs.shape  # doctest: +SKIP
(5,)
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from robots.params import DriveParams, load_drive_params
from robots.spec import RobotSpec, load_spec
from sim2real.envs.metrics import MetricsTracker
from sim2real.errors import Sim2RealValueError
from sim2real.mujoco import MujocoRobot

__all__ = ["MujocoNavEnv"]

FloatArray = NDArray[np.float32]
#: Observation bounds: the goal distance over the farthest start one, the speeds over the top.
_DISTANCE_BOUND, _SPEED_BOUND = 100.0, 5.0


class MujocoNavEnv(gym.Env[FloatArray, FloatArray]):
    """Go to a goal with the exported MuJoCo robot (see the module docstring).

    Parameters
    ----------
    robot : str or RobotSpec
        A robot name, spec file or spec.
    params : str or Path, optional
        A sysid result for the robot (default: the spec's drive).
    xml : str or Path, optional
        An MJCF file written by ``robots export`` for this robot (default: written in memory).
    control_dt_s : float
        How long each action is held, s.
    goal_distance_m : tuple of float
        Range of the goal's start distance, m.
    goal_tolerance_m : float
        Reaching distance, m.
    max_episode_steps : int
        Steps before the episode is truncated.
    """

    metadata: dict[str, Any] = {"render_modes": []}  # noqa: RUF012 - gymnasium's convention

    def __init__(
        self,
        robot: str | RobotSpec = "turtlebot3_burger",
        *,
        params: str | Path | None = None,
        xml: str | Path | None = None,
        control_dt_s: float = 0.1,
        goal_distance_m: tuple[float, float] = (1.0, 3.0),
        goal_tolerance_m: float = 0.2,
        max_episode_steps: int = 300,
    ) -> None:
        self.robot_spec = robot if isinstance(robot, RobotSpec) else load_spec(robot)
        spec = self.robot_spec
        drive = spec.drive
        if params is not None:
            drive = load_drive_params(params, robot=spec.name, base=spec.drive)
        text = None if xml is None else Path(xml).read_text(encoding="utf-8")
        self.sim = MujocoRobot(spec, drive, xml=text)
        lo, hi = goal_distance_m
        if not (0.0 < lo <= hi and math.isfinite(hi) and control_dt_s > 0):
            raise Sim2RealValueError(
                f"goal_distance_m must be 0 < low <= high and control_dt_s > 0, got "
                f"{goal_distance_m!r} and {control_dt_s!r}; e.g. goal_distance_m=(1.0, 3.0)"
            )
        self.goal_distance_m = (float(lo), float(hi))
        self.goal_tolerance_m = float(goal_tolerance_m)
        self.max_episode_steps = int(max_episode_steps)
        self._substeps = max(1, round(control_dt_s / self.sim.drive.dt_s))
        self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        low = np.array([0.0, -1.0, -1.0, -_SPEED_BOUND, -_SPEED_BOUND], dtype=np.float32)
        high = np.array([_DISTANCE_BOUND, 1.0, 1.0, _SPEED_BOUND, _SPEED_BOUND], dtype=np.float32)
        self.observation_space = gym.spaces.Box(low, high, dtype=np.float32)
        self._goal = np.zeros(2)
        self._distance = 0.0
        self.control_dt = self._substeps * self.sim.drive.dt_s
        self._tracker = MetricsTracker(control_dt_s=self.control_dt)

    # ------------------------------------------------------------------ drive protocol

    def get_drive_params(self) -> DriveParams:
        """The drive parameters the robot runs."""
        return self.sim.params

    def set_drive_params(self, params: DriveParams) -> None:
        """Run ``params`` from the next step (written into the compiled model in place)."""
        self.sim.set_params(params)

    # ------------------------------------------------------------------ gymnasium

    def _observe(self) -> FloatArray:
        x, y = self.sim.data.qpos[0], self.sim.data.qpos[1]
        quat = self.sim.data.qpos[3:7]
        yaw = math.atan2(
            2.0 * (quat[0] * quat[3] + quat[1] * quat[2]), 1.0 - 2.0 * (quat[2] ** 2 + quat[3] ** 2)
        )
        dx, dy = self._goal[0] - x, self._goal[1] - y
        self._distance = math.hypot(dx, dy)
        bearing = math.atan2(dy, dx) - yaw
        v, w = self.sim.velocity()
        spec = self.robot_spec
        return np.array(
            [
                min(self._distance / self.goal_distance_m[1], _DISTANCE_BOUND),
                math.sin(bearing),
                math.cos(bearing),
                *np.clip((v / spec.max_v_mps, w / spec.max_w_radps), -_SPEED_BOUND, _SPEED_BOUND),
            ],
            dtype=np.float32,
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[FloatArray, dict[str, Any]]:
        """A new goal; the robot at rest at the origin facing +x."""
        super().reset(seed=seed)
        angle = self.np_random.uniform(-math.pi, math.pi)
        distance = self.np_random.uniform(*self.goal_distance_m)
        self._goal = distance * np.array([math.cos(angle), math.sin(angle)])
        self.sim.reset()
        self._tracker.reset(0.0, 0.0)
        return self._observe(), {"goal_m": self._goal.copy()}

    def step(self, action: FloatArray) -> tuple[FloatArray, float, bool, bool, dict[str, Any]]:
        """Command (v, w) = action x (top speed, top yaw rate) for ``control_dt_s``."""
        a = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        sim, spec = self.sim, self.robot_spec
        sim.drive.command(
            float(sim.data.time), float(a[0]) * spec.max_v_mps, float(a[1]) * spec.max_w_radps
        )
        before = self._distance
        sim.drive.advance(sim.model, sim.data, self._substeps)
        obs = self._observe()
        v, w = sim.velocity()
        self._tracker.record(x=float(sim.data.qpos[0]), y=float(sim.data.qpos[1]), v=v, w=w)
        reached = self._distance <= self.goal_tolerance_m
        reward = (before - self._distance) - 0.01 + (1.0 if reached else 0.0)
        truncated = not reached and self._tracker.steps >= self.max_episode_steps
        info: dict[str, Any] = {"distance_m": self._distance, "outcome": None}
        if reached or truncated:
            info["outcome"] = "success" if reached else "timeout"
            info["metrics"] = self._tracker.finish(info["outcome"]).to_dict()
        return obs, float(reward), reached, truncated, info
