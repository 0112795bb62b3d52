"""Drive-model parameters of a differential-drive base, and the geometry they act on.

The drive model is the chain described in ``shared/notes/drive-model.md``::

    command (v, w) -> transport delay -> firmware speed clamp -> velocity smoother
    (acceleration limits) -> wheel targets (per-wheel speed cap, both wheels scaled
    together) -> per-wheel proportional speed loop with torque saturation -> base
    dynamics with mass, yaw inertia, Coulomb and viscous friction -> measured (v, w)

The same :class:`DriveParams` drive the numpy/numba reduced model (:mod:`robots.reduced`)
and the pybullet robot. Spec files give the defaults; a sysid result file overrides them
(:func:`load_drive_params`).

Example
-------
>>> from robots.params import DriveParams
>>> p = DriveParams(delay_s=0.1, motor_gain_nms_per_rad=0.01)
>>> p.replace(delay_s=0.2).delay_s
0.2
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import yaml

from robots.errors import ParamsFileError, RobotsValueError

__all__ = [
    "MAY_BE_INF",
    "MAY_BE_NEGATIVE",
    "MUST_BE_POSITIVE",
    "PARAMS_FILE_FORMAT",
    "BaseGeometry",
    "DriveParams",
    "ParamsFile",
    "load_drive_params",
    "read_params_file",
]

#: ``format:`` key of a sysid result / drive-parameter YAML file.
PARAMS_FILE_FORMAT = "sim2real.sysid/1"

#: Parameters that may be +inf (meaning "no such limit").
MAY_BE_INF = frozenset(
    {
        "cmd_timeout_s",
        "speed_lim_v_mps",
        "speed_lim_w_radps",
        "accel_lim_v_mps2",
        "accel_lim_w_radps2",
        "wheel_speed_max_radps",
        "wheel_torque_max_nm",
    }
)
#: Parameters that may be negative (payload lighter than the spec); all others are >= 0.
MAY_BE_NEGATIVE = frozenset({"added_mass_kg", "added_yaw_inertia_kgm2"})
#: Parameters that must be > 0 (gains and limits; use +inf for "no limit").
MUST_BE_POSITIVE = frozenset(
    {
        "cmd_timeout_s",
        "speed_lim_v_mps",
        "speed_lim_w_radps",
        "accel_lim_v_mps2",
        "accel_lim_w_radps2",
        "wheel_speed_max_radps",
        "motor_gain_nms_per_rad",
        "wheel_torque_max_nm",
    }
)


@dataclass(frozen=True, kw_only=True)
class BaseGeometry:
    """Rigid-body facts of a base that the drive model needs (from the robot spec).

    Parameters
    ----------
    mass_kg : float
        Total mass of the robot as built in the spec (base, wheels, sensors), kg.
    yaw_inertia_kgm2 : float
        Moment of inertia about the vertical axis through the base origin, kg m^2.
    wheel_radius_m : float
        Drive-wheel radius r, m.
    wheel_separation_m : float
        Distance L between the two drive-wheel contact points, m.
    """

    mass_kg: float
    yaw_inertia_kgm2: float
    wheel_radius_m: float
    wheel_separation_m: float

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise RobotsValueError(
                    f"geometry key '{f.name}' must be a finite number > 0, got {value!r}; "
                    "fix the robot spec file"
                )


@dataclass(frozen=True, kw_only=True)
class DriveParams:
    r"""Physical parameters of the drive chain (SI units; see the module docstring).

    Per-wheel speed loop: each wheel motor produces the torque
    :math:`\tau_i = \mathrm{clip}(K(\omega_i^{ref} - \omega_i), \pm\tau_{max})`; the base obeys

    .. math::

        (m + \Delta m)\dot v = \frac{\tau_r + \tau_l}{r} - b_v v - F_c\,\mathrm{sgn}(v)

        (I + \Delta I)\dot\omega = \frac{L(\tau_r - \tau_l)}{2r} - b_\omega\omega
            - T_c\,\mathrm{sgn}(\omega)

    Unsaturated, each axis is first order with time constant
    :math:`T_v = (m+\Delta m) r^2 / (2K + b_v r^2)` and steady state
    :math:`v_{ss} = (2K v_{ref}/r^2 - F_c) / (2K/r^2 + b_v)`: Coulomb friction and a finite loop
    gain make the base run under the command, as real bases do.

    Parameters
    ----------
    delay_s : float
        Command transport delay (dead time) between a command's stamp and its effect, s.
    cmd_timeout_s : float
        The base stops when no new command arrives for this long (Kobuki: 0.6 s); inf = never.
    speed_lim_v_mps, speed_lim_w_radps : float
        Firmware clamp on the commanded linear (m/s) and angular (rad/s) velocity.
    accel_lim_v_mps2, accel_lim_w_radps2 : float
        Velocity-smoother rate limits on the reference, m/s^2 and rad/s^2 (inf = none).
    wheel_speed_max_radps : float
        Per-wheel speed cap, rad/s; when a wheel target exceeds it both targets are scaled
        together (curvature kept).
    motor_gain_nms_per_rad : float
        Proportional gain K of each wheel's speed loop, N m s/rad.
    wheel_torque_max_nm : float
        Per-wheel torque saturation, N m.
    coulomb_v_fwd_n, coulomb_v_bwd_n : float
        Coulomb friction force on the forward axis when moving forward / backward, N.
    coulomb_w_nm : float
        Coulomb friction torque about the yaw axis (caster drag, scrub), N m.
    viscous_v_ns_per_m, viscous_w_nms_per_rad : float
        Viscous friction on the forward axis (N s/m) and about yaw (N m s/rad).
    added_mass_kg, added_yaw_inertia_kgm2 : float
        Payload beyond the spec (laptop, arm), kg and kg m^2; may be negative.
    """

    delay_s: float = 0.0
    cmd_timeout_s: float = math.inf
    speed_lim_v_mps: float = math.inf
    speed_lim_w_radps: float = math.inf
    accel_lim_v_mps2: float = math.inf
    accel_lim_w_radps2: float = math.inf
    wheel_speed_max_radps: float = math.inf
    motor_gain_nms_per_rad: float = 0.01
    wheel_torque_max_nm: float = math.inf
    coulomb_v_fwd_n: float = 0.0
    coulomb_v_bwd_n: float = 0.0
    coulomb_w_nm: float = 0.0
    viscous_v_ns_per_m: float = 0.0
    viscous_w_nms_per_rad: float = 0.0
    added_mass_kg: float = 0.0
    added_yaw_inertia_kgm2: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            _check_value(f.name, getattr(self, f.name))

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """Names of all parameters, in declaration order."""
        return tuple(f.name for f in fields(cls))

    def replace(self, **changes: float) -> DriveParams:
        """Return a copy with ``changes`` applied (validated like the constructor)."""
        unknown = sorted(set(changes) - set(self.names()))
        if unknown:
            raise RobotsValueError(
                f"unknown drive parameter(s) {unknown}; known ones are {list(self.names())}"
            )
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, float]:
        """Plain ``{name: value}`` mapping (floats), suitable for YAML."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}

    @classmethod
    def from_dict(cls, values: Mapping[str, Any], *, source: str = "parameters") -> DriveParams:
        """Build from a mapping, refusing unknown keys (``source`` names it in errors)."""
        unknown = sorted(set(values) - set(cls.names()))
        if unknown:
            raise RobotsValueError(
                f"{source} has unknown drive parameter(s) {unknown}; "
                f"known ones are {list(cls.names())}"
            )
        return cls(**{k: _as_float(k, v, source) for k, v in values.items()})

    def total_mass_kg(self, geometry: BaseGeometry) -> float:
        """Spec mass plus :attr:`added_mass_kg`; raises if not positive."""
        m = geometry.mass_kg + self.added_mass_kg
        if m <= 0:
            raise RobotsValueError(
                f"added_mass_kg={self.added_mass_kg} makes the total mass {m:.4g} kg <= 0; "
                f"it must be > -{geometry.mass_kg} kg for this robot"
            )
        return m

    def total_yaw_inertia_kgm2(self, geometry: BaseGeometry) -> float:
        """Spec yaw inertia plus :attr:`added_yaw_inertia_kgm2`; raises if not positive."""
        j = geometry.yaw_inertia_kgm2 + self.added_yaw_inertia_kgm2
        if j <= 0:
            raise RobotsValueError(
                f"added_yaw_inertia_kgm2={self.added_yaw_inertia_kgm2} makes the total yaw "
                f"inertia {j:.4g} kg m^2 <= 0; it must be > -{geometry.yaw_inertia_kgm2}"
            )
        return j


def _as_float(name: str, value: Any, source: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise RobotsValueError(
            f"{source}: drive parameter '{name}' must be a number, got {value!r}; "
            "write a plain number (or .inf where no limit applies)"
        )
    return float(value)


def _check_value(name: str, value: float) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
        raise RobotsValueError(f"drive parameter '{name}' must be a number, got {value!r}")
    if math.isinf(value) and not (name in MAY_BE_INF and value > 0):
        raise RobotsValueError(
            f"drive parameter '{name}' must be finite, got {value!r}; give a finite value"
        )
    if name in MUST_BE_POSITIVE and value <= 0:
        raise RobotsValueError(
            f"drive parameter '{name}' must be > 0, got {value!r}; "
            "use .inf for 'no limit' rather than 0"
        )
    if name not in MAY_BE_NEGATIVE and value < 0:
        raise RobotsValueError(
            f"drive parameter '{name}' must be >= 0 (non-physical otherwise), got {value!r}"
        )


@dataclass(frozen=True, kw_only=True)
class ParamsFile:
    """What :func:`read_params_file` finds in a drive-parameter (sysid result) YAML file.

    Attributes
    ----------
    path : Path
        The file read.
    robot : str
        The robot the parameters were identified for.
    values : dict
        ``{name: value}`` for every parameter the file lists.
    stds : dict
        ``{name: standard deviation}`` for the parameters that carry one (fitted ones).
    """

    path: Path
    robot: str
    values: dict[str, float]
    stds: dict[str, float]


def read_params_file(path: str | Path) -> ParamsFile:
    """Read a drive-parameter YAML file as written by ``sim2real sysid fit``.

    The file holds ``format: sim2real.sysid/1``, ``robot: NAME`` and a ``parameters`` mapping
    of ``name: {value: float, std: float | null, ...}``. Unknown parameter names are refused.

    Examples
    --------
    >>> pf = read_params_file("params.yaml")  # doctest: +SKIP
    >>> pf.values["delay_s"]  # doctest: +SKIP
    0.12
    """
    p = Path(path)
    if p.is_dir():
        raise ParamsFileError(f"params file '{p}' is a folder; give the path of a params file")
    if not p.is_file():
        raise ParamsFileError(
            f"params file '{p}' does not exist; give the path of a file written by "
            "'sim2real sysid fit -o FILE'"
        )
    try:
        doc = yaml.safe_load(p.read_text(encoding="utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise ParamsFileError(
            f"params file '{p}' is not valid YAML ({' '.join(str(exc).split())}); regenerate it"
        ) from None
    if not isinstance(doc, dict) or not isinstance(doc.get("parameters"), dict):
        raise ParamsFileError(
            f"params file '{p}' has no 'parameters' mapping; it must be a file written by "
            "'sim2real sysid fit -o FILE'"
        )
    robot = doc.get("robot")
    if not isinstance(robot, str) or not robot:
        raise ParamsFileError(f"params file '{p}' has no 'robot' name; add 'robot: NAME'")
    values: dict[str, float] = {}
    stds: dict[str, float] = {}
    known = set(DriveParams.names())
    for name, entry in doc["parameters"].items():
        if name not in known:
            raise ParamsFileError(
                f"params file '{p}' has unknown parameter '{name}'; known ones are {sorted(known)}"
            )
        raw = entry.get("value") if isinstance(entry, dict) else entry
        values[name] = _as_float(name, raw, f"params file '{p}'")
        if isinstance(entry, dict) and isinstance(entry.get("std"), int | float):
            stds[name] = float(entry["std"])
    return ParamsFile(path=p, robot=robot, values=values, stds=stds)


def load_drive_params(path: str | Path, *, robot: str, base: DriveParams) -> DriveParams:
    """Override ``base`` (the spec defaults) with the values in a params file for ``robot``.

    Raises :class:`~robots.errors.ParamsFileError` when the file is for another robot.

    Examples
    --------
    >>> load_drive_params("params.yaml", robot="turtlebot3_burger", base=DriveParams())
    ... # doctest: +SKIP
    """
    pf = read_params_file(path)
    if pf.robot != robot:
        raise ParamsFileError(
            f"params file '{pf.path}' was identified for robot '{pf.robot}', not '{robot}'; "
            f"pass --robot {pf.robot} or fit a params file for {robot}"
        )
    try:
        return base.replace(**pf.values)
    except RobotsValueError as exc:
        raise ParamsFileError(f"params file '{pf.path}': {exc}") from None
