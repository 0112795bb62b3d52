r"""Initial estimates for the output-error fit, from the field's standard tools.

A good start point makes the nonlinear fit converge in a few iterations (the 2 s budget for a
10-minute log) and keeps it out of local minima of the delay:

1. **Spike removal** (median filter + MAD): real odometry holds impossible samples (the
   Drexel log has one 1.35 m/s spike); they are masked from the estimates below.
2. **Delay by cross-correlation**: the zero-delay model response is correlated with the
   measurement (:func:`sysid.metrics.xcorr_lag_s`, parabolic sub-sample peak). Correlating with
   the *model* rather than with the raw command removes the lag the first-order response itself
   adds, which would otherwise be read as dead time.
3. **RTS smoothing** (a compiled Kalman filter + Rauch-Tung-Striebel smoother of a
   constant-acceleration model with irregular sample times): differentiating noisy, quantised odometry directly amplifies
   the noise; the fixed-interval smoother gives clean velocity *and* acceleration estimates using
   the samples on both sides of each instant.
4. **Linear regression** of the smoothed acceleration on the delayed command, the velocity and
   its sign: :math:`\dot v = \alpha u(t-d) - \beta v - \gamma\,\mathrm{sgn}\,v` gives the
   mass-over-gain time constant :math:`1/\alpha`, the viscous ratio :math:`\beta/\alpha - 1` and
   the Coulomb speed loss :math:`\gamma/\alpha`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numba
import numpy as np
from scipy.ndimage import median_filter

from robots.arrays import BoolArray, FloatArray
from robots.params import BaseGeometry, DriveParams, Prior
from sysid._coords import COORDS, Mapper
from sysid._excitation import held_command
from sysid._logs import LogArrays, crop_log
from sysid._problem import Problem
from sysid.metrics import xcorr_lag_s
from sysid.steady import difference_sd, robust_sd

__all__ = ["busiest_window", "initial_coords", "spike_mask"]


#: At most this many samples go through the (pure-Python) RTS smoother per axis.
_MAX_SMOOTH = 1500


def spike_mask(x: FloatArray, floor: float) -> BoolArray:
    """True where ``x`` is an isolated spike: > 8 robust sigmas and > ``floor`` off its median.

    Examples
    --------
    >>> import numpy as np
    >>> spike_mask(np.array([0.2, 0.2, 1.35, 0.2, 0.2]), 0.05).tolist()
    [False, False, True, False, False]
    """
    if x.size < 5:
        return np.zeros(x.shape, dtype=bool)
    dev = x - median_filter(x, size=5, mode="nearest")
    sigma = robust_sd(dev, about=0.0) + 1e-12
    mask: BoolArray = np.abs(dev) > max(8.0 * sigma, floor)
    return mask


@numba.njit(cache=True)
def _rts_kernel(
    dts: FloatArray,
    z: FloatArray,
    good: BoolArray,
    x0: FloatArray,
    p0: FloatArray,
    q: float,
    r: float,
) -> FloatArray:  # pragma: no cover - compiled
    """Kalman filter + Rauch-Tung-Striebel smoother of a constant-acceleration model (state
    value, rate; white-jerk process noise ``q``; scalar measurement variance ``r``; samples
    with ``good`` False are predicted only). Returns the smoothed states, shape (n, 2)."""
    n = z.size
    xf = np.empty((n, 2))
    pf = np.empty((n, 2, 2))
    x = x0.copy()
    p = p0.copy()
    for i in range(n):
        d = dts[i]
        # predict: x = F x, P = F P F^T + Q with F = [[1, d], [0, 1]]
        x = np.array([x[0] + d * x[1], x[1]])
        a = p[0, 0] + d * (p[1, 0] + p[0, 1]) + d * d * p[1, 1] + q * d**3 / 3.0
        b = p[0, 1] + d * p[1, 1] + q * d * d / 2.0
        c = p[1, 1] + q * d
        p = np.array([[a, b], [b, c]])
        if good[i]:
            s = p[0, 0] + r
            k0, k1 = p[0, 0] / s, p[1, 0] / s
            y = z[i] - x[0]
            x = np.array([x[0] + k0 * y, x[1] + k1 * y])
            p = np.array(
                [
                    [(1.0 - k0) * p[0, 0], (1.0 - k0) * p[0, 1]],
                    [p[1, 0] - k1 * p[0, 0], p[1, 1] - k1 * p[0, 1]],
                ]
            )
        xf[i] = x
        pf[i] = p
    xs = xf.copy()
    ps = pf.copy()
    for i in range(n - 2, -1, -1):
        d = dts[i + 1]
        f = np.array([[1.0, d], [0.0, 1.0]])
        qm = q * np.array([[d**3 / 3.0, d * d / 2.0], [d * d / 2.0, d]])
        pp = f @ pf[i] @ f.T + qm
        gain = pf[i] @ f.T @ np.linalg.inv(pp)
        xs[i] = xf[i] + gain @ (xs[i + 1] - f @ xf[i])
        ps[i] = pf[i] + gain @ (ps[i + 1] - pp) @ gain.T
    return xs


def _rts(t: FloatArray, z: FloatArray, good: BoolArray) -> tuple[FloatArray, FloatArray]:
    """Smoothed value and derivative of ``z``: Kalman filter and RTS smoother of a
    constant-acceleration model (Rauch, Tung & Striebel 1965) with irregular sample times."""
    sigma = max(difference_sd(z[good]), 1e-4)
    span = float(np.ptp(z[good])) or 1.0
    q = span**2 / 0.1**3  # jerk intensity of a step of size `span` through a 0.1 s lag
    dts = np.maximum(np.diff(t, prepend=t[0]), 1e-4)
    x0 = np.array([float(z[good][0]), 0.0])
    p0 = np.diag([sigma**2, (span / 0.1) ** 2])
    zz = np.where(good, z, 0.0).astype(np.float64)
    xs = _rts_kernel(dts, zz, good.astype(np.bool_), x0, p0, float(q), float(sigma**2))
    return np.asarray(xs[:, 0]), np.asarray(xs[:, 1])


def busiest_window(log: LogArrays, n: int) -> tuple[float, float]:
    """Time window of ``n`` measurement samples over which the command varies most."""
    size = log.meas_t_s.size
    if size <= n:
        return float(log.meas_t_s[0]), float(log.meas_t_s[-1]) + 1e-9
    best, best_var = 0, -1.0
    for start in range(0, size - n + 1, max(1, n // 4)):
        t0, t1 = log.meas_t_s[start], log.meas_t_s[start + n - 1]
        c = (log.cmd_t_s >= t0) & (log.cmd_t_s <= t1)
        var = float(
            np.sum(np.abs(np.diff(log.cmd_v[c]))) + 0.1 * np.sum(np.abs(np.diff(log.cmd_w[c])))
        )
        if var > best_var:
            best, best_var = start, var
    return float(log.meas_t_s[best]), float(log.meas_t_s[best + n - 1]) + 1e-9


@numba.njit(cache=True)
def _rate_limit_kernel(t: FloatArray, u: FloatArray, acc: float) -> FloatArray:  # pragma: no cover
    out = np.empty_like(u)
    r = 0.0
    prev = t[0]
    for i in range(u.size):
        step = acc * max(t[i] - prev, 0.0)
        r += min(max(u[i] - r, -step), step)
        out[i] = r
        prev = t[i]
    return out


def _rate_limited(t: FloatArray, u: FloatArray, acc: float) -> FloatArray:
    """Reference after the velocity smoother (rate limit ``acc``) on the sample grid (numba:
    the delay scan calls it ~100 times per log window)."""
    if not math.isfinite(acc):
        return u
    out: FloatArray = _rate_limit_kernel(t, u, float(acc))
    return out


@dataclass(frozen=True, kw_only=True)
class _Smoothed:
    """RTS-smoothed samples of one axis of one log window."""

    log: LogArrays
    t: FloatArray
    x: FloatArray
    a: FloatArray
    good: BoolArray


def _smooth(windows: Sequence[LogArrays], masks: Sequence[BoolArray], axis: str) -> list[_Smoothed]:
    out = []
    for log, good in zip(windows, masks, strict=True):
        z = log.meas_v if axis == "v" else log.meas_w
        if good.sum() < 10:
            continue
        x, a = _rts(log.meas_t_s, z, good)
        out.append(_Smoothed(log=log, t=log.meas_t_s, x=x, a=a, good=good))
    return out


def _references(
    log: LogArrays,
    t: FloatArray,
    delay_s: float,
    acc: dict[str, float],
    params: DriveParams,
    geometry: BaseGeometry,
) -> dict[str, FloatArray]:
    """Wheel-loop references on the sample grid: delayed command -> clamp -> rate limit ->
    per-wheel speed cap (both wheels scaled together, or each clipped on its own), as in the
    drive chain."""
    ref = {}
    for axis, lim in (("v", params.speed_lim_v_mps), ("w", params.speed_lim_w_radps)):
        cmd = log.cmd_v if axis == "v" else log.cmd_w
        u = np.clip(held_command(log.cmd_t_s, cmd, t - delay_s), -lim, lim)
        ref[axis] = _rate_limited(t, u, acc.get(axis, math.inf))
    cap = params.wheel_speed_max_radps
    if not math.isfinite(cap):
        return ref
    half, r = 0.5 * geometry.wheel_separation_m, geometry.wheel_radius_m
    if params.wheel_cap_per_side:
        right = np.clip((ref["v"] + ref["w"] * half) / r, -cap, cap)
        left = np.clip((ref["v"] - ref["w"] * half) / r, -cap, cap)
        return {"v": 0.5 * r * (right + left), "w": 0.5 * r * (right - left) / half}
    peak = (np.abs(ref["v"]) + np.abs(ref["w"]) * half) / r
    scale = np.where(peak > cap, cap / np.maximum(peak, 1e-12), 1.0)
    return {k: v * scale for k, v in ref.items()}


def _regress(
    data: Sequence[_Smoothed], refs: Sequence[FloatArray], axis: str
) -> tuple[float, float, float, float] | None:
    """(tau_m, viscous ratio, Coulomb fwd, Coulomb bwd) of one axis, or None.

    Least squares of the smoothed acceleration on the wheel-loop reference, the smoothed
    velocity and its sign.
    """
    floor = 0.01 if axis == "v" else 0.05
    rows: list[FloatArray] = []
    acc_rows: list[FloatArray] = []
    for d, u in zip(data, refs, strict=True):
        use = d.good & ((np.abs(d.x) > floor) | (np.abs(u) > floor))
        pos = np.where(d.x > floor, 1.0, 0.0)
        neg = np.where(d.x < -floor, 1.0, 0.0)
        rows.append(np.column_stack([u, -d.x, -pos, neg])[use])
        acc_rows.append(d.a[use])
    if not rows:
        return None
    design = np.concatenate(rows)
    target = np.concatenate(acc_rows)
    if design.shape[0] < 10:
        return None
    two_sided = bool(np.any(design[:, 3]))
    if not two_sided:  # no backward motion: one Coulomb level
        design = design[:, :3]
    coef, *_ = np.linalg.lstsq(design, target, rcond=None)
    alpha = float(coef[0])
    if not (alpha > 0 and math.isfinite(alpha)):
        return None
    top = 0.3 if axis == "v" else 2.0
    ratio = float(np.clip(coef[1] / alpha - 1.0, 0.0, 3.0))
    c_fwd = float(np.clip(coef[2] / alpha, 0.0, top))
    c_bwd = float(np.clip(coef[3] / alpha, 0.0, top)) if two_sided else c_fwd
    return 1.0 / alpha, ratio, c_fwd, c_bwd


_AXIS_FIELDS = {
    "v": ("added_mass_kg", "viscous_v_ns_per_m", "coulomb_v_fwd_n", "accel_lim_v_mps2"),
    "w": ("added_yaw_inertia_kgm2", "viscous_w_nms_per_rad", "coulomb_w_nm", "accel_lim_w_radps2"),
}


def _params_at(
    delay: float,
    *,
    data: dict[str, list[_Smoothed]],
    acc: dict[str, float],
    base: DriveParams,
    mapper: Mapper,
    free: Sequence[str],
) -> DriveParams | None:
    """Parameters from the regressions at ``delay`` (only free fields change); None when a
    regression finds no positive gain (the candidate delay is implausible)."""
    changes: dict[str, float] = {"delay_s": delay} if "delay_s" in free else {}
    cache: dict[int, dict[str, FloatArray]] = {}
    for axis, smoothed in data.items():
        fields = _AXIS_FIELDS[axis]
        if fields[3] in free:
            changes[fields[3]] = acc[axis]
        refs = []
        for d in smoothed:
            if id(d.log) not in cache:
                cache[id(d.log)] = _references(d.log, d.t, delay, acc, base, mapper.geometry)
            refs.append(cache[id(d.log)][axis])
        est = _regress(smoothed, refs, axis)
        if est is None:
            return None
        tau_m, ratio, c_fwd, c_bwd = est
        k = mapper.kv if axis == "v" else mapper.kw
        base_m = mapper.geometry.mass_kg if axis == "v" else mapper.geometry.yaw_inertia_kgm2
        if fields[0] in free:
            changes[fields[0]] = k * float(np.clip(tau_m, 0.005, 5.0)) - base_m
        if fields[1] in free:
            changes[fields[1]] = ratio * k
        if fields[2] in free:
            changes[fields[2]] = c_fwd * k
        if axis == "v" and "coulomb_v_bwd_n" in free:
            changes["coulomb_v_bwd_n"] = c_bwd * k
    try:
        return base.replace(**changes)
    except ValueError:
        return None


def _window_cost(prob: Problem, params: DriveParams) -> float:
    f = prob.scaled_sim(params) - prob.meas
    return float(np.sum(np.sqrt(1.0 + f * f) - 1.0))


def _xcorr_delay(prob: Problem, params: DriveParams, axes: Sequence[str]) -> float | None:
    """Dead time: lag of the zero-delay model response behind the measurement (s)."""
    sims = prob.simulate(params.replace(delay_s=0.0))
    lags: list[float] = []
    for log, sim in zip(prob.logs, sims, strict=True):
        for axis in axes:
            real = log.meas_v if axis == "v" else log.meas_w
            good = ~spike_mask(real, 0.05 if axis == "v" else 0.3)
            model = sim.v if axis == "v" else sim.w
            lag = xcorr_lag_s(log.meas_t_s[good], real[good], model[good], max_lag_s=1.0, dt_s=0.01)
            if math.isfinite(lag):
                lags.append(-lag)
    return float(np.median(lags)) if lags else None


def initial_coords(
    logs: Sequence[LogArrays],
    geometry: BaseGeometry,
    base: DriveParams,
    free: Sequence[str],
    ties: dict[str, str],
    priors: Mapping[str, Prior] | None = None,
    *,
    release_accel_limits: bool = False,
) -> tuple[dict[str, float], list[str]]:
    """Start values of the free coordinates, and notes (e.g. spikes found).

    An acceleration limit without a spec value starts at the log's smoothed peak acceleration
    (the limit active), or at "no limit" with ``release_accel_limits`` (the other start of
    :func:`sysid._map.restarts`; the regressions then assume no limit too).

    The delay is scanned on a 10 ms grid: at each candidate the axis regressions give the other
    parameters and the output-error cost of that parameter set is evaluated on the busiest
    window of each log; the best candidate is refined to sub-sample precision by
    cross-correlating the measurement with the zero-delay model response.
    """
    mapper = Mapper(geometry, base, priors)
    notes = _spike_notes(logs)
    windows = [crop_log(g, *busiest_window(g, _MAX_SMOOTH), lead_s=2.0) for g in logs]
    axes = [a for a in ("v", "w") if any(COORDS[f].axis == a for f in free)]
    data: dict[str, list[_Smoothed]] = {}
    acc: dict[str, float] = {}
    for axis in axes:
        data[axis], acc[axis] = _axis_start(windows, axis, base, free, release_accel_limits)
    start = _yaw_clamp_start(logs, _speed_cap_start(logs, geometry, base, free), free)
    prob = Problem(windows, mapper, (), {}, scale_v=0.02, scale_w=0.1, dt_s=0.01)
    fallback = start.replace(delay_s=base.delay_s)
    at = functools.partial(_params_at, data=data, acc=acc, base=start, mapper=mapper, free=free)
    if "delay_s" in free:
        params = _delay_scan(prob, at, axes, fallback)
    else:
        params = at(base.delay_s) or fallback
    for field, source in ties.items():
        params = params.replace(**{field: getattr(params, source)})
    coords = {}
    for field in free:
        c = COORDS[field]
        x = mapper.to_coord(params, field)
        margin = 1e-6 * (c.upper - c.lower)
        coords[field] = float(np.clip(x, c.lower + margin, c.upper - margin))
    return coords, notes


def _spike_notes(logs: Sequence[LogArrays]) -> list[str]:
    """A note for each log with odometry spikes (the initial estimates ignore them)."""
    notes: list[str] = []
    for log in logs:
        sv, sw = spike_mask(log.meas_v, 0.05), spike_mask(log.meas_w, 0.3)
        if sv.any() or sw.any():
            notes.append(
                f"{log.name}: {int(sv.sum())} v and {int(sw.sum())} w odometry spike(s)"
                + (_largest_spike(log.meas_v, sv) if sv.any() else "")
                + "; ignored by the initial estimates and down-weighted by the robust loss"
            )
    return notes


def _largest_spike(v: FloatArray, spikes: BoolArray) -> str:
    """The largest v spike: its value and how far it sits off its neighbours' median, m/s."""
    jump = v - median_filter(v, size=5, mode="nearest")
    k = int(np.argmax(np.where(spikes, np.abs(jump), -1.0)))
    return f" (the largest at {v[k]:.2f} m/s, {abs(jump[k]):.2f} m/s off its neighbours)"


def _axis_start(
    windows: Sequence[LogArrays],
    axis: str,
    base: DriveParams,
    free: Sequence[str],
    release_accel_limits: bool,
) -> tuple[list[_Smoothed], float]:
    """The smoothed measurements of one axis and the start of its acceleration limit."""
    masks = [
        ~spike_mask(g.meas_v if axis == "v" else g.meas_w, 0.05 if axis == "v" else 0.3)
        for g in windows
    ]
    data = _smooth(windows, masks, axis)
    field = _AXIS_FIELDS[axis][3]
    acc = float(getattr(base, field))
    if field in free and not math.isfinite(acc) and data and not release_accel_limits:
        accels = np.concatenate([np.abs(d.a[d.good]) for d in data])
        acc = max(1.1 * float(np.percentile(accels, 99)), 0.2)
    return data, acc


def _speed_cap_start(
    logs: Sequence[LogArrays], geometry: BaseGeometry, base: DriveParams, free: Sequence[str]
) -> DriveParams:
    """``base`` with a free wheel-speed cap of no spec value started above the logs' peak."""
    if "wheel_speed_max_radps" not in free or math.isfinite(base.wheel_speed_max_radps):
        return base
    half = 0.5 * geometry.wheel_separation_m
    peak_w = max(float(np.percentile(np.abs(g.meas_v) + np.abs(g.meas_w) * half, 99)) for g in logs)
    return base.replace(wheel_speed_max_radps=max(1.15 * peak_w / geometry.wheel_radius_m, 0.5))


def _yaw_clamp_start(
    logs: Sequence[LogArrays], base: DriveParams, free: Sequence[str]
) -> DriveParams:
    """``base`` with a free yaw-rate clamp of no spec value started at the logs' fastest
    measured yaw rate (5-sample median, so no spike sets it)."""
    if "speed_lim_w_radps" not in free or math.isfinite(base.speed_lim_w_radps):
        return base
    peak = max(float(np.max(np.abs(median_filter(g.meas_w, size=5, mode="nearest")))) for g in logs)
    return base.replace(speed_lim_w_radps=max(peak, 0.05))


def _delay_scan(
    prob: Problem,
    at: Callable[[float], DriveParams | None],
    axes: list[str],
    fallback: DriveParams,
) -> DriveParams:
    """The parameters of the best delay on a 10 ms grid, refined by cross-correlation (``at``:
    the regressions' parameters at a delay, :func:`_params_at`)."""
    best_cost, params = math.inf, fallback
    for d in np.arange(0.0, 0.61, 0.01):
        cand = at(float(d))
        if cand is None:
            continue
        cost = _window_cost(prob, cand)
        if cost < best_cost:
            best_cost, params = cost, cand
    refined = _xcorr_delay(prob, params, axes or ["v", "w"])
    if refined is not None and abs(refined - params.delay_s) <= 0.015:
        params = at(max(refined, 0.0)) or params
    return params
