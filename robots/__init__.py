"""Robot models: spec files of published facts, the drive model, pybullet robots and sensors."""

from __future__ import annotations

from robots.params import BaseGeometry, DriveParams, load_drive_params
from robots.reduced import ReducedDrive, simulate

__all__ = ["BaseGeometry", "DriveParams", "ReducedDrive", "load_drive_params", "simulate"]
