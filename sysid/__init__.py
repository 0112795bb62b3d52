"""System identification of a differential-drive base's drive-model parameters.

Fit the parameters of :class:`robots.params.DriveParams` (delay, friction, inertia, limits)
to logs of commanded and measured velocity, with uncertainty and validation scores.

Example
-------
>>> from sysid import fit_drive
>>> result = fit_drive([trace], geometry=spec.geometry, base_params=spec.drive,
...                    robot="turtlebot3_waffle_pi")  # doctest: +SKIP
>>> result.save("params.yaml")  # doctest: +SKIP
"""

from __future__ import annotations

from sysid._logs import LogArrays, VelocityLog, crop_log
from sysid.errors import (
    ExcitationError,
    ResultFileError,
    SysidError,
    SysidFileError,
    SysidValueError,
)
from sysid.fit import Progress, fit_drive, score_logs
from sysid.result import DataFile, FitScores, ParameterEstimate, SysidResult

__all__ = [
    "DataFile",
    "ExcitationError",
    "FitScores",
    "LogArrays",
    "ParameterEstimate",
    "Progress",
    "ResultFileError",
    "SysidError",
    "SysidFileError",
    "SysidResult",
    "SysidValueError",
    "VelocityLog",
    "crop_log",
    "fit_drive",
    "score_logs",
]
