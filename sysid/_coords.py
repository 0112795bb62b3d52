r"""Well-conditioned fit coordinates for :class:`robots.params.DriveParams`.

With velocity-only data the wheel-loop gain :math:`K` and the mass trade off (only their ratio
shapes the response), so the motor gain stays at the spec prior and every other parameter is
fitted through a normalised coordinate that does not depend on that choice. With
:math:`k_v = 2K/r^2` and :math:`k_\omega = K L^2 / (2 r^2)`:

==========================  ====================================  =========
DriveParams field           fit coordinate                        unit
==========================  ====================================  =========
delay_s                     delay                                 s
added_mass_kg               log((m + dm) / k_v)                   log s
added_yaw_inertia_kgm2      log((I + dI) / k_w)                   log s
viscous_v_ns_per_m          b_v / k_v                             1
viscous_w_nms_per_rad       b_w / k_w                             1
coulomb_v_fwd_n (bwd)       F_c / k_v  (steady-state speed loss)  m/s
coulomb_w_nm                T_c / k_w                             rad/s
accel_lim_*, speed_lim_*,   log of the value                      log
wheel_speed_max_radps,
wheel_torque_max_nm
==========================  ====================================  =========

Each coordinate maps to exactly one field (given K), so fixing a field fixes its coordinate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from robots.params import BaseGeometry, DriveParams

__all__ = ["COORDS", "NOT_FITTABLE", "Coord", "Mapper"]


@dataclass(frozen=True, kw_only=True)
class Coord:
    """One fit coordinate: the DriveParams field it sets, its kind, its bounds and FD step."""

    field: str
    kind: str  # "lin", "log", "mass", "inertia", "ratio_v", "ratio_w"
    lower: float
    upper: float
    step: float
    axis: str  # "v", "w" or "vw" (shared)
    unit: str


COORDS: dict[str, Coord] = {
    c.field: c
    for c in (
        Coord(field="delay_s", kind="lin", lower=0.0, upper=1.0, step=1e-3, axis="vw", unit="s"),
        Coord(
            field="added_mass_kg",
            kind="mass",
            lower=math.log(2e-3),
            upper=math.log(20.0),
            step=1e-3,
            axis="v",
            unit="kg",
        ),
        Coord(
            field="added_yaw_inertia_kgm2",
            kind="inertia",
            lower=math.log(2e-3),
            upper=math.log(20.0),
            step=1e-3,
            axis="w",
            unit="kg m^2",
        ),
        Coord(
            field="viscous_v_ns_per_m",
            kind="ratio_v",
            lower=0.0,
            upper=5.0,
            step=1e-3,
            axis="v",
            unit="N s/m",
        ),
        Coord(
            field="viscous_w_nms_per_rad",
            kind="ratio_w",
            lower=0.0,
            upper=5.0,
            step=1e-3,
            axis="w",
            unit="N m s/rad",
        ),
        Coord(
            field="coulomb_v_fwd_n",
            kind="ratio_v",
            lower=0.0,
            upper=0.5,
            step=1e-4,
            axis="v",
            unit="N",
        ),
        Coord(
            field="coulomb_v_bwd_n",
            kind="ratio_v",
            lower=0.0,
            upper=0.5,
            step=1e-4,
            axis="v",
            unit="N",
        ),
        Coord(
            field="coulomb_w_nm",
            kind="ratio_w",
            lower=0.0,
            upper=3.0,
            step=5e-4,
            axis="w",
            unit="N m",
        ),
        Coord(
            field="accel_lim_v_mps2",
            kind="log",
            lower=math.log(0.02),
            upper=math.log(50.0),
            step=1e-3,
            axis="v",
            unit="m/s^2",
        ),
        Coord(
            field="accel_lim_w_radps2",
            kind="log",
            lower=math.log(0.1),
            upper=math.log(300.0),
            step=1e-3,
            axis="w",
            unit="rad/s^2",
        ),
        Coord(
            field="speed_lim_v_mps",
            kind="log",
            lower=math.log(0.01),
            upper=math.log(10.0),
            step=1e-3,
            axis="v",
            unit="m/s",
        ),
        Coord(
            field="speed_lim_w_radps",
            kind="log",
            lower=math.log(0.05),
            upper=math.log(50.0),
            step=1e-3,
            axis="w",
            unit="rad/s",
        ),
        Coord(
            field="wheel_speed_max_radps",
            kind="log",
            lower=math.log(0.3),
            upper=math.log(300.0),
            step=1e-3,
            axis="vw",
            unit="rad/s",
        ),
        Coord(
            field="wheel_torque_max_nm",
            kind="log",
            lower=math.log(1e-4),
            upper=math.log(100.0),
            step=1e-3,
            axis="vw",
            unit="N m",
        ),
    )
}

#: Fields that velocity data cannot identify (with the reason, used in error messages).
NOT_FITTABLE: dict[str, str] = {
    "motor_gain_nms_per_rad": (
        "the wheel-loop gain trades off with mass and inertia in velocity data, so it stays at "
        "the spec prior and added_mass_kg / added_yaw_inertia_kgm2 are derived relative to it"
    ),
    "cmd_timeout_s": "the command timeout is a firmware setting; set it in the robot spec",
}

UNITS: dict[str, str] = {name: c.unit for name, c in COORDS.items()} | {
    "motor_gain_nms_per_rad": "N m s/rad",
    "cmd_timeout_s": "s",
}


class Mapper:
    """Maps between DriveParams and fit coordinates for one geometry and motor gain."""

    def __init__(self, geometry: BaseGeometry, base: DriveParams) -> None:
        self.geometry = geometry
        self.base = base
        r, sep, k = (
            geometry.wheel_radius_m,
            geometry.wheel_separation_m,
            base.motor_gain_nms_per_rad,
        )
        self.kv = 2.0 * k / (r * r)
        self.kw = k * sep * sep / (2.0 * r * r)

    def to_coord(self, params: DriveParams, field: str) -> float:
        """The fit coordinate of ``field`` for ``params``."""
        c = COORDS[field]
        value = float(getattr(params, field))
        if c.kind == "lin":
            return value
        if c.kind == "log":
            return math.log(value) if math.isfinite(value) else c.upper
        if c.kind == "mass":
            return math.log(params.total_mass_kg(self.geometry) / self.kv)
        if c.kind == "inertia":
            return math.log(params.total_yaw_inertia_kgm2(self.geometry) / self.kw)
        if c.kind == "ratio_v":
            return value / self.kv
        return value / self.kw  # ratio_w

    def from_coords(self, values: dict[str, float], ties: dict[str, str]) -> DriveParams:
        """DriveParams with the given coordinates applied (``ties``: field -> source field)."""
        changes: dict[str, float] = {}
        for field, x in values.items():
            c = COORDS[field]
            if c.kind == "lin":
                changes[field] = x
            elif c.kind == "log":
                changes[field] = math.exp(x)
            elif c.kind == "mass":
                changes[field] = self.kv * math.exp(x) - self.geometry.mass_kg
            elif c.kind == "inertia":
                changes[field] = self.kw * math.exp(x) - self.geometry.yaw_inertia_kgm2
            elif c.kind == "ratio_v":
                changes[field] = x * self.kv
            else:
                changes[field] = x * self.kw
        for field, source in ties.items():
            changes[field] = changes.get(source, float(getattr(self.base, source)))
        return self.base.replace(**changes)

    def identifiable(self, params: DriveParams) -> dict[str, tuple[float, str]]:
        """The combinations the log identifies, independent of the motor-gain prior.

        Returns ``{name: (value, unit)}``: time constants, steady-state gains, friction per
        unit mass / inertia, the Coulomb speed loss, delay and limits.
        """
        m = params.total_mass_kg(self.geometry)
        j = params.total_yaw_inertia_kgm2(self.geometry)
        kv, kw = self.kv, self.kw
        bv, bw = params.viscous_v_ns_per_m, params.viscous_w_nms_per_rad
        out: dict[str, tuple[float, str]] = {
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
            "wheel_speed_max_mps": (
                params.wheel_speed_max_radps * self.geometry.wheel_radius_m,
                "m/s",
            ),
            "mass_per_motor_gain_kg_per_nms": (m / params.motor_gain_nms_per_rad, "kg rad/(N m s)"),
        }
        return out
