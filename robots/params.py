"""Drive-model parameters of a differential-drive base, and the geometry they act on.

The drive model is the chain described in ``shared/notes/drive-model.md``::

    command (v, w) -> transport delay -> firmware speed clamp -> velocity smoother
    (acceleration limits) -> wheel targets (per-wheel speed cap: both wheels scaled
    together, or each clipped on its own) -> per-wheel PI speed loop with torque saturation -> base
    dynamics with mass, yaw inertia, Coulomb and viscous friction -> measured (v, w)

The same :class:`DriveParams` drive the numpy/numba reduced model (:mod:`robots.reduced`)
and the pybullet robot. Spec files give the defaults; a sysid result file overrides them
(:func:`load_drive_params`).

Examples
--------
>>> from robots.params import DriveParams
>>> p = DriveParams(delay_s=0.1, motor_gain_nms_per_rad=0.01)
>>> p.replace(delay_s=0.2).delay_s
0.2
"""

from __future__ import annotations

import copy
import dataclasses
import math
import shlex
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import yaml

from robots.errors import ParamsFileError, RobotsValueError
from robots.units import GRAVITY_MPS2 as _G

__all__ = [
    "COORD_KINDS",
    "MAY_BE_INF",
    "MAY_BE_NEGATIVE",
    "MUST_BE_POSITIVE",
    "PARAMS_FILE_FORMAT",
    "PER_TOTAL",
    "SCHEMA",
    "SIGN_RULES",
    "SPECS_DIR",
    "UNITS",
    "BaseGeometry",
    "DriveParams",
    "FieldSchema",
    "ParamsFile",
    "Prior",
    "coords_to_values",
    "generic_priors",
    "load_drive_params",
    "load_params_document",
    "params_file_for",
    "read_params_file",
]

#: Folder of the shipped spec files (``robots.spec`` loads them by name).
SPECS_DIR = Path(__file__).resolve().parent / "specs"

#: ``format:`` key of a sysid result / drive-parameter YAML file.
PARAMS_FILE_FORMAT = "sim2real.sysid/1"


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
    wheels_mass_kg, wheels_yaw_inertia_kgm2 : float
        The part of ``mass_kg`` and ``yaw_inertia_kgm2`` in the wheels (their mass, the
        apparent mass of their spin, their yaw inertia about the base origin); 0 when unknown.
        Payload (``added_mass_kg``, ``added_yaw_inertia_kgm2``) changes only the rest, the
        base link, so a total may never fall to these (:meth:`FieldSchema.coord_bounds`).
    """

    mass_kg: float
    yaw_inertia_kgm2: float
    wheel_radius_m: float
    wheel_separation_m: float
    wheels_mass_kg: float = 0.0
    wheels_yaw_inertia_kgm2: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            wheel_part = f.name.startswith("wheels_")
            if not (
                isinstance(value, int | float)
                and math.isfinite(value)
                and (value >= 0 if wheel_part else value > 0)
            ):
                raise RobotsValueError(
                    f"geometry key '{f.name}' must be a finite number "
                    f"{'>= 0' if wheel_part else '> 0'}, got {value!r}; fix the robot spec file"
                )
        for part, total in (
            ("wheels_mass_kg", "mass_kg"),
            ("wheels_yaw_inertia_kgm2", "yaw_inertia_kgm2"),
        ):
            if getattr(self, part) >= getattr(self, total):
                raise RobotsValueError(
                    f"geometry key '{part}' ({getattr(self, part)!r}) must be below '{total}' "
                    f"({getattr(self, total)!r}): the base link carries the rest; fix the spec"
                )


@dataclass(frozen=True, kw_only=True)
class DriveParams:
    r"""Physical parameters of the drive chain (SI units; see the module docstring).

    Per-wheel speed loop: each wheel motor produces the torque
    :math:`\tau_i = \mathrm{clip}(K(e_i + k_i \int e_i\,dt), \pm\tau_{max})` with
    :math:`e_i = \omega_i^{ref} - \omega_i` (a P loop when :math:`k_i = 0`; the integrator holds
    while its wheel's torque is saturated and clears at a zero wheel target); the base obeys

    .. math::

        (m + \Delta m)\dot v = \frac{\tau_r + \tau_l}{r} - b_v v - F_c\,\mathrm{sgn}(v)

        (I + \Delta I)\dot\omega = \frac{L(\tau_r - \tau_l)}{2r} - b_\omega\omega
            - T_c\,\mathrm{sgn}(\omega)

    Unsaturated with :math:`k_i = 0`, each axis is first order with time constant
    :math:`T_v = (m+\Delta m) r^2 / (2K + b_v r^2)` and steady state
    :math:`v_{ss} = (2K v_{ref}/r^2 - F_c) / (2K/r^2 + b_v)`: Coulomb friction and a finite loop
    gain make the base run under the command; the integral term (:math:`k_i > 0`) removes that
    offset and makes step responses overshoot, as real bases' PI wheel loops do.

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
        Per-wheel speed cap, rad/s; what the driver does with a wheel target beyond it is
        ``wheel_cap_per_side``.
    motor_gain_nms_per_rad : float
        Proportional gain K of each wheel's speed loop, N m s/rad.
    speed_loop_ki_per_s : float
        Integral gain of each wheel's speed loop relative to ``K`` (:math:`k_i = K_I/K =
        1/T_i`, the reset rate; :math:`T_i` the integral time), 1/s; 0 = a pure P loop.
    wheel_torque_max_nm : float
        Per-wheel torque saturation, N m (traction or the driver's current limit).
    wheel_stall_torque_nm, wheel_no_load_speed_radps : float
        The wheel motors' torque-speed line at the battery's voltage (N m at the wheel, rad/s
        of the wheel): a DC motor at full drive voltage gives :math:`\tau_s(1 -
        \omega/\omega_0)`, falling linearly from the stall torque at rest to zero at the
        no-load speed (and more, up to the cap, while it brakes), so a loaded wheel tops out
        below :math:`\omega_0`, lower on a tired battery. The torque is limited to
        :math:`[\max(-\tau_{max}, -\tau_s(1 + \omega/\omega_0)),
        \min(\tau_{max}, \tau_s(1 - \omega/\omega_0))]`; inf (either) = no such line,
        the flat cap ``wheel_torque_max_nm`` at every speed.
    coulomb_v_fwd_n, coulomb_v_bwd_n : float
        Coulomb friction force on the forward axis when moving forward / backward, N.
    coulomb_w_nm : float
        Coulomb friction torque about the yaw axis (caster drag, scrub), N m.
    viscous_v_ns_per_m, viscous_w_nms_per_rad : float
        Viscous friction on the forward axis (N s/m) and about yaw (N m s/rad).
    added_mass_kg, added_yaw_inertia_kgm2 : float
        Payload beyond the spec (laptop, arm), kg and kg m^2; may be negative.
    track_factor : float
        Skid steer: effective track over the geometric one, :math:`\chi \ge 1` (1 = wheels
        that roll without lateral slip, a differential drive). The wheels' speeds and the body
        motion are linked through the effective track :math:`\chi L` (the instantaneous
        centres of rotation of the treads lie outside the wheels: Mandow et al. 2007,
        "Experimental kinematics for wheeled skid-steer mobile robots", IROS), so
        :math:`\omega = r(\omega_r - \omega_l)/(\chi L)`, while the wheel forces act at the
        geometric half-track. The turning resistance of the treads' lateral scrub is the yaw
        Coulomb torque ``coulomb_w_nm``.
    driver_track_factor : float
        The multiplier of the track with which the base's driver turns a (v, w) command into
        wheel targets (ROS ``diff_drive_controller``'s ``wheel_separation_multiplier``: 1.875
        on the Husky); a driver setting, not fitted. A yaw command w then turns the base at
        about ``w * driver_track_factor / track_factor``.
    wheel_cap_per_side : float
        How the driver holds the wheel targets to ``wheel_speed_max_radps`` (a driver
        setting, not fitted): 0, it scales both targets by one factor when either exceeds
        the cap, keeping the turn's curvature (Clearpath's ``husky_base``
        ``limitDifferentialSpeed``; the Neato driver); 1, it clips each side's target at the
        cap on its own, so a turn beyond the cap loses yaw rate to the outer side alone.
    command_starts_new_move : float
        How the firmware takes a new command (a driver setting, not fitted): 0, its wheel
        loops run on and keep their integrators (TurtleBot3's OpenCR, Kobuki, Husky); 1, it
        runs each command as a new move, so both wheel integrators clear whenever the wheel
        targets change (the Neato's ``SetMotor(left_mm, right_mm, speed)``, which moves each
        wheel a distance from where it stands: Neato Robotics, *XV Series Programmer's
        Manual*; ``neato_node`` sends every ``cmd_vel`` as one).
    """

    delay_s: float = 0.0
    cmd_timeout_s: float = math.inf
    speed_lim_v_mps: float = math.inf
    speed_lim_w_radps: float = math.inf
    accel_lim_v_mps2: float = math.inf
    accel_lim_w_radps2: float = math.inf
    wheel_speed_max_radps: float = math.inf
    motor_gain_nms_per_rad: float = 0.01
    speed_loop_ki_per_s: float = 0.0
    wheel_torque_max_nm: float = math.inf
    wheel_stall_torque_nm: float = math.inf
    wheel_no_load_speed_radps: float = math.inf
    coulomb_v_fwd_n: float = 0.0
    coulomb_v_bwd_n: float = 0.0
    coulomb_w_nm: float = 0.0
    viscous_v_ns_per_m: float = 0.0
    viscous_w_nms_per_rad: float = 0.0
    added_mass_kg: float = 0.0
    added_yaw_inertia_kgm2: float = 0.0
    track_factor: float = 1.0
    driver_track_factor: float = 1.0
    wheel_cap_per_side: float = 0.0
    command_starts_new_move: float = 0.0

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
        # the constructor's rules are per field: the unchanged fields passed them already (a
        # fit builds thousands of candidates, each changing a few fields)
        for name, value in changes.items():
            _check_value(name, value)
        new = copy.copy(self)
        for name, value in changes.items():
            object.__setattr__(new, name, value)
        return new

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
        return self._total("added_mass_kg", geometry.mass_kg, "mass", "kg")

    def total_yaw_inertia_kgm2(self, geometry: BaseGeometry) -> float:
        """Spec yaw inertia plus :attr:`added_yaw_inertia_kgm2`; raises if not positive."""
        return self._total(
            "added_yaw_inertia_kgm2", geometry.yaw_inertia_kgm2, "yaw inertia", "kg m^2"
        )

    def _total(self, added_key: str, spec: float, what: str, unit: str) -> float:
        added = getattr(self, added_key)
        total = spec + added
        if total <= 0:
            raise RobotsValueError(
                f"{added_key}={added} makes the total {what} {total:.4g} {unit} <= 0; "
                f"it must be > -{spec} {unit} for this robot"
            )
        return float(total)


# ----------------------------------------------------------------------------- the schema

#: Coordinate kinds: the space in which a field is fitted, given a prior and sampled.
#: ``lin``: the value itself; ``log``: log of the value; ``log_total_mass``:
#: log(spec mass + added_mass_kg); ``log_total_inertia``: log(spec yaw inertia + added one);
#: ``per_total_mass`` / ``per_total_inertia``: the value over the robot's total mass / yaw
#: inertia (a friction force per kg, a deceleration; a viscous coefficient per kg, a rate).
#:
#: Why friction is per mass: velocity logs fix only ratios to the motor gain, so scaling the
#: gain, the masses, the frictions and the torque cap together leaves every response as it
#: is (``sysid._coords``). With friction in absolute units its prior would have a say in where
#: on that ridge the fit lands, and a plant whose friction is larger than the spec's nominal
#: pulls the fitted mass down. Per unit mass
#: the friction coordinates do not move along the ridge: the mass, inertia, gain and torque
#: priors alone place it, and the ridge is a straight line in the coordinates (masses, gain
#: and cap all shift by the same log), so a fleet's Gaussian population stays on it.
COORD_KINDS = (
    "lin",
    "log",
    "log_total_mass",
    "log_total_inertia",
    "per_total_mass",
    "per_total_inertia",
)
#: Coordinate kinds that divide the value by a total (the field that total belongs to).
PER_TOTAL = {"per_total_mass": "added_mass_kg", "per_total_inertia": "added_yaw_inertia_kgm2"}
#: Sign rules: ``nonneg`` (>= 0), ``positive`` (> 0; +inf allowed where ``may_be_inf``),
#: ``total_positive`` (any sign, but the spec value plus it must stay > 0).
SIGN_RULES = ("nonneg", "positive", "total_positive")


def _abs(value: float) -> Callable[[BaseGeometry], float]:
    """A spread that does not depend on the robot's size."""
    return lambda geometry: value


def _weight(fraction: float) -> Callable[[BaseGeometry], float]:
    """A spread of a force per unit mass: ``fraction`` of g, m/s^2 (a ``per_total_mass``
    friction coordinate)."""
    return lambda g: fraction * _G


def _weight_arm(fraction: float) -> Callable[[BaseGeometry], float]:
    """A spread of a yaw torque per unit yaw inertia: ``fraction`` of the spec weight acting at
    half the wheel track, over the spec yaw inertia, rad/s^2 (a ``per_total_inertia``
    coordinate)."""
    return lambda g: fraction * g.mass_kg * _G * 0.5 * g.wheel_separation_m / g.yaw_inertia_kgm2


@dataclass(frozen=True, kw_only=True)
class FieldSchema:
    """Everything the toolkit knows about one :class:`DriveParams` field.

    Attributes
    ----------
    name : str
        The DriveParams field.
    unit : str
        SI unit of the value.
    sign : str
        One of :data:`SIGN_RULES`.
    may_be_inf : bool
        ``+inf`` is allowed and means "no such limit".
    coord : str
        One of :data:`COORD_KINDS`: the coordinate of the fit, the prior and the sampler.
    lower, upper : float
        Physically plausible range of the value (natural units; for ``total_positive`` fields
        the range of the *total* as a multiple of the spec value, where the lower one applies
        to the base link's own part: the total stays above the wheels' part plus ``lower`` x
        the base link's, :meth:`total_floor`). Fits and draws stay inside.
    axis : str
        ``"v"``, ``"w"`` or ``"vw"``: which measured channel the field shapes.
    fittable : bool
        Velocity logs can inform it (the command timeout cannot: it is a firmware setting).
    prior_sd, session_sd : callable
        Generic prior spread and default between-session spread in coordinate units, as a
        function of the geometry (used when a spec gives none; see ``robots/specs/*.yaml``).
    absurd_sd : float
        A spread (coordinate units, relative to ``prior_sd`` for ``lin`` fields) above this is
        refused as absurd when a distribution is read.
    doc : str
        One line on what it is.
    fit_kind : str
        How velocity data see the field, the kind of sysid's internal fit coordinate
        (``sysid._coords``): ``lin`` or ``log`` (the value, its log), ``mass`` / ``inertia``
        (log of the total over the loop gain: a time constant), ``ratio_v`` / ``ratio_w``
        (friction over the loop gain), ``torque_ratio`` (log of the torque cap over the gain).
    fit_range : tuple of float or None
        Bounds of that internal coordinate; None: :attr:`lower`, :attr:`upper` (logs of them
        for ``log``).
    fit_step : float
        Finite-difference step of the internal coordinate.
    choices : tuple of float
        The only values a mode field takes (a driver's mode, coded as a number); () = any
        value the other rules allow.
    """

    name: str
    unit: str
    sign: str
    may_be_inf: bool
    coord: str
    lower: float
    upper: float
    axis: str
    fittable: bool
    prior_sd: Callable[[BaseGeometry], float]
    session_sd: Callable[[BaseGeometry], float]
    absurd_sd: float
    doc: str
    fit_kind: str = "lin"
    fit_range: tuple[float, float] | None = None
    fit_step: float = 1e-3
    choices: tuple[float, ...] = ()

    @property
    def per_field(self) -> str | None:
        """For a ``per_total_*`` coordinate, the field whose total divides the value."""
        return PER_TOTAL.get(self.coord)

    def total_of(self, geometry: BaseGeometry, added: float = 0.0) -> float:
        """The total a ``per_total_*`` coordinate divides by: the spec mass or yaw inertia plus
        ``added`` (the value of :attr:`per_field`)."""
        if self.per_field is None:
            raise RobotsValueError(f"drive parameter '{self.name}' is not per unit of a total")
        return SCHEMA[self.per_field].spec_value(geometry) + float(added)

    def reference(self, geometry: BaseGeometry) -> float:
        """The spec total a ``per_total_*`` coordinate divides by when no other total is given
        (1 for the other kinds): a spec's friction prior written in the value's unit is turned
        into coordinate units with it."""
        return self.total_of(geometry) if self.per_field is not None else 1.0

    def spec_value(self, geometry: BaseGeometry) -> float:
        """The spec quantity a ``total_positive`` field adds to (0 for the others)."""
        if self.coord == "log_total_mass":
            return geometry.mass_kg
        if self.coord == "log_total_inertia":
            return geometry.yaw_inertia_kgm2
        return 0.0

    def wheels_part(self, geometry: BaseGeometry) -> float:
        """The part of :meth:`spec_value` in the wheels, which payload cannot remove."""
        if self.coord == "log_total_mass":
            return geometry.wheels_mass_kg
        if self.coord == "log_total_inertia":
            return geometry.wheels_yaw_inertia_kgm2
        return 0.0

    def total_floor(self, geometry: BaseGeometry, share: float = 1.0) -> float:
        """Least plausible total of a ``total_positive`` field: the wheels' part plus
        ``share`` x :attr:`lower` of the base link's own spec value (so the base link keeps
        at least that share of it: pybullet needs its mass and yaw inertia > 0)."""
        wheels = self.wheels_part(geometry)
        return wheels + share * self.lower * (self.spec_value(geometry) - wheels)

    def to_coord(self, value: float, geometry: BaseGeometry, total: float | None = None) -> float:
        """The coordinate of ``value`` (inf stays inf for ``log`` fields).

        ``total``: the robot's total mass (kg) or yaw inertia (kg m^2) for a ``per_total_*``
        field; the spec's (:meth:`reference`) when omitted. Raises
        :class:`~robots.errors.RobotsValueError` when ``value`` has no coordinate (a
        non-positive limit or total mass).
        """
        if self.coord == "lin":
            return float(value)
        if self.per_field is not None:
            return float(value) / self._total(geometry, total)
        total = float(value) + self.spec_value(geometry)
        if not total > 0:
            raise RobotsValueError(
                f"drive parameter '{self.name}' = {value!r} has no {self.coord} coordinate: "
                f"the {'total ' if self.spec_value(geometry) else ''}value must be > 0"
            )
        return math.log(total)

    def from_coord(self, z: float, geometry: BaseGeometry, total: float | None = None) -> float:
        """The value at coordinate ``z`` (inverse of :meth:`to_coord`, same ``total``)."""
        if self.coord == "lin":
            return float(z)
        if self.per_field is not None:
            return float(z) * self._total(geometry, total)
        return math.exp(float(z)) - self.spec_value(geometry)

    def clamped_value(self, z: float, geometry: BaseGeometry, total: float | None = None) -> float:
        """The value at coordinate ``z`` kept inside :meth:`coord_bounds` (same ``total`` as
        :meth:`from_coord`): how a fitted or drawn coordinate becomes a parameter."""
        lo, hi = self.coord_bounds(geometry)
        return self.from_coord(min(max(float(z), lo), hi), geometry, total)

    def _total(self, geometry: BaseGeometry, total: float | None) -> float:
        t = self.reference(geometry) if total is None else float(total)
        if not (t > 0 and math.isfinite(t)):
            raise RobotsValueError(
                f"drive parameter '{self.name}' is per unit of the total of '{self.per_field}', "
                f"which must be a finite number > 0, got {t!r}"
            )
        return t

    def coord_bounds(self, geometry: BaseGeometry) -> tuple[float, float]:
        """:attr:`lower`, :attr:`upper` in coordinates (``per_total_*``: of the value per unit
        of the total; only 0 and inf occur there)."""
        if self.coord == "lin" or self.per_field is not None:
            return self.lower, self.upper
        scale = self.spec_value(geometry) or 1.0
        low = self.total_floor(geometry) if self.spec_value(geometry) else self.lower
        return math.log(low), math.log(self.upper * scale)

    def derivative(self, value: float, geometry: BaseGeometry) -> float:
        """d value / d coordinate at ``value`` (to turn a coordinate std into a value std; for a
        ``per_total_*`` field at the spec total)."""
        if self.coord == "lin":
            return 1.0
        if self.per_field is not None:
            return self.reference(geometry)
        return float(value) + self.spec_value(geometry)


def _f(
    name: str,
    unit: str,
    sign: str,
    coord: str,
    bounds: tuple[float, float],
    axis: str,
    spread: tuple[float | Callable[[BaseGeometry], float], float | Callable[[BaseGeometry], float]],
    *,
    inf: bool = False,
    **kw: Any,
) -> FieldSchema:
    """One row of :data:`SCHEMA`: ``spread`` is the generic (prior, session) sd, a number
    for a spread that does not depend on the robot's size or a function of the geometry;
    ``inf``: :attr:`FieldSchema.may_be_inf`; ``kw``: other attributes where not the default."""
    prior_sd, session_sd = (s if callable(s) else _abs(s) for s in spread)
    return FieldSchema(
        name=name,
        unit=unit,
        sign=sign,
        coord=coord,
        lower=bounds[0],
        upper=bounds[1],
        may_be_inf=inf,
        axis=axis,
        prior_sd=prior_sd,
        session_sd=session_sd,
        fittable=kw.pop("fittable", True),
        absurd_sd=kw.pop("absurd_sd", 3.0 if coord.startswith("log") else 100.0),
        fit_kind=kw.pop("fit_kind", "lin" if coord == "lin" else "log"),
        **kw,
    )


def _mode(name: str, doc: str, choices: tuple[float, ...] = (0.0, 1.0)) -> FieldSchema:
    """A driver's mode, coded as one of ``choices``: set in the spec, never fitted or spread."""
    bounds = (min(choices), max(choices))
    return _f(name, "1", "nonneg", "lin", bounds, "vw", (0.0, 0.0), fittable=False,
              choices=choices, doc=doc)  # fmt: skip


#: Fit ranges of sysid's internal coordinates (``sysid._coords``): the log of a torque cap
#: over the loop gain, and the log of a total mass or yaw inertia over it.
_LOG_TORQUE_RATIO = (math.log(1e-3), math.log(1e4))
_LOG_TOTAL_RATIO = (math.log(2e-3), math.log(20.0))


#: The drive-parameter schema, one entry per :class:`DriveParams` field in declaration order.
#: Generic priors (used when a spec has no ``priors`` entry): typical command latencies are
#: 0.05-0.3 s (Liang et al. 2020; GitHub yujinrobot/kobuki issue #389: ~0.2 s), so the delay
#: prior is 0.1 s wide; a motor gain nobody publishes is known to a factor e (log sd 1);
#: payload changes the total mass by ~30 % (log sd 0.3); floor friction is a few % of the
#: weight. Wheel-speed loops in base firmware are PI/PID (Kobuki's protocol sets P, I, D
#: wheel-controller gains; Dynamixel servos in velocity mode run a PI loop with a nonzero
#: default I gain), tuned with integral times of ~0.05-0.5 s: the reset rate
#: ``speed_loop_ki_per_s`` gets an 8 /s prior sd.
# fmt: off
SCHEMA: dict[str, FieldSchema] = {f.name: f for f in (
    _f("delay_s", "s", "nonneg", "lin", (0.0, 1.0), "vw", (0.1, 0.02), absurd_sd=10.0,
       doc="command transport delay"),
    _f("cmd_timeout_s", "s", "positive", "log", (0.01, 100.0), "vw", (0.0, 0.0), inf=True,
       fittable=False, doc="stop after this long without a command (firmware setting)"),
    _f("speed_lim_v_mps", "m/s", "positive", "log", (0.01, 10.0), "v", (0.02, 0.0), inf=True,
       doc="firmware clamp on the commanded forward speed"),
    _f("speed_lim_w_radps", "rad/s", "positive", "log", (0.05, 50.0), "w", (0.02, 0.0), inf=True,
       doc="firmware clamp on the commanded yaw rate"),
    _f("accel_lim_v_mps2", "m/s^2", "positive", "log", (0.02, 50.0), "v", (0.3, 0.05), inf=True,
       doc="velocity-smoother rate limit, forward"),
    _f("accel_lim_w_radps2", "rad/s^2", "positive", "log", (0.1, 300.0), "w", (0.3, 0.05), inf=True,
       doc="velocity-smoother rate limit, yaw"),
    _f("wheel_speed_max_radps", "rad/s", "positive", "log", (0.3, 300.0), "vw", (0.15, 0.05),
       inf=True, doc="per-wheel speed cap (loaded, at the battery's voltage)"),
    _f("motor_gain_nms_per_rad", "N m s/rad", "positive", "log", (1e-5, 1e3), "vw", (1.0, 0.05),
       doc="P gain of each wheel's speed loop"),
    _f("speed_loop_ki_per_s", "1/s", "nonneg", "lin", (0.0, 200.0), "vw", (8.0, 0.0), fit_step=1e-2,
       doc="integral gain of each wheel's speed loop over its P gain (1/integral time)"),
    # Wheel torques span small robots to large field bases: traction alone lets a 1 t
    # base on 0.4 m wheels push ~2000 N m per side (mu 1 on half its weight), so the
    # plausible range ends at 1e4 N m, never below what the spec template's traction
    # prior gives a heavy base.
    _f("wheel_torque_max_nm", "N m", "positive", "log", (1e-4, 1e4), "vw", (0.7, 0.1), inf=True,
       fit_kind="torque_ratio", fit_range=_LOG_TORQUE_RATIO,
       doc="per-wheel torque saturation (traction or the driver's current limit)"),
    # A DC motor at full drive voltage V gives k_t (V - k_e omega) / R: its torque falls
    # linearly from stall to zero at the no-load speed omega_0 = V / k_e, and both scale
    # with V (Hughes & Drury, Electric Motors and Drives, 4th ed., ch. 3). Datasheets
    # quote them at the wheel at a nominal voltage, e.g. ROBOTIS XL430-W250 (TurtleBot3
    # Burger): 1.4 N m stall and 57 rev/min no-load at 11.1 V, 1.5 N m and 61 rev/min at
    # 12 V. A battery between tired and full moves both by ~+-8 % (Li-ion 3.6-4.2 V per
    # cell): a between-session spread. Generic priors: known to ~35 % (log sd 0.3).
    _f("wheel_stall_torque_nm", "N m", "positive", "log", (1e-4, 1e4), "vw", (0.3, 0.05),
       inf=True, fit_kind="torque_ratio", fit_range=_LOG_TORQUE_RATIO,
       doc="the wheel motors' stall torque (their torque-speed line; at the battery's voltage)"),
    _f("wheel_no_load_speed_radps", "rad/s", "positive", "log", (0.3, 300.0), "vw", (0.3, 0.05),
       inf=True,
       doc="the motors' no-load wheel speed (their torque-speed line; at the battery's voltage)"),
    _f("coulomb_v_fwd_n", "N", "nonneg", "per_total_mass", (0.0, math.inf), "v",
       (_weight(0.02), _weight(0.005)), fit_kind="ratio_v", fit_range=(0.0, 0.5), fit_step=1e-4,
       doc="Coulomb friction force, moving forward"),
    _f("coulomb_v_bwd_n", "N", "nonneg", "per_total_mass", (0.0, math.inf), "v",
       (_weight(0.02), _weight(0.005)), fit_kind="ratio_v", fit_range=(0.0, 0.5), fit_step=1e-4,
       doc="Coulomb friction force, moving backward"),
    _f("coulomb_w_nm", "N m", "nonneg", "per_total_inertia", (0.0, math.inf), "w",
       (_weight_arm(0.03), _weight_arm(0.008)), fit_kind="ratio_w", fit_range=(0.0, 3.0),
       fit_step=5e-4, doc="Coulomb friction torque about yaw"),
    _f("viscous_v_ns_per_m", "N s/m", "nonneg", "per_total_mass", (0.0, math.inf), "v", (1.0, 0.2),
       fit_kind="ratio_v", fit_range=(0.0, 5.0), doc="viscous friction, forward"),
    _f("viscous_w_nms_per_rad", "N m s/rad", "nonneg", "per_total_inertia", (0.0, math.inf), "w",
       (1.0, 0.2), fit_kind="ratio_w", fit_range=(0.0, 5.0), doc="viscous friction about yaw"),
    _f("added_mass_kg", "kg", "total_positive", "log_total_mass", (0.1, 20.0), "v", (0.3, 0.1),
       fit_kind="mass", fit_range=_LOG_TOTAL_RATIO, doc="payload beyond the spec mass"),
    _f("added_yaw_inertia_kgm2", "kg m^2", "total_positive", "log_total_inertia", (0.1, 30.0), "w",
       (0.4, 0.15), fit_kind="inertia", fit_range=_LOG_TOTAL_RATIO,
       doc="payload yaw inertia beyond the spec"),
    # Differential drive: 1 exactly (no prior spread). Skid steer: Mandow et al. 2007
    # measured chi ~1.5-2 on their four-wheel base; Clearpath ships a separation
    # multiplier of 1.875 for Husky and 1.5 for Jackal (robots/template.py's skid prior).
    _f("track_factor", "1", "positive", "log", (1.0, 4.0), "vw", (0.0, 0.0),
       doc="skid steer: effective / geometric track (ICR spread; 1 = differential drive)"),
    _f("driver_track_factor", "1", "positive", "log", (1.0, 4.0), "vw", (0.0, 0.0), fittable=False,
       doc="the driver's track multiplier for its wheel targets (a driver setting)"),
    _mode("wheel_cap_per_side",
          "the driver clips each wheel's target at the speed cap on its own (1) or scales "
          "both together (0; a driver setting)"),
    _mode("command_starts_new_move",
          "the firmware runs each new command as a new move, its wheel loops' integrators "
          "cleared (1), or its loops run on (0; a driver setting)"),
)}
# fmt: on

#: Parameters that may be +inf (meaning "no such limit"); derived from :data:`SCHEMA`.
MAY_BE_INF = frozenset(n for n, f in SCHEMA.items() if f.may_be_inf)
#: Parameters that may be negative (payload lighter than the spec); derived from :data:`SCHEMA`.
MAY_BE_NEGATIVE = frozenset(n for n, f in SCHEMA.items() if f.sign == "total_positive")
#: Parameters that must be > 0 (gains and limits; +inf for "no limit"); from :data:`SCHEMA`.
MUST_BE_POSITIVE = frozenset(n for n, f in SCHEMA.items() if f.sign == "positive")
#: Units of every field; derived from :data:`SCHEMA`.
UNITS = {n: f.unit for n, f in SCHEMA.items()}


@dataclass(frozen=True, kw_only=True)
class Prior:
    """Prior belief about one drive parameter, in the field's coordinate (:data:`SCHEMA`).

    Attributes
    ----------
    name : str
        The DriveParams field.
    nominal : float
        Prior centre in natural units (the spec's drive value unless the spec says otherwise);
        ``+inf`` for "no such limit" (then there is no prior: the field is fixed unless a fit
        finds the limit).
    sd : float
        Prior standard deviation in coordinate units (``lin``: the unit of the value; log
        coordinates: a relative spread, 0.1 = about 10 %); 0 = known exactly.
    session_sd : float
        Default between-session standard deviation in coordinate units (payload, floor,
        battery sag and latency change from day to day): used as the session-to-session
        spread when only one log is fitted.
    source : str
        ``"spec"`` (written in the robot spec) or ``"generic"`` (from the schema).
    """

    name: str
    nominal: float
    sd: float
    session_sd: float
    source: str

    def __post_init__(self) -> None:
        for key in ("sd", "session_sd"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise RobotsValueError(
                    f"prior of '{self.name}': {key} must be a number, got {value!r}"
                )
            if not (math.isfinite(value) and value >= 0):
                raise RobotsValueError(
                    f"prior of '{self.name}': {key} must be a finite number >= 0, got {value!r}"
                )
        _check_value(self.name, self.nominal)

    @property
    def informative(self) -> bool:
        """True when the prior constrains the value (finite nominal, sd > 0)."""
        return math.isfinite(self.nominal) and self.sd > 0

    def mean(self, geometry: BaseGeometry) -> float:
        """Prior centre in coordinates (inf for an infinite nominal)."""
        if math.isinf(self.nominal):
            return math.inf
        return SCHEMA[self.name].to_coord(self.nominal, geometry)


def coords_to_values(
    names: Sequence[str],
    z: Sequence[float],
    geometry: BaseGeometry,
    others: Mapping[str, float] | None = None,
) -> dict[str, float]:
    """The values of fields ``names`` at schema coordinates ``z``, each kept inside the
    schema's range.

    A ``per_total_*`` field (friction per unit mass or yaw inertia) is multiplied by the total
    of its :attr:`FieldSchema.per_field`: taken from ``z`` when that field is among ``names``,
    else from ``others`` (its value there; 0 when absent).

    Examples
    --------
    >>> geo = BaseGeometry(mass_kg=2.0, yaw_inertia_kgm2=0.02, wheel_radius_m=0.03,
    ...                    wheel_separation_m=0.2)
    >>> z = [0.1, math.log(3.0)]  # 0.1 N/kg of Coulomb friction; a 3 kg total mass
    >>> v = coords_to_values(["coulomb_v_fwd_n", "added_mass_kg"], z, geo)
    >>> round(v["coulomb_v_fwd_n"], 6), round(v["added_mass_kg"], 6)
    (0.3, 1.0)
    """
    others = {} if others is None else others
    out: dict[str, float] = {}
    pairs = list(zip(names, (float(x) for x in z), strict=True))
    for per_total_pass in (False, True):  # the totals first, then what is per unit of them
        for name, zi in pairs:
            f = SCHEMA[name]
            if (f.per_field is not None) != per_total_pass:
                continue
            total = None
            if f.per_field is not None:
                total = f.total_of(geometry, out.get(f.per_field, others.get(f.per_field, 0.0)))
            out[name] = f.clamped_value(zi, geometry, total)
    return out


def generic_priors(drive: DriveParams, geometry: BaseGeometry) -> dict[str, Prior]:
    """Wide priors for every field, centred on ``drive``, with the schema's generic spreads.

    Specs without a ``priors`` section (e.g. the ones ``sim2real robots new`` writes) get
    these; see :data:`SCHEMA` for the reasoning behind each spread.

    Examples
    --------
    >>> geo = BaseGeometry(mass_kg=1.0, yaw_inertia_kgm2=0.01, wheel_radius_m=0.033,
    ...                    wheel_separation_m=0.16)
    >>> generic_priors(DriveParams(delay_s=0.1), geo)["delay_s"].sd
    0.1
    """
    return {
        name: Prior(
            name=name,
            nominal=float(getattr(drive, name)),
            sd=float(f.prior_sd(geometry)),
            session_sd=float(f.session_sd(geometry)),
            source="generic",
        )
        for name, f in SCHEMA.items()
    }


def _as_float(name: str, value: Any, source: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise RobotsValueError(
            f"{source}: drive parameter '{name}' must be a number, got {value!r}; "
            "write a plain number (or .inf where no limit applies)"
        )
    return float(value)


def _check_value(name: str, value: float) -> None:
    """The sign and finiteness rules of :data:`SCHEMA` (bounds are for fits and draws only)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
        raise RobotsValueError(f"drive parameter '{name}' must be a number, got {value!r}")
    rule = SCHEMA[name]
    if rule.choices and value not in rule.choices:
        raise RobotsValueError(
            f"drive parameter '{name}' must be one of {[_plain(c) for c in rule.choices]} "
            f"({rule.doc}), got {value!r}"
        )
    if math.isinf(value) and not (rule.may_be_inf and value > 0):
        raise RobotsValueError(
            f"drive parameter '{name}' must be finite, got {value!r}; give a finite value"
        )
    if rule.sign == "positive" and value <= 0:
        raise RobotsValueError(
            f"drive parameter '{name}' must be > 0, got {value!r}; "
            "use .inf for 'no limit' rather than 0"
        )
    if rule.sign == "nonneg" and value < 0:
        raise RobotsValueError(
            f"drive parameter '{name}' must be >= 0 (non-physical otherwise), got {value!r}"
        )


def _plain(x: float) -> float | int:
    """A whole number as an int (how a mode's choices read in a message)."""
    return int(x) if float(x).is_integer() else x


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
    document : dict
        The whole parsed file (e.g. its ``randomization`` block, read by
        :mod:`robots.randomization`).
    """

    path: Path
    robot: str
    values: dict[str, float]
    stds: dict[str, float]
    document: dict[str, Any] = dataclasses.field(default_factory=dict)

    def fitted_on(self, sha256: str | None) -> str | None:
        """The name the file gives the log of this SHA-256 when it was fitted on it (a
        ``data`` entry whose role is ``fit``, ``[start:end]`` after it for a fitted part);
        None when it was not (a validation log is not).

        Examples
        --------
        >>> doc = {"data": [{"file": "runs/a.mcap[0:16]", "sha256": "ab12", "role": "fit"}]}
        >>> pf = ParamsFile(path=Path("p.yaml"), robot="r", values={}, stds={}, document=doc)
        >>> pf.fitted_on("ab12"), pf.fitted_on("cd34")
        ('a.mcap[0:16]', None)
        """
        entries = self.document.get("data")
        for e in entries if isinstance(entries, list) and sha256 else []:
            if isinstance(e, dict) and e.get("sha256") == sha256 and e.get("role", "fit") == "fit":
                return Path(str(e.get("file", "this log"))).name
        return None

    def robot_option(self) -> str:
        """The ``--robot`` option that loads this file's robot, as a user can paste it.

        The spec file the fit used when it was given as a file (``settings.spec_file``) and
        still exists; else the robot's name when a spec of that name is shipped; else a
        pointer to the robot's own spec file (a name alone would not load).

        Examples
        --------
        >>> ParamsFile(path=Path("p.yaml"), robot="turtlebot2", values={}, stds={},
        ...            document={}).robot_option()
        '--robot turtlebot2'
        """
        settings = self.document.get("settings")
        spec_file = settings.get("spec_file") if isinstance(settings, dict) else None
        if isinstance(spec_file, str) and Path(spec_file).is_file():
            return f"--robot {shlex.quote(spec_file)}"
        if (SPECS_DIR / f"{self.robot}.yaml").is_file():
            return f"--robot {self.robot}"
        return f"--robot with the spec file of robot '{self.robot}' (e.g. its {self.robot}.yaml)"


def load_params_document(path: str | Path) -> Any:
    """Parse a params (sysid result) YAML file: the one place that file is read and parsed.

    Returns the YAML document (whatever it holds; callers check the layout). Raises
    :class:`~robots.errors.ParamsFileError` for a missing file, a folder or invalid YAML.

    Examples
    --------
    >>> load_params_document("params.yaml")["robot"]  # doctest: +SKIP
    'turtlebot3_burger'
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
        return yaml.safe_load(p.read_text(encoding="utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise ParamsFileError(
            f"params file '{p}' is not valid YAML ({' '.join(str(exc).split())}); regenerate it"
        ) from None


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
    doc = load_params_document(p)
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
    return ParamsFile(path=p, robot=robot, values=values, stds=stds, document=doc)


def params_file_for(path: str | Path | ParamsFile, robot: str) -> ParamsFile:
    """The params file at ``path`` (or the :class:`ParamsFile` already read) when it was
    identified for ``robot``; raises :class:`~robots.errors.ParamsFileError` (naming the
    ``--robot`` that loads its own robot) when it was identified for another.

    Examples
    --------
    >>> params_file_for("params.yaml", "turtlebot3_burger").robot  # doctest: +SKIP
    'turtlebot3_burger'
    """
    pf = path if isinstance(path, ParamsFile) else read_params_file(path)
    if pf.robot != robot:
        raise ParamsFileError(
            f"params file '{pf.path}' was identified for robot '{pf.robot}', not '{robot}'; "
            f"pass {pf.robot_option()} or fit a params file for {robot}"
        )
    return pf


def load_drive_params(
    path: str | Path | ParamsFile, *, robot: str, base: DriveParams
) -> DriveParams:
    """Override ``base`` (the spec defaults) with the values in a params file for ``robot``.

    ``path`` is the file, or a :class:`ParamsFile` :func:`read_params_file` read already (a
    command that uses the file for several things reads it once). Raises :class:`~robots.errors.ParamsFileError` when the file is for another robot.

    Examples
    --------
    >>> load_drive_params("params.yaml", robot="turtlebot3_burger", base=DriveParams())
    ... # doctest: +SKIP
    """
    pf = params_file_for(path, robot)
    try:
        return base.replace(**pf.values)
    except RobotsValueError as exc:
        raise ParamsFileError(f"params file '{pf.path}': {exc}") from None
