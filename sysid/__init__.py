"""System identification of a differential-drive base's drive-model parameters.

Fit the parameters of :class:`robots.params.DriveParams` (delay, friction, inertia, limits)
to logs of commanded and measured velocity, with uncertainty and validation scores.

Names are loaded on first use (PEP 562): ``import sysid.errors`` or ``sysid.metrics`` does not
pull in scipy or numba; :func:`fit_drive` does.

A floor above :mod:`robots`: sysid imports robots (the drive model, specs, files), never
:mod:`randomizers` or :mod:`sim2real`.

Examples
--------
>>> from sysid import fit_drive
>>> result = fit_drive([trace], geometry=spec.geometry, base_params=spec.drive,
...                    robot="turtlebot3_waffle_pi")  # doctest: +SKIP
>>> result.save("params.yaml")  # doctest: +SKIP
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from robots._lazy import lazy_exports
from sysid.errors import (
    ExcitationError,
    ResultFileError,
    SysidError,
    SysidFileError,
    SysidValueError,
)

if TYPE_CHECKING:
    from sysid._excitation import why_not_fittable
    from sysid._fleet import spread_degrees_of_freedom
    from sysid._logs import LogArrays, VelocityLog, crop_log
    from sysid._needs import held_speeds
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
    "held_speeds",
    "score_logs",
    "spread_degrees_of_freedom",
    "why_not_fittable",
]

_LAZY = {
    "LogArrays": "sysid._logs",
    "VelocityLog": "sysid._logs",
    "crop_log": "sysid._logs",
    "Progress": "sysid.fit",
    "fit_drive": "sysid.fit",
    "score_logs": "sysid.fit",
    "spread_degrees_of_freedom": "sysid._fleet",
    "held_speeds": "sysid._needs",
    "why_not_fittable": "sysid._excitation",
    "DataFile": "sysid.result",
    "FitScores": "sysid.result",
    "ParameterEstimate": "sysid.result",
    "SysidResult": "sysid.result",
}


__getattr__, __dir__ = lazy_exports("sysid", _LAZY, globals(), __all__)
