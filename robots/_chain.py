"""The command side of the drive chain, step by step, for the pybullet robot.

The same arithmetic as the reduced model's kernel (:mod:`robots.reduced`): firmware speed clamp,
velocity-smoother rate limit, wheel targets with the per-wheel speed cap (both wheels scaled
together), per-wheel proportional speed loop with torque saturation, and the axis friction
applied as a proximal step (Coulomb friction stops the base but never reverses it).

Example
-------
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

from robots.params import BaseGeometry, DriveParams

__all__ = ["CommandShaper", "DriveStep", "clip", "drive_step", "friction_of"]


def clip(x: float, lim: float) -> float:
    """``x`` limited to ``[-lim, lim]``."""
    return lim if x > lim else (-lim if x < -lim else x)


class CommandShaper:
    """Clamp, rate-limit and cap a (v, w) command into per-wheel speed targets.

    Parameters
    ----------
    params, geometry : DriveParams, BaseGeometry
        The drive parameters and the wheel geometry.
    """

    def __init__(self, params: DriveParams, geometry: BaseGeometry) -> None:
        self.params = params
        self.geometry = geometry
        self.ref_v = 0.0
        self.ref_w = 0.0

    def reset(self, v: float = 0.0, w: float = 0.0) -> None:
        """Set the smoother's reference (the base's current velocity)."""
        self.ref_v, self.ref_w = v, w

    def wheel_targets(self, u_v: float, u_w: float, dt: float) -> tuple[float, float]:
        """Advance the smoother by ``dt`` s with command (u_v, u_w); return (right, left) rad/s."""
        p, g = self.params, self.geometry
        u_v = clip(u_v, p.speed_lim_v_mps)
        u_w = clip(u_w, p.speed_lim_w_radps)
        self.ref_v += clip(u_v - self.ref_v, p.accel_lim_v_mps2 * dt)
        self.ref_w += clip(u_w - self.ref_w, p.accel_lim_w_radps2 * dt)
        half_l, r = 0.5 * g.wheel_separation_m, g.wheel_radius_m
        wr = (self.ref_v + self.ref_w * half_l) / r
        wl = (self.ref_v - self.ref_w * half_l) / r
        peak = max(abs(wr), abs(wl))
        if peak > p.wheel_speed_max_radps:
            scale = p.wheel_speed_max_radps / peak
            wr *= scale
            wl *= scale
        return wr, wl


def _coulomb_prox(x_nc: float, impulse_pos: float, impulse_neg: float) -> float:
    if x_nc > impulse_pos:
        return x_nc - impulse_pos
    if x_nc < -impulse_neg:
        return x_nc + impulse_neg
    return 0.0


@dataclass(frozen=True, kw_only=True)
class DriveStep:
    """Result of one step of the drive: next velocities and the wheel torques.

    Attributes
    ----------
    v1, w1 : float
        Forward (m/s) and yaw (rad/s) velocity at the end of the step.
    torque_l, torque_r : float
        Left and right wheel torques over the step, N m.
    """

    v1: float
    w1: float
    torque_l: float
    torque_r: float


def drive_step(
    v: float,
    w: float,
    wr_ref: float,
    wl_ref: float,
    dt: float,
    params: DriveParams,
    geometry: BaseGeometry,
) -> DriveStep:
    r"""One step of the wheel loops and axis friction, discretised as the reduced model does.

    Unsaturated: backward Euler of the P loops and viscous friction, then Coulomb friction as a
    proximal step; the torques are the loops' torques at the end-of-step wheel speeds.
    Saturated (a torque above ``wheel_torque_max_nm``): clipped torques of the current wheel
    speeds. Mirrors ``robots.reduced._step`` line by line (a test checks they agree).
    """
    p = params
    r, sep = geometry.wheel_radius_m, geometry.wheel_separation_m
    half_l = 0.5 * sep
    m, inertia, k = (
        p.total_mass_kg(geometry),
        p.total_yaw_inertia_kgm2(geometry),
        p.motor_gain_nms_per_rad,
    )
    ref_v = 0.5 * r * (wr_ref + wl_ref)
    ref_w = r * (wr_ref - wl_ref) / sep
    kv = 2.0 * k / (r * r)
    kw = k * sep * sep / (2.0 * r * r)
    den_v = m + dt * (kv + p.viscous_v_ns_per_m)
    den_w = inertia + dt * (kw + p.viscous_w_nms_per_rad)
    v_nc = (m * v + dt * kv * ref_v) / den_v
    w_nc = (inertia * w + dt * kw * ref_w) / den_w
    v1 = _coulomb_prox(v_nc, dt * p.coulomb_v_fwd_n / den_v, dt * p.coulomb_v_bwd_n / den_v)
    w1 = _coulomb_prox(w_nc, dt * p.coulomb_w_nm / den_w, dt * p.coulomb_w_nm / den_w)
    tr = k * (wr_ref - (v1 + w1 * half_l) / r)
    tl = k * (wl_ref - (v1 - w1 * half_l) / r)
    tmax = p.wheel_torque_max_nm
    if max(abs(tr), abs(tl)) > tmax:
        tr = clip(k * (wr_ref - (v + w * half_l) / r), tmax)
        tl = clip(k * (wl_ref - (v - w * half_l) / r), tmax)
        force = (tr + tl) / r
        torque = (tr - tl) * half_l / r
        den_v = m + dt * p.viscous_v_ns_per_m
        den_w = inertia + dt * p.viscous_w_nms_per_rad
        v_nc = (m * v + dt * force) / den_v
        w_nc = (inertia * w + dt * torque) / den_w
        v1 = _coulomb_prox(v_nc, dt * p.coulomb_v_fwd_n / den_v, dt * p.coulomb_v_bwd_n / den_v)
        w1 = _coulomb_prox(w_nc, dt * p.coulomb_w_nm / den_w, dt * p.coulomb_w_nm / den_w)
    return DriveStep(v1=v1, w1=w1, torque_l=tl, torque_r=tr)


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
    force = m * (step.v1 - v) / dt - (step.torque_r + step.torque_l) / r
    torque = inertia * (step.w1 - w) / dt - (step.torque_r - step.torque_l) * half_l / r
    return force, torque
