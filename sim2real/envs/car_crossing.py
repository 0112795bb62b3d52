r"""``sim2real/CarCrossing-v0``: a small car passes an obstacle while an occluded pedestrian crosses.

Trararak, Hoang and Pham ("Pedestrian avoidance simulation by deep
reinforcement learning using Webots"), Sec. III-A. The car (:mod:`sim2real.envs._car`: chassis
26 x 18 x 5 cm, wheels r = 5 cm, front-wheel Ackermann steering) drives along +x on a straight
two-lane road (two 0.6 m lanes, y in [-0.6, 0.6]); its own lane is the left one (centre
y = +0.3), the adjacent lane the right one (centre y = -0.3), as the paper's PPO car makes
"rightward adjustments" to pass.

Scenario (Trararak et al.: car at 0.6 m/s, obstacle 1.3 m ahead, pedestrian 1.8 m ahead crossing
the adjacent lane at 0.16 m/s, starting when the car "can drive to 1.5 m", goal 2.5 m)
    - the car starts at x = 0 in the centre of its lane (y jittered by U(-0.03, 0.03) m),
      heading +x, rolling at 0.6 m/s;
    - a static box obstacle (0.2 m long, 0.36 m wide, 0.3 m high) stands in the car's lane,
      its near face U(1.2, 1.4) m ahead of the car's centre;
    - a pedestrian (disc of radius 0.1 m) waits hidden behind the obstacle in the car's lane,
      U(1.7, 1.9) m ahead, and walks across the adjacent lane to the right road side
      (y = -0.9 m, where it stops) at U(0.14, 0.18) m/s;
    - it starts walking when the car comes within U(1.4, 1.6) m of it along the road: we read
      "starts walking if the agent can drive to 1.5 m" as a trigger distance, because the
      alternative (after 1.5 m of driving) would put the car beside the obstacle with the
      pedestrian already behind it, and the crossing would no longer be a hazard;
    - the goal is reached when the car's centre passes x = 2.5 m on the road.

Each episode's draws come from the env's seeded ``np_random``.

Observation (14 float32 values, the kinds of Trararak et al. Sec. III-C-a)
    0-1: position x / 2.5 m and y / 0.6 m; 2-6: five front distance sensors (rays from the
    front of the chassis at -40, -20, 0, 20, 40 degrees, 1 m range, reading / range); 7: steering
    angle / 30 degrees; 8-9: distance (centre to centre) to the obstacle and to the pedestrian
    / 3 m, 1.0 while not detected; 10: lane status (1 in its own lane, 0 in the adjacent
    lane); 11-12: obstacle and pedestrian detected (1/0): in the camera's view (+-60 degrees,
    3 m) and not hidden behind the obstacle (a line of sight test, which is what makes the
    pedestrian occluded); 13: heading / pi. (The paper lists the robot's roll angle; on a flat
    road the heading is the informative angle.)
Action (``Discrete(4)``, Trararak et al. Sec. III-C-b)
    0: speed command +0.15 m/s; 1: speed command -0.075 m/s (not below 0); 2: steering command
    +5 degrees (left); 3: steering command -5 degrees (right); the steering command is limited
    to +-30 degrees, the speed by the drive chain (1.2 m/s by default).
Reward (Trararak et al. eqs. 7-8, constants in :class:`CarCrossingReward`)
    - progress: :math:`0.15\,(d_t - d_{t+1})` with the distances in decimetres (1.5 per metre)
      when the goal distance changed, and -0.05 when it did not (immobile). Eq. (7) prints
      :math:`(d_{t+1} - d_t)\cdot 0.15` for :math:`\Delta d > 0`: the sign is fixed so that
      approaching the goal pays, and the case of moving away (undefined in the paper) uses
      the same linear term. The decimetre unit is the one eq. (8) multiplies the distance into
      (:math:`10\,d`);
    - goal: +20; obstacle collision: -7; pedestrian collision: -8;
    - leaving the road: :math:`-\min(|2.733 - 10\,d_{t+1}|, 2)`. Eq. (8) prints
      ``min[abs(2.733 - d*10, 2)]`` with a misplaced bracket (a one-argument min); we read
      it as the two-argument min. It is 2 everywhere except within 0.47 m of the goal.
    :math:`d` is the distance from the car's centre to the goal point (2.5 m ahead in its own
    lane).
Termination
    goal (``info["is_success"]``), collision (``info["collision"]`` is ``"obstacle"`` or
    ``"pedestrian"``), leaving the road (any footprint corner beyond |y| = 0.6 m; ``info
    ["outcome"] == "off_road"``); truncation at ``max_episode_steps`` (default 300 = 30 s).

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs
>>> env = gym.make("sim2real/CarCrossing-v0")
>>> obs, info = env.reset(seed=0)
>>> obs.shape, env.action_space
((14,), Discrete(4))
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from robots.params import DriveParams
from sim2real.envs._base import WorldEnv
from sim2real.envs._car import CAR, DEFAULT_CAR_PARAMS, CarModel, PybulletCar, ReducedCar
from sim2real.envs._world import PybulletWorld
from sim2real.envs.geometry import (
    FloatArray,
    Scene2D,
    cast_rays,
    distance_bearing,
    rectangle_corners,
    rectangle_segments,
)
from sim2real.envs.metrics import MetricsTracker
from sim2real.errors import Sim2RealValueError

__all__ = ["CAR_OUTCOMES", "CarCrossingEnv", "CarCrossingReward"]

#: Episode outcomes of CarCrossing-v0.
CAR_OUTCOMES = ("success", "collision", "off_road", "timeout")

LANE_WIDTH_M = 0.6
ROAD_HALF_WIDTH_M = LANE_WIDTH_M
OWN_LANE_Y_M = 0.5 * LANE_WIDTH_M
GOAL_X_M = 2.5
START_SPEED_MPS = 0.6
SPEED_STEP_UP_MPS = 0.15
SPEED_STEP_DOWN_MPS = 0.075
STEER_STEP_RAD = math.radians(5.0)
OBSTACLE_SIZE_M = (0.2, 0.36, 0.3)
PED_RADIUS_M = 0.1
PED_HEIGHT_M = 0.35
PED_STOP_Y_M = -0.9
SENSOR_ANGLES_RAD = np.radians([-40.0, -20.0, 0.0, 20.0, 40.0])
SENSOR_RANGE_M = 1.0
CAMERA_HALF_FOV_RAD = math.radians(60.0)
DETECT_RANGE_M = 3.0
_N_OBS = 14


@dataclass(frozen=True, kw_only=True)
class CarCrossingReward:
    """Constants of the CarCrossing-v0 reward (see the module docstring)."""

    progress_per_m: float = 1.5
    immobile: float = 0.05
    goal: float = 20.0
    obstacle: float = 7.0
    pedestrian: float = 8.0
    off_road_ref: float = 2.733
    off_road_cap: float = 2.0


def _rects_overlap(a: FloatArray, b: FloatArray) -> bool:
    """Separating-axis test of two convex quadrilaterals (corners in order)."""
    for poly in (a, b):
        for k in range(4):
            e = poly[(k + 1) % 4] - poly[k]
            axis = np.array([-e[1], e[0]])
            pa, pb = a @ axis, b @ axis
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def _disc_rect_distance(
    xy: FloatArray, cx: float, cy: float, yaw: float, size: tuple[float, float]
) -> float:
    """Distance from a point to an oriented rectangle (0 inside), m."""
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = xy[0] - cx, xy[1] - cy
    u, v = c * dx + s * dy, -s * dx + c * dy
    qu = max(abs(u) - 0.5 * size[0], 0.0)
    qv = max(abs(v) - 0.5 * size[1], 0.0)
    return math.hypot(qu, qv)


def _segment_hits_box(a: FloatArray, b: FloatArray, box: FloatArray) -> bool:
    """Whether the segment a-b crosses the axis-aligned box (xmin, xmax, ymin, ymax)."""
    t0, t1 = 0.0, 1.0
    d = b - a
    for k, (lo, hi) in enumerate(((box[0], box[1]), (box[2], box[3]))):
        if abs(d[k]) < 1e-12:
            if a[k] < lo or a[k] > hi:
                return False
            continue
        ta, tb = (lo - a[k]) / d[k], (hi - a[k]) / d[k]
        t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
        if t0 > t1:
            return False
    return True


class CarCrossingEnv(WorldEnv):
    """Pass a static obstacle and an occluded crossing pedestrian with a small car (Trararak et al.).

    Parameters
    ----------
    dynamics : str
        ``"reduced"`` (drive chain + kinematic bicycle, no pybullet) or ``"pybullet"`` (the
        rigid multibody car).
    control_dt : float
        Control period, s.
    max_episode_steps : int
        Steps before truncation (default 300 = 30 s).
    reward : CarCrossingReward, optional
        Reward constants.
    drive_params : DriveParams, optional
        The car's drive chain (default :data:`sim2real.envs._car.DEFAULT_CAR_PARAMS`).
    """

    def __init__(
        self,
        *,
        dynamics: str = "reduced",
        control_dt: float = 0.1,
        max_episode_steps: int = 300,
        reward: CarCrossingReward | None = None,
        drive_params: DriveParams | None = None,
    ) -> None:
        super().__init__(
            dynamics,
            control_dt,
            max_episode_steps,
            drive_params,
            pybullet_body="rigid-body car",
            choices=("reduced", "pybullet"),
        )
        self.reward_config = reward if reward is not None else CarCrossingReward()
        self.geometry = CAR
        params = drive_params if drive_params is not None else DEFAULT_CAR_PARAMS
        self.car: CarModel
        if dynamics == "pybullet":
            self._world = PybulletWorld()
            self.car = PybulletCar(self._world.client, CAR, params)
        else:
            self.car = ReducedCar(CAR, params)
        low = np.array([-0.5, -2.0, *[0.0] * 5, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0], np.float32)
        high = np.array([1.5, 2.0, *[1.0] * 5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0], np.float32)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self.action_space = spaces.Discrete(4)
        self._tracker = MetricsTracker(control_dt_s=self.control_dt)
        self._done = False
        self.obstacle_xy = np.zeros(2)
        self.pedestrian_xy = np.zeros(2)
        self.pedestrian_speed_mps = 0.0
        self.trigger_distance_m = 1.5
        self.pedestrian_walking = False
        self.cmd_speed_mps = START_SPEED_MPS
        self.cmd_steer_rad = 0.0
        self._prev_goal_dist = 0.0
        self._steps = 0

    # ------------------------------------------------------------------ protocols
    def get_drive_params(self) -> DriveParams:
        """The car's drive parameters now (``robots.DriveParams``; see :mod:`sim2real.envs._car`)."""
        return self.car.get_drive_params()

    def set_drive_params(self, params: DriveParams) -> None:
        """Use ``params`` from the next step on (e.g. a randomizer's draw)."""
        self.car.set_drive_params(params)

    # ------------------------------------------------------------------ world
    @property
    def goal_xy(self) -> FloatArray:
        """The goal point: 2.5 m ahead, in the car's own lane."""
        return np.array([GOAL_X_M, OWN_LANE_Y_M])

    def _obstacle_box(self) -> FloatArray:
        ox, oy = self.obstacle_xy
        hl, hw = 0.5 * OBSTACLE_SIZE_M[0], 0.5 * OBSTACLE_SIZE_M[1]
        return np.array([ox - hl, ox + hl, oy - hw, oy + hw])

    def _scene(self) -> Scene2D:
        seg = rectangle_segments(
            self.obstacle_xy[0], self.obstacle_xy[1], OBSTACLE_SIZE_M[0], OBSTACLE_SIZE_M[1], 0.0
        )
        return Scene2D(
            circles_xy=self.pedestrian_xy.reshape(1, 2).copy(),
            circles_r=np.array([PED_RADIUS_M]),
            seg_a=seg[:, :2].copy(),
            seg_b=seg[:, 2:].copy(),
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[FloatArray, dict[str, Any]]:
        super().reset(seed=seed)
        if options:
            raise Sim2RealValueError(
                f"CarCrossing-v0 takes no reset options, got {sorted(options)}; the scenario is "
                "drawn from the seed"
            )
        rng = self.np_random
        y0 = OWN_LANE_Y_M + rng.uniform(-0.03, 0.03)
        near_face = rng.uniform(1.2, 1.4)
        self.obstacle_xy = np.array([near_face + 0.5 * OBSTACLE_SIZE_M[0], OWN_LANE_Y_M])
        self.pedestrian_xy = np.array([rng.uniform(1.7, 1.9), OWN_LANE_Y_M])
        self.pedestrian_speed_mps = float(rng.uniform(0.14, 0.18))
        self.trigger_distance_m = float(rng.uniform(1.4, 1.6))
        self.pedestrian_walking = False
        if self._world is not None:
            self._world.reset_simulation()
            self._world.set_static(
                cylinders=np.zeros((0, 3)),
                cylinder_height_m=0.0,
                boxes=np.array([[*self.obstacle_xy, OBSTACLE_SIZE_M[0], OBSTACLE_SIZE_M[1], 0.0]]),
                box_height_m=OBSTACLE_SIZE_M[2],
            )
            self._sync_pedestrian()
        self.car.reset(0.0, y0, 0.0, START_SPEED_MPS)
        self.cmd_speed_mps = START_SPEED_MPS
        self.cmd_steer_rad = 0.0
        self._tracker.reset(0.0, y0)
        self._prev_goal_dist = self._goal_distance()
        self._done = False
        self._steps = 0
        return self._observation(), self._info(None, None)

    def _sync_pedestrian(self) -> None:
        if self._world is not None:
            self._world.set_pedestrians(
                self.pedestrian_xy.reshape(1, 2), np.array([PED_RADIUS_M]), np.array([PED_HEIGHT_M])
            )

    def _goal_distance(self) -> float:
        x, y, _ = self.car.pose
        return math.hypot(GOAL_X_M - x, OWN_LANE_Y_M - y)

    def _advance_pedestrian(self, dt_s: float) -> None:
        x, _, _ = self.car.pose
        if not self.pedestrian_walking and self.pedestrian_xy[0] - x <= self.trigger_distance_m:
            self.pedestrian_walking = True
        if self.pedestrian_walking:
            y = max(self.pedestrian_xy[1] - self.pedestrian_speed_mps * dt_s, PED_STOP_Y_M)
            self.pedestrian_xy = np.array([self.pedestrian_xy[0], y])
            self._sync_pedestrian()

    # ------------------------------------------------------------------ sensing
    def _detected(self, target: FloatArray, *, through_obstacle: bool) -> bool:
        x, y, yaw = self.car.pose
        eye = np.array([x, y])
        dist, bearing = distance_bearing(eye, yaw, target)
        if dist > DETECT_RANGE_M or abs(bearing) > CAMERA_HALF_FOV_RAD:
            return False
        return through_obstacle or not _segment_hits_box(eye, target, self._obstacle_box())

    def _sensor_readings(self) -> FloatArray:
        x, y, yaw = self.car.pose
        front = 0.5 * self.geometry.chassis_length_m
        origin = np.array([x + front * math.cos(yaw), y + front * math.sin(yaw)])
        r = cast_rays(self._scene(), origin, SENSOR_ANGLES_RAD + yaw, SENSOR_RANGE_M)
        return np.asarray(r / SENSOR_RANGE_M)

    def _observation(self) -> FloatArray:
        x, y, yaw = self.car.pose
        eye = np.array([x, y])
        obst_seen = self._detected(self.obstacle_xy, through_obstacle=True)
        ped_seen = self._detected(self.pedestrian_xy, through_obstacle=False)
        d_obst = float(np.hypot(*(self.obstacle_xy - eye))) if obst_seen else DETECT_RANGE_M
        d_ped = float(np.hypot(*(self.pedestrian_xy - eye))) if ped_seen else DETECT_RANGE_M
        obs = np.concatenate(
            [
                [x / GOAL_X_M, y / ROAD_HALF_WIDTH_M],
                self._sensor_readings(),
                [
                    self.car.steer_rad / self.geometry.max_steer_rad,
                    min(d_obst, DETECT_RANGE_M) / DETECT_RANGE_M,
                    min(d_ped, DETECT_RANGE_M) / DETECT_RANGE_M,
                    1.0 if y > 0.0 else 0.0,
                    float(obst_seen),
                    float(ped_seen),
                    yaw / math.pi,
                ],
            ]
        )
        space = self.observation_space
        return np.clip(obs, space.low, space.high).astype(np.float32)  # type: ignore[attr-defined]

    def _collision(self) -> str | None:
        x, y, yaw = self.car.pose
        g = self.geometry
        car = rectangle_corners(x, y, g.footprint_length_m, g.footprint_width_m, yaw)
        ox, oy = float(self.obstacle_xy[0]), float(self.obstacle_xy[1])
        obst = rectangle_corners(ox, oy, OBSTACLE_SIZE_M[0], OBSTACLE_SIZE_M[1], 0.0)
        if _rects_overlap(car, obst):
            return "obstacle"
        gap = _disc_rect_distance(
            self.pedestrian_xy, x, y, yaw, (g.footprint_length_m, g.footprint_width_m)
        )
        if gap <= PED_RADIUS_M:
            return "pedestrian"
        return None

    def _off_road(self) -> bool:
        x, y, yaw = self.car.pose
        g = self.geometry
        car = rectangle_corners(x, y, g.footprint_length_m, g.footprint_width_m, yaw)
        return bool(np.max(np.abs(car[:, 1])) > ROAD_HALF_WIDTH_M)

    # ------------------------------------------------------------------ step
    def step(self, action: Any) -> tuple[FloatArray, float, bool, bool, dict[str, Any]]:
        if self._done:
            raise Sim2RealValueError("step() called after the episode ended; call reset() first")
        if not self.action_space.contains(action):
            try:
                a = int(action)
            except (TypeError, ValueError):
                a = -1
            if a not in range(4) or a != action:
                raise Sim2RealValueError(
                    f"action must be 0 (speed +0.15 m/s), 1 (speed -0.075 m/s), 2 (steer left "
                    f"5 deg) or 3 (steer right 5 deg), got {action!r}"
                )
        a = int(action)
        if a == 0:
            self.cmd_speed_mps += SPEED_STEP_UP_MPS
        elif a == 1:
            self.cmd_speed_mps = max(self.cmd_speed_mps - SPEED_STEP_DOWN_MPS, 0.0)
        else:
            lim = self.geometry.max_steer_rad
            step = STEER_STEP_RAD if a == 2 else -STEER_STEP_RAD
            self.cmd_steer_rad = min(max(self.cmd_steer_rad + step, -lim), lim)
        v_cap = self.car.get_drive_params().speed_lim_v_mps
        self.cmd_speed_mps = min(self.cmd_speed_mps, v_cap)
        self.car.step(self.cmd_speed_mps, self.cmd_steer_rad, self.control_dt)
        self._advance_pedestrian(self.control_dt)
        self._steps += 1
        x, y, _ = self.car.pose
        self._tracker.record(x=x, y=y, v=self.car.speed_mps, w=0.0)
        d = self._goal_distance()
        collision = self._collision()
        outcome: str | None = None
        if collision is not None:
            outcome = "collision"
        elif self._off_road():
            outcome = "off_road"
        elif x >= GOAL_X_M:
            outcome = "success"
        elif self._steps >= self.max_episode_steps:
            outcome = "timeout"
        reward = self._reward(d, outcome, collision)
        self._prev_goal_dist = d
        obs = self._observation()
        if outcome is not None:
            self._done = True
        terminated = outcome in ("success", "collision", "off_road")
        truncated = outcome == "timeout"
        return obs, reward, terminated, truncated, self._info(outcome, collision)

    def _reward(self, d: float, outcome: str | None, collision: str | None) -> float:
        cfg = self.reward_config
        delta = self._prev_goal_dist - d
        r = cfg.progress_per_m * delta if abs(delta) > 1e-4 else -cfg.immobile
        if outcome == "success":
            r += cfg.goal
        elif collision == "obstacle":
            r -= cfg.obstacle
        elif collision == "pedestrian":
            r -= cfg.pedestrian
        elif outcome == "off_road":
            r -= min(abs(cfg.off_road_ref - 10.0 * d), cfg.off_road_cap)
        return float(r)

    def _info(self, outcome: str | None, collision: str | None) -> dict[str, Any]:
        info: dict[str, Any] = {
            "is_success": outcome == "success",
            "collision": collision,
            "outcome": outcome,
            "pedestrian_walking": self.pedestrian_walking,
        }
        if outcome is not None:
            base = self._tracker.finish("collision" if outcome == "off_road" else outcome)
            metrics: dict[str, Any] = dict(base.to_dict())
            metrics.update(outcome=outcome, collision=outcome == "collision")
            metrics["off_road"] = outcome == "off_road"
            metrics["collision_with"] = collision
            info["metrics"] = metrics
        return info
