"""The drive chain step by step from Python: a view of the shared kernel :mod:`robots._kernel`.

:class:`CommandShaper` (firmware speed clamp, velocity-smoother rate limit, wheel targets with
the per-wheel speed cap), :func:`drive_step` (per-wheel PI speed loops with torque
saturation and the axis friction as a proximal step) and :func:`friction_of` call the same
compiled arithmetic as the reduced model (:mod:`robots.reduced`) and the pybullet robot
(:func:`robots._kernel.pybullet_substep`), so there is one copy of it.

Examples
--------
>>> from robots import load_spec
>>> spec = load_spec("turtlebot3_burger")
>>> shaper = CommandShaper(spec.drive, spec.geometry)
>>> wr, wl = shaper.wheel_targets(0.22, 0.0, 0.005)  # no smoother limits: the full command
>>> round(wr, 3), round(wl, 3)
(6.667, 6.667)
>>> step = drive_step(0.0, 0.0, wr, wl, 0.005, spec.drive, spec.geometry)
>>> round(step.v1, 4), round(step.torque_r, 4)  # 5 ms later: m/s, N m (cap 0.081)
(0.0196, 0.0688)
"""

from __future__ import annotations

from dataclasses import dataclass

from robots import _kernel
from robots.params import BaseGeometry, DriveParams

__all__ = ["CommandShaper", "DriveStep", "clip", "drive_step", "friction_of"]


def clip(x: float, lim: float) -> float:
    """``x`` limited to ``[-lim, lim]``."""
    return lim if x > lim else (-lim if x < -lim else x)


class CommandShaper(_kernel.PackedParams):
    """Clamp, rate-limit and cap a (v, w) command into per-wheel speed targets.

    Parameters
    ----------
    params, geometry : DriveParams, BaseGeometry
        The drive parameters and the wheel geometry.
    """

    def __init__(self, params: DriveParams, geometry: BaseGeometry) -> None:
        self.geometry = geometry
        self.params = params
        self.ref_v = 0.0
        self.ref_w = 0.0

    def reset(self, v: float = 0.0, w: float = 0.0) -> None:
        """Set the smoother's reference (the base's current velocity)."""
        self.ref_v, self.ref_w = v, w

    def wheel_targets(self, u_v: float, u_w: float, dt: float) -> tuple[float, float]:
        """Advance the smoother by ``dt`` s with command (u_v, u_w); return (right, left) rad/s."""
        self.ref_v, self.ref_w, wr, wl = _kernel.shape_command(
            u_v, u_w, self.ref_v, self.ref_w, dt, self._packed
        )
        return wr, wl


@dataclass(frozen=True, kw_only=True)
class DriveStep:
    """Result of one step of the drive: next velocities, wheel torques and integrators.

    Attributes
    ----------
    v1, w1 : float
        Forward (m/s) and yaw (rad/s) velocity at the end of the step.
    torque_l, torque_r : float
        Left and right wheel torques over the step, N m.
    integral_l_rad, integral_r_rad : float
        The wheel loops' integrators (integrated wheel-speed error) at the end of the step.
    """

    v1: float
    w1: float
    torque_l: float
    torque_r: float
    integral_l_rad: float = 0.0
    integral_r_rad: float = 0.0


def drive_step(
    v: float,
    w: float,
    wr_ref: float,
    wl_ref: float,
    dt: float,
    params: DriveParams,
    geometry: BaseGeometry,
    *,
    integral_r_rad: float = 0.0,
    integral_l_rad: float = 0.0,
) -> DriveStep:
    r"""One step of the wheel loops and axis friction (:func:`robots._kernel.wheel_loops`).

    Unsaturated: backward Euler of the PI loops and viscous friction, then Coulomb friction as
    a proximal step; the torques are the loops' torques at the end-of-step wheel speeds.
    Saturated (a torque above ``wheel_torque_max_nm``): clipped torques of the current wheel
    speeds. ``integral_*_rad`` are the wheel integrators before the step.
    """
    packed = _kernel.pack_params(params, geometry)
    v1, w1, ir, il, tr, tl = _kernel.wheel_loops(
        v, w, wr_ref, wl_ref, integral_r_rad, integral_l_rad, dt, packed
    )
    return DriveStep(v1=v1, w1=w1, torque_l=tl, torque_r=tr, integral_l_rad=il, integral_r_rad=ir)


def friction_of(
    step: DriveStep, v: float, w: float, dt: float, m: float, inertia: float, geometry: BaseGeometry
) -> tuple[float, float]:
    r"""Axis friction force (N) and yaw torque (N m) over a step of :func:`drive_step`.

    What the friction must contribute, beyond the wheel torques, for the base to reach
    ``(v1, w1)``: :math:`f = m (v_1 - v)/dt - (\tau_r + \tau_l)/r`. It equals
    :math:`-b v_1 - c\,\mathrm{sgn}` while sliding and is bounded by the Coulomb level while
    stuck (it holds the base against a drive below breakaway, and never reverses it).
    """
    r, half_l = geometry.wheel_radius_m, 0.5 * geometry.wheel_separation_m
    force, torque = _kernel.axis_friction(
        v, w, step.v1, step.w1, step.torque_r, step.torque_l, dt, m, inertia, r, half_l
    )
    return force, torque
