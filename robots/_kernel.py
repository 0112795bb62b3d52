r"""The ONE drive-step kernel, shared by the reduced model and the pybullet robot.

One physics step of the drive chain of :class:`robots.params.DriveParams`, on plain floats and a
packed parameter vector (:func:`pack_params`), compiled with numba and callable from Python:

1. :func:`shape_command`: firmware speed clamp, velocity-smoother rate limit, wheel speed
   targets with the per-wheel speed cap (both wheels scaled together, or each clipped on its
   own: ``wheel_cap_per_side``);
2. :func:`wheel_loops`: per-wheel PI speed loops with torque saturation and the axis
   friction. Unsaturated: backward Euler of the PI loops and viscous friction, then Coulomb
   friction as a proximal step (it stops the base but never reverses it); the torques are the
   loops' torques at the end-of-step wheel speeds. Saturated (a torque above
   ``wheel_torque_max_nm``): clipped torques of the current wheel speeds, viscous term implicit.
   Each wheel's integrator (its integrated speed error, rad) is advanced by the trapezoidal
   rule (a step's start and end errors; backward Euler would damp the loop's overshoot by
   O(dt k_i) and bias a fitted integral gain), except while that wheel's torque is clipped and
   the error pushes further into the limit (conditional-integration anti-windup); a zero wheel
   target clears it (a stop), and so does a change of the wheel targets when the firmware runs
   each command as a new move (``command_starts_new_move``: :func:`starts_new_move`). With
   ``speed_loop_ki_per_s = 0`` the loops are P loops and the arithmetic is exactly theirs.

:func:`drive_step` chains the two (what :mod:`robots.reduced` integrates) and
:func:`pybullet_substep` adds what the rigid-body robot needs around it (the yaw of its
quaternion, the wheels' slip correction and the axis friction as wheel torques, carried by the
tyres: step 4 of :mod:`robots.pybullet_robot`). To extend the chain, add an entry to the
packed vector in :func:`pack_params` and use it here: both engines follow (as the skid steer's ``TRACK`` and
``CMD_TRACK`` do: see :func:`wheel_loops`; the pybullet robot's slip correction and axis
friction stay on the geometric track, where its gripping tyres roll).

Examples
--------
>>> from robots import load_spec
>>> spec = load_spec("turtlebot3_burger")
>>> p = pack_params(spec.drive, spec.geometry)
>>> v1, w1, ref_v, ref_w, ir, il, tr, tl = drive_step(
...     0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.22, 0.0, 0.005, p)
>>> round(v1, 4), round(tr, 4)  # 5 ms later: m/s, N m (cap 0.081)
(0.0196, 0.0688)
"""

from __future__ import annotations

import math

import numpy as np

from robots._jit import njit
from robots.arrays import FloatArray
from robots.params import BaseGeometry, DriveParams

__all__ = [
    "N_PACKED",
    "PackedParams",
    "axis_friction",
    "clip",
    "drive_step",
    "pack_params",
    "pybullet_substep",
    "shape_command",
    "starts_new_move",
    "wheel_loops",
]


# Index of each entry of the packed parameter vector.
SPEED_V, SPEED_W, ACC_V, ACC_W, WMAX, K, TMAX = 0, 1, 2, 3, 4, 5, 6
CFWD, CBWD, CW, BV, BW, MASS, INERTIA, R, L = 7, 8, 9, 10, 11, 12, 13, 14, 15
TRACK = 16  # skid steer: effective / geometric track (1 = differential drive)
CMD_TRACK = 17  # the driver's track multiplier for its wheel targets
KI = 18  # the wheel loops' integral gain over the P gain, 1/s (0 = P loops)
TS = 19  # the motors' stall torque at the wheel, N m (the torque-speed line)
W0 = 20  # the motors' no-load wheel speed, rad/s (inf: no line, a flat torque cap)
CAP_SIDE = 21  # 1: each wheel target clipped at the cap on its own; 0: both scaled together
NEW_MOVE = 22  # 1: the firmware runs each new command as a new move (integrators cleared)
#: Length of the packed parameter vector.
N_PACKED = 23
#: A wheel target below this (rad/s) is a stop: it clears that wheel's integrator; a target
#: that moves by more than this starts a new move (:func:`starts_new_move`): the held command
#: average leaves rounding-level changes where none was sent.
ZERO_TARGET_RADPS = 1e-9


#: The entries of the packed vector that are a DriveParams field as it is.
_AS_IS = {
    SPEED_V: "speed_lim_v_mps",
    SPEED_W: "speed_lim_w_radps",
    ACC_V: "accel_lim_v_mps2",
    ACC_W: "accel_lim_w_radps2",
    WMAX: "wheel_speed_max_radps",
    K: "motor_gain_nms_per_rad",
    TMAX: "wheel_torque_max_nm",
    CFWD: "coulomb_v_fwd_n",
    CBWD: "coulomb_v_bwd_n",
    CW: "coulomb_w_nm",
    BV: "viscous_v_ns_per_m",
    BW: "viscous_w_nms_per_rad",
    TRACK: "track_factor",
    CMD_TRACK: "driver_track_factor",
    KI: "speed_loop_ki_per_s",
    CAP_SIDE: "wheel_cap_per_side",
    NEW_MOVE: "command_starts_new_move",
}


def pack_params(params: DriveParams, geometry: BaseGeometry) -> FloatArray:
    """Pack parameters and geometry into the flat float vector the kernels take."""
    p = np.empty(N_PACKED)
    for index, name in _AS_IS.items():
        p[index] = getattr(params, name)
    p[MASS] = params.total_mass_kg(geometry)
    p[INERTIA] = params.total_yaw_inertia_kgm2(geometry)
    p[R] = geometry.wheel_radius_m
    p[L] = geometry.wheel_separation_m
    # the torque-speed line needs both ends: without either there is none (a flat cap)
    line = math.isfinite(params.wheel_stall_torque_nm) and math.isfinite(
        params.wheel_no_load_speed_radps
    )
    p[TS] = params.wheel_stall_torque_nm if line else math.inf
    p[W0] = params.wheel_no_load_speed_radps if line else math.inf
    return p


class PackedParams:
    """Drive parameters kept with their packed vector (:func:`pack_params`), re-packed each
    time they are set; a subclass sets ``geometry`` before ``params``."""

    geometry: BaseGeometry
    _params: DriveParams
    _packed: FloatArray

    @property
    def params(self) -> DriveParams:
        """The drive parameters in use."""
        return self._params

    @params.setter
    def params(self, params: DriveParams) -> None:
        self._params = params
        self._packed = pack_params(params, self.geometry)


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
def _sign_impulse(x: float, pos: float, neg: float) -> float:  # pragma: no cover - compiled
    """The Coulomb impulse opposing a motion ``x`` (``pos`` forward, ``neg`` backward)."""
    if x > 0.0:
        return pos
    if x < 0.0:
        return -neg
    return 0.0


@njit(cache=True)
def _coupled_prox(
    a11: float,
    a12: float,
    a21: float,
    a22: float,
    b1: float,
    b2: float,
    cv_pos: float,
    cv_neg: float,
    cw: float,
) -> tuple[float, float]:  # pragma: no cover - compiled
    """Solve ``[[a11, a12], [a21, a22]] (v, w) = (b1, b2) - Coulomb impulses`` (N s, N m s).

    Each axis's impulse (``cv_pos`` / ``cv_neg`` on v forward / backward, ``cw`` on w)
    opposes its end motion, or holds the axis at rest when it cannot move it (the proximal
    step of one axis, per axis). Uncoupled (``a12 = a21 = 0``): the one-axis steps. Coupled
    (a wheel on the torque-speed line, the other not): the sliding solution when every axis
    keeps its direction, else Gauss-Seidel over the rows (each the one-axis step given the
    other; the diagonals dominate, so it converges).
    """
    if a12 == 0.0 and a21 == 0.0:
        return (
            _coulomb_prox(b1 / a11, cv_pos / a11, cv_neg / a11),
            _coulomb_prox(b2 / a22, cw / a22, cw / a22),
        )
    det = a11 * a22 - a12 * a21
    v0 = (b1 * a22 - a12 * b2) / det
    w0 = (a11 * b2 - a21 * b1) / det
    fv = _sign_impulse(v0, cv_pos, cv_neg)
    fw = _sign_impulse(w0, cw, cw)
    v1 = ((b1 - fv) * a22 - a12 * (b2 - fw)) / det
    w1 = (a11 * (b2 - fw) - a21 * (b1 - fv)) / det
    if v1 * v0 > 0.0 and w1 * w0 > 0.0:
        return v1, w1
    for _ in range(100):
        v_prev, w_prev = v1, w1
        v1 = _coulomb_prox((b1 - a12 * w1) / a11, cv_pos / a11, cv_neg / a11)
        w1 = _coulomb_prox((b2 - a21 * v1) / a22, cw / a22, cw / a22)
        if abs(v1 - v_prev) + abs(w1 - w_prev) <= 1e-15 * (1.0 + abs(v1) + abs(w1)):
            break
    return v1, w1


@njit(cache=True, inline="always")
def _targets(ref_v: float, ref_w: float, p: FloatArray) -> tuple[float, float]:  # pragma: no cover
    """(wr_ref, wl_ref): the capped wheel targets of the reference (ref_v, ref_w), rad/s."""
    r, half_l = p[R], 0.5 * (p[L] * p[CMD_TRACK])
    wr_ref = (ref_v + ref_w * half_l) / r
    wl_ref = (ref_v - ref_w * half_l) / r
    if p[CAP_SIDE] > 0.0:
        return clip(wr_ref, p[WMAX]), clip(wl_ref, p[WMAX])
    peak = max(abs(wr_ref), abs(wl_ref))
    if peak > p[WMAX]:
        s = p[WMAX] / peak
        wr_ref *= s
        wl_ref *= s
    return wr_ref, wl_ref


@njit(cache=True, inline="always")
def shape_command(
    u_v: float, u_w: float, ref_v: float, ref_w: float, dt: float, p: FloatArray
) -> tuple[float, float, float, float]:  # pragma: no cover - compiled
    """Clamp, rate-limit and cap command (u_v, u_w); returns (ref_v, ref_w, wr_ref, wl_ref).

    The wheel targets use the driver's track (``driver_track_factor`` x the geometric one);
    a target beyond the cap ``wheel_speed_max_radps`` scales both by one factor (the turn's
    curvature kept) or, with ``wheel_cap_per_side``, is clipped on its own.
    """
    u_v = clip(u_v, p[SPEED_V])
    u_w = clip(u_w, p[SPEED_W])
    ref_v += clip(u_v - ref_v, p[ACC_V] * dt)
    ref_w += clip(u_w - ref_w, p[ACC_W] * dt)
    wr_ref, wl_ref = _targets(ref_v, ref_w, p)
    return ref_v, ref_w, wr_ref, wl_ref


@njit(cache=True, inline="always")
def starts_new_move(
    ref_v0: float, ref_w0: float, wr_ref: float, wl_ref: float, p: FloatArray
) -> bool:  # pragma: no cover - compiled
    """True when a step's wheel targets start a new move: both wheel integrators clear.

    With ``command_starts_new_move`` the firmware runs each command it receives as a new move
    (the Neato's ``SetMotor(left_mm, right_mm, speed)``: the wheels travel the given distances
    from where they stand), so its loops keep no memory of the speed error of the move before:
    a step whose wheel targets (``wr_ref``, ``wl_ref``, rad/s) differ (beyond rounding:
    :data:`ZERO_TARGET_RADPS`) from those of the previous reference (``ref_v0``, ``ref_w0``: the driver's previous command, in the state as
    the smoother's reference) starts a new one. Off (0): never.
    """
    if p[NEW_MOVE] > 0.0:
        wr0, wl0 = _targets(ref_v0, ref_w0, p)
        return abs(wr_ref - wr0) > ZERO_TARGET_RADPS or abs(wl_ref - wl0) > ZERO_TARGET_RADPS
    return False


@njit(cache=True, inline="always")
def torque_limits(
    omega: float, tmax: float, stall: float, w0: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    r"""(lowest, highest) torque a wheel motor can give at wheel speed ``omega``, N m.

    A DC motor on an H-bridge at full drive voltage :math:`\pm V` gives
    :math:`k_t(\pm V - k_e\omega)/R`: the available torque falls linearly with speed from the
    stall torque :math:`\tau_s` at rest to zero at the no-load speed :math:`\omega_0 = V/k_e`
    (Hughes & Drury, *Electric Motors and Drives*, 4th ed., ch. 3), and the traction or the
    driver's current limit caps it at :math:`\tau_{max}`: the torque lies in
    :math:`[\max(-\tau_{max}, -\tau_s(1 + \omega/\omega_0)),
    \min(\tau_{max}, \tau_s(1 - \omega/\omega_0))]`. ``w0 = inf``: :math:`\pm\tau_{max}`.
    """
    if w0 == math.inf:
        return -tmax, tmax
    drive = omega / w0
    hi = max(min(tmax, stall * (1.0 - drive)), -tmax)
    lo = min(max(-tmax, -stall * (1.0 + drive)), tmax)
    return lo, hi


@njit(cache=True, inline="always")
def _on_line(limit: float, tmax: float) -> bool:  # pragma: no cover - compiled
    """True when a torque limit lies on the sloped torque-speed line, not on the cap."""
    return -tmax < limit < tmax


@njit(cache=True, inline="always")
def _segment(
    raw: float, omega: float, end: float, omega_end: float, tmax: float, stall: float, w0: float
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """A wheel's torque over a saturated step as ``a + s * omega_end``, and its clip side.

    ``raw``: the loop's torque at the start speed ``omega``; ``end``: the unsaturated step's
    torque at its end speed ``omega_end``. Returns (a, s, side): ``side`` +1 / -1 when the
    torque is clipped at the top / bottom limit, 0 when not (then ``a = raw``, s = 0). The
    cap clips ``raw`` at the start speed; on the torque-speed line the torque follows the
    end-of-step speed (``a = +-stall``, ``s = -stall / w0``: the back-EMF implicit, stable
    at any step), whenever the step would end beyond it.
    """
    lo, hi = torque_limits(omega, tmax, stall, w0)
    lo1, hi1 = torque_limits(omega_end, tmax, stall, w0)
    if _on_line(hi1, tmax) and (raw > hi or end > hi1):
        return stall, -stall / w0, 1.0
    if _on_line(lo1, tmax) and (raw < lo or end < lo1):
        return -stall, -stall / w0, -1.0
    if raw > hi:
        return hi, 0.0, 1.0
    if raw < lo:
        return lo, 0.0, -1.0
    return raw, 0.0, 0.0


@njit(cache=True, inline="always")
def _integrate(
    integ: float, err: float, side: float, dt: float
) -> float:  # pragma: no cover - compiled
    """Advance one wheel's integrator by ``err`` over ``dt`` unless that winds it up further
    (``side``: +1 / -1 the torque is clipped at its top / bottom limit, 0 not clipped)."""
    if side * err > 0.0:
        return integ
    return integ + dt * err


@njit(cache=True, inline="always")
def wheel_loops(
    v: float,
    w: float,
    wr_ref: float,
    wl_ref: float,
    ir: float,
    il: float,
    dt: float,
    p: FloatArray,
) -> tuple[float, float, float, float, float, float]:  # pragma: no cover - compiled
    r"""Wheel loops and axis friction over one step.

    ``ir``, ``il``: the right and left integrators (integrated wheel-speed error, rad). The
    torque of a wheel is :math:`K(e_1 + k_i I_1)` with :math:`I_1 = I + (e_0 + e_1)\,dt/2`,
    :math:`e_0`, :math:`e_1` its speed errors at the start and end of the step (implicit in
    :math:`e_1`). Returns (v1, w1, ir1, il1, torque_r, torque_l).

    Skid steer (``p[TRACK]`` = :math:`\chi > 1`): the wheel speeds follow the body through
    the effective track :math:`\chi L` (the treads slip), while the wheel forces act at the
    geometric half-track, so the yaw loop gain is :math:`K L \chi L / (2 r^2)`.
    """
    r, half_l, half_e = p[R], 0.5 * p[L], 0.5 * (p[L] * p[TRACK])
    m, inertia, k, ki = p[MASS], p[INERTIA], p[K], p[KI]
    # a stop (a zero target, to rounding: the held command average leaves ~1e-15 rad/s where
    # a command ends inside a step) clears the integrator
    if abs(wr_ref) < ZERO_TARGET_RADPS:
        ir = 0.0
    if abs(wl_ref) < ZERO_TARGET_RADPS:
        il = 0.0
    a = 1.0 + 0.5 * ki * dt
    er0 = wr_ref - (v + w * half_e) / r
    el0 = wl_ref - (v - w * half_e) / r
    ir_half = ir + 0.5 * dt * er0
    il_half = il + 0.5 * dt * el0
    ref_v = 0.5 * r * (wr_ref + wl_ref)
    ref_w = r * (wr_ref - wl_ref) / (p[L] * p[TRACK])
    int_v = 0.5 * r * (ir_half + il_half)
    int_w = r * (ir_half - il_half) / (p[L] * p[TRACK])
    kv = 2.0 * k / (r * r)
    kw = k * p[L] * (p[L] * p[TRACK]) / (2.0 * r * r)
    den_v = m + dt * (kv * a + p[BV])
    den_w = inertia + dt * (kw * a + p[BW])
    v_nc = (m * v + dt * kv * (a * ref_v + ki * int_v)) / den_v
    w_nc = (inertia * w + dt * kw * (a * ref_w + ki * int_w)) / den_w
    v1 = _coulomb_prox(v_nc, dt * p[CFWD] / den_v, dt * p[CBWD] / den_v)
    w1 = _coulomb_prox(w_nc, dt * p[CW] / den_w, dt * p[CW] / den_w)
    er = wr_ref - (v1 + w1 * half_e) / r
    el = wl_ref - (v1 - w1 * half_e) / r
    tr = k * (a * er + ki * ir_half)
    tl = k * (a * el + ki * il_half)
    tmax, stall, w0 = p[TMAX], p[TS], p[W0]
    lo_r, hi_r = torque_limits((v1 + w1 * half_e) / r, tmax, stall, w0)
    lo_l, hi_l = torque_limits((v1 - w1 * half_e) / r, tmax, stall, w0)
    if tr > hi_r or tr < lo_r or tl > hi_l or tl < lo_l:
        tr_raw = k * (a * er0 + ki * ir_half)
        tl_raw = k * (a * el0 + ki * il_half)
        omega_r, omega_l = (v + w * half_e) / r, (v - w * half_e) / r
        omega_r1, omega_l1 = (v1 + w1 * half_e) / r, (v1 - w1 * half_e) / r
        ar, sr, side_r = _segment(tr_raw, omega_r, tr, omega_r1, tmax, stall, w0)
        al, sl, side_l = _segment(tl_raw, omega_l, tl, omega_l1, tmax, stall, w0)
        # tau_i = a_i + s_i omega_i(end), omega_r,l = (v1 +- half_e w1) / r: one linear
        # 2x2 step (s_i <= 0 only adds damping, so it is always solvable)
        ss, sd = (sr + sl) / (r * r), (sr - sl) / (r * r)
        a11 = m + dt * (p[BV] - ss)
        a12 = -dt * sd * half_e
        a21 = -dt * half_l * sd
        a22 = inertia + dt * (p[BW] - half_l * half_e * ss)
        b1 = m * v + dt * ((ar + al) / r)
        b2 = inertia * w + dt * ((ar - al) * half_l / r)
        # Coulomb friction as a proximal step per axis (it stops an axis, never reverses it)
        v1, w1 = _coupled_prox(a11, a12, a21, a22, b1, b2, dt * p[CFWD], dt * p[CBWD], dt * p[CW])
        tr = ar + sr * (v1 + w1 * half_e) / r
        tl = al + sl * (v1 - w1 * half_e) / r
        er = wr_ref - (v1 + w1 * half_e) / r
        el = wl_ref - (v1 - w1 * half_e) / r
        ir = _integrate(ir, er0 + er, side_r, 0.5 * dt)
        il = _integrate(il, el0 + el, side_l, 0.5 * dt)
    else:
        ir = ir_half + 0.5 * dt * er
        il = il_half + 0.5 * dt * el
    return v1, w1, ir, il, tr, tl


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
    v: float,
    w: float,
    ref_v: float,
    ref_w: float,
    ir: float,
    il: float,
    u_v: float,
    u_w: float,
    dt: float,
    p: FloatArray,
) -> tuple[float, float, float, float, float, float, float, float]:  # pragma: no cover - compiled
    """One step of the chain; returns (v1, w1, ref_v, ref_w, ir, il, torque_r, torque_l)."""
    ref_v0, ref_w0 = ref_v, ref_w
    ref_v, ref_w, wr_ref, wl_ref = shape_command(u_v, u_w, ref_v, ref_w, dt, p)
    if starts_new_move(ref_v0, ref_w0, wr_ref, wl_ref, p):
        ir, il = 0.0, 0.0
    v1, w1, ir, il, tr, tl = wheel_loops(v, w, wr_ref, wl_ref, ir, il, dt, p)
    return v1, w1, ref_v, ref_w, ir, il, tr, tl


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

    ``state`` is ``[ref_v, ref_w, yaw, ir, il]``, advanced in place: the smoother's reference,
    the base's yaw one step earlier and the wheel loops' integrators (rad); the yaw advances by :math:`dt\,w_z` (what pybullet's
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
    ir, il = state[3], state[4]
    if starts_new_move(state[0], state[1], wr_ref, wl_ref, p):
        ir, il = 0.0, 0.0
    v1, w1, ir, il, tr_model, tl_model = wheel_loops(v, w, wr_ref, wl_ref, ir, il, dt, p)
    state[0] = ref_v
    state[1] = ref_w
    state[3] = ir
    state[4] = il
    r, sep, k, tmax = p[R], p[L], p[K], p[TMAX]
    half_l = 0.5 * sep
    slip_l = wl_meas - (v - w * half_l) / r
    slip_r = wr_meas - (v + w * half_l) / r
    k_slip = k / (1.0 + dt * k / spin_inertia)
    lo_l, hi_l = torque_limits(wl_meas, tmax, p[TS], p[W0])
    lo_r, hi_r = torque_limits(wr_meas, tmax, p[TS], p[W0])
    # the slip correction stays inside the motor's limits at the encoders' speed (the model's
    # own torque is already inside them at the end-of-step speed)
    tl = min(max(tl_model - k_slip * slip_l, min(lo_l, tl_model)), max(hi_l, tl_model))
    tr = min(max(tr_model - k_slip * slip_r, min(lo_r, tr_model)), max(hi_r, tr_model))
    force, torque = axis_friction(
        v, w, v1, w1, tr_model, tl_model, dt, p[MASS], p[INERTIA], r, half_l
    )
    common = 0.5 * r * force
    differential = r * torque / sep
    return tl + common - differential, tr + common + differential
