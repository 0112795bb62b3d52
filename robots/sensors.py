r"""Sensors of a :class:`~robots.pybullet_robot.PybulletRobot`: 2-D lidar and depth camera.

Conventions (all outputs float32 numpy arrays in SI units):

- **Lidar** ``scan() -> (beams,)`` ranges in m along each beam, beam ``i`` at angle
  ``angle_min + i * angle_increment`` (counter-clockwise from the lidar's x axis, which is
  parallel to base_link). One ``rayTestBatch`` per scan; each ray starts ``range_min`` from the
  lidar origin. A beam that hits nothing within ``range_max``, and an obstacle nearer than
  ``range_min``, both read **``range_max``** (the LDS-01 driver reports such beams as 0, which
  consumers treat as "no return"; here "no return" is always ``range_max``). Rays hit collision
  shapes, the robot's own included (the mounts are above the bodies, so this does not happen
  for the shipped specs).
- **Depth camera** ``render() -> (height, width)`` depth in m **along the optical axis** (the
  z-buffer linearised with the near/far clip distances; not the ray length). Pixels with
  nothing before ``far_m`` are **NaN**. pybullet's renderer draws *visual* shapes, so obstacles
  need a visual shape (:mod:`robots.world` adds both). The mount pose (base frame, camera body
  frame with x along the optical axis) can be changed at run time with :meth:`DepthCamera.set_pose`.
- **Odometry**: :meth:`~robots.pybullet_robot.PybulletRobot.odometry`.

Examples
--------
>>> from robots import DepthCamera, Lidar, PybulletRobot, load_spec
>>> robot = PybulletRobot(load_spec("turtlebot3_waffle_pi"))
>>> Lidar(robot.spec.lidar, robot).scan().shape
(360,)
>>> DepthCamera(robot.spec.depth_camera, robot, width=64, height=48).render().shape
(48, 64)
>>> robot.close()
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from robots._pybullet import pybullet as p
from robots.arrays import FloatArray
from robots.errors import RobotsValueError
from robots.pybullet_robot import PybulletRobot
from robots.spec import CameraSpec, LidarSpec

__all__ = ["DepthCamera", "Lidar", "rpy_matrix"]

Float32Array = NDArray[np.float32]


def rpy_matrix(rpy: Sequence[float]) -> FloatArray:
    """Rotation matrix of roll-pitch-yaw angles (rad), ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    return np.asarray(
        p.getMatrixFromQuaternion(p.getQuaternionFromEuler(list(rpy))), dtype=np.float64
    ).reshape(3, 3)


def _base_pose(robot: PybulletRobot) -> tuple[FloatArray, FloatArray]:
    """World position (m) and rotation matrix of base_link."""
    pos, orn = p.getBasePositionAndOrientation(robot.body_id, physicsClientId=robot.client)
    rot = np.asarray(p.getMatrixFromQuaternion(orn), dtype=np.float64).reshape(3, 3)
    return np.asarray(pos, dtype=np.float64), rot


def _vec3(name: str, values: Sequence[float]) -> FloatArray:
    arr = np.asarray(values, dtype=np.float64)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise RobotsValueError(f"{name} must be 3 finite numbers, got {values!r}")
    return arr


class Lidar:
    """2-D lidar by batched ray casts (see the module docstring for the conventions).

    Parameters
    ----------
    spec : LidarSpec
        Beams, angles, ranges and mount.
    robot : PybulletRobot
        The robot carrying it.
    """

    def __init__(self, spec: LidarSpec, robot: PybulletRobot) -> None:
        self.spec = spec
        self.robot = robot
        angles = spec.angle_min_rad + spec.angle_increment_rad * np.arange(
            spec.beams, dtype=np.float64
        )
        self.angles_rad: FloatArray = np.asarray(angles, dtype=np.float64)
        self._dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
        self._mount = np.asarray(spec.xyz_m, dtype=np.float64)

    def scan(self) -> Float32Array:
        """Ranges (m) of one scan from the current pose, float32, shape ``(beams,)``."""
        s = self.spec
        pos, rot = _base_pose(self.robot)
        origin = pos + rot @ self._mount
        dirs = self._dirs @ rot.T
        starts = origin + s.range_min_m * dirs
        ends = origin + s.range_max_m * dirs
        hits = p.rayTestBatch(starts.tolist(), ends.tolist(), physicsClientId=self.robot.client)
        frac = np.fromiter((h[2] if h[0] >= 0 else 1.0 for h in hits), np.float64, len(hits))
        ranges = s.range_min_m + frac * (s.range_max_m - s.range_min_m)
        return ranges.astype(np.float32)


class DepthCamera:
    """Depth camera rendered with pybullet's TinyRenderer (works in DIRECT mode).

    Parameters
    ----------
    spec : CameraSpec
        Intrinsics, clip distances and nominal mount.
    robot : PybulletRobot
        The robot carrying it.
    width, height : int, optional
        Override the spec's resolution (the horizontal FOV is kept).
    """

    def __init__(
        self,
        spec: CameraSpec,
        robot: PybulletRobot,
        *,
        width: int | None = None,
        height: int | None = None,
    ) -> None:
        self.spec = spec
        self.robot = robot
        self.width = int(width or spec.width)
        self.height = int(height or spec.height)
        if self.width < 1 or self.height < 1:
            raise RobotsValueError(
                f"camera size must be >= 1 x 1 pixels, got {self.width} x {self.height}"
            )
        aspect = self.width / self.height
        vfov = math.degrees(2.0 * math.atan(math.tan(math.radians(spec.hfov_deg) / 2) / aspect))
        self.vfov_deg = vfov
        self._proj = p.computeProjectionMatrixFOV(vfov, aspect, spec.near_m, spec.far_m)
        self.set_pose(spec.xyz_m, spec.rpy_rad)

    def get_pose(self) -> tuple[FloatArray, FloatArray]:
        """Current mount: (xyz [m], rpy [rad]) of the camera body frame in base_link."""
        return self._xyz.copy(), self._rpy.copy()

    def set_pose(self, xyz: Sequence[float], rpy: Sequence[float]) -> None:
        """Move the camera to ``xyz`` (m) and ``rpy`` (rad) in base_link (body frame)."""
        self._xyz = _vec3("camera xyz", xyz)
        self._rpy = _vec3("camera rpy", rpy)
        self._rot = rpy_matrix(self._rpy.tolist())

    def world_pose(self) -> tuple[FloatArray, FloatArray]:
        """World position (m) and rotation matrix of the camera body frame now."""
        pos, rot = _base_pose(self.robot)
        return pos + rot @ self._xyz, rot @ self._rot

    def view_matrix(self) -> FloatArray:
        """pybullet's view matrix (16 floats, column-major) of the current camera frame."""
        eye, rot = self.world_pose()
        view = p.computeViewMatrix(
            cameraEyePosition=eye.tolist(),
            cameraTargetPosition=(eye + rot[:, 0]).tolist(),
            cameraUpVector=rot[:, 2].tolist(),
        )
        return np.asarray(view, dtype=np.float64)

    def projection_matrix(self) -> FloatArray:
        """pybullet's projection matrix (16 floats, column-major)."""
        return np.asarray(self._proj, dtype=np.float64)

    def render(self) -> Float32Array:
        """Depth image (m along the optical axis; NaN beyond ``far_m``), shape (height, width)."""
        s = self.spec
        out = p.getCameraImage(
            self.width,
            self.height,
            viewMatrix=self.view_matrix().tolist(),
            projectionMatrix=list(self._proj),
            renderer=p.ER_TINY_RENDERER,
            flags=p.ER_NO_SEGMENTATION_MASK,
            physicsClientId=self.robot.client,
        )
        zbuf = np.asarray(out[3], dtype=np.float64).reshape(self.height, self.width)
        depth = s.far_m * s.near_m / (s.far_m - (s.far_m - s.near_m) * zbuf)
        depth[zbuf >= 1.0] = np.nan
        return depth.astype(np.float32)
