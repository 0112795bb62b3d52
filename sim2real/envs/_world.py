"""The pybullet side of an env world: static obstacles, pedestrian bodies and the depth camera.

pybullet runs in DIRECT mode, one client per env. Static obstacles (cylinders, boxes, walls)
are rebuilt at each reset; pedestrians are upright cylinders moved kinematically every step.
The depth camera renders with pybullet's software (TinyRenderer) rasteriser.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from sim2real.envs.geometry import FloatArray

__all__ = ["DepthCameraRig", "PybulletWorld", "rpy_matrix"]


def rpy_matrix(roll: float, pitch: float, yaw: float) -> FloatArray:
    """Rotation matrix R = Rz(yaw) Ry(pitch) Rx(roll) (fixed-axis roll-pitch-yaw)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


class PybulletWorld:
    """Bodies of one env in its own DIRECT pybullet client."""

    def __init__(self) -> None:
        import pybullet as p

        self.p = p
        self.client: int = p.connect(p.DIRECT)
        p.setGravity(0.0, 0.0, -9.81, physicsClientId=self.client)
        self._static: list[int] = []
        self._peds: list[int] = []
        self._ped_key: tuple[float, ...] = ()
        col = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=self.client)
        # a thin visual box whose top face is the collision plane z = 0
        vis = p.createVisualShape(
            p.GEOM_BOX,
            halfExtents=[50.0, 50.0, 0.005],
            visualFramePosition=[0.0, 0.0, -0.005],
            physicsClientId=self.client,
        )
        self.floor = p.createMultiBody(
            0.0, col, vis, basePosition=[0.0, 0.0, 0.0], physicsClientId=self.client
        )

    def close(self) -> None:
        """Disconnect the client (idempotent)."""
        if self.client >= 0:
            self.p.disconnect(physicsClientId=self.client)
            self.client = -1

    def set_static(
        self,
        *,
        cylinders: FloatArray,
        cylinder_height_m: float | Sequence[float],
        boxes: FloatArray,
        box_height_m: float | Sequence[float],
    ) -> None:
        """Replace the static obstacles.

        Parameters
        ----------
        cylinders : ndarray, shape (N, 3)
            ``(x, y, r)`` of upright cylinders, m.
        boxes : ndarray, shape (K, 5)
            ``(cx, cy, length, width, yaw)`` of upright boxes (walls), m and rad.
        cylinder_height_m, box_height_m : float or sequence
            Heights, m (one value or one per obstacle).
        """
        p, c = self.p, self.client
        for body in self._static:
            p.removeBody(body, physicsClientId=c)
        self._static = []
        ch = np.broadcast_to(np.asarray(cylinder_height_m, dtype=float), (len(cylinders),))
        for (x, y, r), h in zip(cylinders, ch, strict=True):
            col = p.createCollisionShape(p.GEOM_CYLINDER, radius=r, height=h, physicsClientId=c)
            vis = p.createVisualShape(p.GEOM_CYLINDER, radius=r, length=h, physicsClientId=c)
            self._static.append(
                p.createMultiBody(0.0, col, vis, basePosition=[x, y, 0.5 * h], physicsClientId=c)
            )
        bh = np.broadcast_to(np.asarray(box_height_m, dtype=float), (len(boxes),))
        for (cx, cy, length, width, yaw), h in zip(boxes, bh, strict=True):
            half = [0.5 * length, 0.5 * width, 0.5 * h]
            col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
            vis = p.createVisualShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
            orn = p.getQuaternionFromEuler([0.0, 0.0, yaw])
            self._static.append(
                p.createMultiBody(
                    0.0,
                    col,
                    vis,
                    basePosition=[cx, cy, 0.5 * h],
                    baseOrientation=orn,
                    physicsClientId=c,
                )
            )

    def set_pedestrians(self, xy: FloatArray, radius_m: FloatArray, height_m: FloatArray) -> None:
        """Place the pedestrian bodies (rebuilt when their number or sizes change)."""
        p, c = self.p, self.client
        key = tuple(np.round(np.concatenate([radius_m, height_m]), 6).tolist())
        if key != self._ped_key:
            for body in self._peds:
                p.removeBody(body, physicsClientId=c)
            self._peds = []
            for r, h in zip(radius_m, height_m, strict=True):
                vis = p.createVisualShape(p.GEOM_CYLINDER, radius=r, length=h, physicsClientId=c)
                self._peds.append(p.createMultiBody(0.0, -1, vis, physicsClientId=c))
            self._ped_key = key
        for body, (x, y), h in zip(self._peds, xy, height_m, strict=True):
            p.resetBasePositionAndOrientation(
                body, [x, y, 0.5 * h], [0.0, 0.0, 0.0, 1.0], physicsClientId=c
            )


class DepthCameraRig:
    """A depth camera mounted on the base (pose in the base frame, changeable at run time).

    Parameters
    ----------
    world : PybulletWorld
        Where to render.
    width, height : int
        Image size, pixels.
    hfov_deg : float
        Horizontal field of view, degrees.
    near_m, far_m : float
        Clip planes, m; pixels with no return read ``far_m``.
    xyz_m, rpy_rad : sequence
        Mount pose of the camera body frame (x along the optical axis, z up) in the base frame.
    base_height_m : float
        Height of the base frame above the floor, m.
    """

    def __init__(
        self,
        world: PybulletWorld,
        *,
        width: int,
        height: int,
        hfov_deg: float,
        near_m: float,
        far_m: float,
        xyz_m: Sequence[float],
        rpy_rad: Sequence[float],
        base_height_m: float,
    ) -> None:
        self.world = world
        self.width, self.height = int(width), int(height)
        self.hfov_deg = float(hfov_deg)
        self.near_m, self.far_m = float(near_m), float(far_m)
        self.base_height_m = float(base_height_m)
        vfov = math.degrees(
            2.0 * math.atan(math.tan(math.radians(hfov_deg) / 2.0) * self.height / self.width)
        )
        self.projection = world.p.computeProjectionMatrixFOV(
            vfov, self.width / self.height, self.near_m, self.far_m
        )
        self.set_pose(xyz_m, rpy_rad)
        self.view_matrix: FloatArray = np.eye(4).reshape(-1)

    def set_pose(self, xyz_m: Sequence[float], rpy_rad: Sequence[float]) -> None:
        """Mount pose in the base frame (m, rad)."""
        self.xyz_m = np.asarray(xyz_m, dtype=np.float64).reshape(3).copy()
        self.rpy_rad = np.asarray(rpy_rad, dtype=np.float64).reshape(3).copy()
        self._r_mount = rpy_matrix(*self.rpy_rad)

    def update_view(self, x: float, y: float, yaw: float) -> FloatArray:
        """pybullet's column-major view matrix for the base at planar pose (x, y, yaw)."""
        r_base = rpy_matrix(0.0, 0.0, yaw)
        eye = np.array([x, y, self.base_height_m]) + r_base @ self.xyz_m
        rot = r_base @ self._r_mount
        target = eye + rot[:, 0]
        up = rot[:, 2]
        self.view_matrix = np.asarray(
            self.world.p.computeViewMatrix(eye.tolist(), target.tolist(), up.tolist()),
            dtype=np.float64,
        )
        return self.view_matrix

    def render(self, x: float, y: float, yaw: float) -> FloatArray:
        """Metric depth image (z along the optical axis), shape (height, width), m."""
        p = self.world.p
        view = self.update_view(x, y, yaw)
        _, _, _, buf, _ = p.getCameraImage(
            self.width,
            self.height,
            view.tolist(),
            self.projection,
            renderer=p.ER_TINY_RENDERER,
            flags=p.ER_NO_SEGMENTATION_MASK,
            physicsClientId=self.world.client,
        )
        d = np.asarray(buf, dtype=np.float64).reshape(self.height, self.width)
        n, f = self.near_m, self.far_m
        depth = f * n / (f - (f - n) * d)
        return np.asarray(np.clip(depth, n, f))
