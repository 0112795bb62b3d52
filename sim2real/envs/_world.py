"""The pybullet side of an env world: static obstacles, pedestrian bodies and the depth camera.

pybullet runs in DIRECT mode, one client per env. Static obstacles (cylinders, boxes, walls)
are rebuilt at each reset; pedestrians are upright cylinder bodies (with collision shapes, so
ray tests and the camera see them) moved kinematically every step.
The envs render depth with :mod:`sim2real.envs.depth`; pybullet's TinyRenderer
(:func:`render_pybullet_depth`) is the reference it is tested and benchmarked against.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from robots.units import GRAVITY_MPS2
from sim2real.envs.geometry import FloatArray

__all__ = ["PybulletWorld", "render_pybullet_depth"]


def _pybullet() -> tuple[Any, Any]:
    """pybullet and :mod:`robots.world`, imported by the first pybullet world: an env with the
    reduced dynamics never loads pybullet."""
    from robots import _pybullet, world

    return _pybullet.pybullet, world


class PybulletWorld:
    """Bodies of one env in its own DIRECT pybullet client (ground from :mod:`robots.world`)."""

    def __init__(self) -> None:
        p, self._bodies = _pybullet()
        self.p = p
        self.client: int = p.connect(p.DIRECT)
        p.setGravity(0.0, 0.0, -GRAVITY_MPS2, physicsClientId=self.client)
        self.ground = self._bodies.add_ground(self.client)
        self._static: list[int] = []
        self._peds: list[int] = []
        self._ped_key: tuple[float, ...] = ()

    @property
    def pedestrian_ids(self) -> list[int]:
        """pybullet body ids of the pedestrians, in the order of the last ``set_pedestrians``."""
        return list(self._peds)

    def reset_simulation(self) -> None:
        """Remove every body and start from a fresh physics state (same seed, same rollout)."""
        self.p.resetSimulation(physicsClientId=self.client)
        self.p.setGravity(0.0, 0.0, -GRAVITY_MPS2, physicsClientId=self.client)
        self.ground = self._bodies.add_ground(self.client)
        self._static, self._peds, self._ped_key = [], [], ()

    def close(self) -> None:
        """Disconnect the client (idempotent)."""
        if self.client >= 0:
            self.p.disconnect(physicsClientId=self.client)
            self.client = -1

    def set_static(
        self,
        *,
        cylinders: FloatArray,
        cylinder_height_m: float | FloatArray,
        boxes: FloatArray,
        box_height_m: float | FloatArray,
    ) -> None:
        """Replace the static obstacles.

        Parameters
        ----------
        cylinders : ndarray, shape (N, 3)
            ``(x, y, r)`` of upright cylinders, m.
        boxes : ndarray, shape (K, 5)
            ``(cx, cy, length, width, yaw)`` of upright boxes (walls), m and rad.
        cylinder_height_m, box_height_m : float or ndarray
            Heights, m (one value or one per obstacle).
        """
        for body in self._static:
            self.p.removeBody(body, physicsClientId=self.client)
        ch = np.broadcast_to(np.asarray(cylinder_height_m, dtype=float), (len(cylinders),))
        bh = np.broadcast_to(np.asarray(box_height_m, dtype=float), (len(boxes),))
        self._static = self._cylinder_batches(cylinders, ch) + [
            self._bodies.add_box(
                self.client, (cx, cy, 0.5 * h), (0.5 * ln, 0.5 * wd, 0.5 * h), yaw=yaw
            )
            for (cx, cy, ln, wd, yaw), h in zip(boxes, bh, strict=True)
        ]

    def _cylinder_batches(self, cylinders: FloatArray, heights: FloatArray) -> list[int]:
        """Static cylinders, one shared shape and one batched call per distinct (r, h)."""
        p, c = self.p, self.client
        ids: list[int] = []
        keys = np.column_stack([cylinders[:, 2], heights]) if len(cylinders) else np.zeros((0, 2))
        for r, h in np.unique(keys, axis=0):
            sel = (keys[:, 0] == r) & (keys[:, 1] == h)
            col = p.createCollisionShape(p.GEOM_CYLINDER, radius=r, height=h, physicsClientId=c)
            vis = p.createVisualShape(p.GEOM_CYLINDER, radius=r, length=h, physicsClientId=c)
            pos = [[x, y, 0.5 * h] for x, y in cylinders[sel, :2]]
            out = p.createMultiBody(
                baseMass=0.0,
                baseCollisionShapeIndex=col,
                baseVisualShapeIndex=vis,
                batchPositions=pos,
                physicsClientId=c,
            )
            ids.extend([out] if isinstance(out, int) else list(out))
        return ids

    def set_pedestrians(self, xy: FloatArray, radius_m: FloatArray, height_m: FloatArray) -> None:
        """Place the pedestrian cylinders (rebuilt when their number or sizes change).

        They are kinematic bodies with a collision shape: pybullet's ray tests (lidar) and
        camera see them, and the robot touches them.
        """
        p, c = self.p, self.client
        key = tuple(np.round(np.concatenate([radius_m, height_m]), 6).tolist())
        if key != self._ped_key:
            for body in self._peds:
                p.removeBody(body, physicsClientId=c)
            self._peds = []
            for r, h in zip(radius_m, height_m, strict=True):
                col = p.createCollisionShape(p.GEOM_CYLINDER, radius=r, height=h, physicsClientId=c)
                vis = p.createVisualShape(p.GEOM_CYLINDER, radius=r, length=h, physicsClientId=c)
                self._peds.append(p.createMultiBody(0.0, col, vis, physicsClientId=c))
            self._ped_key = key
        for body, (x, y), h in zip(self._peds, xy, height_m, strict=True):
            p.resetBasePositionAndOrientation(
                body, [x, y, 0.5 * h], [0.0, 0.0, 0.0, 1.0], physicsClientId=c
            )


def render_pybullet_depth(
    world: PybulletWorld,
    view_matrix: FloatArray,
    *,
    width: int,
    height: int,
    hfov_deg: float,
    near_m: float,
    far_m: float,
) -> FloatArray:
    """Depth image rendered by pybullet's TinyRenderer (the reference for the numba renderer).

    Returns metres along the optical axis, shape (height, width), clipped to [near, far].
    """
    p = world.p
    vfov = math.degrees(2.0 * math.atan(math.tan(math.radians(hfov_deg) / 2.0) * height / width))
    proj = p.computeProjectionMatrixFOV(vfov, width / height, near_m, far_m)
    _, _, _, buf, _ = p.getCameraImage(
        width,
        height,
        [float(v) for v in view_matrix],
        proj,
        renderer=p.ER_TINY_RENDERER,
        flags=p.ER_NO_SEGMENTATION_MASK,
        physicsClientId=world.client,
    )
    d = np.asarray(buf, dtype=np.float64).reshape(height, width)
    depth = far_m * near_m / (far_m - (far_m - near_m) * d)
    return np.asarray(np.clip(depth, near_m, far_m))
