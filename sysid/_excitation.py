"""What a set of logs can identify: refuse empty ones, choose free parameters, say why."""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robots.arrays import FloatArray
from robots.params import BaseGeometry, DriveParams
from sysid._coords import COORDS, NOT_FITTABLE
from sysid._logs import LogArrays, as_log_arrays
from sysid.errors import ExcitationError, SysidValueError
from sysid.metrics import DEFAULT_TOL_V, DEFAULT_TOL_W, active_mask

__all__ = ["Excitation", "active_samples", "analyse", "held_command", "why_not_fittable"]


#: Minimum total measured span and number of measurement samples for a fit.
MIN_SPAN_S = 3.0
MIN_SAMPLES = 30
#: Command ranges below these are "flat" on that axis (m/s, rad/s).
MIN_RANGE_V, MIN_RANGE_W = 0.02, 0.1
#: A command jump at least this large can reveal an acceleration limit (m/s, rad/s).
STEP_V, STEP_W = 0.1, 0.5
#: Motion thresholds on the measurement (m/s, rad/s).
MOVE_V, MOVE_W = 0.01, 0.05
#: A clamp on the yaw rate shows where the commands ask for more than this factor times the
#: fastest measured yaw rate while the forward speed keeps at least :data:`_CLAMP_TRACK` of
#: its command (median over at least :data:`_CLAMP_SAMPLES` such samples, each one at least
#: :data:`_CLAMP_HOLD_S` after the command last changed with the yaw rate within
#: :data:`_CLAMP_TRACK` of its peak: settled at the clamp, no transient counts).
_CLAMP_OVER, _CLAMP_TRACK, _CLAMP_SAMPLES, _CLAMP_HOLD_S = 1.25, 0.8, 10, 1.0


@dataclass(frozen=True, kw_only=True)
class Excitation:
    """Outcome of the excitation analysis.

    Attributes
    ----------
    free : tuple of str
        DriveParams fields to fit.
    ties : dict
        ``{field: source field}`` for parameters set equal to another (e.g. backward friction).
    warnings : tuple of str
        Plain sentences naming what the logs did not excite and what was done instead.
    coupled : bool
        True when a wheel-speed or torque cap can couple the two axes (dense Jacobian).
    """

    free: tuple[str, ...]
    ties: dict[str, str]
    warnings: tuple[str, ...]
    coupled: bool


def held_command(cmd_t_s: FloatArray, cmd: FloatArray, t_s: FloatArray) -> FloatArray:
    """The zero-order-held command at times ``t_s`` (0 before the first command)."""
    idx = np.searchsorted(cmd_t_s, t_s, side="right") - 1
    out = np.where(idx >= 0, cmd[np.clip(idx, 0, None)], 0.0)
    return np.asarray(out, dtype=np.float64)


def active_samples(
    log: LogArrays, *, tol_v: float = DEFAULT_TOL_V, tol_w: float = DEFAULT_TOL_W
) -> NDArray[np.bool_]:
    """The measurement samples of ``log`` where the robot is commanded to move (the command
    held at each sample) or moves: :func:`sysid.metrics.active_mask`."""
    cv = held_command(log.cmd_t_s, log.cmd_v, log.meas_t_s)
    cw = held_command(log.cmd_t_s, log.cmd_w, log.meas_t_s)
    return active_mask(cv, cw, log.meas_v, log.meas_w, tol_v=tol_v, tol_w=tol_w)


def _cmd_with_rest(log: LogArrays, cmd: FloatArray) -> FloatArray:
    """Commands, preceded by the implicit 0 when odometry starts before the first command."""
    if log.meas_t_s[0] < log.cmd_t_s[0] - 0.5:
        return np.concatenate(([0.0], cmd))
    return cmd


def _spread(values: FloatArray, floor: float) -> float:
    """Relative spread (p90 - p10) / p90 of |values| where |values| > floor (0 if none)."""
    a = np.abs(values[np.abs(values) > floor])
    if a.size < 10:
        return 0.0
    hi, lo = np.percentile(a, [90, 10])
    return float((hi - lo) / hi) if hi > 0 else 0.0


def _refuse_empty(logs: Sequence[LogArrays]) -> None:
    span = sum(float(g.meas_t_s[-1] - g.meas_t_s[0]) for g in logs)
    n = sum(int(g.meas_t_s.size) for g in logs)
    names = ", ".join(g.name for g in logs)
    if span < MIN_SPAN_S or n < MIN_SAMPLES:
        raise ExcitationError(
            f"{names} is too short to fit: {span:.2f} s with {n} odometry samples; sysid needs "
            f"at least {MIN_SPAN_S:g} s and {MIN_SAMPLES} samples, so record a longer log"
        )
    flat = all(
        np.ptp(_cmd_with_rest(g, g.cmd_v)) == 0 and np.ptp(_cmd_with_rest(g, g.cmd_w)) == 0
        for g in logs
    )
    if flat:
        g = logs[0]
        raise ExcitationError(
            f"the commands in {names} never change (cmd_v = {g.cmd_v[0]:g} m/s, cmd_w = "
            f"{g.cmd_w[0]:g} rad/s throughout), so there is nothing to identify; record a log "
            "with steps or varying commands"
        )
    moving = any(
        np.percentile(np.abs(g.meas_v), 95) > MOVE_V or np.percentile(np.abs(g.meas_w), 95) > MOVE_W
        for g in logs
    )
    if not moving:
        raise ExcitationError(
            f"the robot never moves in {names} (95th percentile of |v| <= {MOVE_V} m/s and of "
            f"|w| <= {MOVE_W} rad/s); check the odometry topic or record a log with motion"
        )


def why_not_fittable(log: object, index: int = 0) -> str:
    """Why ``log`` alone has nothing to identify (too short, flat commands, no motion), or "".

    The same rules as the fit's own check, so a caller can set such a part aside (e.g. a
    segment of a recording where the robot stood still) instead of failing the whole fit.

    Parameters
    ----------
    log : VelocityLog
        A velocity log (e.g. a ``sim2real.logs.Trace`` or :class:`LogArrays`).
    index : int
        Its position among the caller's logs, which names it in the reason when it has no
        ``meta.path``.

    Returns
    -------
    str
        One sentence naming the log and the rule it misses, or "" when it can be fitted.

    Examples
    --------
    >>> import numpy as np
    >>> from sysid import LogArrays, why_not_fittable
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> still = LogArrays(cmd_t_s=t, cmd_v=0 * t, cmd_w=0 * t, meas_t_s=t, meas_v=0 * t,
    ...                   meas_w=0 * t, name="still")
    >>> why_not_fittable(still).startswith("still")
    True
    """
    try:
        _refuse_empty([as_log_arrays(log, index)])
    except ExcitationError as exc:
        return str(exc)
    return ""


def _axis_excited(logs: Sequence[LogArrays], axis: str) -> bool:
    cmd_rng, mv, thr_c, thr_m = (
        ("cmd_v", "meas_v", MIN_RANGE_V, MOVE_V)
        if axis == "v"
        else ("cmd_w", "meas_w", MIN_RANGE_W, MOVE_W)
    )
    return any(
        np.ptp(_cmd_with_rest(g, getattr(g, cmd_rng))) >= thr_c
        and np.percentile(np.abs(getattr(g, mv)), 95) > thr_m
        for g in logs
    )


def _peak_wheel_cmd(logs: Sequence[LogArrays], geometry: BaseGeometry) -> float:
    half = 0.5 * geometry.wheel_separation_m
    return max(
        float(np.max(np.abs(g.cmd_v) + np.abs(g.cmd_w) * half)) / geometry.wheel_radius_m
        for g in logs
    )


def _peak_wheel_meas(logs: Sequence[LogArrays], geometry: BaseGeometry) -> float:
    half = 0.5 * geometry.wheel_separation_m
    return max(
        float(np.percentile(np.abs(g.meas_v) + np.abs(g.meas_w) * half, 98))
        / geometry.wheel_radius_m
        for g in logs
    )


_TIE_NOTE = (
    "backward Coulomb friction is not identifiable; tied to forward (coulomb_v_bwd_n = "
    "coulomb_v_fwd_n)"
)
_UNTIED_NOTE = (
    "backward Coulomb friction is barely informed by the log (its posterior stays near its prior)"
)


def _auto_free(
    logs: Sequence[LogArrays], geometry: BaseGeometry, base: DriveParams
) -> tuple[list[str], dict[str, str], list[str]]:
    free: list[str] = ["delay_s"]
    ties: dict[str, str] = {}
    notes: list[str] = []
    cat = {k: np.concatenate([getattr(g, k) for g in logs]) for k in ("cmd_v", "cmd_w")}
    for axis in ("v", "w"):
        if not _axis_excited(logs, axis):
            what = "forward" if axis == "v" else "yaw"
            fields = [f for f, c in COORDS.items() if c.axis == axis]
            notes.append(
                f"the {what} axis is not excited (its command never changes or the robot never "
                f"moves along it): {', '.join(fields)} barely informed by the log (their posteriors stay near their priors)"
            )
            continue
        if axis == "v":
            _free_forward(cat["cmd_v"], free, ties, notes)
        else:
            free += ["added_yaw_inertia_kgm2", "coulomb_w_nm"]
        _free_viscous(cat[f"cmd_{axis}"], axis, free, notes)
        _free_accel(logs, axis, free, notes)
    if "added_mass_kg" in free or "added_yaw_inertia_kgm2" in free:
        # velocity data fix mass/gain ratios: the gain is fitted too, the priors split them
        free.append("motor_gain_nms_per_rad")
    _free_speed_cap(logs, geometry, base, free, ties, notes)
    if "added_yaw_inertia_kgm2" in free:
        _free_yaw_clamp(logs, base, free, notes)
    return free, ties, notes


def _held_for(log: LogArrays) -> FloatArray:
    """Seconds since the command last changed, at each measurement time."""
    changed = np.flatnonzero((np.diff(log.cmd_v) != 0) | (np.diff(log.cmd_w) != 0)) + 1
    starts = np.concatenate(([log.cmd_t_s[0]], log.cmd_t_s[changed]))
    idx = np.searchsorted(starts, log.meas_t_s, side="right") - 1
    since: FloatArray = log.meas_t_s - starts[np.clip(idx, 0, None)]
    return np.where(idx >= 0, since, 0.0)


def _free_yaw_clamp(
    logs: Sequence[LogArrays], base: DriveParams, free: list[str], notes: list[str]
) -> None:
    """A clamp on the commanded yaw rate (``speed_lim_w_radps``, no spec value), when the logs
    show one: where the commands ask for a faster turn than the robot ever made, the forward
    speed still follows its command. A wheel-speed cap scales both wheels together and slows v
    and w alike; a driver's clamp on w alone leaves v."""
    if math.isfinite(base.speed_lim_w_radps):
        return
    peak = max(float(np.percentile(np.abs(g.meas_w), 98)) for g in logs)
    ratios, asked = [], 0.0
    for g in logs:
        cv = held_command(g.cmd_t_s, g.cmd_v, g.meas_t_s)
        cw = held_command(g.cmd_t_s, g.cmd_w, g.meas_t_s)
        over = (np.abs(cw) > _CLAMP_OVER * max(peak, MOVE_W)) & (np.abs(cv) > MOVE_V)
        # settled at the clamp: the command held for a while, the robot turning at its peak
        over &= (_held_for(g) >= _CLAMP_HOLD_S) & (np.abs(g.meas_w) >= _CLAMP_TRACK * peak)
        ratios.append(g.meas_v[over] / cv[over])
        asked = max(asked, float(np.max(np.abs(cw), initial=0.0)))
    share = np.concatenate(ratios)
    if share.size < _CLAMP_SAMPLES or float(np.median(share)) < _CLAMP_TRACK:
        return
    free.append("speed_lim_w_radps")
    notes.append(
        f"the yaw rate stops near {peak:.3g} rad/s while the commands ask up to {asked:.3g} "
        f"rad/s and the forward speed keeps {float(np.median(share)):.0%} of its command "
        "there: a clamp on the commanded yaw rate (speed_lim_w_radps) is fitted"
    )


def _free_forward(
    cmd_v: FloatArray, free: list[str], ties: dict[str, str], notes: list[str]
) -> None:
    """The forward axis's mass and Coulomb friction; the backward one only with reversals."""
    free += ["added_mass_kg", "coulomb_v_fwd_n"]
    neg = np.sum(cmd_v < -MIN_RANGE_V)
    pos = np.sum(cmd_v > MIN_RANGE_V)
    if neg >= 3 and pos >= 3:
        free.append("coulomb_v_bwd_n")
    else:
        ties["coulomb_v_bwd_n"] = "coulomb_v_fwd_n"
        notes.append(f"no reversal in the log (cmd_v never changes sign): {_TIE_NOTE}")


def _free_viscous(cmd: FloatArray, axis: str, free: list[str], notes: list[str]) -> None:
    """The axis's viscous friction, when the log holds more than one command level."""
    floor = MIN_RANGE_V if axis == "v" else MIN_RANGE_W
    visc = "viscous_v_ns_per_m" if axis == "v" else "viscous_w_nms_per_rad"
    if _spread(cmd, floor) >= 0.3:
        free.append(visc)
        return
    lvl = float(np.median(np.abs(cmd[np.abs(cmd) > floor]))) if np.any(np.abs(cmd) > floor) else 0.0
    notes.append(
        f"the log holds essentially one {'forward speed' if axis == 'v' else 'yaw rate'}"
        f" level ({lvl:.2f} {'m/s' if axis == 'v' else 'rad/s'}): viscous and Coulomb "
        f"friction trade off; {visc} barely informed by the log (its posterior stays near its prior)"
    )


def _free_accel(logs: Sequence[LogArrays], axis: str, free: list[str], notes: list[str]) -> None:
    """The axis's acceleration limit, when a command steps by at least ``STEP_V``/``STEP_W``."""
    acc = "accel_lim_v_mps2" if axis == "v" else "accel_lim_w_radps2"
    step = STEP_V if axis == "v" else STEP_W
    jumps = max(
        float(np.max(np.abs(np.diff(_cmd_with_rest(g, getattr(g, f"cmd_{axis}")))), initial=0))
        for g in logs
    )
    if jumps >= step:
        free.append(acc)
    else:
        notes.append(
            f"no command step of {step:g} {'m/s' if axis == 'v' else 'rad/s'} or more on "
            f"the {axis} axis (largest {jumps:.3g}): {acc} barely informed by the log (its posterior stays near its prior)"
        )


def _free_speed_cap(
    logs: Sequence[LogArrays],
    geometry: BaseGeometry,
    base: DriveParams,
    free: list[str],
    ties: dict[str, str],
    notes: list[str],
) -> None:
    """The wheel-speed cap, when a wheel is driven near it (or falls short of its command)."""
    cap = base.wheel_speed_max_radps
    peak_cmd = _peak_wheel_cmd(logs, geometry)
    peak_meas = _peak_wheel_meas(logs, geometry)
    if not (
        (math.isfinite(cap) and peak_cmd >= 0.9 * cap)
        or (not math.isfinite(cap) and peak_meas < 0.75 * peak_cmd)
    ):
        notes.append(
            f"no wheel near its speed cap (peak commanded wheel speed {peak_cmd:.1f} rad/s): "
            "wheel_speed_max_radps barely informed by the log (its posterior stays near its prior)"
        )
        return
    free.append("wheel_speed_max_radps")
    if "added_mass_kg" in free and "viscous_v_ns_per_m" not in free:
        # one forward level and a cap: the speed deficit is either friction or saturation
        for name in ("coulomb_v_fwd_n", "coulomb_v_bwd_n"):
            if name in free:
                free.remove(name)
        ties.pop("coulomb_v_bwd_n", None)
        notes.append(
            "the forward command holds one level and drives the wheels into their speed "
            "cap: Coulomb friction and the cap both explain the speed deficit; the cap is "
            "fitted and coulomb_v_fwd_n / coulomb_v_bwd_n are barely informed by the log (their posteriors stay near their priors)"
        )


def _with_priors(
    logs: Sequence[LogArrays],
    names: list[str],
    ties: dict[str, str],
    informative: Collection[str],
) -> tuple[list[str], dict[str, str]]:
    """Add every field with an informative prior that an excited axis (or both) can feel.

    MAP: a field the log barely informs is still fitted against its prior, so its posterior
    is its prior and the others' intervals account for it (a fixed nuisance value would make
    them too narrow). A tie is dropped when its field has a prior of its own."""
    axes = {a for a in ("v", "w") if _axis_excited(logs, a)}
    if axes:
        axes.add("vw")
    out = list(names)
    for name, c in COORDS.items():
        if name in informative and c.axis in axes and name not in out:
            out.append(name)
    kept_ties = {k: v for k, v in ties.items() if k not in informative}
    return out, kept_ties


#: Why ``"auto"`` leaves a skid steer's track factor at its prior when the yaw rate comes from
#: the wheel encoders.
ENCODER_YAW_NOTE = (
    "track_factor is kept at its prior {value:.3g}: the log's yaw rate comes from the wheel "
    "encoders (odometry.w_source: wheels), which read the wheels' speeds whatever the treads' "
    "slip, so the track factor only rescales the yaw inertia and viscous yaw friction the fit "
    "has (chi, I, b act as 1, I/chi, b/chi); a gyro's yaw rate would measure it"
)


def analyse(
    logs: Sequence[LogArrays],
    geometry: BaseGeometry,
    base: DriveParams,
    free: str | Sequence[str] | None,
    informative: Collection[str] = (),
    *,
    encoder_yaw: bool = False,
) -> Excitation:
    """Refuse logs with nothing to identify, then choose the free parameters.

    ``free`` is ``None``/``"auto"`` (choose from the excitation, plus every field of an excited
    axis with a prior in ``informative``; with ``encoder_yaw``, a yaw rate read by the wheel
    encoders, not the track factor: :data:`ENCODER_YAW_NOTE`) or a list of DriveParams
    fields. Raises
    :class:`~sysid.errors.ExcitationError` (too short, no motion, flat commands) or
    :class:`~sysid.errors.SysidValueError` (unknown or unidentifiable names).
    """
    _refuse_empty(logs)
    notes: list[str] = []
    if free is None or free == "auto":
        names, ties, notes = _auto_free(logs, geometry, base)
        names, ties = _with_priors(logs, names, ties, informative)
        if encoder_yaw and "track_factor" in names:
            names.remove("track_factor")
            notes.append(ENCODER_YAW_NOTE.format(value=base.track_factor))
        if "coulomb_v_bwd_n" not in ties:
            notes = [n.replace(_TIE_NOTE, _UNTIED_NOTE) for n in notes]
    elif isinstance(free, str):
        raise SysidValueError(
            f"free must be None, 'auto' or a list of parameter names, got {free!r}; "
            "e.g. free=['delay_s', 'added_mass_kg']"
        )
    else:
        names, ties = list(dict.fromkeys(free)), {}
        for name in names:
            if name in NOT_FITTABLE:
                raise SysidValueError(f"parameter '{name}' cannot be fitted: {NOT_FITTABLE[name]}")
            if name not in COORDS:
                raise SysidValueError(
                    f"unknown free parameter '{name}'; choose from {sorted(COORDS)}"
                )
        if not names:
            raise SysidValueError("free is an empty list; name at least one parameter to fit")
    cap = base.wheel_speed_max_radps
    coupled = (
        "wheel_speed_max_radps" in names
        or "wheel_torque_max_nm" in names
        or math.isfinite(base.wheel_torque_max_nm)
        or (math.isfinite(cap) and _peak_wheel_cmd(logs, geometry) >= cap)
    )
    return Excitation(free=tuple(names), ties=ties, warnings=tuple(notes), coupled=coupled)
