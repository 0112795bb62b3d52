r"""Fit the drive-model parameters to logged velocity traces: MAP, robust, with a population.

The reduced drive model (:func:`robots.reduced.simulate`) is driven by the logged commands and
its v and w are compared with the measured ones at every measurement time. The scaled residuals
:math:`(\hat y - y)\,w_c / s_c` (scale :math:`s_c` = agreement tolerance of the channel by
default) under a robust loss (``soft_l1``: real odometry carries spikes) plus one residual per
prior, :math:`(z-\mu)/\sigma` in the coordinates of :data:`robots.params.SCHEMA`, are minimised
with ``scipy.optimize.least_squares`` (trust-region reflective): a maximum-a-posteriori fit
(:mod:`sysid._map`). Where a log informs a parameter its posterior is narrow; where not, the
posterior *is* its prior -- every parameter keeps an honest spread.

Identifiability
---------------
Velocity data fix the *response* of each axis, not the split between motor gain and mass:
:math:`T_v = (m+\Delta m)/(k_v + b_v)` with :math:`k_v = 2K/r^2`. The motor gain is fitted with
the rest, and the priors resolve that family: masses and inertias stay near their priors (a
total mass is :math:`e^z`, never <= 0) and the remainder goes into the motor gain. The
combinations the data identify whatever the split is (time constants, steady-state gains,
friction per unit mass, Coulomb speed loss, delay, limits) are reported in
:attr:`SysidResult.identifiable`.

Several logs
------------
Each log is fitted on its own (per-session estimates in :attr:`SysidResult.sessions`), then a
random-effects model gives the population mean and the between-session covariance
(:mod:`sysid._fleet`). :attr:`SysidResult.randomization` holds the distribution to train on:
the predictive of a new session: uncertainty of the mean + between-session covariance,
widened to the Student-t of a spread known from few sessions (one log: its posterior + the
spec's default between-session spread, once for the unknown deviation of the logged session
from the mean and once, widened, for the new one), the priors of the fields no log informed,
and the odometry noise.

Examples
--------
>>> from sysid import fit_drive
>>> res = fit_drive([trace], geometry=spec.geometry, base_params=spec.drive,
...                 priors=spec.priors, robot="turtlebot3_burger")  # doctest: +SKIP
>>> res.estimate("delay_s").ci95_low  # doctest: +SKIP
0.112
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from numbers import Integral
from typing import Any

import numpy as np

from robots.arrays import FloatArray
from robots.measurement import MeasurementModel
from robots.params import (
    SCHEMA,
    BaseGeometry,
    DriveParams,
    Prior,
    coords_to_values,
    generic_priors,
)
from robots.randomization import DriveDistribution, ObservationNoise
from robots.reduced import DEFAULT_DT_S
from sysid import metrics
from sysid._bootstrap import segment_bootstrap
from sysid._coords import Mapper
from sysid._excitation import active_samples, analyse, held_command
from sysid._fleet import SessionInfo, population
from sysid._linear import first_order_stats
from sysid._logs import LogArrays, as_log_arrays, log_name, log_warnings
from sysid._map import MapOptions, Posterior, _solve, map_fit
from sysid._needs import BEYOND_PRIOR_FACTOR, limit_needs, lower_bounds, measured_speeds
from sysid._problem import Problem
from sysid._summary import (
    FitSummary,
    distribution,
    estimate_noise,
    field_estimates,
    identifiable_estimates,
)
from sysid._timeout import fit_cmd_timeout
from sysid.definitions import LOSSES
from sysid.envelope import envelope_of
from sysid.errors import SysidValueError
from sysid.result import DataFile, FitScores, ParameterEstimate, SysidResult
from sysid.steady import measurement_lead_s, pooled_steady_noise, speed_noise, steady_noise

__all__ = ["Progress", "fit_drive", "score_logs"]


#: ``progress(stage, fraction)`` callback: stage text and overall fraction done in [0, 1].
Progress = Callable[[str, float], None]


def _tool_version() -> str:
    try:
        return version("sim2real")
    except PackageNotFoundError:  # pragma: no cover - source tree without install
        return "unknown"


def _check_args(loss: str, scale: str | tuple[float, float], weights: tuple[float, float]) -> None:
    if loss not in LOSSES:
        raise SysidValueError(f"loss must be one of {list(LOSSES)}, got {loss!r}")
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
    w_source: str = "imu",
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
        w_source=w_source,
    )
    out = []
    for log, sim in zip(prob.logs, prob.simulate(params), strict=True):
        act = active_samples(log, tol_v=tol_v, tol_w=tol_w)
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


def _correlation(
    cov: FloatArray, weak: list[int], names: list[str], notes: list[str]
) -> FloatArray:
    """Correlation matrix (NaN rows for undetermined parameters); notes strong pairs."""
    d = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.where(np.isfinite(np.outer(d, d)), cov / np.outer(d, d), math.nan)
    for j in weak:
        corr[j, :] = corr[:, j] = math.nan
    family = False
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            if not abs(corr[a, b]) > 0.95:
                continue
            if names[a] in _SCALE_FAMILY and names[b] in _SCALE_FAMILY:
                family = True
                continue
            notes.append(
                f"{names[a]} and {names[b]} are strongly correlated ({corr[a, b]:+.2f}): "
                "the log barely separates them"
            )
    if family:
        notes.append(
            "the motor gain, masses, inertias and friction forces move together (velocity data "
            "fix their ratios): their split, and so their intervals, rest on the spec priors; "
            "see 'identifiable' for what the log fixes on its own"
        )
    return np.asarray(corr)


#: Fields that velocity data only see relative to the motor gain (see sysid._coords).
_SCALE_FAMILY = frozenset(
    {
        "motor_gain_nms_per_rad",
        "wheel_torque_max_nm",
        "added_mass_kg",
        "added_yaw_inertia_kgm2",
        "coulomb_v_fwd_n",
        "coulomb_v_bwd_n",
        "coulomb_w_nm",
        "viscous_v_ns_per_m",
        "viscous_w_nms_per_rad",
    }
)


def _check_priors(
    priors: Mapping[str, Prior] | None, base: DriveParams, geo: BaseGeometry
) -> dict[str, Prior]:
    out = generic_priors(base, geo)
    if priors is None:
        return out
    unknown = sorted(set(priors) - set(SCHEMA))
    if unknown:
        raise SysidValueError(
            f"priors has unknown drive parameter(s) {unknown}; known ones are {list(SCHEMA)}"
        )
    return out | {k: v for k, v in priors.items() if isinstance(v, Prior)}


def _prior_base(base: DriveParams, priors: Mapping[str, Prior]) -> DriveParams:
    """The values of the fields a fit does not free: their prior nominal (finite ones)."""
    return base.replace(**{n: p.nominal for n, p in priors.items() if math.isfinite(p.nominal)})


def _channel_residuals(post: Posterior) -> tuple[FloatArray, FloatArray]:
    """Measured minus modelled v and w (m/s, rad/s) at the MAP point, all logs."""
    prob = post.problem
    sims = prob.simulate(post.params)
    res_v = [g.meas_v - s.v for g, s in zip(prob.logs, sims, strict=True)]
    res_w = [g.meas_w - s.w for g, s in zip(prob.logs, sims, strict=True)]
    return np.concatenate(res_v), np.concatenate(res_w)


def _convergence_notes(posts: Sequence[Posterior], names: Sequence[str], nfev: int) -> list[str]:
    return [
        f"{name}: the optimiser stopped at its evaluation limit ({nfev}) before converging "
        f"({post.message}); the estimates may be off: record a richer log, fix parameters "
        "(--free) or allow more evaluations"
        for post, name in zip(posts, names, strict=True)
        if not post.converged
    ]


def _single(post: Posterior) -> FitSummary:
    return FitSummary(**post.coords(), between=None)


def _fleet(
    posts: Sequence[Posterior],
    logs: Sequence[LogArrays],
    mapper: Mapper,
    problem_kw: dict[str, Any],
) -> FitSummary:
    """Random-effects population of per-log posteriors (see :mod:`sysid._fleet`)."""
    used = set()
    for p in posts:
        used |= {f for j, f in enumerate(p.free) if j not in p.weak}
    names = tuple(n for n in DriveParams.names() if n in used)
    priors = [mapper.prior(n) for n in names]
    mu_p = np.array([p[0] if p else 0.0 for p in priors])
    prec = np.array([1.0 / p[1] ** 2 if p else 0.0 for p in priors])
    s0 = np.diag([max(mapper.priors[n].session_sd, 1e-6) ** 2 for n in names])
    sessions = [_session_info(p, names, mu_p) for p in posts]
    pop = population(sessions, prior_mu=mu_p, prior_prec=prec, session_cov=s0)
    # the population mean is unconstrained; keep it inside the schema's range (its sign rules),
    # as every single-log MAP point is, so params, intervals and the randomisation mean agree
    bounds = [SCHEMA[n].coord_bounds(mapper.geometry) for n in names]
    mean = np.array(
        [min(max(float(z), lo), hi) for z, (lo, hi) in zip(pop.mean, bounds, strict=True)]
    )
    ties: dict[str, str] = {}
    for p in posts:
        ties |= {k: v for k, v in p.ties.items() if v in names and k not in names}
    prob = Problem(logs, mapper, names, ties, **problem_kw)
    values = coords_to_values(
        names, mean.tolist(), mapper.geometry, dataclasses.asdict(mapper.base)
    )
    params = mapper.base.replace(**(values | {k: values[v] for k, v in ties.items()}))
    u = np.array([mapper.to_coord(params, n) for n in names])
    _, g = prob.schema_coords(u)
    g_inv = np.linalg.pinv(g)
    return FitSummary(
        params=params,
        free=names,
        ties=ties,
        u=u,
        cov_u=g_inv @ pop.mean_cov @ g_inv.T,
        z=mean,
        cov=pop.mean_cov,
        weak=(),
        between=pop.between,
        problem=prob,
    )


def _session_info(post: Posterior, names: Sequence[str], mu_p: FloatArray) -> SessionInfo:
    """One session's estimate and information over ``names`` (the prior mean where its fit
    left a field out or found it weak)."""
    z = mu_p.copy()
    info = np.zeros((len(names), len(names)))
    idx = [(i, post.free.index(n)) for i, n in enumerate(names) if n in post.free]
    idx = [(i, j) for i, j in idx if j not in post.weak]
    rows = [i for i, _ in idx]
    cols = [j for _, j in idx]
    z[rows] = post.z[cols]
    info[np.ix_(rows, rows)] = post.info[np.ix_(cols, cols)]
    return SessionInfo(z=z, info=info)


def _session_entry(post: Posterior, mapper: Mapper, name: str) -> dict[str, Any]:
    sd = np.sqrt(np.clip(np.diag(post.cov), 0.0, None))
    values = coords_to_values(
        post.free, post.z.tolist(), mapper.geometry, dataclasses.asdict(mapper.base)
    )
    return {
        "log": name,
        "converged": post.converged,
        "parameters": {
            f: {"value": values[f], "coord_std": float(sd[j])} for j, f in enumerate(post.free)
        },
    }


def _priors_doc(priors: Mapping[str, Prior]) -> dict[str, dict[str, Any]]:
    return {
        n: {
            "nominal": p.nominal,
            "sd": p.sd,
            "session_sd": p.session_sd,
            "coord": SCHEMA[n].coord,
            "source": p.source,
        }
        for n, p in priors.items()
    }


def _bootstrap_std(
    logs: Sequence[LogArrays], summary: FitSummary, mapper: Mapper, **kw: Any
) -> dict[str, float]:
    """Bootstrap standard deviation of every fitted DriveParams value."""
    free = list(summary.free)
    if not free:
        return {}
    rows = segment_bootstrap(logs, mapper, free, summary.ties, summary.u, **kw)
    values = np.array(
        [
            [
                getattr(mapper.from_coords(dict(zip(free, r, strict=True)), summary.ties), f)
                for f in free
            ]
            for r in rows
        ]
    )
    return {f: float(np.std(values[:, j], ddof=1)) for j, f in enumerate(free)}


@dataclass(frozen=True)
class _Session:
    """Fit of one session (a group of logs): excitation analysis, then the MAP fit.

    A picklable callable, so that ``fit_drive(map_sessions=...)`` can run sessions as tasks
    elsewhere (``sim2real sysid fit --ray``); it returns the posterior and the notes it adds.
    """

    geometry: BaseGeometry
    base: DriveParams
    free: Any
    mapper: Mapper
    options: MapOptions
    several: bool
    informative: frozenset[str] = frozenset()

    def __call__(
        self,
        group: Sequence[LogArrays],
        *,
        on_eval: Callable[[int], None] | None = None,
        notes: list[str] | None = None,
    ) -> tuple[Posterior, list[str]]:
        out = notes if notes is not None else []
        start = len(out)
        encoder_yaw = self.options.problem_kw.get("w_source") == "wheels"
        exc = analyse(
            group,
            self.geometry,
            self.base,
            self.free,
            set(self.informative),
            encoder_yaw=encoder_yaw,
        )
        prefix = f"{group[0].name}: " if self.several else ""
        out += [prefix + w for w in exc.warnings]
        post = map_fit(group, self.mapper, exc, self.options, on_eval=on_eval, notes=out)
        out += [
            f"{prefix}{post.free[j]} is not determined by the log and has no prior (flat "
            "direction of the fit): it is kept at its value and not randomised; fix it (--free) "
            "or record a richer log"
            for j in post.weak
        ]
        return post, out[start:]


def fit_drive(
    logs: Sequence[object],
    *,
    geometry: BaseGeometry,
    base_params: DriveParams,
    priors: Mapping[str, Prior] | None = None,
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
    w_source: str = "imu",
    max_nfev: int = 60,
    python: bool = False,
    bootstrap: int = 0,
    segment_s: float = 10.0,
    seed: int = 0,
    progress: Progress | None = None,
    map_sessions: Callable[[Callable[[Any], Any], Sequence[Any]], Sequence[Any]] | None = None,
) -> SysidResult:
    r"""MAP fit of the drive parameters to velocity logs (one or several sessions).

    Parameters
    ----------
    logs : sequence of VelocityLog
        Fitting logs (``cmd_t_s, cmd_v, cmd_w, meas_t_s, meas_v, meas_w``; e.g.
        ``sim2real.logs.Trace``), each simulated from its first measurement. Several logs are
        several sessions: each is fitted on its own and a population is estimated.
    geometry : BaseGeometry
        The robot's spec geometry (mass, yaw inertia, wheel radius and separation).
    base_params : DriveParams
        Spec defaults (the centre of the generic priors).
    priors : mapping of Prior, optional
        ``{field: Prior}`` (``RobotSpec.priors``); fields it lacks get the schema's generic
        prior around ``base_params``. Fields the fit does not free take the prior's nominal.
    free : "auto", None or list of str
        Fields to fit. ``"auto"``/None chooses from the excitation of the logs (plus the motor
        gain whenever a mass or inertia is fitted) and explains what it leaves at the prior in
        :attr:`SysidResult.warnings`.
    validate : sequence of VelocityLog
        Logs scored (FIT %, agreement) with the fitted parameters, and the judges of the wheel
        loops' integral term: when the fit frees it, the fit is also made with P loops and the
        one that predicts these logs better is returned, with a note
        (:func:`_judge_integral`).
    robot : str
        Robot name written in the result.
    loss, f_scale : str, float
        Robust loss of the data residuals and its inlier scale (in units of ``scale``).
    scale : "tol", "std" or (s_v, s_w)
        Residual scale per channel: the agreement tolerances (default), the channels' standard
        deviations, or explicit values (m/s, rad/s).
    weights : (float, float)
        Extra weight of the v and w channels.
    tol_v, tol_w : float
        Agreement tolerances (m/s, rad/s) for the scores.
    dt_s : float
        Integration step of the reduced model, s.
    odom_v_window_s : float
        Measurement model of v: the odometry's v is the mean over this preceding window, s
        (wheel-encoder tick differences over one odometry period, e.g. 1/30 s on a
        TurtleBot3); 0 (default) compares the instantaneous model v. A log with its own
        measurement operator (``log.measurement``, :mod:`robots.measurement`: a pose
        derivative, a zero-order hold) is read through that instead, in v and w.
    w_source : {"imu", "wheels"}
        Where the logs' yaw rate comes from (the spec's ``odometry.w_source``): a gyro reads
        the model's body rate, wheel encoders read it times the effective over the driver's
        track (:func:`robots.measurement.yaw_reading_factor`; a skid steer's slip is invisible
        to them).
    max_nfev : int
        Cap on residual evaluations of the optimiser (hitting it is a warning).
    python : bool
        Run the plain-Python model loop (benchmark baseline; identical numbers, much slower).
    bootstrap : int
        Number of block-bootstrap replicates over ``segment_s``-second segments of the fit
        logs (0 = none), a check on the Jacobian errors. Draws from
        ``numpy.random.default_rng(seed)``.
    segment_s : float
        Segment length of the bootstrap, s.
    seed : int
        Seed of the bootstrap draws.
    progress : callable, optional
        ``progress(stage, fraction)``, called as the fit advances.
    map_sessions : callable, optional
        ``map_sessions(fn, groups) -> [fn(g) for g in groups]`` for several logs, e.g. one Ray
        task per session (``sim2real.cluster.map_tasks``); the results are identical to the
        default in-process loop.

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
    options: dict[str, Any] = {
        "geometry": geometry,
        "base_params": base_params,
        "free": free,
        "validate": validate,
        "robot": robot,
        "loss": loss,
        "f_scale": f_scale,
        "scale": scale,
        "weights": weights,
        "tol_v": tol_v,
        "tol_w": tol_w,
        "dt_s": dt_s,
        "odom_v_window_s": odom_v_window_s,
        "w_source": w_source,
        "max_nfev": max_nfev,
        "python": python,
        "bootstrap": bootstrap,
        "segment_s": segment_s,
        "seed": seed,
        "progress": progress,
        "map_sessions": map_sessions,
    }
    result = _fit_once(logs, priors=priors, **options)
    return _judge_integral(
        result,
        lambda: _fit_once(logs, priors=_p_loops(priors, base_params, geometry), **options),
        (tol_v, tol_w),
        started,
    )


#: The wheel loops' integral gain, judged on the validation logs (:func:`_judge_integral`).
_INTEGRAL = "speed_loop_ki_per_s"
#: Validation errors within this fraction of each other are a tie (one validation log cannot
#: resolve a 1 % difference of a mean squared error): the P loops, the simpler model, win it.
_TIE = 0.01


def _p_loops(
    priors: Mapping[str, Prior] | None, base: DriveParams, geometry: BaseGeometry
) -> dict[str, Prior]:
    """``priors`` with the wheel loops' integral gain known to be 0 (P loops)."""
    out = _check_priors(priors, base, geometry)
    out[_INTEGRAL] = dataclasses.replace(out[_INTEGRAL], nominal=0.0, sd=0.0, session_sd=0.0)
    return out


def _validation_error(result: SysidResult, tol: tuple[float, float]) -> float:
    """Mean over the validation logs of the squared RMSE in tolerance units, v plus w."""
    errs = [(s.rmse_v / tol[0]) ** 2 + (s.rmse_w / tol[1]) ** 2 for s in result.scores_validation]
    finite = [e for e in errs if math.isfinite(e)]
    return float(np.mean(finite)) if finite else math.nan


def _judge_integral(
    result: SysidResult,
    p_loops: Callable[[], SysidResult],
    tol: tuple[float, float],
    started: float,
) -> SysidResult:
    r"""The fit with the wheel loops' integral term, or with P loops if the validation logs
    say so.

    An integral term shows in a log as the slow part of a step response, and it sets how far
    a large step overshoots: the speed error integrated during the rise (about the step times
    the loop's time constant) is worked off again beyond the target. A log whose steps are
    small or end in the wheel-speed cap constrains it little while friction and the integral
    trade off, so the in-sample fit can prefer it and still overshoot where a held-out log
    reverses a wheel or spins at the cap. In-sample likelihood always favours the larger
    model; held-out prediction judges the two nested loop structures fairly: the fit is redone
    with P loops (:math:`k_i = 0`, every other field as before) and the one whose mean squared
    validation error (v and w in tolerance units, :func:`_validation_error`) is lower is
    returned, P loops on a tie (:data:`_TIE`). Without validation logs, or when the fit did
    not free the integral gain, ``result`` as it is.
    """
    if not result.scores_validation or _INTEGRAL not in result.settings.get("free", ()):
        return result
    alt = p_loops()
    with_ki, without = _validation_error(result, tol), _validation_error(alt, tol)
    if not (math.isfinite(with_ki) and math.isfinite(without)):
        return result
    said = (
        f"the validation logs judged the wheel loops' integral term: their mean squared error "
        f"(v and w in tolerance units) is {with_ki:.3g} with it ({_INTEGRAL} "
        f"{result.params.speed_loop_ki_per_s:.3g} 1/s) and {without:.3g} with P loops"
    )
    if with_ki < (1.0 - _TIE) * without:
        return dataclasses.replace(result, warnings=(*result.warnings, f"{said}: it is kept"))
    return dataclasses.replace(
        alt,
        warnings=(*alt.warnings, f"{said}: P loops are kept ({_INTEGRAL} 0)"),
        settings=alt.settings | {"seconds": time.perf_counter() - started},
        priors=alt.priors | {_INTEGRAL: result.priors[_INTEGRAL]},
    )


def _fit_once(
    logs: Sequence[object],
    *,
    geometry: BaseGeometry,
    base_params: DriveParams,
    priors: Mapping[str, Prior] | None,
    free: str | Sequence[str] | None,
    validate: Sequence[object],
    robot: str,
    loss: str,
    f_scale: float,
    scale: str | tuple[float, float],
    weights: tuple[float, float],
    tol_v: float,
    tol_w: float,
    dt_s: float,
    odom_v_window_s: float,
    w_source: str,
    max_nfev: int,
    python: bool,
    bootstrap: int,
    segment_s: float,
    seed: int,
    progress: Progress | None,
    map_sessions: Callable[[Callable[[Any], Any], Sequence[Any]], Sequence[Any]] | None,
) -> SysidResult:
    """:func:`fit_drive` with the given priors (no judging of the integral term)."""
    started = time.perf_counter()
    _check_args(loss, scale, weights)
    _check_numbers(logs, dt_s, bootstrap, segment_s, odom_v_window_s)
    report = progress or (lambda stage, frac: None)
    fit_logs = [as_log_arrays(g, i) for i, g in enumerate(logs)]
    val_logs = [as_log_arrays(g, len(fit_logs) + i) for i, g in enumerate(validate)]
    mapper, notes = _start(fit_logs, geometry, base_params, priors)
    notes[:0] = [
        f"{log_name(g, i)}: {w}" for i, g in enumerate([*logs, *validate]) for w in log_warnings(g)
    ]
    notes += [f"{name}: {model.sentence()}" for name, model in _operated(fit_logs)]
    base = mapper.base
    informative = {n for n, p in mapper.priors.items() if p.informative}
    report("checking excitation", 0.0)
    sv, sw = _scales(fit_logs, scale, tol_v, tol_w)
    problem_kw: dict[str, Any] = {
        "scale_v": sv,
        "scale_w": sw,
        "weight_v": weights[0],
        "weight_w": weights[1],
        "dt_s": dt_s,
        "v_window_s": odom_v_window_s,
        "w_source": w_source,
    }
    groups = [fit_logs] if len(fit_logs) == 1 else [[g] for g in fit_logs]
    session = _Session(
        geometry=geometry,
        base=base,
        free=free,
        mapper=mapper,
        options=MapOptions(
            problem_kw=problem_kw, loss=loss, f_scale=f_scale, max_nfev=max_nfev, python=python
        ),
        several=len(groups) > 1,
        informative=frozenset(informative),
    )
    posts = _fit_sessions(session, groups, map_sessions, notes, report, max_nfev)
    notes += _convergence_notes(
        posts, [g.name for g in fit_logs] if len(posts) > 1 else ["fit"], max_nfev
    )
    report("uncertainty", 0.92)
    summary = _single(posts[0]) if len(posts) == 1 else _fleet(posts, fit_logs, mapper, problem_kw)
    notes += mapper.floor_notes(summary.params)
    return _finish(
        summary=summary,
        posts=posts,
        mapper=mapper,
        noise=_noise(posts, fit_logs),
        fit_logs=fit_logs,
        val_logs=val_logs,
        notes=notes,
        robot=robot,
        problem_kw=problem_kw,
        settings={
            "loss": loss,
            "f_scale": f_scale,
            "scale_v": sv,
            "scale_w": sw,
            "weights": list(weights),
            "dt_s": dt_s,
            "odom_v_window_s": odom_v_window_s,
            "w_source": w_source,
            "measurement": {name: model.describe() for name, model in _operated(fit_logs)},
            **_measurement_noise(fit_logs),
            "max_nfev": max_nfev,
            "bootstrap": {"replicates": bootstrap, "segment_s": segment_s, "seed": seed},
        },
        scoring={
            "dt_s": dt_s,
            "tol_v": tol_v,
            "tol_w": tol_w,
            "odom_v_window_s": odom_v_window_s,
            "w_source": w_source,
        },
        bootstrap=(bootstrap, segment_s, seed, loss, f_scale),
        started=started,
        report=report,
    )


def _operated(logs: Sequence[LogArrays]) -> list[tuple[str, MeasurementModel]]:
    """(file, operator) of the logs with a measurement operator (:mod:`robots.measurement`),
    the first piece of each file."""
    seen: dict[str, MeasurementModel] = {}
    for g in logs:
        if g.measurement is not None:
            seen.setdefault(g.name.split(" (segment")[0].split("[")[0], g.measurement)
    return list(seen.items())


def _start(
    fit_logs: Sequence[LogArrays],
    geometry: BaseGeometry,
    base_params: DriveParams,
    priors: Mapping[str, Prior] | None,
) -> tuple[Mapper, list[str]]:
    """The coordinate mapper of the checked priors around ``base_params`` (with the command
    timeout the logs show) and the timeout's notes."""
    pri = _check_priors(priors, base_params, geometry)
    pri, raised = _raise_exceeded_caps(fit_logs, geometry, pri)
    base = _prior_base(base_params, pri)
    base, timeout_notes = fit_cmd_timeout(fit_logs, base)  # held or timed-out commands
    return Mapper(geometry, base, pri), raised + timeout_notes


def _raise_exceeded_caps(
    fit_logs: Sequence[LogArrays], geometry: BaseGeometry, priors: dict[str, Prior]
) -> tuple[dict[str, Prior], list[str]]:
    """The priors with each finite speed limit the logs exceed by
    :data:`sysid._needs.BEYOND_PRIOR_FACTOR` or more centred on what they measured
    (:func:`sysid._needs.measured_speeds`), and a note per limit moved.

    A prior centred far below a speed the robot was measured at is contradicted by the log: the
    limit is at least that speed (a proven lower bound). Centred there, with its spread, the fit
    starts from a cap the log allows and the prior no longer holds the fit below the data.
    """
    seen = measured_speeds([g.meas_v for g in fit_logs], [g.meas_w for g in fit_logs], geometry)
    out, notes = dict(priors), []
    for name, speed in seen.items():
        p = priors.get(name)
        if p is None or not math.isfinite(p.nominal) or speed < BEYOND_PRIOR_FACTOR * p.nominal:
            continue
        out[name] = dataclasses.replace(p, nominal=speed)
        notes.append(
            f"the logs measure {name} {speed:.4g} (99th percentile), above its prior centre "
            f"{p.nominal:.4g}: the limit is at least that, so its prior is centred there"
        )
    return out, notes


def _measurement_noise(fit_logs: Sequence[LogArrays]) -> dict[str, Any]:
    """``settings.measurement_noise``: the fitted logs' own odometry noise where they run
    steady (:func:`sysid.steady.steady_noise`, no model), the measurement's share of the
    noise the residuals show, with the parts of its growth with speed the logs tell
    (:func:`sysid.steady.speed_noise`: ``floor_v_mps``, ``fraction_v``, ``floor_w_radps``,
    ``fraction_w``); nothing when no log runs steady long enough to tell it."""
    columns = [
        (
            log.meas_t_s,
            held_command(log.cmd_t_s, log.cmd_v, log.meas_t_s),
            held_command(log.cmd_t_s, log.cmd_w, log.meas_t_s),
            log.meas_v,
            log.meas_w,
        )
        for log in fit_logs
    ]
    own = pooled_steady_noise([steady_noise(*c) for c in columns])
    if not own.measured:
        return {}
    lead = max((measurement_lead_s(log.measurement) for log in fit_logs), default=0.0)
    law = speed_noise(columns, ahead_s=lead)
    return {
        "measurement_noise": {
            "std_v_mps": own.std_v_mps,
            "std_w_radps": own.std_w_radps,
            "samples": own.n_samples,
            # the noise's growth with speed (sysid.steady.SpeedNoise), the parts these logs
            # measure: a checked log takes them where it cannot tell its own
            **{k: getattr(law, k) for k in law.told},
        }
    }


def _noise(posts: Sequence[Posterior], fit_logs: Sequence[LogArrays]) -> ObservationNoise:
    """The observation noise the fits' residuals show."""
    res_v, res_w = (
        np.concatenate(parts) for parts in zip(*map(_channel_residuals, posts), strict=True)
    )
    return estimate_noise(fit_logs, res_v, res_w)


def _fit_sessions(
    session: _Session,
    groups: Sequence[Sequence[LogArrays]],
    map_sessions: Callable[[Callable[[Any], Any], Sequence[Any]], Sequence[Any]] | None,
    notes: list[str],
    report: Progress,
    max_nfev: int,
) -> list[Posterior]:
    """The posterior of each group of logs, through ``map_sessions`` or in this process."""
    posts: list[Posterior] = []
    if map_sessions is not None and len(groups) > 1:
        # one task per session (e.g. Ray): no per-evaluation progress, notes merged in order
        report("fitting", 0.05)
        for post, session_notes in map_sessions(session, groups):
            posts.append(post)
            notes += session_notes
        return posts
    for k, group in enumerate(groups):
        lo, span = 0.05 + 0.85 * k / len(groups), 0.85 / len(groups)

        def on_eval(n: int, lo: float = lo, span: float = span) -> None:
            report("fitting", lo + span * min(n / (4 * max_nfev), 1.0))

        post, _ = session(group, on_eval=on_eval, notes=notes)
        posts.append(post)
    return posts


def _proven_lower_bounds(
    s: FitSummary, mapper: Mapper, dist: DriveDistribution
) -> dict[str, float]:
    """Lower bounds of the limits the fit logs never reached (:mod:`sysid._needs`)."""
    sims = s.problem.simulate(s.params)
    needs = limit_needs(
        [g.meas_t_s for g in s.problem.logs],
        [r.v for r in sims],
        [r.w for r in sims],
        s.params,
        mapper.geometry,
    )
    return lower_bounds(needs, s.params, dist.names)


def _finish(
    *,
    summary: FitSummary,
    posts: Sequence[Posterior],
    mapper: Mapper,
    noise: ObservationNoise,
    fit_logs: Sequence[LogArrays],
    val_logs: Sequence[LogArrays],
    notes: list[str],
    robot: str,
    problem_kw: dict[str, Any],
    settings: dict[str, Any],
    scoring: dict[str, Any],
    bootstrap: tuple[int, float, int, str, float],
    started: float,
    report: Progress,
) -> SysidResult:
    s = summary
    corr = _correlation(s.cov, list(s.weak), list(s.free), notes)
    estimates = field_estimates(mapper, s)
    identifiable = identifiable_estimates(s.problem, s.u, s.cov_u, s.weak)
    dist = distribution(robot, mapper, s, noise, sessions=len(posts))
    dist = dataclasses.replace(dist, lower=_proven_lower_bounds(s, mapper, dist))
    boot_std = _replicate(bootstrap, s, posts, mapper, fit_logs, problem_kw, report)
    report("scoring", 0.95)
    scores_fit = score_logs(fit_logs, s.params, mapper.geometry, **scoring)
    scores_val = score_logs(val_logs, s.params, mapper.geometry, **scoring) if val_logs else ()
    data = tuple(DataFile(file=g.name, sha256=g.sha256, role="fit") for g in fit_logs) + tuple(
        DataFile(file=g.name, sha256=g.sha256, role="validation") for g in val_logs
    )
    settings = settings | _run_settings(s, posts, started)
    sessions = (
        tuple(_session_entry(p, mapper, g.name) for p, g in zip(posts, fit_logs, strict=True))
        if len(posts) > 1
        else ()
    )
    report("done", 1.0)
    return SysidResult(
        robot=robot,
        params=s.params,
        estimates=estimates,
        identifiable=identifiable,
        correlation_names=tuple(s.free),
        correlation=tuple(tuple(float(c) for c in row) for row in corr),
        linear=_linear_stats(identifiable),
        scores_fit=scores_fit,
        scores_validation=scores_val,
        data=data,
        tool_version=_tool_version(),
        warnings=tuple(notes),
        settings=settings,
        bootstrap_std=boot_std,
        randomization=dist,
        sessions=sessions,
        priors=_priors_doc(mapper.priors),
        envelope=envelope_of(fit_logs, tol_v=scoring["tol_v"], tol_w=scoring["tol_w"]),
    )


def _replicate(
    bootstrap: tuple[int, float, int, str, float],
    s: FitSummary,
    posts: Sequence[Posterior],
    mapper: Mapper,
    fit_logs: Sequence[LogArrays],
    problem_kw: dict[str, Any],
    report: Progress,
) -> dict[str, float]:
    """The block-bootstrap standard deviations (empty without replicates)."""
    replicates, segment_s, seed, loss, f_scale = bootstrap
    if replicates <= 0:
        return {}
    report("bootstrap", 0.93)
    coupled = any(p.coupled for p in posts)

    def solve(pr: Problem, x0: FloatArray) -> Any:
        return _solve(pr, x0, coupled, loss, f_scale, 12)

    return _bootstrap_std(
        fit_logs,
        s,
        mapper,
        solve=solve,
        problem_kw=problem_kw | {"prior_weight": posts[0].problem.prior_weight},
        replicates=replicates,
        segment_s=segment_s,
        seed=seed,
    )


def _jitter_settings(post: Posterior) -> dict[str, Any]:
    """A session's arrival-time jitter (:class:`sysid._timing.JitterEstimate`) as settings."""
    est = post.jitter
    if est is None:
        return {}
    return {
        "jitter_s": est.sigma_t_s,
        "commands": est.commands,
        "spread": est.spread,
        "whitened": post.problem.timing is not None,
    }


def _run_settings(s: FitSummary, posts: Sequence[Posterior], started: float) -> dict[str, Any]:
    """The result's settings that the run found (free fields, optimiser, cost, time)."""
    return {
        "free": list(s.free),
        "ties": dict(s.ties),
        "model_evaluations": sum(p.evaluations for p in posts),
        "model_steps": sum(p.steps for p in posts),
        "optimizer_status": "; ".join(p.message for p in posts),
        "converged": all(p.converged for p in posts),
        "cost": sum(p.cost for p in posts),
        "std_inflation_autocorr": max(p.inflation for p in posts),
        # per session: the commands' arrival-time jitter its residuals show (sysid._timing)
        "command_jitter": [_jitter_settings(p) for p in posts],
        "prior_weight": [p.problem.prior_weight for p in posts],
        "sessions": len(posts),
        "seconds": time.perf_counter() - started,
        "note": (
            "MAP fit against the spec priors: velocity data only identify mass/gain ratios, "
            "the priors keep masses and inertias near theirs and move the rest into the motor "
            "gain; see 'identifiable' for what the data fix on their own"
        ),
    }
