"""A small Dict-observation env for the randomizer tests: a TEST DOUBLE of the env protocols.

It is not a simulator. It implements the camera protocol (a mount pose in the base frame and
a numpy view matrix = inverse of world<-base<-camera) and the drive protocol (it holds a
:class:`robots.params.DriveParams`) exactly as docs/ARCHITECTURE.md specifies, with dynamics
simple enough that tests can predict every number:

- ``velocity`` echoes the (clipped) action of the current step: ``[v, w]``;
- the base moves by ``v * control_dt`` along its heading and turns by ``w * control_dt``;
- ``goal`` is the goal (3, 4) m in the base frame, Cartesian or (distance, bearing);
- ``depth`` is a fixed 64x64 ramp from 0.5 to 7.5 m with invalid pixels (NaN, 0, far);
- ``lidar`` is 36 beams from 0.5 to 2.25 m with two beams at max range (3.5 m);
- the episode terminates (success) within 0.3 m of the goal.

Variants break one protocol promise each, to test that the wrappers notice.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from robots.params import DriveParams

__all__ = [
    "DEPTH_FAR_M",
    "DEPTH_NEAR_M",
    "ENV_ID",
    "FULL_STACK",
    "ForgetfulDriveEnv",
    "IgnoringCameraEnv",
    "LastFrameViewEnv",
    "NavDouble",
    "StaticViewEnv",
    "depth_image",
]

DEPTH_NEAR_M = 0.05  # TurtleBot 2 Kinect model clip range (robot-specs.md)
DEPTH_FAR_M = 8.0
LIDAR_MIN_M, LIDAR_MAX_M = 0.12, 3.5  # LDS-01 (robot-specs.md)
GOAL_XY = np.array([3.0, 4.0])


def depth_image(size: int = 64, invalid_pixels: bool = True) -> np.ndarray:
    """The fixed depth image: a ramp with NaN, 0, max-range and inf pixels in the first row."""
    img = np.linspace(0.5, 7.5, size * size, dtype=np.float32).reshape(size, size)
    if not invalid_pixels:  # stays inside the Box (for gymnasium's env checkers)
        return img
    img[0, 0] = np.nan
    img[0, 1] = 0.0
    img[0, 2] = DEPTH_FAR_M
    img[0, 3] = np.inf
    return img


def _rot(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _transform(xyz: np.ndarray, rpy: np.ndarray) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = _rot(*rpy)
    t[:3, 3] = xyz
    return t


class NavDouble(gym.Env[dict[str, np.ndarray], np.ndarray]):
    """Dict-observation navigation test double with the camera and drive protocols."""

    metadata: dict[str, Any] = {"render_modes": []}  # noqa: RUF012
    control_dt = 0.1

    def __init__(
        self, size: int = 64, polar_goal: bool = False, invalid_pixels: bool = True
    ) -> None:
        self.size = size
        self.polar_goal = polar_goal
        goal_low = np.array([0.0, -math.pi] if polar_goal else [-20.0, -20.0], np.float32)
        goal_high = np.array([40.0, math.pi] if polar_goal else [20.0, 20.0], np.float32)
        self.observation_space = spaces.Dict(
            {
                "depth": spaces.Box(0.0, DEPTH_FAR_M, (size, size), np.float32),
                "lidar": spaces.Box(LIDAR_MIN_M, LIDAR_MAX_M, (36,), np.float32),
                "goal": spaces.Box(goal_low, goal_high, dtype=np.float32),
                "velocity": spaces.Box(-2.0, 2.0, (2,), np.float32),
            }
        )
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.drive_params = DriveParams(
            delay_s=0.1, coulomb_v_fwd_n=1.0, motor_gain_nms_per_rad=0.5, added_mass_kg=0.5
        )
        # TurtleBot 2 camera_rgb_frame from base_link (robot-specs.md): x -0.087, y -0.0125, z 0.287.
        self.camera_xyz = np.array([-0.087, -0.0125, 0.287])
        self.camera_rpy = np.zeros(3)
        self._depth = depth_image(size, invalid_pixels)
        self._lidar = np.linspace(0.5, 2.25, 36).astype(np.float32)
        self._lidar[[5, 20]] = LIDAR_MAX_M
        self.pose = np.zeros(3)
        self.velocity = np.zeros(2, np.float32)
        self.steps = 0

    # -- camera protocol -------------------------------------------------------------------
    def get_camera_pose(self) -> tuple[np.ndarray, np.ndarray]:
        return self.camera_xyz.copy(), self.camera_rpy.copy()

    def set_camera_pose(self, xyz: np.ndarray, rpy: np.ndarray) -> None:
        self.camera_xyz = np.asarray(xyz, dtype=np.float64).copy()
        self.camera_rpy = np.asarray(rpy, dtype=np.float64).copy()

    def get_camera_view_matrix(self) -> np.ndarray:
        x, y, yaw = self.pose
        world_base = _transform(np.array([x, y, 0.0]), np.array([0.0, 0.0, yaw]))
        world_cam = world_base @ _transform(self.camera_xyz, self.camera_rpy)
        return np.linalg.inv(world_cam).T.reshape(16)  # column-major, like pybullet

    # -- drive protocol --------------------------------------------------------------------
    def get_drive_params(self) -> DriveParams:
        return self.drive_params

    def set_drive_params(self, params: DriveParams) -> None:
        self.drive_params = params

    # -- gymnasium API ---------------------------------------------------------------------
    def _obs(self) -> dict[str, np.ndarray]:
        x, y, yaw = self.pose
        dx, dy = GOAL_XY[0] - x, GOAL_XY[1] - y
        gx = math.cos(yaw) * dx + math.sin(yaw) * dy
        gy = -math.sin(yaw) * dx + math.cos(yaw) * dy
        goal = [math.hypot(gx, gy), math.atan2(gy, gx)] if self.polar_goal else [gx, gy]
        return {
            "depth": self._depth.copy(),
            "lidar": self._lidar.copy(),
            "goal": np.asarray(goal, dtype=np.float32),
            "velocity": self.velocity.copy(),
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        super().reset(seed=seed)
        self.pose = np.array([*self.np_random.uniform(-0.5, 0.5, 2), 0.0])
        self.velocity = np.zeros(2, np.float32)
        self.steps = 0
        return self._obs(), {}

    def step(
        self, action: np.ndarray
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        v, w = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        self.velocity = np.array([v, w], np.float32)
        x, y, yaw = self.pose
        self.pose = np.array(
            [
                x + v * self.control_dt * math.cos(yaw),
                y + v * self.control_dt * math.sin(yaw),
                yaw + w * self.control_dt,
            ]
        )
        self.steps += 1
        distance = float(np.hypot(*(GOAL_XY - self.pose[:2])))
        success = distance < 0.3
        return self._obs(), -distance, success, False, {"is_success": success}


class IgnoringCameraEnv(NavDouble):
    """Breaks the camera protocol: set_camera_pose is ignored."""

    def set_camera_pose(self, xyz: np.ndarray, rpy: np.ndarray) -> None:
        return None


class StaticViewEnv(NavDouble):
    """Breaks the camera protocol: the view matrix never depends on the mount pose."""

    def get_camera_view_matrix(self) -> np.ndarray:
        return np.eye(4).reshape(16)


class ForgetfulDriveEnv(NavDouble):
    """Breaks the drive protocol: reset() restores the default drive parameters."""

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        self.drive_params = DriveParams()
        return super().reset(seed=seed, options=options)


class LastFrameViewEnv(NavDouble):
    """Reports the view matrix of the last rendered frame (updated in reset/step), as a
    renderer that caches it does; ``use_pose=False`` breaks it (renders the default mount)."""

    def __init__(self, use_pose: bool = True) -> None:
        super().__init__()
        self.use_pose = use_pose
        self._last_view = np.eye(4).reshape(16)

    def _render(self) -> None:
        if self.use_pose:
            self._last_view = super().get_camera_view_matrix()
        else:
            saved = self.camera_xyz, self.camera_rpy
            self.camera_xyz, self.camera_rpy = np.array([-0.087, -0.0125, 0.287]), np.zeros(3)
            self._last_view = super().get_camera_view_matrix()
            self.camera_xyz, self.camera_rpy = saved

    def get_camera_view_matrix(self) -> np.ndarray:
        return self._last_view.copy()

    def _obs(self) -> dict[str, np.ndarray]:
        self._render()
        return super()._obs()


ENV_ID = "sim2real-tests/NavDouble-v0"
if ENV_ID not in gym.registry:
    gym.register(
        id=ENV_ID, entry_point=NavDouble, max_episode_steps=50, kwargs={"invalid_pixels": False}
    )

#: Every randomizer once, innermost first (the stack the vector, checker and config tests use).
FULL_STACK: dict[str, Any] = {
    "format": "sim2real.randomizers/1",
    "randomizers": [
        {
            "type": "DynamicsRandomizer",
            "uniform": {"coulomb_v_fwd_n": [0.5, 1.5]},
            "normal": {"added_mass_kg": [0.5, 0.2]},
        },
        {"type": "CameraPoseJitter", "position_std_m": 0.02, "orientation_std_deg": 2.0},
        {"type": "ActionDelay", "delay_s": [0.0, 0.3]},
        {"type": "OdometryDelay", "key": "velocity", "delay_steps": [1, 3]},
        {"type": "DepthNoise", "key": "depth", "near_m": DEPTH_NEAR_M, "far_m": DEPTH_FAR_M},
        {"type": "LidarNoise", "key": "lidar", "std_m": 0.01, "dropout": 0.05},
        {"type": "GoalNoise", "key": "goal"},
        {"type": "ObservationNoise", "key": "velocity", "std": 0.01},
    ],
}
