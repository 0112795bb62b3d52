"""A driver mode (0 or 1) on both engines: pybullet against the reduced model, and how far the
reduced model's two modes part (tests of ``wheel_cap_per_side`` and
``command_starts_new_move``)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from robots import PybulletRobot, ReducedDrive
from robots.params import DriveParams
from robots.spec import RobotSpec

__all__ = ["engines_and_modes"]


def engines_and_modes(
    spec: RobotSpec, params: DriveParams, mode: str, commands: Sequence[tuple[float, float]]
) -> tuple[float, float, float, float]:
    """Drive ``commands`` (v m/s, w rad/s, 0.05 s each, then 0.3 s of stop) on the pybullet
    robot and the reduced model with ``params``, and on the reduced model with ``mode``
    flipped: (rms v m/s, rms w rad/s of pybullet - reduced, largest |v|, |w| between the
    modes)."""
    red = ReducedDrive(params, spec.geometry)
    other = ReducedDrive(params.replace(**{mode: 1.0 - getattr(params, mode)}), spec.geometry)
    err_v, err_w, parted_v, parted_w = [], [], 0.0, 0.0
    with PybulletRobot(spec, params=params) as robot:
        for cmd in [*commands, *[(0.0, 0.0)] * 6]:
            a = robot.step(*cmd, 0.05)
            b = red.step(*cmd, 0.05)
            c = other.step(*cmd, 0.05)
            err_v.append(a[0] - b[0])
            err_w.append(a[1] - b[1])
            parted_v, parted_w = max(parted_v, abs(b[0] - c[0])), max(parted_w, abs(b[1] - c[1]))
    rms_v, rms_w = (math.sqrt(float(np.mean(np.square(e)))) for e in (err_v, err_w))
    return rms_v, rms_w, parted_v, parted_w
