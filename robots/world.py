"""Minimal pybullet world building: a ground plane and static boxes/cylinders.

Shapes get both a collision shape (what the lidar's ray casts hit) and a visual shape (what the
depth camera renders), so every sensor sees them.

Examples
--------
>>> import pybullet as p
>>> from robots.world import add_box, add_ground
>>> cid = p.connect(p.DIRECT)
>>> ground = add_ground(cid)
>>> wall = add_box(cid, (2.0, 0.0, 0.5), (0.05, 1.0, 0.5))
>>> p.disconnect(cid)
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from robots._pybullet import pybullet as p

__all__ = ["GROUND_FRICTION", "add_box", "add_cylinder", "add_ground"]

#: Lateral friction of the ground (pybullet multiplies the two bodies' coefficients).
GROUND_FRICTION = 1.0

_GROUND_HALF_SIZE_M = 50.0


def add_ground(client: int, *, friction: float = GROUND_FRICTION) -> int:
    """Add a flat ground at z = 0 (an infinite collision plane, a 100 m visual slab).

    Returns the body id. Generated shapes only: no ``pybullet_data`` files are needed.
    """
    col = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client)
    half = _GROUND_HALF_SIZE_M
    vis = p.createVisualShape(
        p.GEOM_BOX,
        halfExtents=[half, half, 0.005],
        visualFramePosition=[0.0, 0.0, -0.005],
        rgbaColor=[0.8, 0.8, 0.8, 1.0],
        physicsClientId=client,
    )
    body = int(
        p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=col,
            baseVisualShapeIndex=vis,
            physicsClientId=client,
        )
    )
    p.changeDynamics(body, -1, lateralFriction=friction, restitution=0.0, physicsClientId=client)
    return body


def _quat_yaw(yaw: float) -> list[float]:
    return [0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw)]


def add_box(
    client: int,
    center_xyz: Sequence[float],
    half_extents: Sequence[float],
    *,
    yaw: float = 0.0,
    rgba: Sequence[float] = (0.6, 0.3, 0.2, 1.0),
) -> int:
    """Add a static box (centre in m, half extents in m, yaw in rad); returns the body id."""
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half_extents), physicsClientId=client)
    vis = p.createVisualShape(
        p.GEOM_BOX, halfExtents=list(half_extents), rgbaColor=list(rgba), physicsClientId=client
    )
    return _static_body(client, col, vis, center_xyz, yaw)


def add_cylinder(
    client: int,
    center_xyz: Sequence[float],
    radius_m: float,
    height_m: float,
    *,
    rgba: Sequence[float] = (0.2, 0.4, 0.7, 1.0),
) -> int:
    """Add a static upright cylinder (centre, radius and height in m); returns the body id."""
    col = p.createCollisionShape(
        p.GEOM_CYLINDER, radius=radius_m, height=height_m, physicsClientId=client
    )
    vis = p.createVisualShape(
        p.GEOM_CYLINDER,
        radius=radius_m,
        length=height_m,
        rgbaColor=list(rgba),
        physicsClientId=client,
    )
    return _static_body(client, col, vis, center_xyz, 0.0)


def _static_body(
    client: int,
    collision: int,
    visual: int,
    center_xyz: Sequence[float],
    yaw: float,
) -> int:
    """A massless (static) body of the given shapes at ``center_xyz`` (m) turned by ``yaw``
    (rad); its body id."""
    return int(
        p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=collision,
            baseVisualShapeIndex=visual,
            basePosition=list(center_xyz),
            baseOrientation=_quat_yaw(yaw),
            physicsClientId=client,
        )
    )
