"""Robot models: spec files of published facts, the drive model, pybullet robots and sensors.

Every name is loaded on first use (PEP 562), so ``import robots.spec`` or
``import robots.errors`` stays light: numba comes with the drive model (:func:`simulate`,
:class:`ReducedDrive`), pybullet with :class:`PybulletRobot`, :class:`Lidar` and
:class:`DepthCamera`.

The bottom floor: robots imports no other package of the project. :mod:`robots.files` (the
atomic write) and :mod:`robots.units` (nanoseconds and seconds) serve the floors above.

Examples
--------
>>> import robots
>>> spec = robots.load_spec("turtlebot3_burger")
>>> spec.max_v_mps
0.22
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from robots._lazy import lazy_exports

if TYPE_CHECKING:
    from robots.params import BaseGeometry, DriveParams, load_drive_params
    from robots.pybullet_robot import PybulletRobot
    from robots.reduced import ReducedDrive, simulate
    from robots.sensors import DepthCamera, Lidar
    from robots.spec import (
        CameraSpec,
        LidarSpec,
        OdometrySpec,
        RobotSpec,
        list_robots,
        load_spec,
    )

__all__ = [
    "BaseGeometry",
    "CameraSpec",
    "DepthCamera",
    "DriveParams",
    "Lidar",
    "LidarSpec",
    "OdometrySpec",
    "PybulletRobot",
    "ReducedDrive",
    "RobotSpec",
    "list_robots",
    "load_drive_params",
    "load_spec",
    "simulate",
]

_LAZY = {
    "BaseGeometry": "robots.params",
    "DriveParams": "robots.params",
    "load_drive_params": "robots.params",
    "ReducedDrive": "robots.reduced",
    "simulate": "robots.reduced",
    "CameraSpec": "robots.spec",
    "LidarSpec": "robots.spec",
    "OdometrySpec": "robots.spec",
    "RobotSpec": "robots.spec",
    "list_robots": "robots.spec",
    "load_spec": "robots.spec",
    "PybulletRobot": "robots.pybullet_robot",
    "Lidar": "robots.sensors",
    "DepthCamera": "robots.sensors",
}


__getattr__, __dir__ = lazy_exports("robots", _LAZY, globals(), __all__)
