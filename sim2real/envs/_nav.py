"""Shared machinery of the navigation envs: robot back-end, lidar, goal, outcome and metrics.

Subclasses build the world in :meth:`NavEnvBase._build` (called from ``reset``), may move
things in :meth:`NavEnvBase._advance` (pedestrians), and define the observation and reward.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from robots.params import DriveParams
from robots.randomization import DriveDistribution
from robots.spec import load_spec
from sim2real.envs._base import WorldEnv
from sim2real.envs._robot import (
    RobotBackend,
    checked_action,
    footprint_radius_m,
    make_backend,
)
from sim2real.envs._world import PybulletWorld
from sim2real.envs.geometry import FloatArray, Scene2D, cast_rays, disc_clearance, wrap_angle
from sim2real.envs.metrics import EpisodeMetrics, MetricsTracker
from sim2real.errors import Sim2RealValueError

__all__ = ["NavEnvBase", "StepInfo"]


def _load_spec(robot: str) -> Any:
    return load_spec(robot)


def _check_distribution(distribution: Any, spread: Any, robot: str) -> DriveDistribution | None:
    """Refuse a drive distribution of another robot or a spread that is not a number >= 0."""
    if isinstance(spread, bool) or not (
        isinstance(spread, int | float) and math.isfinite(spread) and spread >= 0
    ):
        raise Sim2RealValueError(
            f"drive_spread must be a finite number >= 0 (1 = the distribution as given), "
            f"got {spread!r}"
        )
    if distribution is None:
        return None
    if not isinstance(distribution, DriveDistribution):
        raise Sim2RealValueError(
            f"drive_distribution must be a robots.randomization.DriveDistribution, got "
            f"{type(distribution).__name__}; load one with DriveDistribution.from_params_file"
        )
    if distribution.robot != robot:
        raise Sim2RealValueError(
            f"drive_distribution is for robot '{distribution.robot}' but the env drives "
            f"'{robot}'; load the distribution of '{robot}'"
        )
    return distribution


class StepInfo:
    """Per-step quantities the subclasses' reward functions use (plain attributes)."""

    __slots__ = ("clearance_m", "goal_dist_m", "outcome", "prev_goal_dist_m", "v", "w")

    def __init__(
        self,
        *,
        goal_dist_m: float,
        prev_goal_dist_m: float,
        clearance_m: float,
        outcome: str | None,
        v: float,
        w: float,
    ) -> None:
        self.goal_dist_m = goal_dist_m
        self.prev_goal_dist_m = prev_goal_dist_m
        self.clearance_m = clearance_m
        self.outcome = outcome
        self.v = v
        self.w = w


class NavEnvBase(WorldEnv):
    """Base of :class:`~sim2real.envs.RandomMapEnv` and :class:`~sim2real.envs.CrowdNavEnv`."""

    def __init__(
        self,
        *,
        robot: str,
        dynamics: str,
        control_dt: float,
        max_episode_steps: int,
        goal_tolerance_m: float,
        drive_params: DriveParams | None,
        needs_world: bool,
        drive_distribution: DriveDistribution | None = None,
        drive_spread: float = 1.0,
        plant_sessions: Any = None,
        goal_speed_mps: float = math.inf,
    ) -> None:
        super().__init__(dynamics, control_dt, max_episode_steps, drive_params)
        if isinstance(goal_speed_mps, bool) or not (
            isinstance(goal_speed_mps, int | float) and goal_speed_mps > 0
        ):
            raise Sim2RealValueError(
                f"goal_speed_mps must be a number of m/s > 0 (inf: passing through the goal "
                f"counts), got {goal_speed_mps!r}"
            )
        self.robot_spec = _load_spec(robot)
        self._drive_distribution = _check_distribution(
            drive_distribution, drive_spread, self.robot_spec.name
        )
        self._drive_spread = float(drive_spread)
        if dynamics == "plant" and drive_distribution is not None:
            raise Sim2RealValueError(
                "drive_distribution randomises the drive model, which dynamics='plant' does "
                "not use; pass plant_sessions= for the plant's sessions, or use "
                "dynamics='reduced'"
            )
        self.goal_tolerance_m = float(goal_tolerance_m)
        #: Success needs the measured speed at or below this inside the tolerance, m/s.
        self.goal_speed_mps = float(goal_speed_mps)
        self.robot_radius_m = footprint_radius_m(self.robot_spec)
        self._world = PybulletWorld() if (needs_world or dynamics == "pybullet") else None
        params = drive_params if drive_params is not None else self.robot_spec.drive
        self._backend: RobotBackend = make_backend(
            dynamics,
            self.robot_spec,
            params,
            client=None if self._world is None else self._world.client,
            plant_sessions=plant_sessions,
        )
        self._tracker = MetricsTracker(control_dt_s=self.control_dt)
        self._scene = Scene2D.build()
        self._goal = np.zeros(2)
        self._prev_goal_dist = 0.0
        self._done = False
        self._in_goal = False
        self._last_action = np.zeros(2)

    # ------------------------------------------------------------------ protocols
    def get_drive_params(self) -> DriveParams:
        """The drive parameters the robot uses now (``robots.DriveParams``)."""
        return self._backend.get_drive_params()

    def set_drive_params(self, params: DriveParams) -> None:
        """Use ``params`` from the next step on (e.g. a randomizer's draw)."""
        if not isinstance(params, DriveParams):
            raise Sim2RealValueError(
                f"set_drive_params needs a robots.DriveParams, got {type(params).__name__}"
            )
        self._backend.set_drive_params(params)

    def set_goal_criteria(
        self, *, speed_mps: float | None = None, tolerance_m: float | None = None
    ) -> None:
        """Use a new goal speed (m/s) and/or tolerance (m) from the next step on.

        What a training curriculum anneals (``curriculum`` of the training config); None keeps
        the current value.

        Examples
        --------
        >>> from sim2real.envs import RandomMapEnv
        >>> env = RandomMapEnv(goal_speed_mps=0.05)
        >>> env.set_goal_criteria(speed_mps=0.5)
        >>> env.goal_speed_mps, env.goal_tolerance_m
        (0.5, 0.3)
        """
        for name, value in (("speed_mps", speed_mps), ("tolerance_m", tolerance_m)):
            if value is not None and (
                isinstance(value, bool) or not isinstance(value, int | float) or not value > 0
            ):
                raise Sim2RealValueError(
                    f"set_goal_criteria: {name} must be a number > 0 or None, got {value!r}"
                )
        if speed_mps is not None:
            self.goal_speed_mps = float(speed_mps)
        if tolerance_m is not None:
            self.goal_tolerance_m = float(tolerance_m)

    # ------------------------------------------------------------------ hooks
    def _build(self, options: dict[str, Any]) -> tuple[float, float, float]:
        """Build the world for a new episode; return the start pose (x, y, yaw)."""
        raise NotImplementedError

    def _advance(self, dt_s: float) -> None:
        """Move the dynamic parts of the world by ``dt_s`` (after the robot moved)."""

    def _dynamic_scene(self) -> Scene2D:
        """Static scene plus whatever moves (pedestrians)."""
        return self._scene

    def _observation(self) -> Any:
        raise NotImplementedError

    def _reward(self, s: StepInfo) -> float:
        raise NotImplementedError

    def _extra_info(self) -> dict[str, Any]:
        return {}

    # ------------------------------------------------------------------ helpers
    def _lidar_ranges(self, scene: Scene2D, angles_body_rad: FloatArray) -> FloatArray:
        """Ranges from the lidar mount along body-frame angles; outside [min, max] -> max."""
        x, y, yaw = self._backend.pose
        lid = self.robot_spec.lidar
        c, s = math.cos(yaw), math.sin(yaw)
        origin = np.array(
            [x + c * lid.xyz_m[0] - s * lid.xyz_m[1], y + s * lid.xyz_m[0] + c * lid.xyz_m[1]]
        )
        r = cast_rays(scene, origin, angles_body_rad + yaw, lid.range_max_m)
        return np.where(r < lid.range_min_m, lid.range_max_m, r)

    def _goal_polar(self) -> tuple[float, float]:
        """Goal distance (m) and bearing in the base frame (rad)."""
        x, y, yaw = self._backend.pose
        dx, dy = self._goal[0] - x, self._goal[1] - y
        return math.hypot(dx, dy), wrap_angle(math.atan2(dy, dx) - yaw)

    def _clearance(self) -> float:
        x, y, _ = self._backend.pose
        return disc_clearance(self._dynamic_scene(), np.array([x, y]), self.robot_radius_m)

    # ------------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        super().reset(seed=seed)
        if self._world is not None:
            self._world.reset_simulation()
        x, y, yaw = self._build(dict(options or {}))
        if self._drive_distribution is not None:  # this episode's robot, from np_random
            drawn = self._drive_distribution.sample(self.np_random, 1, spread=self._drive_spread)
            self._backend.set_drive_params(drawn[0])
        self._backend.new_session(self.np_random)  # dynamics="plant": this episode's plant
        self._backend.reset(x, y, yaw)
        self._tracker.reset(x, y)
        self._prev_goal_dist = self._goal_polar()[0]
        self._done = False
        self._in_goal = False
        self._last_action = np.zeros(2)
        info = {"outcome": None, **self._extra_info()}
        return self._observation(), info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        a = checked_action(action, self.action_space)
        if self._done:
            raise Sim2RealValueError("step() called after the episode ended; call reset() first")
        v, w = self._backend.step(float(a[0]), float(a[1]), self.control_dt)
        self._advance(self.control_dt)
        x, y, _ = self._backend.pose
        self._tracker.record(x=x, y=y, v=v, w=w)
        obs = self._observation()
        d_goal, _ = self._goal_polar()
        clearance = self._clearance()
        outcome: str | None = None
        in_goal = d_goal < self.goal_tolerance_m
        if clearance <= 0.0:
            outcome = "collision"
        elif in_goal and abs(v) <= self.goal_speed_mps:
            outcome = "success"
        elif self._in_goal and not in_goal:  # only reachable with a finite goal speed
            outcome = "overshoot"
        elif self._tracker.steps >= self.max_episode_steps:
            outcome = "timeout"
        self._in_goal = in_goal
        s = StepInfo(
            goal_dist_m=d_goal,
            prev_goal_dist_m=self._prev_goal_dist,
            clearance_m=clearance,
            outcome=outcome,
            v=v,
            w=w,
        )
        reward = float(self._reward(s))
        self._prev_goal_dist = d_goal
        self._last_action = a
        info: dict[str, Any] = {"outcome": None, "clearance_m": clearance, **self._extra_info()}
        if outcome is not None:
            self._done = True
            metrics: EpisodeMetrics = self._tracker.finish(outcome)
            info["outcome"] = self._outcome_name(outcome)
            info["metrics"] = metrics.to_dict()
        terminated = outcome in ("collision", "success", "overshoot")
        truncated = outcome == "timeout"
        return obs, reward, terminated, truncated, info

    def _outcome_name(self, outcome: str) -> str:
        return outcome
