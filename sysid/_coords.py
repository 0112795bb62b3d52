r"""Fit coordinates of :class:`robots.params.DriveParams`, and the schema's coordinates.

Two coordinate systems meet here:

* the **schema coordinates** :math:`z` of :data:`robots.params.SCHEMA` (``lin`` delay,
  ``log`` gains and limits, ``log_total_mass``, ``log_total_inertia``, friction per unit of
  the total mass or yaw inertia): the priors, the posterior, the population and the
  randomisation distribution live in them;
* the **internal fit coordinates** :math:`u` the optimiser moves, chosen so that velocity data
  see each one alone; their kind, bounds and step come from the schema too
  (``FieldSchema.fit_kind``, ``fit_range``, ``fit_step``). With :math:`k_v = 2K/r^2` and
  :math:`k_\omega = K L^2/(2 r^2)`:

==========================  ====================================  =========
DriveParams field           internal coordinate                   unit
==========================  ====================================  =========
delay_s                     delay                                 s
speed_loop_ki_per_s         k_i (a ratio of gains: scale-free)    1/s
motor_gain_nms_per_rad      log K                                 log
added_mass_kg               log((m + dm) / k_v)                   log s
added_yaw_inertia_kgm2      log((I + dI) / k_w)                   log s
viscous_v_ns_per_m          b_v / k_v                             1
viscous_w_nms_per_rad       b_w / k_w                             1
coulomb_v_fwd_n (bwd)       F_c / k_v  (steady-state speed loss)  m/s
coulomb_w_nm                T_c / k_w                             rad/s
wheel_torque_max_nm         log(tau_max / K)                      log rad/s
track_factor                log chi (skid steer)                  log
accel_lim_*, speed_lim_*,   log of the value                      log
wheel_speed_max_radps
==========================  ====================================  =========

A total mass or inertia never falls below the wheels' part plus half the schema's ``lower``
share of the base link's own (:meth:`robots.params.FieldSchema.total_floor`): below the
schema's plausible floor ``k`` (the full share) the map bends smoothly onto the hard floor
``b`` (:func:`soft_floor`), so every fit leaves the pybullet base link a positive mass and yaw
inertia whatever the robot, and the map is unchanged above ``k``.

Velocity data only fix mass/gain ratios, so with every other coordinate held, moving
:math:`\log K` scales masses, inertias, friction forces and the torque cap together and leaves
the response unchanged (exactly so without a fixed finite torque cap): the data Jacobian column
of :math:`\log K` is zero and the priors (in :math:`z`) alone place the gain. Along that ridge
the friction coordinates (per unit mass or inertia) do not move, so only the mass, inertia, gain
and torque-cap priors place it, and it is a straight line in :math:`z`. The posterior is
computed in :math:`u` and mapped to :math:`z` with the Jacobian :math:`G = \partial z/\partial u`.
A total mass or inertia is :math:`e^{z} > 0` for every :math:`u`, so no fit is non-physical.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from robots.arrays import FloatArray
from robots.params import SCHEMA, BaseGeometry, DriveParams, FieldSchema, Prior, generic_priors

__all__ = ["COORDS", "NOT_FITTABLE", "Coord", "Mapper", "soft_floor", "soft_floor_inverse"]


def soft_floor(y: float, hard: float, knee: float) -> float:
    r"""``y`` above ``knee``; below it :math:`b + (k - b)(y/k)^p`, :math:`p = k/(k - b)`.

    Continuous with a continuous slope at the knee, increasing, and above ``hard`` (b) for
    every ``y > 0``: a fit can approach the floor but never cross it.

    Examples
    --------
    >>> soft_floor(2.0, 0.5, 1.0), round(soft_floor(1e-9, 0.5, 1.0), 6)
    (2.0, 0.5)
    """
    if y >= knee:
        return y
    power = knee / (knee - hard)
    return hard + (knee - hard) * (max(y, 0.0) / knee) ** power


def soft_floor_inverse(total: float, hard: float, knee: float) -> float:
    """The ``y`` with ``soft_floor(y, hard, knee) == total`` (a tiny y at or below ``hard``)."""
    if total >= knee:
        return total
    power = knee / (knee - hard)
    share = max((total - hard) / (knee - hard), 1e-300)
    return float(knee * share ** (1.0 / power))


@dataclass(frozen=True, kw_only=True)
class Coord:
    """One internal fit coordinate: the field it sets, its kind, bounds and FD step."""

    field: str
    kind: str  # "lin", "log", "mass", "inertia", "ratio_v", "ratio_w", "torque_ratio"
    lower: float
    upper: float
    step: float
    axis: str  # "v", "w" or "vw" (shared)
    unit: str


def _coord(field: FieldSchema) -> Coord:
    """The internal coordinate of a schema field (its ``fit_kind``, ``fit_range``, ``fit_step``)."""
    if field.fit_range is not None:
        lower, upper = field.fit_range
    elif field.fit_kind == "log":
        lower, upper = math.log(field.lower), math.log(field.upper)
    else:
        lower, upper = field.lower, field.upper
    return Coord(
        field=field.name,
        kind=field.fit_kind,
        lower=lower,
        upper=upper,
        step=field.fit_step,
        axis=field.axis,
        unit=field.unit,
    )


#: Fields a fit can free (velocity logs can inform them), in DriveParams order; derived from
#: :data:`robots.params.SCHEMA` (its ``fittable``, ``axis``, ``unit`` and ``fit_*`` entries).
COORDS: dict[str, Coord] = {n: _coord(f) for n, f in SCHEMA.items() if f.fittable}

#: Fields that velocity data cannot inform (with the reason, used in error messages).
NOT_FITTABLE: dict[str, str] = {
    n: f"it is a firmware or driver setting ({f.doc}); set it in the robot spec"
    for n, f in SCHEMA.items()
    if not f.fittable
}


class Mapper:
    """Maps DriveParams to internal fit coordinates and schema coordinates.

    Parameters
    ----------
    geometry : BaseGeometry
        Spec geometry.
    base : DriveParams
        Values of the fields that are not fitted (the prior nominals).
    priors : mapping, optional
        ``{field: Prior}``; the schema's generic priors around ``base`` when omitted.
    """

    def __init__(
        self,
        geometry: BaseGeometry,
        base: DriveParams,
        priors: Mapping[str, Prior] | None = None,
    ) -> None:
        self.geometry = geometry
        self.base = base
        self.priors = dict(priors) if priors is not None else generic_priors(base, geometry)

    # --- loop gains ---------------------------------------------------------------------------

    def gains(self, k: float) -> tuple[float, float]:
        """(k_v, k_w) for motor gain ``k``."""
        r, sep = self.geometry.wheel_radius_m, self.geometry.wheel_separation_m
        return 2.0 * k / (r * r), k * sep * sep / (2.0 * r * r)

    @property
    def kv(self) -> float:
        """k_v at the base motor gain."""
        return self.gains(self.base.motor_gain_nms_per_rad)[0]

    @property
    def kw(self) -> float:
        """k_w at the base motor gain."""
        return self.gains(self.base.motor_gain_nms_per_rad)[1]

    # --- internal coordinates -----------------------------------------------------------------

    def to_coord(self, params: DriveParams, field: str) -> float:
        """The internal fit coordinate of ``field`` for ``params``."""
        c = COORDS[field]
        value = float(getattr(params, field))
        k = params.motor_gain_nms_per_rad
        kv, kw = self.gains(k)
        if c.kind in ("lin",):
            return value
        if c.kind == "log":
            return math.log(value) if math.isfinite(value) else c.upper
        if c.kind == "torque_ratio":
            return math.log(value / k) if math.isfinite(value) else c.upper
        if c.kind == "mass":
            total = params.total_mass_kg(self.geometry)
            return math.log(soft_floor_inverse(total, *self._floor(field)) / kv)
        if c.kind == "inertia":
            total = params.total_yaw_inertia_kgm2(self.geometry)
            return math.log(soft_floor_inverse(total, *self._floor(field)) / kw)
        return value / (kv if c.kind == "ratio_v" else kw)

    def floor_notes(self, params: DriveParams) -> list[str]:
        """One sentence per total mass or inertia that the fit pressed below the schema's
        plausible floor (the base link keeps less than ``lower`` x its spec value)."""
        notes = []
        for field, total in (
            ("added_mass_kg", params.total_mass_kg(self.geometry)),
            ("added_yaw_inertia_kgm2", params.total_yaw_inertia_kgm2(self.geometry)),
        ):
            hard, knee = self._floor(field)
            if total < knee:
                notes.append(
                    f"{field} = {getattr(params, field):.4g} {SCHEMA[field].unit} pressed the "
                    f"total to {total:.4g}, near the least the base link allows ({hard:.4g}: the "
                    "wheels plus a share of the base link); the log asks for less mass or "
                    "inertia than the spec's wheels hold: check the spec, the odometry source "
                    "(--odom-velocity) and the time source"
                )
        return notes

    def _floor(self, field: str) -> tuple[float, float]:
        """(hard floor, knee) of a total mass or inertia (see the module docstring)."""
        schema = SCHEMA[field]
        return schema.total_floor(self.geometry, 0.5), schema.total_floor(self.geometry)

    def from_coords(self, values: dict[str, float], ties: dict[str, str]) -> DriveParams:
        """DriveParams with the given internal coordinates applied (``ties``: field -> source)."""
        k = (
            math.exp(values["motor_gain_nms_per_rad"])
            if "motor_gain_nms_per_rad" in values
            else self.base.motor_gain_nms_per_rad
        )
        kv, kw = self.gains(k)
        changes: dict[str, float] = {}
        for field, x in values.items():
            kind = COORDS[field].kind
            if kind == "lin":
                changes[field] = x
            elif kind == "log":
                changes[field] = math.exp(x)
            elif kind == "torque_ratio":
                changes[field] = k * math.exp(x)
            elif kind == "mass":
                total = soft_floor(kv * math.exp(x), *self._floor(field))
                changes[field] = total - self.geometry.mass_kg
            elif kind == "inertia":
                total = soft_floor(kw * math.exp(x), *self._floor(field))
                changes[field] = total - self.geometry.yaw_inertia_kgm2
            else:
                changes[field] = x * (kv if kind == "ratio_v" else kw)
        for field, source in ties.items():
            changes[field] = changes.get(source, float(getattr(self.base, source)))
        return self.base.replace(**changes)

    # --- schema coordinates -------------------------------------------------------------------

    def bounds(self, field: str) -> tuple[float, float]:
        """Plausible range of the schema coordinate of ``field``."""
        return SCHEMA[field].coord_bounds(self.geometry)

    def prior(self, field: str) -> tuple[float, float] | None:
        """(mean, sd) of the prior of ``field`` in schema coordinates, None if uninformative."""
        p = self.priors[field]
        return (p.mean(self.geometry), p.sd) if p.informative else None

    def z(self, params: DriveParams, field: str) -> float:
        """Schema coordinate of ``field`` (inf limits map to the upper bound)."""
        value = float(getattr(params, field))
        if math.isinf(value):
            return self.bounds(field)[1]
        return SCHEMA[field].to_coord(value, self.geometry, self.total(params, field))

    def value(self, field: str, z: float, params: DriveParams | None = None) -> float:
        """The value of ``field`` at schema coordinate ``z`` (kept inside the schema's bounds);
        a per-unit-mass friction takes its total mass or yaw inertia from ``params`` (the base
        values when omitted)."""
        total = self.total(self.base if params is None else params, field)
        return SCHEMA[field].clamped_value(z, self.geometry, total)

    def total(self, params: DriveParams, field: str) -> float | None:
        """The total mass or yaw inertia that ``field``'s coordinate is per unit of (None for a
        field that is not per unit of a total)."""
        f = SCHEMA[field]
        if f.per_field is None:
            return None
        return f.total_of(self.geometry, getattr(params, f.per_field))

    def schema_coords(
        self, free: Sequence[str], ties: dict[str, str], u: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Schema coordinates of the free fields at internal ``u``, and G = dz/du (FD)."""
        params = self.from_coords(dict(zip(free, map(float, u), strict=True)), ties)
        z = np.array([self.z(params, f) for f in free])
        g = np.zeros((len(free), len(free)))
        for j, f in enumerate(free):
            h = COORDS[f].step
            up = np.array(u, dtype=np.float64)
            up[j] += h
            p = self.from_coords(dict(zip(free, map(float, up), strict=True)), ties)
            g[:, j] = (np.array([self.z(p, name) for name in free]) - z) / h
        return z, g

    def identifiable(self, params: DriveParams) -> dict[str, tuple[float, str]]:
        """The combinations velocity data identify whatever the mass/gain split is.

        Returns ``{name: (value, unit)}``: time constants, steady-state gains, friction per
        unit mass / inertia, the Coulomb speed loss, delay and limits.
        """
        g = self.geometry
        k = params.motor_gain_nms_per_rad
        kv, kw = self.gains(k)
        m = params.total_mass_kg(g)
        j = params.total_yaw_inertia_kgm2(g)
        bv, bw = params.viscous_v_ns_per_m, params.viscous_w_nms_per_rad
        return {
            "delay_s": (params.delay_s, "s"),
            "time_constant_v_s": (m / (kv + bv), "s"),
            "time_constant_w_s": (j / (kw + bw), "s"),
            "gain_v": (kv / (kv + bv), "1"),
            "gain_w": (kw / (kw + bw), "1"),
            "coulomb_v_fwd_per_mass_mps2": (params.coulomb_v_fwd_n / m, "m/s^2"),
            "coulomb_v_bwd_per_mass_mps2": (params.coulomb_v_bwd_n / m, "m/s^2"),
            "coulomb_w_per_inertia_radps2": (params.coulomb_w_nm / j, "rad/s^2"),
            "coulomb_v_fwd_speed_loss_mps": (params.coulomb_v_fwd_n / (kv + bv), "m/s"),
            "coulomb_w_speed_loss_radps": (params.coulomb_w_nm / (kw + bw), "rad/s"),
            "viscous_v_per_mass_1ps": (bv / m, "1/s"),
            "viscous_w_per_inertia_1ps": (bw / j, "1/s"),
            "accel_lim_v_mps2": (params.accel_lim_v_mps2, "m/s^2"),
            "accel_lim_w_radps2": (params.accel_lim_w_radps2, "rad/s^2"),
            "wheel_speed_max_radps": (params.wheel_speed_max_radps, "rad/s"),
            "wheel_speed_max_mps": (params.wheel_speed_max_radps * g.wheel_radius_m, "m/s"),
            "mass_per_motor_gain_kg_per_nms": (m / k, "kg rad/(N m s)"),
        }
