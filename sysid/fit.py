r"""Fit the drive-model parameters to logged velocity traces (output-error, robust).

The reduced drive model (:func:`robots.reduced.simulate`) is driven by the logged commands
and its v and w are compared with the measured ones at every measurement time. The scaled
residuals :math:`(\hat y - y)\,w_c / s_c` (scale :math:`s_c` = agreement tolerance of the
channel by default) are minimised with ``scipy.optimize.least_squares`` (trust-region
reflective, bounds from physics) under a robust loss (``soft_l1``): real odometry carries
spikes and bursts that a squared loss would chase.

Identifiability
---------------
Velocity data fix the *response* of each axis, not the split between motor gain and mass:
:math:`T_v = (m+\Delta m)/(k_v + b_v)` with :math:`k_v = 2K/r^2`. So the wheel-loop gain
:math:`K` stays at the spec prior and the fit runs in normalised coordinates
(:mod:`sysid._coords`); ``added_mass_kg`` and ``added_yaw_inertia_kgm2`` are *derived*
relative to that prior. The quantities the data identify whatever :math:`K` is (time constants,
steady-state gains, friction per unit mass/inertia, Coulomb speed loss, delay, limits) are
reported in :attr:`SysidResult.identifiable`.

Example
-------
>>> from sysid import fit_drive
>>> res = fit_drive([trace], geometry=spec.geometry, base_params=spec.drive,
...                 robot="turtlebot3_burger")  # doctest: +SKIP
>>> res.estimate("delay_s").ci95_low  # doctest: +SKIP
0.112
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from importlib.metadata import PackageNotFoundError, version
from numbers import Integral
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

from robots.params import BaseGeometry, DriveParams
from robots.reduced import DEFAULT_DT_S
from sysid import metrics
from sysid._bootstrap import segment_bootstrap
from sysid._coords import COORDS, UNITS, Mapper
from sysid._excitation import analyse, held_command
from sysid._initial import busiest_window, initial_coords
from sysid._linear import first_order_stats
from sysid._logs import LogArrays, as_log_arrays, crop_log, log_name, log_warnings
from sysid._problem import Problem
from sysid.errors import SysidValueError
from sysid.result import DataFile, FitScores, ParameterEstimate, SysidResult

__all__ = ["Progress", "fit_drive", "score_logs"]

FloatArray = NDArray[np.float64]

#: ``progress(stage, fraction)`` callback: stage text and overall fraction done in [0, 1].
Progress = Callable[[str, float], None]

_LIMITS = (
    "accel_lim_v_mps2",
    "accel_lim_w_radps2",
    "wheel_speed_max_radps",
    "speed_lim_v_mps",
    "speed_lim_w_radps",
    "wheel_torque_max_nm",
)
_DERIVED = ("added_mass_kg", "added_yaw_inertia_kgm2")
_Z95 = 1.959963984540054


#: Logs longer than this (s, in total) are first fitted on their busiest windows.
_COARSE_SPAN_S = 150.0
#: Residual-evaluation cap of the polishing pass on all the data.
_POLISH_NFEV = 3


def _span(log: LogArrays) -> float:
    return float(log.meas_t_s[-1] - log.meas_t_s[0])


def _window_samples(log: LogArrays, span_s: float) -> int:
    rate = log.meas_t_s.size / max(_span(log), 1e-9)
    return max(int(rate * span_s), 10)


def _solve(
    prob: Problem, x0: FloatArray, coupled: bool, loss: str, f_scale: float, max_nfev: int
) -> Any:
    """One trust-region-reflective robust least-squares run (single-threaded BLAS: the
    Jacobian is tall and thin, where threads only add contention)."""
    with threadpool_limits(limits=1):
        return least_squares(
            prob.residuals,
            x0,
            jac=lambda x: prob.jacobian(x, coupled),
            bounds=(prob.lower, prob.upper),
            loss=loss,
            f_scale=f_scale,
            x_scale="jac",
            method="trf",
            ftol=1e-6,
            xtol=1e-6,
            gtol=1e-8,
            max_nfev=max_nfev,
        )


def _tool_version() -> str:
    try:
        return version("sim2real")
    except PackageNotFoundError:  # pragma: no cover - source tree without install
        return "unknown"


def _check_args(loss: str, scale: str | tuple[float, float], weights: tuple[float, float]) -> None:
    allowed = ("linear", "soft_l1", "huber", "cauchy", "arctan")
    if loss not in allowed:
        raise SysidValueError(f"loss must be one of {list(allowed)}, got {loss!r}")
    if isinstance(scale, str):
        if scale not in ("tol", "std"):
            raise SysidValueError(
                f"scale must be 'tol', 'std' or a pair (s_v, s_w) > 0, got {scale!r}"
            )
    elif not (len(scale) == 2 and all(math.isfinite(s) and s > 0 for s in scale)):
        raise SysidValueError(f"scale must be a pair of numbers > 0, got {scale!r}")
    if not all(math.isfinite(w) and w >= 0 for w in weights) or not any(weights):
        raise SysidValueError(
            f"channel weights must be >= 0 and not both 0, got {weights!r}; e.g. (1.0, 1.0)"
        )


def _scales(
    logs: Sequence[LogArrays], scale: str | tuple[float, float], tol_v: float, tol_w: float
) -> tuple[float, float]:
    if scale == "tol":
        return tol_v, tol_w
    if scale == "std":
        sv = float(np.std(np.concatenate([g.meas_v for g in logs])))
        sw = float(np.std(np.concatenate([g.meas_w for g in logs])))
        return max(sv, 1e-3), max(sw, 1e-2)
    return float(scale[0]), float(scale[1])


def score_logs(
    logs: Sequence[LogArrays],
    params: DriveParams,
    geometry: BaseGeometry,
    *,
    dt_s: float = DEFAULT_DT_S,
    tol_v: float = metrics.DEFAULT_TOL_V,
    tol_w: float = metrics.DEFAULT_TOL_W,
    odom_v_window_s: float = 0.0,
) -> tuple[FitScores, ...]:
    """FIT %, agreement and RMSE of ``params`` on each log (model started at the first sample).

    Examples
    --------
    >>> scores = score_logs([log], params, geometry)  # doctest: +SKIP
    >>> scores[0].fit_percent_v  # doctest: +SKIP
    93.1
    """
    mapper = Mapper(geometry, params)
    prob = Problem(
        [as_log_arrays(g, i) for i, g in enumerate(logs)],
        mapper,
        (),
        {},
        scale_v=1.0,
        scale_w=1.0,
        dt_s=dt_s,
        v_window_s=odom_v_window_s,
    )
    out = []
    for log, sim in zip(prob.logs, prob.simulate(params), strict=True):
        cv = held_command(log.cmd_t_s, log.cmd_v, log.meas_t_s)
        cw = held_command(log.cmd_t_s, log.cmd_w, log.meas_t_s)
        act = metrics.active_mask(cv, cw, log.meas_v, log.meas_w, tol_v=tol_v, tol_w=tol_w)
        both, av, aw = metrics.agreement_fraction(
            sim.v - log.meas_v, sim.w - log.meas_w, act, tol_v=tol_v, tol_w=tol_w
        )
        out.append(
            FitScores(
                log=log.name,
                n_samples=int(log.meas_t_s.size),
                n_active=int(act.sum()),
                fit_percent_v=metrics.fit_percent(log.meas_v, sim.v),
                fit_percent_w=metrics.fit_percent(log.meas_w, sim.w),
                agreement=both,
                agreement_v=av,
                agreement_w=aw,
                rmse_v=metrics.rmse(log.meas_v, sim.v),
                rmse_w=metrics.rmse(log.meas_w, sim.w),
            )
        )
    return tuple(out)


def _covariance(res: Any, prob: Problem, keep: list[int]) -> tuple[FloatArray, float, list[int]]:
    """Parameter covariance from the Jacobian at the solution, the inflation used, and the
    (kept) columns the data do not determine.

    :math:`\\Sigma = s^2 (J^T J)^{-1}` with the loss-modified Jacobian of ``least_squares``,
    :math:`s` the robust (MAD) residual scale, and a factor :math:`(1+\\rho_1)/(1-\\rho_1)`
    for the lag-1 autocorrelation :math:`\\rho_1` of the residuals (correlated residuals carry
    less information than independent ones; without it the intervals would be far too
    narrow). Directions of the column-normalised Jacobian with singular value below 1e-4 are
    not identified: parameters with weight on them get an infinite variance.
    """
    jac = np.asarray(res.jac)[:, keep]
    f = np.asarray(res.fun)
    n, p = f.size, len(keep)
    s2 = (1.4826 * float(np.median(np.abs(f - np.median(f))))) ** 2 * n / max(n - p, 1)
    rho = []
    for rows in (prob.rows["v"], prob.rows["w"]):
        r = f[rows] - np.mean(f[rows])
        den = float(np.dot(r, r))
        if den > 0:
            rho.append(float(np.dot(r[1:], r[:-1]) / den))
    rho1 = float(np.clip(np.mean(rho) if rho else 0.0, 0.0, 0.98))
    inflation = (1.0 + rho1) / (1.0 - rho1)
    norms = np.linalg.norm(jac, axis=0)
    safe = np.where(norms > 0, norms, 1.0)
    _, sv, vt = np.linalg.svd(jac / safe, full_matrices=False)
    good = sv > 1e-4 * max(float(sv[0]) if sv.size else 0.0, 1e-300)
    inv = (vt[good].T / sv[good] ** 2) @ vt[good]
    cov = s2 * inflation * inv / np.outer(safe, safe)
    null = vt[~good]
    weak = [j for j in range(p) if norms[j] == 0 or float(np.sum(null[:, j] ** 2)) > 1e-3]
    for j in weak:
        cov[j, j] = math.inf
    return cov, inflation, weak


def _ci(
    field: str, x: float, sd: float, mapper: Mapper, ties: dict[str, str]
) -> tuple[float, float]:
    c = COORDS[field]
    lo = float(np.clip(x - _Z95 * sd, c.lower, c.upper))
    hi = float(np.clip(x + _Z95 * sd, c.lower, c.upper))
    a = float(getattr(mapper.from_coords({field: lo}, {}), field))
    b = float(getattr(mapper.from_coords({field: hi}, {}), field))
    return min(a, b), max(a, b)


def _param_estimates(
    params: DriveParams,
    free: list[str],
    x: FloatArray,
    sd: FloatArray,
    mapper: Mapper,
    ties: dict[str, str],
) -> tuple[ParameterEstimate, ...]:
    out = []
    for name in DriveParams.names():
        value = float(getattr(params, name))
        source = ties.get(name)
        j = free.index(source if source else name) if (source or name) in free else None
        if j is None:
            status = "tied" if source else "fixed"
            out.append(
                ParameterEstimate(
                    name=name,
                    value=value,
                    std=None,
                    ci95_low=None,
                    ci95_high=None,
                    unit=UNITS[name],
                    status=status,
                )
            )
            continue
        field = free[j]
        lo, hi = _ci(field, float(x[j]), float(sd[j]), mapper, ties)
        dx = COORDS[field].step
        v2 = float(getattr(mapper.from_coords({field: float(x[j]) + dx}, {}), field))
        v1 = float(getattr(mapper.from_coords({field: float(x[j])}, {}), field))
        std = abs(v2 - v1) / dx * float(sd[j])
        status = "tied" if source else ("derived" if name in _DERIVED else "fitted")
        out.append(
            ParameterEstimate(
                name=name,
                value=value,
                std=std,
                ci95_low=lo,
                ci95_high=hi,
                unit=UNITS[name],
                status=status,
            )
        )
    return tuple(out)


def _identifiable(
    prob: Problem, x: FloatArray, cov: FloatArray, mapper: Mapper, weak: list[int]
) -> tuple[ParameterEstimate, ...]:
    """Delta-method uncertainty of the identifiable combinations (no simulation needed)."""
    cov = np.where(np.isfinite(cov), cov, 0.0)
    base = mapper.identifiable(prob.params(x))
    grads = np.zeros((len(base), x.size))
    keys = list(base)
    for j in range(x.size):
        h = 1e-6 * max(1.0, abs(float(x[j])))
        xp, xm = x.copy(), x.copy()
        xp[j] = min(float(x[j]) + h, float(prob.upper[j]))
        xm[j] = max(float(x[j]) - h, float(prob.lower[j]))
        vp = mapper.identifiable(prob.params(xp))
        vm = mapper.identifiable(prob.params(xm))
        span = float(xp[j] - xm[j])
        for i, k in enumerate(keys):
            a, b = vp[k][0], vm[k][0]
            ok = math.isfinite(a) and math.isfinite(b) and span > 0
            grads[i, j] = (a - b) / span if ok else 0.0
    out = []
    for i, k in enumerate(keys):
        value, unit = base[k]
        g = grads[i]
        if not np.any(g) or not math.isfinite(value):
            out.append(
                ParameterEstimate(
                    name=k,
                    value=value,
                    std=None,
                    ci95_low=None,
                    ci95_high=None,
                    unit=unit,
                    status="fixed",
                )
            )
            continue
        std = float(math.sqrt(max(float(g @ cov @ g), 0.0)))
        if any(g[j] != 0 for j in weak):
            std = math.inf
        if value > 0 and std < value:
            # positive quantity: interval symmetric in log space
            lo, hi = value * math.exp(-_Z95 * std / value), value * math.exp(_Z95 * std / value)
        else:
            lo, hi = value - _Z95 * std, value + _Z95 * std
            lo = max(lo, 0.0) if value >= 0 else lo  # these combinations are non-negative
        out.append(
            ParameterEstimate(
                name=k,
                value=value,
                std=std,
                ci95_low=lo,
                ci95_high=hi,
                unit=unit,
                status="fitted" if k == "delay_s" else "derived",
            )
        )
    return tuple(out)


def _drop_inactive_limits(
    prob: Problem, x: FloatArray, base: DriveParams, notes: list[str]
) -> list[int]:
    """Limits that never shape the response are not identified: their prior is kept.

    Returns the indices of the coordinates to drop from the fit result."""
    params = prob.params(x)
    ref = prob.scaled_sim(params)
    dropped = []
    for j, field in enumerate(prob.free):
        if field not in _LIMITS:
            continue
        unlimited = prob.scaled_sim(params.replace(**{field: math.inf}))
        if float(np.max(np.abs(unlimited - ref))) < 0.1:
            prior = float(getattr(base, field))
            dropped.append(j)
            notes.append(
                f"{field} never limited the response in the log (fitted {getattr(params, field):.3g} "
                f"is not identifiable): kept at the spec prior ({prior:g})"
            )
    return dropped


def _bootstrap_std(
    logs: Sequence[LogArrays],
    mapper: Mapper,
    free: list[str],
    ties: dict[str, str],
    x_hat: FloatArray,
    **kw: Any,
) -> dict[str, float]:
    """Bootstrap standard deviation of every fitted DriveParams value."""
    if not free:
        return {}
    rows = segment_bootstrap(logs, mapper, free, ties, x_hat, **kw)
    values = np.array(
        [
            [getattr(mapper.from_coords(dict(zip(free, r, strict=True)), ties), f) for f in free]
            for r in rows
        ]
    )
    return {f: float(np.std(values[:, j], ddof=1)) for j, f in enumerate(free)}


def _linear_stats(identifiable: tuple[ParameterEstimate, ...]) -> dict[str, Any]:
    get = {e.name: e.value for e in identifiable}
    return {
        axis: first_order_stats(get[f"gain_{axis}"], get[f"time_constant_{axis}_s"], get["delay_s"])
        for axis in ("v", "w")
    }


def _check_numbers(
    logs: Sequence[object], dt_s: float, bootstrap: int, segment_s: float, window_s: float
) -> None:
    if not logs:
        raise SysidValueError("no fitting log given; pass at least one VelocityLog")
    if not (math.isfinite(dt_s) and 0 < dt_s <= 0.05):
        raise SysidValueError(
            f"model step dt_s (--dt) must be in (0, 0.05] s, got {dt_s!r}; e.g. --dt 0.005"
        )
    if isinstance(bootstrap, bool) or not isinstance(bootstrap, Integral) or bootstrap < 0:
        raise SysidValueError(
            f"bootstrap (--bootstrap) must be a whole number of resamples >= 0 (0 = none), got "
            f"{bootstrap!r}; e.g. --bootstrap 20"
        )
    if not (math.isfinite(segment_s) and segment_s >= 1.0):
        raise SysidValueError(
            f"bootstrap segment_s must be a finite number of seconds >= 1, got {segment_s!r}; "
            "e.g. segment_s=10.0"
        )
    if not (math.isfinite(window_s) and 0 <= window_s <= 1.0):
        raise SysidValueError(
            f"odom_v_window_s must be in [0, 1] s, got {window_s!r}; e.g. 1/30 for a "
            "30 Hz encoder odometry, 0 for instantaneous velocity"
        )


def _optimise(
    prob: Problem, x0: FloatArray, solve: Callable[[Problem, FloatArray, int], Any], nfev: int
) -> Any:
    """Least squares on all the data; long logs first converge on their busiest windows."""
    logs = prob.logs
    total_s = sum(_span(g) for g in logs)
    if total_s <= _COARSE_SPAN_S:
        return solve(prob, x0, nfev)
    windows = [
        crop_log(g, *busiest_window(g, _window_samples(g, _COARSE_SPAN_S * _span(g) / total_s)))
        for g in logs
    ]
    coarse = Problem(
        windows,
        prob.mapper,
        prob.free,
        prob.ties,
        scale_v=1.0 / prob.gain_v,
        scale_w=1.0 / prob.gain_w,
        dt_s=prob.dt_s,
        python=prob.python,
        v_window_s=prob.v_window_s,
        on_eval=prob.on_eval,
    )
    x1 = np.asarray(solve(coarse, x0, nfev).x)
    prob.n_evals, prob.n_steps = coarse.n_evals, coarse.n_steps
    return solve(prob, x1, min(nfev, _POLISH_NFEV))


def _bound_notes(free: list[str], x: FloatArray, params: DriveParams) -> list[str]:
    out = []
    for j, f in enumerate(free):
        c = COORDS[f]
        tol = 1e-5 * (c.upper - c.lower)
        if x[j] - c.lower < tol or c.upper - x[j] < tol:
            out.append(
                f"{f} ended at its physical bound ({getattr(params, f):.4g}); treat it with care"
            )
    return out


def _correlation(
    cov: FloatArray, weak: list[int], names: list[str], notes: list[str]
) -> FloatArray:
    """Correlation matrix (NaN rows for undetermined parameters); notes strong pairs."""
    d = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.where(np.isfinite(np.outer(d, d)), cov / np.outer(d, d), math.nan)
    for j in weak:
        corr[j, :] = corr[:, j] = math.nan
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            if abs(corr[a, b]) > 0.95:
                notes.append(
                    f"{names[a]} and {names[b]} are strongly correlated ({corr[a, b]:+.2f}): "
                    "the log barely separates them"
                )
    return np.asarray(corr)


def fit_drive(
    logs: Sequence[object],
    *,
    geometry: BaseGeometry,
    base_params: DriveParams,
    free: str | Sequence[str] | None = "auto",
    validate: Sequence[object] = (),
    robot: str = "unknown",
    loss: str = "soft_l1",
    f_scale: float = 1.0,
    scale: str | tuple[float, float] = "tol",
    weights: tuple[float, float] = (1.0, 1.0),
    tol_v: float = metrics.DEFAULT_TOL_V,
    tol_w: float = metrics.DEFAULT_TOL_W,
    dt_s: float = DEFAULT_DT_S,
    odom_v_window_s: float = 0.0,
    max_nfev: int = 60,
    python: bool = False,
    bootstrap: int = 0,
    segment_s: float = 10.0,
    seed: int = 0,
    progress: Progress | None = None,
) -> SysidResult:
    r"""Fit the drive parameters of ``base_params`` to velocity logs.

    Parameters
    ----------
    logs : sequence of VelocityLog
        Fitting logs (``cmd_t_s, cmd_v, cmd_w, meas_t_s, meas_v, meas_w``; e.g.
        ``sim2real.logs.Trace``), each simulated from its first measurement.
    geometry : BaseGeometry
        The robot's spec geometry (mass, yaw inertia, wheel radius and separation).
    base_params : DriveParams
        Spec defaults: the prior for every parameter not fitted, and the motor gain.
    free : "auto", None or list of str
        Fields to fit. ``"auto"``/None chooses from the excitation of the logs and explains
        every parameter it leaves at the prior in :attr:`SysidResult.warnings`.
    validate : sequence of VelocityLog
        Logs only scored (FIT %, agreement) with the fitted parameters.
    robot : str
        Robot name written in the result.
    loss, f_scale : str, float
        Robust loss of ``least_squares`` and its inlier scale (in units of ``scale``).
    scale : "tol", "std" or (s_v, s_w)
        Residual scale per channel: the agreement tolerances (default), the channels' standard
        deviations, or explicit values (m/s, rad/s).
    weights : (float, float)
        Extra weight of the v and w channels.
    tol_v, tol_w : float
        Agreement tolerances (m/s, rad/s) for the scores.
    dt_s : float
        Integration step of the reduced model, s (use the step the params will be used with).
    odom_v_window_s : float
        Measurement model of v: the odometry's v is the mean over this preceding window, s
        (wheel-encoder tick differences over one odometry period, e.g. 1/30 s on a
        TurtleBot3); 0 (default) compares the instantaneous model v. Without it, encoder
        odometry looks half a period late and the fitted delay absorbs that.
    max_nfev : int
        Cap on residual evaluations of the optimiser.
    python : bool
        Run the plain-Python model loop (benchmark baseline; identical numbers, much slower).
    bootstrap : int
        Number of block-bootstrap replicates over ``segment_s``-second segments of the fit
        logs (0 = none); their standard deviations land in :attr:`SysidResult.bootstrap_std`
        as a check on the Jacobian errors. Draws from ``numpy.random.default_rng(seed)``.
    segment_s : float
        Segment length of the bootstrap, s.
    seed : int
        Seed of the bootstrap draws.
    progress : callable, optional
        ``progress(stage, fraction)``, called as the fit advances.

    Returns
    -------
    SysidResult

    Raises
    ------
    SysidValueError
        NaN/inf in a log, mismatched or unsorted arrays, bad arguments.
    ExcitationError
        Too short a log, no motion, commands that never change.
    """
    started = time.perf_counter()
    _check_args(loss, scale, weights)
    _check_numbers(logs, dt_s, bootstrap, segment_s, odom_v_window_s)
    report = progress or (lambda stage, frac: None)
    fit_logs = [as_log_arrays(g, i) for i, g in enumerate(logs)]
    val_logs = [as_log_arrays(g, len(fit_logs) + i) for i, g in enumerate(validate)]
    report("checking excitation", 0.0)
    exc = analyse(fit_logs, geometry, base_params, free)
    notes = [
        f"{log_name(g, i)}: {w}" for i, g in enumerate([*logs, *validate]) for w in log_warnings(g)
    ]
    notes += exc.warnings
    mapper = Mapper(geometry, base_params)
    report("initial estimates", 0.05)
    x0_map, spike_notes = initial_coords(fit_logs, geometry, base_params, exc.free, exc.ties)
    notes += spike_notes
    free_list = list(exc.free)
    sv, sw = _scales(fit_logs, scale, tol_v, tol_w)
    problem_kw: dict[str, Any] = {
        "scale_v": sv,
        "scale_w": sw,
        "weight_v": weights[0],
        "weight_w": weights[1],
        "dt_s": dt_s,
        "v_window_s": odom_v_window_s,
    }

    def solve(prob: Problem, x0: FloatArray, nfev: int) -> Any:
        return _solve(prob, x0, exc.coupled, loss, f_scale, nfev)

    def on_eval(n: int) -> None:
        report("fitting", 0.1 + 0.8 * min(n / (4 * max_nfev), 1.0))

    prob = Problem(
        fit_logs, mapper, free_list, exc.ties, python=python, on_eval=on_eval, **problem_kw
    )
    res = _optimise(prob, np.array([x0_map[f] for f in free_list]), solve, max_nfev)
    report("uncertainty", 0.92)
    x = np.asarray(res.x)
    dropped = _drop_inactive_limits(prob, x, base_params, notes)
    keep = [j for j in range(len(free_list)) if j not in dropped]
    kept_free = [free_list[j] for j in keep]
    with threadpool_limits(limits=1):
        cov, inflation, weak = _covariance(res, prob, keep)
    notes += [
        f"{kept_free[j]} is not determined by the log (flat or degenerate direction of the "
        "fit): its interval is unbounded; fix it (--free) or record a richer log"
        for j in weak
    ]
    prob_kept = Problem(fit_logs, mapper, kept_free, exc.ties, **problem_kw)
    params = prob_kept.params(x[keep])
    notes += _bound_notes(kept_free, x[keep], params)
    corr = _correlation(cov, weak, kept_free, notes)
    estimates = _param_estimates(
        params,
        kept_free,
        x[keep],
        np.sqrt(np.clip(np.diag(cov), 0.0, None)),
        mapper,
        {k: v for k, v in exc.ties.items() if v in kept_free},
    )
    identifiable = _identifiable(prob_kept, x[keep], cov, mapper, weak)
    boot_std: dict[str, float] = {}
    if bootstrap > 0:
        report("bootstrap", 0.93)
        boot_std = _bootstrap_std(
            fit_logs,
            mapper,
            kept_free,
            exc.ties,
            x[keep],
            solve=lambda pr, x0: solve(pr, x0, 12),
            problem_kw=problem_kw,
            replicates=bootstrap,
            segment_s=segment_s,
            seed=seed,
        )
    report("scoring", 0.95)
    kw_scores = {"dt_s": dt_s, "tol_v": tol_v, "tol_w": tol_w, "odom_v_window_s": odom_v_window_s}
    scores_fit = score_logs(fit_logs, params, geometry, **kw_scores)
    scores_val = score_logs(val_logs, params, geometry, **kw_scores) if val_logs else ()
    data = tuple(DataFile(file=g.name, sha256=g.sha256, role="fit") for g in fit_logs) + tuple(
        DataFile(file=g.name, sha256=g.sha256, role="validation") for g in val_logs
    )
    settings = {
        "loss": loss,
        "f_scale": f_scale,
        "scale_v": sv,
        "scale_w": sw,
        "weights": list(weights),
        "dt_s": dt_s,
        "odom_v_window_s": odom_v_window_s,
        "free": kept_free,
        "ties": dict(exc.ties),
        "motor_gain_prior_nms_per_rad": base_params.motor_gain_nms_per_rad,
        "model_evaluations": prob.n_evals,
        "model_steps": prob.n_steps,
        "optimizer_status": str(res.message),
        "cost": float(res.cost),
        "std_inflation_autocorr": inflation,
        "bootstrap": {"replicates": bootstrap, "segment_s": segment_s, "seed": seed},
        "seconds": time.perf_counter() - started,
        "note": (
            "added_mass_kg and added_yaw_inertia_kgm2 are derived relative to the spec motor "
            "gain (velocity data only identify mass/gain ratios); see 'identifiable'"
        ),
    }
    report("done", 1.0)
    return SysidResult(
        robot=robot,
        params=params,
        estimates=estimates,
        identifiable=identifiable,
        correlation_names=tuple(kept_free),
        correlation=tuple(tuple(float(c) for c in row) for row in corr),
        linear=_linear_stats(identifiable),
        scores_fit=scores_fit,
        scores_validation=scores_val,
        data=data,
        tool_version=_tool_version(),
        warnings=tuple(notes),
        settings=settings,
        bootstrap_std=boot_std,
    )
