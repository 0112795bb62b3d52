r"""``sim2real/CrowdNav-v0``: a TurtleBot 2 with lidar and depth camera among pedestrians (Liang et al. 2020).

The robot crosses an enclosed 8 m x 8 m room from x = -3 m to a goal at x = +3 m (reached
within 0.3 m). The world holds static obstacles (cylinders and boxes), walls and
pedestrians (:mod:`sim2real.envs.pedestrians`, walking speed by eq. (1) of Liang et al. (2020)).

Scenario families and the complexity factor c in [0, 1] (Liang et al. 2020, Sec. I-A-2)
    ``"static"``
        Only immovable obstacles in the room of constant size; c sets their number
        (round(20 c)).
    ``"dynamic"``
        Random static and dynamic obstacles: round(10 c) static obstacles and
        round(5 + 15 c) pedestrians (20 at c = 1; 20 % of them stand still), and pedestrians
        walk faster as c grows: the stride constant alpha of eq. (1) is scaled by (1 + 0.5 c)
        ("higher than average values for the constants").
    ``"occluded"``
        Two staggered wall panels in front of the start hide part of the camera's view; c sets
        the occlusion % = (angle not visible / camera FOV) x 100 = 90 c (measured exactly by ray
        casting and reported as ``info["occlusion_pct"]``) and the number of pedestrians,
        round(2 + 8 c), who wait behind the panels and start walking across the robot's path at
        random times in [0, 8] s.

``reset(options={"scenario": ..., "complexity": c})`` picks them per episode;
``"num_pedestrians"`` or ``"pedestrian_density"`` (per m^2 of room; 1-3 run) override the
pedestrian count.

Pedestrian policy (``pedestrians=`` or the reset option ``"pedestrians"``)
    ``"eq1"`` (default): the density-dependent walking speed of eq. (1) of Liang et al. (2020)
    (:mod:`sim2real.envs.pedestrians`); ``"orca"``: optimal reciprocal collision avoidance
    (:mod:`sim2real.envs.orca`, the policy crowd-navigation papers compare against) at the
    same preferred speeds, goals and start times; pedestrians then avoid the robot with its
    current velocity.

Observation (``Dict``)
    ``"lidar"``: ranges of the 2-D lidar of the spec (m; outside its limits read the maximum);
    ``"depth"``: depth image (m along the optical axis, shape (height, width), 64 x 48 by
    default; no return reads ``far_m``); ``"goal"``: goal distance (m) and bearing (rad) in
    the base frame; ``"velocity"``: measured (v [m/s], w [rad/s]); with ``neighbours=K`` > 0
    also ``"neighbours"``: the K nearest pedestrians relative to the robot, in its frame, K
    rows of (x, y [m], vx, vy [m/s]) flattened, nearest first, zero rows where fewer walk
    (the human states a crowd-aware policy such as SARL, Chen et al. 2019, attends over).
Action
    (v, w), v in [0, max_v] m/s and w in [-max_w, max_w] rad/s of the robot spec (0.7 m/s,
    3.14 rad/s for the TurtleBot 2).
Reward (constants in :class:`CrowdNavReward`)
    .. math::

        r = r_{reach}[\text{success}] - r_{coll}[\text{collision}]
            + k_{prog}(d_{t-1} - d_t)
            - k_{prox}\max(0, 1 - c_t / c_{safe})
            - k_v|\Delta v| - k_w|\Delta w| - r_{step}

    with :math:`d` the goal distance and :math:`c` the clearance between the robot's
    footprint disc and the nearest body; defaults :math:`r_{reach}` = 10, :math:`r_{coll}` =
    10, :math:`k_{prog}` = 2.5 /m, :math:`k_{prox}` = 0.25 with :math:`c_{safe}` = 0.3 m,
    :math:`k_v` = 0.5 s/m, :math:`k_w` = 0.1 s/rad (smoothness, the paper's jerk concern),
    :math:`r_{step}` = 0.01. ``reward`` takes a :class:`CrowdNavReward` or a mapping of some
    of its fields (a YAML config's ``env.kwargs``).
Outcome
    ``info["outcome"]`` is ``"success"``, ``"collision"`` or ``"timeout"``;
    ``info["metrics"]`` holds the episode metrics (:class:`~sim2real.envs.EpisodeMetrics`).

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs
>>> env = gym.make("sim2real/CrowdNav-v0")
>>> obs, info = env.reset(seed=0, options={"scenario": "occluded", "complexity": 0.5})
>>> obs["depth"].shape
(48, 64)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from robots.params import DriveParams
from robots.randomization import DriveDistribution
from sim2real.envs._nav import NavEnvBase, StepInfo
from sim2real.envs._reward import reward_constants
from sim2real.envs.depth import DepthCamera, DepthScene
from sim2real.envs.geometry import (
    FloatArray,
    Scene2D,
    cast_rays,
    nearest_relative_states,
    rectangle_segments,
)
from sim2real.envs.orca import OrcaCrowd
from sim2real.envs.pedestrians import ALPHA, Crowd, spawn_positions
from sim2real.errors import Sim2RealValueError
from sim2real.plants.closed_loop import PlantSessions
from sim2real.plants.diff_drive import PlantParams

__all__ = [
    "PEDESTRIAN_POLICIES",
    "SCENARIOS",
    "CrowdNavEnv",
    "CrowdNavReward",
    "occlusion_fraction",
]

#: The scenario families of Liang et al. (2020).
SCENARIOS = ("static", "dynamic", "occluded")

_HALF_ROOM_M = 4.0
_WALL_T_M = 0.1
_WALL_H_M = 1.5
_START_X_M = -3.0
_GOAL_X_M = 3.0
_PANEL_D_M = (1.5, 3.0)
_PED_R_M = (0.18, 0.24)
_NEIGHBOUR_BOUND = 20.0  # m and m/s: beyond the room's diagonal and any relative speed
_OPTIONS = {"scenario", "complexity", "num_pedestrians", "pedestrian_density", "pedestrians"}
#: Pedestrian policies: the speed model of eq. (1) of Liang et al. (2020), or ORCA (van den Berg et al. 2011).
PEDESTRIAN_POLICIES = ("eq1", "orca")


@dataclass(frozen=True, kw_only=True)
class CrowdNavReward:
    """Constants of the CrowdNav-v0 reward (see the module docstring)."""

    reach: float = 10.0
    collision: float = 10.0
    progress_per_m: float = 2.5
    proximity: float = 0.25
    safe_clearance_m: float = 0.3
    dv_per_mps: float = 0.5
    dw_per_radps: float = 0.1
    step_penalty: float = 0.01


def occlusion_fraction(
    panels: Scene2D, eye_xy: FloatArray, yaw_rad: float, hfov_rad: float, *, n_rays: int = 721
) -> float:
    """Fraction of the camera's horizontal FOV whose rays hit an occluding panel."""
    angles = yaw_rad + np.linspace(-0.5 * hfov_rad, 0.5 * hfov_rad, n_rays)
    return float(np.mean(cast_rays(panels, eye_xy, angles, 1e3) < 1e3))


def _room_walls() -> FloatArray:
    h, t = _HALF_ROOM_M, _WALL_T_M
    length = 2.0 * h + 2.0 * t
    return np.array(
        [
            [0.0, h + 0.5 * t, length, t, 0.0],
            [0.0, -h - 0.5 * t, length, t, 0.0],
            [h + 0.5 * t, 0.0, length, t, 0.5 * math.pi],
            [-h - 0.5 * t, 0.0, length, t, 0.5 * math.pi],
        ]
    )


def _scene(cylinders: FloatArray, boxes: FloatArray) -> Scene2D:
    seg = np.vstack([rectangle_segments(*b) for b in boxes]) if len(boxes) else np.zeros((0, 4))
    return Scene2D(
        circles_xy=cylinders[:, :2].copy(),
        circles_r=cylinders[:, 2].copy(),
        seg_a=seg[:, :2].copy(),
        seg_b=seg[:, 2:].copy(),
    )


class CrowdNavEnv(NavEnvBase):
    """Dense-crowd navigation of a TurtleBot 2 with lidar and depth camera (Liang et al. 2020).

    Parameters
    ----------
    scenario : str
        Default scenario family (one of :data:`SCENARIOS`).
    complexity : float
        Default complexity factor c in [0, 1].
    num_pedestrians : int, optional
        Fixed pedestrian count (overrides the complexity rule) for the dynamic and occluded
        scenarios.
    pedestrians : str
        Pedestrian policy, one of :data:`PEDESTRIAN_POLICIES` (``"eq1"`` or ``"orca"``).
    depth_width, depth_height : int
        Depth image size, pixels.
    lidar_beams : int, optional
        Beams of the ``"lidar"`` entry, spread evenly over the spec's scan angles (default:
        the spec's count; the TurtleBot 2's 640 beams are its depth camera's columns, and the
        seed papers' policies read 36-72).
    neighbours : int
        Nearest pedestrians in the observation's ``"neighbours"`` entry (0 = no such entry).
    dynamics : str
        ``"reduced"``, ``"pybullet"`` or ``"plant"`` (a foreign base, to evaluate on).
    control_dt : float
        Control period, s.
    max_episode_steps : int
        Steps before a timeout (default 600 = 60 s).
    reward : CrowdNavReward or mapping, optional
        Reward constants (a mapping sets some of the fields).
    drive_params : DriveParams, optional
        Drive parameters (default: the robot spec's).
    drive_distribution : robots.randomization.DriveDistribution, optional
        Draw each episode's robot from it at reset, from the env's ``np_random`` (after the
        world; same seed, same robot), e.g.
        ``DriveDistribution.from_params_file("params.yaml", robot=...)``. The native vector
        env's sub-envs draw the same robots as single envs with the same seeds.
    drive_spread : float
        Multiplies every standard deviation of ``drive_distribution`` (1 = as given).
    plant_sessions : PlantSessions or PlantParams, optional
        ``dynamics="plant"`` only: where each episode's plant session comes from, drawn at
        reset from the env's ``np_random`` after the world (default: the robot's plant with
        the default payload, floor, battery and latency variation); a ``PlantParams`` is one
        fixed session.
    robot : str
        Robot spec name (needs a lidar and a depth camera).
    """

    def __init__(
        self,
        *,
        scenario: str = "dynamic",
        complexity: float = 0.5,
        num_pedestrians: int | None = None,
        pedestrians: str = "eq1",
        depth_width: int = 64,
        depth_height: int = 48,
        lidar_beams: int | None = None,
        neighbours: int = 0,
        dynamics: str = "reduced",
        control_dt: float = 0.1,
        max_episode_steps: int = 600,
        reward: CrowdNavReward | Mapping[str, Any] | None = None,
        drive_params: DriveParams | None = None,
        drive_distribution: DriveDistribution | None = None,
        drive_spread: float = 1.0,
        plant_sessions: PlantSessions | PlantParams | None = None,
        robot: str = "turtlebot2",
    ) -> None:
        self.scenario, self.complexity = self._check_scenario(scenario, complexity)
        if num_pedestrians is not None and not (
            isinstance(num_pedestrians, int) and num_pedestrians >= 0
        ):
            raise Sim2RealValueError(
                f"num_pedestrians must be an integer >= 0 or None, got {num_pedestrians!r}"
            )
        self.num_pedestrians = num_pedestrians
        if isinstance(neighbours, bool) or not (isinstance(neighbours, int) and neighbours >= 0):
            raise Sim2RealValueError(
                f"neighbours must be an integer >= 0 (pedestrians observed), got {neighbours!r}"
            )
        #: (slots, values per slot) of the ``"neighbours"`` entry, None without one
        self.neighbour_slots: tuple[int, int] | None = (neighbours, 4) if neighbours else None
        self.pedestrians = self._check_policy(pedestrians)
        self._episode_policy = self.pedestrians
        super().__init__(
            robot=robot,
            dynamics=dynamics,
            control_dt=control_dt,
            max_episode_steps=max_episode_steps,
            goal_tolerance_m=0.3,
            drive_params=drive_params,
            needs_world=False,
            drive_distribution=drive_distribution,
            drive_spread=drive_spread,
            plant_sessions=plant_sessions,
        )
        cam = self.robot_spec.depth_camera
        if cam is None:
            raise Sim2RealValueError(
                f"robot '{robot}' has no depth camera in its spec; CrowdNav-v0 needs one "
                "(use turtlebot2)"
            )
        if (
            not (isinstance(depth_width, int) and isinstance(depth_height, int))
            or min(depth_width, depth_height) < 1
        ):
            raise Sim2RealValueError(
                f"depth_width and depth_height must be integers >= 1, got "
                f"{depth_width!r} x {depth_height!r}"
            )
        self.camera = DepthCamera(
            width=depth_width,
            height=depth_height,
            hfov_deg=cam.hfov_deg,
            near_m=cam.near_m,
            far_m=cam.far_m,
            xyz_m=cam.xyz_m,
            rpy_rad=cam.rpy_rad,
            base_height_m=self.robot_spec.base_link_height_m,
        )
        self.reward_config = reward_constants(CrowdNavReward, reward, "step_penalty")
        lid = self.robot_spec.lidar
        beams = lid.beams if lidar_beams is None else lidar_beams
        if isinstance(beams, bool) or not (isinstance(beams, int) and beams >= 1):
            raise Sim2RealValueError(
                f"lidar_beams must be an integer >= 1 or None (the spec's {lid.beams}), got "
                f"{lidar_beams!r}; e.g. lidar_beams=64"
            )
        self.lidar_angles_rad = np.linspace(lid.angle_min_rad, lid.angle_max_rad, beams)
        vmax, wmax = float(self.robot_spec.max_v_mps), float(self.robot_spec.max_w_radps)
        f32 = np.float32
        self.observation_space = spaces.Dict(
            {
                "lidar": spaces.Box(lid.range_min_m, lid.range_max_m, (beams,), f32),
                "depth": spaces.Box(cam.near_m, cam.far_m, (depth_height, depth_width), f32),
                "goal": spaces.Box(
                    np.array([0.0, -math.pi], f32), np.array([20.0, math.pi], f32), dtype=f32
                ),
                "velocity": spaces.Box(
                    np.array([-vmax, -wmax], f32), np.array([vmax, wmax], f32), dtype=f32
                ),
                **(
                    {
                        "neighbours": spaces.Box(
                            -_NEIGHBOUR_BOUND, _NEIGHBOUR_BOUND, (4 * neighbours,), f32
                        )
                    }
                    if neighbours
                    else {}
                ),
            }
        )
        self.action_space = spaces.Box(
            np.array([0.0, -wmax], f32), np.array([vmax, wmax], f32), dtype=f32
        )
        self.crowd: Crowd | None = None
        self._full_scene = self._scene
        self._depth_static = DepthScene.build()
        self._depth_scene = self._depth_static
        self._occlusion = 0.0
        self._episode_scenario = self.scenario
        self._episode_complexity = self.complexity

    def set_task(self, *, scenario: str | None = None, complexity: float | None = None) -> None:
        """Use a new default scenario family and/or complexity from the next reset on.

        What a training curriculum moves (``curriculum`` of the training config); None keeps
        the current value, and reset options still override both.

        Examples
        --------
        >>> env = CrowdNavEnv()
        >>> env.set_task(scenario="static", complexity=0.0)
        >>> env.reset(seed=0)[1]["num_pedestrians"]
        0
        """
        self.scenario, self.complexity = self._check_scenario(
            self.scenario if scenario is None else scenario,
            self.complexity if complexity is None else complexity,
        )

    # ------------------------------------------------------------------ protocols
    def get_camera_pose(self) -> tuple[FloatArray, FloatArray]:
        """Depth-camera mount pose in the base frame: (xyz [m], rpy [rad])."""
        return self.camera.xyz_m.copy(), self.camera.rpy_rad.copy()

    def set_camera_pose(self, xyz: Sequence[float], rpy: Sequence[float]) -> None:
        """Move the depth camera on the base (xyz in m, rpy in rad, base frame)."""
        xyz_a = np.asarray(xyz, dtype=np.float64).reshape(-1)
        rpy_a = np.asarray(rpy, dtype=np.float64).reshape(-1)
        if xyz_a.shape != (3,) or rpy_a.shape != (3,) or not np.all(np.isfinite([*xyz_a, *rpy_a])):
            raise Sim2RealValueError(
                f"set_camera_pose needs xyz and rpy as 3 finite numbers each, got {xyz!r}, {rpy!r}"
            )
        self.camera.set_pose(xyz_a, rpy_a)

    def get_camera_view_matrix(self) -> FloatArray:
        """pybullet's column-major view matrix (16 floats) of the last rendered frame."""
        return self.camera.view_matrix.copy()

    # ------------------------------------------------------------------ world
    @staticmethod
    def _check_scenario(scenario: Any, complexity: Any) -> tuple[str, float]:
        if scenario not in SCENARIOS:
            raise Sim2RealValueError(
                f"scenario (--scenario) must be one of {', '.join(SCENARIOS)}, got {scenario!r}; "
                "e.g. --scenario dynamic"
            )
        if not (
            isinstance(complexity, int | float)
            and not isinstance(complexity, bool)
            and 0.0 <= complexity <= 1.0
        ):
            raise Sim2RealValueError(
                f"complexity (--complexity) must be a number in [0, 1], got {complexity!r}; "
                "e.g. --complexity 0.5"
            )
        return str(scenario), float(complexity)

    @staticmethod
    def _check_policy(policy: Any) -> str:
        if policy not in PEDESTRIAN_POLICIES:
            raise Sim2RealValueError(
                f"pedestrians must be one of {', '.join(PEDESTRIAN_POLICIES)}, got {policy!r}; "
                "e.g. pedestrians='orca'"
            )
        return str(policy)

    def _build(self, options: dict[str, Any]) -> tuple[float, float, float]:
        unknown = sorted(set(options) - _OPTIONS)
        if unknown:
            raise Sim2RealValueError(
                f"unknown reset option(s) {unknown} for CrowdNav-v0; known: {sorted(_OPTIONS)}"
            )
        scenario, c = self._check_scenario(
            options.get("scenario", self.scenario), options.get("complexity", self.complexity)
        )
        self._episode_scenario, self._episode_complexity = scenario, c
        self._episode_policy = self._check_policy(options.get("pedestrians", self.pedestrians))
        rng = self.np_random
        walls = _room_walls()
        if scenario == "occluded":
            start = np.array([_START_X_M, 0.0])
            yaw = 0.0
            self._goal = np.array([_GOAL_X_M, 0.0])
            panels = self._panels(rng, 0.9 * c)
            boxes = np.vstack([walls, panels])
            cylinders = np.zeros((0, 3))
        else:
            start = np.array([_START_X_M, rng.uniform(-2.5, 2.5)])
            self._goal = np.array([_GOAL_X_M, rng.uniform(-2.5, 2.5)])
            to_goal = self._goal - start
            yaw = math.atan2(to_goal[1], to_goal[0]) + rng.uniform(-0.25 * math.pi, 0.25 * math.pi)
            n_static = round((20 if scenario == "static" else 10) * c)
            cylinders, extra = self._static_obstacles(rng, n_static, start)
            boxes = np.vstack([walls, extra])
            panels = np.zeros((0, 5))
        self._scene = _scene(cylinders, boxes)
        eye = self._camera_xy(start, yaw)
        self._occlusion = occlusion_fraction(
            _scene(np.zeros((0, 3)), panels), eye, yaw, math.radians(self.camera.hfov_deg)
        )
        box_h = np.full(len(boxes), _WALL_H_M)
        box_h[len(walls) + len(panels) :] = rng.uniform(
            0.8, 1.2, len(boxes) - len(walls) - len(panels)
        )
        cyl_h = rng.uniform(0.8, 1.2, len(cylinders))
        self._depth_static = DepthScene(
            cylinders=np.column_stack([cylinders, cyl_h]), boxes=np.column_stack([boxes, box_h])
        )
        if self._world is not None:  # dynamics="pybullet": the robot needs bodies to touch
            self._world.set_static(
                cylinders=cylinders, cylinder_height_m=cyl_h, boxes=boxes, box_height_m=box_h
            )
        self.crowd = self._make_crowd(rng, scenario, c, options, start, panels)
        self._sync_pedestrians()
        return float(start[0]), float(start[1]), float(yaw)

    def _camera_xy(self, xy: FloatArray, yaw: float) -> FloatArray:
        cx, cy = self.camera.xyz_m[0], self.camera.xyz_m[1]
        c, s = math.cos(yaw), math.sin(yaw)
        return np.array([xy[0] + c * cx - s * cy, xy[1] + s * cx + c * cy])

    def _static_obstacles(
        self, rng: np.random.Generator, n: int, start: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        keep = np.stack([start, self._goal])
        cyl: list[list[float]] = []
        box: list[list[float]] = []
        lim = _HALF_ROOM_M - 0.5
        while len(cyl) + len(box) < n:
            xy = rng.uniform(-lim, lim, 2)
            is_cyl = rng.random() < 0.5
            size = rng.uniform(0.15, 0.35) if is_cyl else rng.uniform(0.3, 0.8)
            reach = size if is_cyl else 0.5 * math.sqrt(2.0) * size
            if np.min(np.linalg.norm(keep - xy, axis=1)) < 0.8 + reach:
                continue
            if is_cyl:
                cyl.append([xy[0], xy[1], size])
            else:
                box.append([xy[0], xy[1], size, rng.uniform(0.3, 0.8), rng.uniform(0, math.pi)])
        return np.array(cyl).reshape(-1, 3), np.array(box).reshape(-1, 5)

    def _panels(self, rng: np.random.Generator, occlusion: float) -> FloatArray:
        """Two staggered panels hiding ``occlusion`` of the FOV seen from the start pose."""
        if occlusion <= 0.0:
            return np.zeros((0, 5))
        eye = self._camera_xy(np.array([_START_X_M, 0.0]), 0.0)
        half = 0.5 * math.radians(self.camera.hfov_deg)
        total = occlusion * 2.0 * half
        share = rng.uniform(0.3, 0.7)
        a_left, a_right = share * total, (1.0 - share) * total
        top = _HALF_ROOM_M
        panels = []
        # left panel (y > 0 side): covers the FOV angles [half - a_left, half] and beyond
        x_l = eye[0] + _PANEL_D_M[0]
        # the panel's corner nearest to the optical axis bounds the hidden angle: the back
        # corner when the panel end lies off the axis' side, else the front corner
        tan_l = math.tan(half - a_left)
        y0 = eye[1] + (_PANEL_D_M[0] + (_WALL_T_M if tan_l > 0 else 0.0)) * tan_l
        panels.append([x_l + 0.5 * _WALL_T_M, 0.5 * (y0 + top), top - y0, _WALL_T_M, 0.5 * math.pi])
        # right panel (y < 0 side): covers [-half, -half + a_right] and beyond
        x_r = eye[0] + _PANEL_D_M[1]
        tan_r = math.tan(-half + a_right)
        y1 = eye[1] + (_PANEL_D_M[1] + (_WALL_T_M if tan_r < 0 else 0.0)) * tan_r
        panels.append([x_r + 0.5 * _WALL_T_M, 0.5 * (y1 - top), y1 + top, _WALL_T_M, 0.5 * math.pi])
        return np.array(panels)

    def _pedestrian_count(self, scenario: str, c: float, options: dict[str, Any]) -> int:
        if "num_pedestrians" in options or "pedestrian_density" in options:
            if "num_pedestrians" in options:
                n = options["num_pedestrians"]
            else:
                rho = options["pedestrian_density"]
                if not (isinstance(rho, int | float) and 0.0 <= rho <= 4.0):
                    raise Sim2RealValueError(
                        f"pedestrian_density must be a number in [0, 4] per m^2, got {rho!r}"
                    )
                n = round(rho * (2.0 * (_HALF_ROOM_M - 0.3)) ** 2)
            if not (isinstance(n, int) and n >= 0):
                raise Sim2RealValueError(f"num_pedestrians must be an integer >= 0, got {n!r}")
            return int(n)
        if self.num_pedestrians is not None:
            return int(self.num_pedestrians)
        if scenario == "static":
            return 0
        return round(5 + 15 * c) if scenario == "dynamic" else round(2 + 8 * c)

    def _make_crowd(
        self,
        rng: np.random.Generator,
        scenario: str,
        c: float,
        options: dict[str, Any],
        start: FloatArray,
        panels: FloatArray,
    ) -> Crowd:
        n = self._pedestrian_count(scenario, c, options)
        lim = _HALF_ROOM_M - 0.3
        bounds = (-lim, lim, -lim, lim)
        keep = np.asarray(start).reshape(1, 2)
        # where pedestrians spawn: in the free space of the scene, 0.6 m off the robot's start
        spawn = functools.partial(
            spawn_positions,
            rng,
            radius_m=_PED_R_M[1],
            scene=self._scene,
            keep_out=keep,
            keep_out_radius_m=0.6,
        )
        start_time = np.zeros(n)
        goals = None
        if scenario == "occluded" and n and len(panels) == 2:
            x_l, x_r = panels[0, 0], panels[1, 0]
            n_a = n // 2
            y_top_l = panels[0, 1] - 0.5 * panels[0, 2]
            y_bot_r = panels[1, 1] + 0.5 * panels[1, 2]
            reg_a = (x_l + 0.3, x_r - 0.3, max(y_top_l, 0.0) + 0.3, lim)
            reg_b = (x_r + 0.3, _GOAL_X_M - 0.6, -lim, min(y_bot_r, 0.0) - 0.3)
            pos = np.vstack([spawn(n_a, bounds=reg_a), spawn(n - n_a, bounds=reg_b)])
            goals = np.column_stack([pos[:, 0], -pos[:, 1]])  # cross the robot's path
            start_time = rng.uniform(0.0, 8.0, n)
        else:
            pos = spawn(n, bounds=bounds)
        pref = rng.uniform(1.0, 1.5, n)
        if scenario == "dynamic":
            pref = np.where(rng.random(n) < 0.2, 0.0, pref)
        kind = OrcaCrowd if self._episode_policy == "orca" else Crowd
        return kind(
            rng,
            position_m=pos,
            radius_m=rng.uniform(*_PED_R_M, n),
            height_m=np.clip(rng.normal(1.72, 0.07, n), 1.5, 1.95),
            pref_speed_mps=pref,
            bounds=bounds,
            alpha=ALPHA * (1.0 + 0.5 * c) if scenario == "dynamic" else ALPHA,
            start_time_s=start_time,
            goals=goals,
        )

    def _sync_pedestrians(self) -> None:
        crowd = self.crowd
        assert crowd is not None
        self._full_scene = self._scene.with_circles(crowd.position_m, crowd.radius_m)
        peds = np.column_stack([crowd.position_m, crowd.radius_m, crowd.height_m])
        if self._world is not None:  # dynamics="pybullet": pedestrians are bodies there too
            self._world.set_pedestrians(crowd.position_m, crowd.radius_m, crowd.height_m)
        self._depth_scene = DepthScene(
            cylinders=np.vstack([self._depth_static.cylinders, peds]),
            boxes=self._depth_static.boxes,
        )

    def _advance(self, dt_s: float) -> None:
        assert self.crowd is not None
        x, y, yaw = self._backend.pose
        v, _ = self._backend.velocity
        self.crowd.step(
            dt_s,
            self._scene,
            robot_xy=np.array([x, y]),
            robot_radius_m=self.robot_radius_m,
            robot_velocity_mps=np.array([v * math.cos(yaw), v * math.sin(yaw)]),
        )
        self._sync_pedestrians()

    def _dynamic_scene(self) -> Scene2D:
        return self._full_scene

    # ------------------------------------------------------------------ obs / reward
    def _observation(self) -> dict[str, FloatArray]:
        x, y, yaw = self._backend.pose
        space = self.observation_space
        lidar = self._lidar_ranges(self._full_scene, self.lidar_angles_rad)
        depth = self.camera.render(self._depth_scene, x, y, yaw)
        d, bearing = self._goal_polar()
        v, w = self._backend.velocity
        vel = space["velocity"]  # type: ignore[index]
        obs = {
            "lidar": lidar.astype(np.float32),
            "depth": depth.astype(np.float32),
            "goal": np.array([min(d, 20.0), bearing], dtype=np.float32),
            "velocity": np.clip(np.array([v, w]), vel.low, vel.high).astype(np.float32),
        }
        if self.neighbour_slots is not None:
            obs["neighbours"] = self._neighbours(x, y, yaw, v, self.neighbour_slots[0])
        return obs

    def _neighbours(self, x: float, y: float, yaw: float, v: float, slots: int) -> FloatArray:
        crowd = self.crowd
        xy = np.zeros((0, 2)) if crowd is None else crowd.position_m
        vel = np.zeros((0, 2)) if crowd is None else crowd.velocity_mps
        rows = nearest_relative_states(
            np.array([x, y]), yaw, np.array([v * math.cos(yaw), v * math.sin(yaw)]), xy, vel, slots
        )
        bound = _NEIGHBOUR_BOUND
        return np.clip(rows.reshape(-1), -bound, bound).astype(np.float32)

    def _reward(self, s: StepInfo) -> float:
        cfg = self.reward_config
        r = cfg.progress_per_m * (s.prev_goal_dist_m - s.goal_dist_m) - cfg.step_penalty
        if s.outcome == "success":
            r += cfg.reach
        elif s.outcome == "collision":
            r -= cfg.collision
        r -= cfg.proximity * max(0.0, 1.0 - s.clearance_m / cfg.safe_clearance_m)
        v_prev, w_prev = self._prev_velocity
        r -= cfg.dv_per_mps * abs(s.v - v_prev) + cfg.dw_per_radps * abs(s.w - w_prev)
        self._prev_velocity = (s.v, s.w)
        return r

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        self._prev_velocity = (0.0, 0.0)
        return super().reset(seed=seed, options=options)

    _prev_velocity: tuple[float, float] = (0.0, 0.0)

    def _extra_info(self) -> dict[str, Any]:
        return {
            "scenario": self._episode_scenario,
            "complexity": self._episode_complexity,
            "occlusion_pct": 100.0 * self._occlusion,
            "num_pedestrians": 0 if self.crowd is None else len(self.crowd),
            "pedestrians": self._episode_policy,
        }
