"""Robot models: spec files of published facts, the drive model, pybullet robots and sensors.

``PybulletRobot``, ``Lidar`` and ``DepthCamera`` import pybullet, so they are loaded on first
use (``import robots`` stays light for the CLI and for sysid).

Example
-------
>>> import robots
>>> spec = robots.load_spec("turtlebot3_burger")
>>> spec.max_v_mps
0.22
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from robots.params import BaseGeometry, DriveParams, load_drive_params
from robots.reduced import ReducedDrive, simulate
from robots.spec import (
    CameraSpec,
    LidarSpec,
    OdometrySpec,
    RobotSpec,
    list_robots,
    load_spec,
)

if TYPE_CHECKING:
    from robots.pybullet_robot import PybulletRobot
    from robots.sensors import DepthCamera, Lidar

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
    "PybulletRobot": "robots.pybullet_robot",
    "Lidar": "robots.sensors",
    "DepthCamera": "robots.sensors",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'robots' has no attribute {name!r}")
