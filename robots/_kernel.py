r"""The ONE drive-step kernel, shared by the reduced model and the pybullet robot.

One physics step of the drive chain of :class:`robots.params.DriveParams`, on plain floats and a
packed parameter vector (:func:`pack_params`), compiled with numba and callable from Python:

1. :func:`shape_command`: firmware speed clamp, velocity-smoother rate limit, wheel speed
   targets with the per-wheel speed cap (both wheels scaled together);
2. :func:`wheel_loops`: per-wheel proportional speed loops with torque saturation and the axis
   friction. Unsaturated: backward Euler of the P loops and viscous friction, then Coulomb
   friction as a proximal step (it stops the base but never reverses it); the torques are the
   loops' torques at the end-of-step wheel speeds. Saturated (a torque above
   ``wheel_torque_max_nm``): clipped torques of the current wheel speeds, viscous term implicit.

:func:`drive_step` chains the two (what :mod:`robots.reduced` integrates) and
:func:`pybullet_substep` adds what the rigid-body robot needs around it (the yaw of its
quaternion, the wheels' slip correction and the axis friction as an external force and torque,
:mod:`robots.pybullet_robot`). To extend the chain, add an entry to the packed vector in
:func:`pack_params` and use it here: both engines follow (as the skid steer's ``TRACK`` and
``CMD_TRACK`` do: see :func:`wheel_loops`; the pybullet robot's slip correction and axis
friction stay on the geometric track, where its gripping tyres roll).

Example
-------
>>> from robots import load_spec
>>> spec = load_spec("turtlebot3_burger")
>>> p = pack_params(spec.drive, spec.geometry)
>>> v1, w1, ref_v, ref_w, tr, tl = drive_step(0.0, 0.0, 0.0, 0.0, 0.22, 0.0, 0.005, p)
>>> round(v1, 4), round(tr, 4)  # 5 ms later: m/s, N m (cap 0.081)
(0.0196, 0.0688)
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from robots._jit import njit
from robots.params import BaseGeometry, DriveParams

__all__ = [
    "N_PACKED",
    "axis_friction",
    "clip",
    "drive_step",
    "pack_params",
    "pybullet_substep",
    "shape_command",
    "wheel_loops",
]

FloatArray = NDArray[np.float64]

# Index of each entry of the packed parameter vector.
SPEED_V, SPEED_W, ACC_V, ACC_W, WMAX, K, TMAX = 0, 1, 2, 3, 4, 5, 6
CFWD, CBWD, CW, BV, BW, MASS, INERTIA, R, L = 7, 8, 9, 10, 11, 12, 13, 14, 15
TRACK = 16  # skid steer: effective / geometric track (1 = differential drive)
CMD_TRACK = 17  # the driver's track multiplier for its wheel targets
#: Length of the packed parameter vector.
N_PACKED = 18


def pack_params(params: DriveParams, geometry: BaseGeometry) -> FloatArray:
    """Pack parameters and geometry into the flat float vector the kernels take."""
    p = np.empty(N_PACKED)
    p[SPEED_V] = params.speed_lim_v_mps
    p[SPEED_W] = params.speed_lim_w_radps
    p[ACC_V] = params.accel_lim_v_mps2
    p[ACC_W] = params.accel_lim_w_radps2
    p[WMAX] = params.wheel_speed_max_radps
    p[K] = params.motor_gain_nms_per_rad
    p[TMAX] = params.wheel_torque_max_nm
    p[CFWD] = params.coulomb_v_fwd_n
    p[CBWD] = params.coulomb_v_bwd_n
    p[CW] = params.coulomb_w_nm
    p[BV] = params.viscous_v_ns_per_m
    p[BW] = params.viscous_w_nms_per_rad
    p[MASS] = params.total_mass_kg(geometry)
    p[INERTIA] = params.total_yaw_inertia_kgm2(geometry)
    p[R] = geometry.wheel_radius_m
    p[L] = geometry.wheel_separation_m
    p[TRACK] = params.track_factor
    p[CMD_TRACK] = params.driver_track_factor
    return p


@njit(cache=True, inline="always")
def clip(x: float, lim: float) -> float:  # pragma: no cover - compiled
    """``x`` limited to ``[-lim, lim]``."""
    if x > lim:
        return lim
    if x < -lim:
        return -lim
    return x


@njit(cache=True, inline="always")
def _coulomb_prox(
    x_nc: float, impulse_pos: float, impulse_neg: float
) -> float:  # pragma: no cover - compiled
    """Apply a Coulomb impulse that opposes motion but never reverses it."""
    if x_nc > impulse_pos:
        return x_nc - impulse_pos
    if x_nc < -impulse_neg:
        return x_nc + impulse_neg
    return 0.0


@njit(cache=True, inline="always")
def shape_command(
    u_v: float, u_w: float, ref_v: float, ref_w: float, dt: float, p: FloatArray
) -> tuple[float, float, float, float]:  # pragma: no cover - compiled
    """Clamp, rate-limit and cap command (u_v, u_w); returns (ref_v, ref_w, wr_ref, wl_ref).

    The wheel targets use the driver's track (``driver_track_factor`` x the geometric one).
    """
    r, half_l = p[R], 0.5 * (p[L] * p[CMD_TRACK])
    u_v = clip(u_v, p[SPEED_V])
    u_w = clip(u_w, p[SPEED_W])
    ref_v += clip(u_v - ref_v, p[ACC_V] * dt)
    ref_w += clip(u_w - ref_w, p[ACC_W] * dt)
    wr_ref = (ref_v + ref_w * half_l) / r
    wl_ref = (ref_v - ref_w * half_l) / r
    peak = max(abs(wr_ref), abs(wl_ref))
    if peak > p[WMAX]:
        s = p[WMAX] / peak
        wr_ref *= s
        wl_ref *= s
    return ref_v, ref_w, wr_ref, wl_ref


@njit(cache=True, inline="always")
def wheel_loops(
    v: float, w: float, wr_ref: float, wl_ref: float, dt: float, p: FloatArray
) -> tuple[float, float, float, float]:  # pragma: no cover - compiled
    r"""Wheel loops and axis friction over one step; returns (v1, w1, torque_r, torque_l).

    Skid steer (``p[TRACK]`` = :math:`\chi > 1`): the wheel speeds follow the body through
    the effective track :math:`\chi L` (the treads slip), while the wheel forces act at the
    geometric half-track, so the yaw loop gain is :math:`K L \chi L / (2 r^2)`.
    """
    r, half_l, half_e = p[R], 0.5 * p[L], 0.5 * (p[L] * p[TRACK])
    m, inertia, k = p[MASS], p[INERTIA], p[K]
    ref_v = 0.5 * r * (wr_ref + wl_ref)
    ref_w = r * (wr_ref - wl_ref) / (p[L] * p[TRACK])
    kv = 2.0 * k / (r * r)
    kw = k * p[L] * (p[L] * p[TRACK]) / (2.0 * r * r)
    den_v = m + dt * (kv + p[BV])
    den_w = inertia + dt * (kw + p[BW])
    v_nc = (m * v + dt * kv * ref_v) / den_v
    w_nc = (inertia * w + dt * kw * ref_w) / den_w
    v1 = _coulomb_prox(v_nc, dt * p[CFWD] / den_v, dt * p[CBWD] / den_v)
    w1 = _coulomb_prox(w_nc, dt * p[CW] / den_w, dt * p[CW] / den_w)
    tr = k * (wr_ref - (v1 + w1 * half_e) / r)
    tl = k * (wl_ref - (v1 - w1 * half_e) / r)
    if max(abs(tr), abs(tl)) > p[TMAX]:
        tr = clip(k * (wr_ref - (v + w * half_e) / r), p[TMAX])
        tl = clip(k * (wl_ref - (v - w * half_e) / r), p[TMAX])
        force = (tr + tl) / r
        torque = (tr - tl) * half_l / r
        den_v = m + dt * p[BV]
        den_w = inertia + dt * p[BW]
        v_nc = (m * v + dt * force) / den_v
        w_nc = (inertia * w + dt * torque) / den_w
        v1 = _coulomb_prox(v_nc, dt * p[CFWD] / den_v, dt * p[CBWD] / den_v)
        w1 = _coulomb_prox(w_nc, dt * p[CW] / den_w, dt * p[CW] / den_w)
    return v1, w1, tr, tl


@njit(cache=True, inline="always")
def axis_friction(
    v: float,
    w: float,
    v1: float,
    w1: float,
    tr: float,
    tl: float,
    dt: float,
    m: float,
    inertia: float,
    r: float,
    half_l: float,
) -> tuple[float, float]:  # pragma: no cover - compiled
    r"""Axis friction (force N, yaw torque N m) that takes the base from (v, w) to (v1, w1).

    What the friction must contribute beyond the wheel torques (``tr``, ``tl``):
    :math:`f = m (v_1 - v)/dt - (\tau_r + \tau_l)/r` and
    :math:`\tau = I (w_1 - w)/dt - (\tau_r - \tau_l) L/(2 r)`.
    """
    force = m * (v1 - v) / dt - (tr + tl) / r
    torque = inertia * (w1 - w) / dt - (tr - tl) * half_l / r
    return force, torque


@njit(cache=True)
def drive_step(
    v: float, w: float, ref_v: float, ref_w: float, u_v: float, u_w: float, dt: float, p: FloatArray
) -> tuple[float, float, float, float, float, float]:  # pragma: no cover - compiled
    """One step of the chain; returns (v1, w1, ref_v, ref_w, torque_r, torque_l)."""
    ref_v, ref_w, wr_ref, wl_ref = shape_command(u_v, u_w, ref_v, ref_w, dt, p)
    v1, w1, tr, tl = wheel_loops(v, w, wr_ref, wl_ref, dt, p)
    return v1, w1, ref_v, ref_w, tr, tl


@njit(cache=True)
def pybullet_substep(
    state: FloatArray,
    u_v: float,
    u_w: float,
    wl_meas: float,
    wr_meas: float,
    vx: float,
    vy: float,
    wz: float,
    dt: float,
    p: FloatArray,
    spin_inertia: float,
) -> tuple[float, float]:  # pragma: no cover - compiled
    r"""The wheel torques of one pybullet physics step (the chain of :func:`drive_step`).

    ``state`` is ``[ref_v, ref_w, yaw]``, advanced in place: the smoother's reference and the
    base's yaw one step earlier; the yaw advances by :math:`dt\,w_z` (what pybullet's
    semi-implicit integrator did in the last step), so the robot reads the orientation once
    per control step only. Inputs are the measured wheel speeds (rad/s, the encoders the
    firmware's loops read) and the base's world velocity.

    The torques are the model's wheel-loop torques (wheel speeds from the base motion) plus
    :math:`K'` times each wheel's slip, with :math:`K' = K/(1 + dt\,K/J_w)` the gain of a
    free wheel of spin inertia :math:`J_w`, clipped to the torque cap, plus the axis friction
    carried by the wheels (as a drivetrain's and the tyres' rolling friction are): the force
    :math:`f = m (v_1 - v)/dt - (\tau_r+\tau_l)/r` and yaw torque that take the base from
    :math:`(v, w)` to the model's end-of-step :math:`(v_1, w_1)`, as wheel torques
    :math:`r f/2 \pm r \tau/L`. While the tyres grip, the torques are thus the generalised
    forces that take the rolling base (whose mass and yaw inertia count the wheels' spin
    inertia) to :math:`(v_1, w_1)`.

    Returns
    -------
    tuple
        (torque_l, torque_r), N m.
    """
    yaw = state[2] + dt * wz
    state[2] = yaw
    v = vx * math.cos(yaw) + vy * math.sin(yaw)
    w = wz
    ref_v, ref_w, wr_ref, wl_ref = shape_command(u_v, u_w, state[0], state[1], dt, p)
    state[0] = ref_v
    state[1] = ref_w
    v1, w1, tr_model, tl_model = wheel_loops(v, w, wr_ref, wl_ref, dt, p)
    r, sep, k, tmax = p[R], p[L], p[K], p[TMAX]
    half_l = 0.5 * sep
    slip_l = wl_meas - (v - w * half_l) / r
    slip_r = wr_meas - (v + w * half_l) / r
    k_slip = k / (1.0 + dt * k / spin_inertia)
    tl = clip(tl_model - k_slip * slip_l, tmax)
    tr = clip(tr_model - k_slip * slip_r, tmax)
    force, torque = axis_friction(
        v, w, v1, w1, tr_model, tl_model, dt, p[MASS], p[INERTIA], r, half_l
    )
    common = 0.5 * r * force
    differential = r * torque / sep
    return tl + common - differential, tr + common + differential
