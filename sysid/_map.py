r"""MAP fit of one set of logs: robust data residuals plus prior residuals, and the posterior.

The objective is :math:`\sum_i \rho(f_i) + \sum_j w_p^2 ((z_j - \mu_j)/\sigma_j)^2` with
:math:`f_i` the scaled output errors, :math:`\rho` the robust loss and :math:`w_p^2 = s^2 c`
the data residuals' variance (robust MAD scale :math:`s`) times the autocorrelation factor
:math:`c` (integrated autocorrelation time): up to a constant the negative log posterior, with
correlated residuals counted as the fewer independent samples they are worth.

The posterior precision is the data's Godambe (sandwich) information
:math:`J^T J\,\hat S^{+} J^T J` plus the prior's, with :math:`\hat S` the
heteroscedasticity- and autocorrelation-consistent covariance of the residuals' scores
(:func:`score_covariance`): per direction of the parameter space rather than one factor for
all, so parameters that transients inform (where stamp jitter and model error concentrate)
get the spread they have. The model's time-step error is propagated too
(:func:`_discretisation_bias`), as an inflation bounded so that it never widens the posterior
past the prior (:func:`bounded_bias`): where the log is informative the posterior is narrow,
where not it is the prior.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

from robots.arrays import FloatArray
from robots.params import DriveParams
from sysid._coords import Mapper
from sysid._excitation import Excitation
from sysid._initial import busiest_window, initial_coords
from sysid._logs import LogArrays, crop_log
from sysid._problem import Problem
from sysid._timing import JitterEstimate, arrival_whitener
from sysid.steady import robust_sd

__all__ = [
    "FittedCoords",
    "MapOptions",
    "Posterior",
    "bounded_bias",
    "data_information",
    "map_fit",
    "noise_scale",
    "score_covariance",
]


#: Logs longer than this (s, in total) are first fitted on their busiest windows.
_COARSE_SPAN_S = 150.0
#: A restart replaces the first start's fit only when it lowers the negative log posterior
#: (the objective over :math:`w_p^2`) by more than this (a likelihood ratio of e^2 ~ 7, with
#: correlated residuals counted as the fewer samples they are worth): smaller differences are
#: near-ties, and the first start's answer is kept.
_RESTART_NLL = 2.0
#: Logs longer than this (s, in total) compare the fit's starts (:func:`restarts`) on their
#: busiest windows of ``_SCOUT_SPAN_S`` seconds in total, with an evaluation cap of
#: ``_SCOUT_NFEV`` each; shorter logs run every start to convergence (eight starts to
#: convergence on five 90 s sessions cost 2.3x four).
_FULL_STARTS_SPAN_S = 30.0
_SCOUT_SPAN_S, _SCOUT_NFEV = 20.0, 8
#: Logs up to :data:`_COARSE_SPAN_S` then run the first start and this many of the best
#: scouted others to convergence.
_SCOUTED_FULL = 2
#: Residual-evaluation cap of the polishing pass on all the data.
_POLISH_NFEV = 3
#: 95 % quantile of the chi-square distribution with one degree of freedom.
_CHI2_1_95 = 3.84
#: Evaluation cap of the refit without a limit (likelihood-ratio test).
_LR_NFEV = 8
#: A limit whose removal (without refit) costs this much chi-square is kept without a refit.
_CHI2_OBVIOUS = 1e4
#: Evaluation cap of the re-balancing pass when the residual scale moved a lot.
_REBALANCE_NFEV = 5
#: Skid steer: starts of log(track_factor) tried besides the spec's, in prior sds (see
#: :func:`_map_point`).
_TRACK_RESTARTS_SD = (-1.0, 1.0)
#: Skid steer: at most this many rounds of re-balancing the prior weight on the candidate
#: fits (:func:`_final_choice`; one suffices on the skid plant's logs).
_REBALANCE_ROUNDS = 3
#: Extra starts of the fit: prior mean + k sd of these fields (see :func:`restarts`).
_RESTART_SDS: dict[str, tuple[float, ...]] = {
    "speed_loop_ki_per_s": (-1.5, 1.5),
    "delay_s": (0.0,),
    "wheel_torque_max_nm": (-1.5,),
}
#: Extra starts from the released start (:func:`released_start`), as :data:`_RESTART_SDS`.
_RELEASED_RESTART_SDS: dict[str, tuple[float, ...]] = {
    "wheel_torque_max_nm": (-1.5, 1.5),
}
#: Acceleration limits whose "no limit" start is one of the fit's starts (see
#: :func:`released_start`).
_ACCEL_LIMITS = ("accel_lim_v_mps2", "accel_lim_w_radps2")
#: Limits that can be "never active" in a log.
_LIMITS = (
    "accel_lim_v_mps2",
    "accel_lim_w_radps2",
    "wheel_speed_max_radps",
    "speed_lim_v_mps",
    "speed_lim_w_radps",
    "wheel_torque_max_nm",
)


@dataclass(frozen=True, kw_only=True)
class MapOptions:
    """How :func:`map_fit` solves.

    Attributes
    ----------
    problem_kw : dict
        Keywords of every :class:`~sysid._problem.Problem` it builds (scales, weights, step).
    loss : str
        scipy's robust loss (``soft_l1``, ``linear``, ``huber``, ``cauchy``, ``arctan``).
    f_scale : float
        Its soft margin between inlier and outlier residuals.
    max_nfev : int
        Evaluation limit of the optimiser.
    python : bool
        Simulate in plain Python rather than with the compiled kernel.
    """

    problem_kw: dict[str, Any]
    loss: str
    f_scale: float
    max_nfev: int
    python: bool = False


@dataclass(frozen=True, kw_only=True)
class FittedCoords:
    """The fitted coordinates, their MAP point and posterior covariance.

    Attributes
    ----------
    free : tuple of str
        Fitted coordinates (the fields kept after dropping never-active, prior-less limits).
    ties : dict
        ``{field: source}`` equalities among them.
    u : ndarray
        MAP point in internal fit coordinates (:mod:`sysid._coords`).
    cov_u : ndarray
        Posterior covariance in internal coordinates.
    z : ndarray
        MAP point in schema coordinates.
    cov : ndarray
        Posterior covariance in schema coordinates (inf on the diagonal of coordinates that
        nothing determines).
    weak : tuple of int
        Indices of coordinates that neither the data nor a prior determine.
    params : DriveParams
        Parameters at the MAP point.
    problem : Problem
        The problem over :attr:`free` (for derived quantities and scoring).
    """

    free: tuple[str, ...]
    ties: dict[str, str]
    u: FloatArray
    cov_u: FloatArray
    z: FloatArray
    cov: FloatArray
    weak: tuple[int, ...]
    params: DriveParams
    problem: Problem

    def coords(self) -> dict[str, Any]:
        """These fields as keywords (to build another :class:`FittedCoords` from them)."""
        return {f.name: getattr(self, f.name) for f in fields(FittedCoords)}


@dataclass(frozen=True, kw_only=True)
class Posterior(FittedCoords):
    """Outcome of :func:`map_fit`: the :class:`FittedCoords` and how the fit went.

    Attributes
    ----------
    info : ndarray
        Data information :math:`G^{-T} J^T J G^{-1}/(s^2 c)` in schema coordinates.
    inflation : float
        Autocorrelation factor :math:`c`.
    residuals : ndarray
        Scaled data residuals at the MAP point.
    converged : bool
        False when the optimiser stopped at its evaluation limit.
    message : str
        The optimiser's status message.
    cost : float
        Final objective.
    evaluations, steps : int
        Model evaluations and integration steps used.
    coupled : bool
        The axes were coupled (dense Jacobian).
    jitter : JitterEstimate or None
        The commands' arrival-time jitter the residuals showed (:mod:`sysid._timing`); the
        fit whitened its residuals for it when it is significant. None: not estimated.
    """

    info: FloatArray
    inflation: float
    residuals: FloatArray
    converged: bool
    message: str
    cost: float
    evaluations: int
    steps: int
    coupled: bool
    jitter: JitterEstimate | None = None


def _rho(kind: str, z: FloatArray) -> FloatArray:
    """scipy's robust losses: rows rho, rho', rho'' of ``z = f**2``."""
    out = np.empty((3, z.size))
    if kind == "linear":
        out[0], out[1], out[2] = z, 1.0, 0.0
    elif kind == "soft_l1":
        t = 1.0 + z
        out[0], out[1], out[2] = 2.0 * (np.sqrt(t) - 1.0), t**-0.5, -0.5 * t**-1.5
    elif kind == "huber":
        big = z > 1.0
        sz = np.sqrt(np.where(big, z, 1.0))
        out[0] = np.where(big, 2.0 * sz - 1.0, z)
        out[1] = np.where(big, 1.0 / sz, 1.0)
        out[2] = np.where(big, -0.5 / (sz * sz * sz), 0.0)
    elif kind == "cauchy":
        t = 1.0 + z
        out[0], out[1], out[2] = np.log1p(z), 1.0 / t, -1.0 / (t * t)
    else:  # arctan
        t = 1.0 + z * z
        out[0], out[1], out[2] = np.arctan(z), 1.0 / t, -2.0 * z / (t * t)
    return out


def _loss(kind: str, n_data: int) -> Callable[[FloatArray], FloatArray]:
    """Robust loss on the data rows, squared loss on the prior rows."""

    def loss(z: FloatArray) -> FloatArray:
        out = _rho(kind, z)
        out[0, n_data:], out[1, n_data:], out[2, n_data:] = z[n_data:], 1.0, 0.0
        return out

    return loss


def _solve(
    prob: Problem, x0: FloatArray, coupled: bool, loss: str, f_scale: float, max_nfev: int
) -> Any:
    """One trust-region-reflective run (single-threaded BLAS: the Jacobian is tall and thin)."""
    with threadpool_limits(limits=1):
        return least_squares(
            prob.residuals,
            x0,
            jac=lambda x: prob.jacobian(x, coupled),
            bounds=(prob.lower, prob.upper),
            loss=_loss(loss, prob.n_data),
            f_scale=f_scale,
            x_scale="jac",
            method="trf",
            ftol=1e-6,
            xtol=1e-6,
            gtol=1e-8,
            max_nfev=max_nfev,
        )


def _autocorr_time(r: FloatArray, max_lag: int = 400) -> float:
    """Integrated autocorrelation time :math:`1 + 2\\sum_k \rho_k` of a residual series
    (Geyer's initial positive sequence: pairs of lags are summed while their sum is > 0)."""
    r = r - np.mean(r)
    n = r.size
    if n < 8 or not np.any(r):
        return 1.0
    spec = np.fft.rfft(r, 2 * n)
    acov = np.fft.irfft(spec * np.conj(spec))[: min(max_lag, n - 1) + 1]
    rho = acov / acov[0]
    tau = 1.0
    for k in range(1, rho.size - 1, 2):
        pair = float(rho[k] + rho[k + 1])
        if pair <= 0:
            break
        tau += 2.0 * pair
    return tau


def noise_scale(prob: Problem, f: FloatArray, n_params: int) -> tuple[float, float]:
    """Robust residual variance :math:`s^2` and the correlation factor :math:`c`.

    :math:`c` is the integrated autocorrelation time of the residuals (mean over the v and w
    channels): correlated residuals -- model error that lasts over several samples, stamp
    jitter -- carry as much information as :math:`n/c` independent ones; counting them as
    :math:`n` would make the intervals far too narrow.

    :math:`s^2` is the scaled median absolute deviation of the rows that can show noise. A
    quantised channel (:func:`sysid._problem.quantised`: an encoder's speed) reads exactly
    zero at every speed under one tick per period, so where the model predicts zero too (at
    rest) its residual is exactly zero whatever the noise: those rows are left out (all rows
    count when fewer than ``n_params + 2`` others remain). Counted, a recording that stands
    for half its length would put the median at zero and the scale on its floor, and the
    priors would weigh nothing against the data.
    """
    n = f.size
    g = f[~(prob.quantised & (f == 0.0))]
    g = g if g.size >= n_params + 2 else f
    s2 = robust_sd(g) ** 2 * n / max(n - n_params, 1)
    taus = [_autocorr_time(f[rows]) for rows in (prob.rows["v"], prob.rows["w"]) if rows.size]
    c = float(np.clip(np.mean(taus) if taus else 1.0, 1.0, 200.0))
    return max(s2, 1e-12), c


def _span(log: LogArrays) -> float:
    return float(log.meas_t_s[-1] - log.meas_t_s[0])


def restarts(prob: Problem, x0: FloatArray, extra: Sequence[FloatArray] = ()) -> list[FloatArray]:
    """Start points of the fit: ``x0``, the ``extra`` starts (:func:`released_start`) and, per
    multimodal field (:data:`_RESTART_SDS`) that is free and has a prior, ``x0`` with that
    field at its prior mean + k sd (inside the bounds); per field of
    :data:`_RELEASED_RESTART_SDS`, each ``extra`` start likewise.

    A delay and the wheel loops' integral gain trade off against each other and against the
    friction and mass ratios: from one start the optimiser ends, on about one synthetic plant
    in three drawn from the TurtleBot3 priors, in a local minimum whose objective is 1.5-3x
    the one at the truth (a delay pinned at 0, an integral gain half the truth), and that
    plant's 95 % intervals miss the truth by 3-11 sd. The torque cap trades against an
    acceleration limit and the integral gain (both shape the transients): from the spec's cap
    the fit can explain torque-limited transients by a limit and a low integral gain, at twice
    the objective of the truth's basin. The shift is made in the field's schema coordinate
    (the prior's), which moves its internal coordinate by the same amount (lin: the value;
    the torque cap: the log of its ratio to the motor gain).
    """
    out = [np.asarray(x0, dtype=np.float64)]
    out += [np.asarray(x, dtype=np.float64) for x in extra]
    for table, bases in ((_RESTART_SDS, out[:1]), (_RELEASED_RESTART_SDS, out[1:])):
        for field, sds in table.items():
            prior = prob.mapper.prior(field) if field in prob.free else None
            if prior is None:
                continue
            j, (mean, sd) = prob.free.index(field), prior
            for base in bases:
                z = float(prob.schema_coords(base)[0][j])
                for k in sds:
                    x = base.copy()
                    x[j] = float(np.clip(base[j] + mean + k * sd - z, prob.lower[j], prob.upper[j]))
                    if abs(x[j] - base[j]) > 0.25 * sd:
                        out.append(x)
    return out


def released_start(
    logs: Sequence[LogArrays], mapper: Mapper, exc: Excitation, free: Sequence[str]
) -> FloatArray | None:
    """The start with the free acceleration limits that have no spec value at "no limit" and
    the other coordinates re-estimated for that (:func:`sysid._initial.initial_coords` with
    ``release_accel_limits``); None when no such limit is free.

    The first start puts such a limit at the log's smoothed peak acceleration, which smoothing
    keeps below the plant's real peak: the limit starts active. From there the optimiser can
    end in a basin where the limit shapes every transient and the wheel loops' integral gain,
    the motor gain and the torque cap compensate: on synthetic TurtleBot3 plants drawn from
    the priors (truth: no limit) such fits ended with an integral gain 50-60 % below the truth,
    4-6 sd outside its interval, at 1.8-2.4x the objective of the truth's basin. A start from
    the other explanation of the transients (no limit; with the torque cap at its prior mean
    +- 1.5 sd, :data:`_RELEASED_RESTART_SDS`) lets the objective choose.
    """
    names = [f for f in _ACCEL_LIMITS if f in free and mapper.prior(f) is None]
    if not names or all(math.isfinite(float(getattr(mapper.base, f))) for f in names):
        return None
    coords, _ = initial_coords(
        logs,
        mapper.geometry,
        mapper.base,
        exc.free,
        exc.ties,
        mapper.priors,
        release_accel_limits=True,
    )
    return np.array([coords[f] for f in free])


def _best(
    prob: Problem,
    starts: Sequence[FloatArray],
    solve: Callable[[Problem, FloatArray, int], Any],
    nfev: int,
    pool: list[Any] | None = None,
) -> Any:
    """The fit from ``starts[0]``, unless another start ends in a clearly lower basin
    (:func:`_clearly_lower`): near-ties keep the first start's answer. Every start's fit is
    appended to ``pool`` when one is given."""
    first = best = solve(prob, starts[0], nfev)
    found = [first]
    for x in starts[1:]:
        res = solve(prob, x, nfev)
        found.append(res)
        if float(res.cost) < float(best.cost) and _clearly_lower(prob, res.cost, first.cost):
            best = res
    if pool is not None:
        pool += found
    return best


def _clearly_lower(prob: Problem, cost: float, reference: float) -> bool:
    """Whether ``cost`` is below ``reference`` by more than :data:`_RESTART_NLL` in negative
    log posterior units (the objective is :math:`w_p^2` times the negative log posterior)."""
    return (float(reference) - float(cost)) > _RESTART_NLL * prob.prior_weight**2


def _optimise(
    prob: Problem,
    x0: FloatArray,
    solve: Callable[[Problem, FloatArray, int], Any],
    nfev: int,
    extra: Sequence[FloatArray] = (),
    pool: list[Any] | None = None,
) -> tuple[Any, bool]:
    """Least squares on all the data from several starts (:func:`restarts`); long logs first
    converge on their busiest windows.

    Returns the result and whether the main pass converged (did not hit ``nfev``); every fit
    on all the data that was compared on the way is appended to ``pool`` when one is given."""
    logs = prob.logs
    total_s = sum(_span(g) for g in logs)
    starts = restarts(prob, x0, extra)
    if len(starts) > 1 and total_s > _FULL_STARTS_SPAN_S:
        # longer logs: the starts are compared on short busy windows
        scout = prob.like(_windows(logs, _SCOUT_SPAN_S))
        costs = [float(solve(scout, x, _SCOUT_NFEV).cost) for x in starts]
        prob.n_evals, prob.n_steps = scout.n_evals, scout.n_steps
        if total_s <= _COARSE_SPAN_S:  # the first and the best scouted others to convergence
            starts = [starts[0], *(starts[k] for k in np.argsort(costs) if k != 0)]
            starts = starts[: 1 + _SCOUTED_FULL]
        else:
            k = int(np.argmin(costs))
            x0 = starts[k] if _clearly_lower(scout, costs[k], costs[0]) else starts[0]
    if total_s <= _COARSE_SPAN_S:
        res = _best(prob, starts, solve, nfev, pool)
        return res, res.status != 0
    coarse = prob.like(_windows(logs))
    coarse.n_evals, coarse.n_steps = prob.n_evals, prob.n_steps
    first = solve(coarse, x0, nfev)
    prob.n_evals, prob.n_steps = coarse.n_evals, coarse.n_steps
    res = solve(prob, np.asarray(first.x), min(nfev, _POLISH_NFEV))
    if pool is not None:
        pool.append(res)
    return res, first.status != 0


def _map_point(
    prob: Problem,
    x0: FloatArray,
    extra: Sequence[FloatArray],
    solve: Callable[[Problem, FloatArray, int], Any],
    nfev: int,
    notes: list[str],
) -> tuple[Any, bool, str]:
    """The optimiser's result from ``x0`` and the ``extra`` starts, whether its last pass
    converged and its message.

    A skid steer (``track_factor`` free) is also fitted with the track factor one prior sd
    below and above, and the candidate with the lowest negative log posterior of the final
    objective is kept (:func:`_final_choice`).

    The effective track trades against the yaw friction, the wheel loops' droop and the torque
    cap (the yaw-loop gain is :math:`K L \\chi L/(2r^2)`), and the trust region can end in a
    basin of twice the cost from a start that is close to the answer (seen on teleop logs of a
    Husky-like skid-steer plant with tyre forces, not this model). Differential drives (chi
    fixed) take the plain starts.
    """
    if "track_factor" not in prob.free:
        res, converged = _optimise(prob, x0, solve, nfev, extra)
        return res, converged, str(res.message)
    j = prob.free.index("track_factor")
    prior = prob.mapper.prior("track_factor")
    sd = prior[1] if prior is not None and prior[1] > 0 else 0.3
    track_starts = []
    for k in _TRACK_RESTARTS_SD:
        start = np.array(x0, dtype=np.float64)
        start[j] = float(np.clip(start[j] + k * sd, prob.lower[j] + 1e-6, prob.upper[j] - 1e-6))
        track_starts.append(start)
    pool: list[Any] = []
    _optimise(prob, x0, solve, nfev, extra, pool)
    origin = [0] * len(pool)
    for start in track_starts:
        _optimise(prob, start, solve, nfev, (), pool)
    origin += [1] * (len(pool) - len(origin))
    # one re-balance of the prior weight (every candidate re-solved under it), then the
    # track factor's starts again under that weight: the paths differ, and so do the minima
    _, _, _, rebalanced = _final_choice(prob, pool, solve, nfev, rounds=1)
    if rebalanced:
        for start in track_starts:
            _optimise(prob, start, solve, nfev, (), pool)
        origin += [1] * (len(pool) - len(origin))
    res, k_best, costs, again = _final_choice(prob, pool, solve, nfev)
    rebalanced = rebalanced or again
    own = min(c for c, i in zip(costs, origin, strict=True) if i == 0)
    if origin[k_best] != 0 and _clearly_lower(prob, res.cost, own):
        notes.append(
            f"the track factor's fit from the spec's start ended in a worse local minimum (cost "
            f"{own:.4g}); a start one prior sd away reached cost {float(res.cost):.4g}"
            f" (track_factor {math.exp(float(res.x[j])):.3g}), which is kept"
        )
    message = str(res.message)
    if rebalanced:
        message += " (the prior weight re-balanced at the solution, the candidates re-solved)"
    return res, res.status != 0, message


def _final_choice(
    prob: Problem,
    pool: list[Any],
    solve: Callable[[Problem, FloatArray, int], Any],
    nfev: int,
    rounds: int = _REBALANCE_ROUNDS,
) -> tuple[Any, int, list[float], bool]:
    """The fit of ``pool`` with the lowest final objective, every candidate on the same one.

    The objective is :math:`w_p^2` times the negative log posterior, and :math:`w_p^2` is
    estimated from the residuals: first at the start point, where on the skid plant's 90 s
    logs it is 240-600x its value at the solution (large, correlated residuals), so the
    starts run with priors that weigh hundreds of times too much. Costs rank basins only
    under one :math:`w_p`, and only the final one ranks them by the final negative log
    posterior: while the weight at the best candidate is off by more than 2x
    (:func:`_balanced`), it is set there and every distinct candidate is re-solved to
    convergence under it (``pool`` is updated in place; at most ``rounds`` rounds). Choosing
    before the re-balance and then polishing the choice a few steps lets a candidate ranked
    under the wrong weight win, and makes the choice flip under tiny changes of the plant.

    Returns the chosen fit, its index in ``pool``, every candidate's final cost and whether
    the weight was re-balanced.
    """
    cands = pool
    rebalanced = False
    for _ in range(rounds):
        best = min(range(len(cands)), key=lambda i: float(cands[i].cost))
        s2, c = noise_scale(prob, prob.data_residuals(np.asarray(cands[best].x)), len(prob.free))
        if _balanced(prob, s2 * c):
            break
        prob.prior_weight = math.sqrt(s2 * c)
        rebalanced = True
        done: list[tuple[FloatArray, Any]] = []
        for i, r in enumerate(cands):
            x = np.asarray(r.x)
            twin = next((res for y, res in done if np.array_equal(x, y)), None)
            cands[i] = twin if twin is not None else solve(prob, x, nfev)
            done.append((x, cands[i]))
    best = min(range(len(cands)), key=lambda i: float(cands[i].cost))
    return cands[best], best, [float(r.cost) for r in cands], rebalanced


def _balanced(prob: Problem, variance: float) -> bool:
    r"""Whether the prior weight :math:`w_p` is within 2x of :math:`\sqrt{s^2 c}` at a fit
    (``variance`` = :math:`s^2 c` there, :func:`noise_scale`); beyond that it is re-balanced."""
    return 0.5 <= math.sqrt(variance) / prob.prior_weight <= 2.0


def _windows(logs: Sequence[LogArrays], span_s: float = _COARSE_SPAN_S) -> list[LogArrays]:
    """The busiest windows of ``logs``, at most ``span_s`` seconds in total."""
    total_s = sum(_span(g) for g in logs)
    if total_s <= span_s:
        return list(logs)
    out = []
    for g in logs:
        rate = g.meas_t_s.size / max(_span(g), 1e-9)
        n = max(int(rate * span_s * _span(g) / total_s), 10)
        out.append(crop_log(g, *busiest_window(g, n)))
    return out


def _cost(prob: Problem, x: FloatArray, loss: str, f_scale: float) -> float:
    """The objective ``least_squares`` reports as ``cost`` at ``x`` (robust data rows)."""
    r = prob.residuals(x)
    rho = _loss(loss, prob.n_data)((r / f_scale) ** 2)
    return 0.5 * f_scale**2 * float(np.sum(rho[0]))


def _drop_inactive_limits(
    prob: Problem,
    res: Any,
    s2c: float,
    solve: Callable[[Problem, FloatArray, int], Any],
    notes: list[str],
    loss: tuple[str, float],
) -> list[int]:
    """Limits without a prior that the log does not show are not identified: they stay at
    "no limit" (their prior). Likelihood-ratio test: the fit is redone without the limit (a few
    steps from the solution) and the limit is kept only when that raises the objective by more
    than the 95 % chi-square quantile of one degree of freedom (in residual-variance units) and
    the response without it moves by 0.1 tolerance somewhere. Returns the indices to drop."""
    x = np.asarray(res.x)
    params = prob.params(x)
    ref = prob.scaled_sim(params)
    ss_fit = float(np.sum((ref - prob.meas) ** 2))
    dropped: list[int] = []
    for j, field in enumerate(prob.free):
        if field not in _LIMITS or prob.mapper.prior(field) is not None:
            continue
        unlimited = prob.scaled_sim(params.replace(**{field: math.inf}))
        gain = 0.0
        if float(np.max(np.abs(unlimited - ref))) >= 0.1:
            # without refitting: an upper bound of the test statistic (cheap)
            gain = (float(np.sum((unlimited - prob.meas) ** 2)) - ss_fit) / s2c
        if _CHI2_1_95 <= gain < _CHI2_OBVIOUS:
            # refit without the limit on the busiest windows (a few steps) and compare there
            rest = [f for i, f in enumerate(prob.free) if i != j and i not in dropped]
            win = prob.like(_windows(prob.logs))
            sub = win.subset(rest)
            alt = solve(sub, np.array([x[prob.free.index(f)] for f in rest]), _LR_NFEV)
            with_limit = _cost(win, x, *loss)
            gain = 2.0 * (float(alt.cost) - with_limit) / s2c
        if gain < _CHI2_1_95:
            dropped.append(j)
            notes.append(
                f"{field} never limited the response in the log (fitted "
                f"{getattr(params, field):.3g} is not identifiable; chi2 of removing it "
                f"{max(gain, 0.0):.2f}): its prior, {getattr(prob.mapper.base, field):g} "
                "(no limit), is kept"
            )
    return dropped


def _row_scores(jac: FloatArray, f: FloatArray, loss: str, f_scale: float) -> FloatArray:
    r"""Per-row scores :math:`\rho'(f_i^2) f_i \nabla f_i` of the robust data objective.

    ``jac`` is the Jacobian ``least_squares`` returns, already scaled for the robust loss
    (row :math:`i` times :math:`\sqrt{\rho' + 2\rho'' f_i^2}`), ``f`` the raw residuals.
    """
    z = (f / f_scale) ** 2
    rho = _rho(loss, z)
    scale = np.sqrt(np.maximum(rho[1] + 2.0 * rho[2] * z, 1e-30))
    out: FloatArray = jac * (rho[1] * f / scale)[:, None]
    return out


def _bandwidth(prob: Problem, f: FloatArray) -> int:
    """Lag window (samples) of the score covariance: Newey & West's (1994) rate
    :math:`4 (n/100)^{2/9}`, and at least three integrated autocorrelation times of the
    residuals (model error lasts over a response time, so its scores do too)."""
    n = max((g.meas_t_s.size for g in prob.logs), default=1)
    taus = [_autocorr_time(f[rows]) for rows in (prob.rows["v"], prob.rows["w"]) if rows.size]
    rule = 4.0 * (n / 100.0) ** (2.0 / 9.0)
    return int(min(max(math.ceil(rule), math.ceil(3.0 * max(taus, default=1.0))), n // 4, 200))


def score_covariance(sizes: Sequence[int], scores: FloatArray, lags: int) -> FloatArray:
    r"""Heteroscedasticity- and autocorrelation-consistent covariance of the summed scores.

    The v and w rows of one measurement instant are added (stamp jitter and model error move
    both), then the Bartlett-weighted lagged cross-products are summed within each log
    (Newey & West, 1987): :math:`\hat S = \sum_{|k| \le L} (1 - |k|/(L+1)) \sum_t g_t
    g_{t+k}^T`. ``sizes`` are the logs' sample counts: ``scores`` stacks, log by log, the v
    rows then the w rows of each (the residual layout of :class:`sysid._problem.Problem`).

    Examples
    --------
    >>> import numpy as np
    >>> ones = np.ones((6, 1))  # one log of 3 instants: v rows then w rows, all scores 1
    >>> float(score_covariance([3], ones, 0)[0, 0]), float(score_covariance([3], ones, 1)[0, 0])
    (12.0, 20.0)
    """
    p = scores.shape[1]
    out = np.zeros((p, p))
    offset = 0
    for n in sizes:
        inst = scores[offset : offset + n] + scores[offset + n : offset + 2 * n]
        offset += 2 * n
        out += inst.T @ inst
        for k in range(1, min(lags, n - 1) + 1):
            cross = inst[:-k].T @ inst[k:]
            out += (1.0 - k / (lags + 1.0)) * (cross + cross.T)
    return 0.5 * (out + out.T)


def data_information(jac: FloatArray, meat: FloatArray) -> FloatArray:
    r"""Godambe (sandwich) information of the data, :math:`H \hat S^{+} H`, in ``u``.

    :math:`H = J^T J` is the Gauss-Newton Hessian of the data part of the objective,
    :math:`\hat S` the covariance of its gradient (:func:`score_covariance`); the prior
    weight :math:`w_p` scales both and cancels (Godambe, 1960; White, 1982). With
    white residuals of variance :math:`s^2` this is :math:`J^T J/s^2`; with correlated or
    heteroscedastic residuals (stamp jitter at transients, model error over a response time)
    it counts them as the information they carry -- per direction of the parameter space,
    where one autocorrelation factor for everything under-covers the parameters that
    transients inform and over-covers the rest.
    """
    h = jac.T @ jac
    d = np.sqrt(np.clip(np.diag(h), 1e-300, None))
    hn = h / np.outer(d, d)
    sn = meat / np.outer(d, d)
    w, v = np.linalg.eigh(0.5 * (sn + sn.T))
    good = w > 1e-12 * max(float(w[-1]) if w.size else 0.0, 1e-300)
    s_inv = (v[:, good] / w[good]) @ v[:, good].T
    info = hn @ s_inv @ hn
    out: FloatArray = 0.5 * (info + info.T) * np.outer(d, d)
    return out


def _posterior_cov(
    info_u: FloatArray, prob: Problem, u: FloatArray, session_info_u: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, list[int]]:
    r"""Posterior from the data information in internal coordinates.

    Returns (z, cov_z, info_z, cov_u, undetermined columns): the precision is the data
    information plus :math:`G_p^T \Sigma_p^{-1} G_p` in :math:`u`, mapped to the schema
    coordinates with :math:`G = \partial z/\partial u`; ``info_z`` is ``session_info_u`` mapped
    to the schema coordinates (what the population weighs the session by).
    """
    z, g = prob.schema_coords(u)
    gp = g[prob.prior_idx]
    prec = info_u + gp.T @ (gp / prob.prior_sd[:, None] ** 2)
    scale = np.sqrt(np.clip(np.diag(prec), 1e-300, None))
    w, v = np.linalg.eigh(prec / np.outer(scale, scale))
    good = w > 1e-10 * max(float(w[-1]) if w.size else 0.0, 1e-300)
    cov_u = (v[:, good] / w[good]) @ v[:, good].T / np.outer(scale, scale)
    null = v[:, ~good]
    p = prec.shape[0]
    weak = [j for j in range(p) if np.diag(prec)[j] == 0 or float(np.sum(null[j] ** 2)) > 1e-3]
    cov = g @ cov_u @ g.T
    g_inv = np.linalg.pinv(g)
    info = g_inv.T @ session_info_u @ g_inv
    for j in weak:
        cov_u[j, j] = math.inf
        cov[j, j] = math.inf
    return z, cov, 0.5 * (info + info.T), cov_u, weak


def _discretisation_bias(
    final: Problem, u: FloatArray, jac: FloatArray, problem_kw: dict[str, Any]
) -> FloatArray:
    r"""Shift of the MAP point, in internal coordinates, that the model's time step causes.

    The fitted model is the drive kernel integrated with step :math:`\Delta t`, whose error
    is first order in :math:`\Delta t` (halving the step halves it),
    while a real base is continuous. Richardson: the step's error at the estimate is
    :math:`D \approx -2 e` with :math:`e = m_{\Delta t/2} - m_{\Delta t}` (one simulation at
    half the step), and a systematic output error :math:`D` moves the regularised
    least-squares estimate by :math:`b = -H^{-1} J^T D / w_p^2`,
    :math:`H = J^T J/w_p^2 + G_p^T \Sigma_p^{-1} G_p`. Velocity logs of a few minutes
    determine friction and cap parameters so tightly that this bias is comparable to their
    posterior sd (0.5-0.7 sd rms, up to 1.8 sd, on 20 s logs against the plant at 1 ms). The
    estimate is kept -- it is the best parameter set *for the model at this step*, which is
    what the band and the replays run -- and :math:`b b^T` is added to the covariance, so that
    the intervals hold the physical values too, bounded by :func:`bounded_bias` so that the
    posterior stays within the prior.
    """
    fine = Problem(
        final.logs,
        final.mapper,
        final.free,
        final.ties,
        timing=final.timing,
        **(problem_kw | {"dt_s": 0.5 * final.dt_s}),
    )
    params = final.params(u)
    e = fine.scaled_sim(params) - final.scaled_sim(params)
    w2 = final.prior_weight**2
    _, g = final.schema_coords(u)
    gp = g[final.prior_idx]
    h = jac.T @ jac / w2 + gp.T @ (gp / final.prior_sd[:, None] ** 2)
    out: FloatArray = np.linalg.pinv(h, hermitian=True) @ (jac.T @ (2.0 * e)) / w2
    return out


def bounded_bias(bias: FloatArray, info: FloatArray, prior_prec: FloatArray) -> FloatArray:
    r"""``bias`` shrunk so that adding :math:`b b^T` to the posterior never widens it past the
    prior.

    :math:`b b^T` is a model-error inflation, not a Bayesian update: it is the squared shift
    of the estimate that the model's time step causes (:func:`_discretisation_bias`). A
    linear extrapolation of an error concentrated at a few samples (the step transitions)
    can put that shift beyond the prior in a direction the data barely inform, which no
    posterior can be. The inflation is bounded so that the time-step error takes back at most
    the information the data gave: with posterior precision :math:`\Pi = I + Q` (data
    information :math:`I`, prior precision :math:`Q`), :math:`(\Pi^{-1} + \beta b b^T)^{-1}
    \succeq Q` holds exactly when :math:`\beta (t - s) \le 1`, with :math:`c = \Pi b`,
    :math:`t = c^T I^{+} c` and :math:`s = b^T \Pi b`; the bias returned is
    :math:`\sqrt{\beta}\, b` with :math:`\beta = \min(1, 1/(t - s))`.

    Parameters
    ----------
    bias : ndarray
        The shift :math:`b` in the fit's internal coordinates (0 in undetermined ones).
    info : ndarray
        The data information :math:`I` in the same coordinates.
    prior_prec : ndarray
        The prior precision :math:`Q` in the same coordinates.

    Returns
    -------
    ndarray
        :math:`\sqrt{\beta}\, b`.

    Examples
    --------
    >>> import numpy as np
    >>> one = np.eye(1)  # data and prior equally informative: posterior variance 1/2
    >>> float(bounded_bias(np.array([0.5]), one, one)[0])  # 1/2 + 1/4 <= 1: kept
    0.5
    >>> round(float(bounded_bias(np.array([3.0]), one, one)[0] ** 2), 12)  # 1/2 + 1/2 = prior
    0.5
    """
    keep = np.flatnonzero(bias != 0.0)
    if keep.size == 0:
        return bias
    data = info[np.ix_(keep, keep)]
    lam, vec = np.linalg.eigh(data + prior_prec[np.ix_(keep, keep)])
    root = vec * np.sqrt(np.clip(lam, 1e-300, None))  # Pi^(1/2) = root @ vec.T
    inv_root = vec / np.sqrt(np.clip(lam, 1e-300, None))
    # in Pi-whitened coordinates: the data's share mu of the posterior precision, 0 to 1
    mu, dirs = np.linalg.eigh(inv_root.T @ data @ inv_root)
    mu = np.clip(mu, 1e-15, 1.0)
    proj = dirs.T @ (root.T @ bias[keep])
    excess = float(np.sum(proj**2 * (1.0 - mu) / mu))  # t - s
    out: FloatArray = bias / math.sqrt(excess) if excess > 1.0 else bias
    return out


def _timing_floor(prob: Problem, z: FloatArray, cov: FloatArray, cov_u: FloatArray) -> None:
    r"""Add the log's timing resolution to the delay's variance (in place).

    A delay is a timing estimate: stamp jitter and irregular sample instants do not average
    out of it when they are systematic, and the model's step quantises time. The floor is
    :math:`\Delta t^2/12` (model step) plus half the robust variance of the sample-interval
    irregularity; white residual statistics cannot see either.
    """
    if "delay_s" not in prob.free:
        return
    j = prob.free.index("delay_s")
    jitter = []
    for g in prob.logs:
        d = np.diff(g.meas_t_s)
        if d.size > 3:
            jitter.append(robust_sd(d))
    floor = prob.dt_s**2 / 12.0 + 0.5 * float(np.mean(jitter) if jitter else 0.0) ** 2
    cov[j, j] += floor
    cov_u[j, j] += floor


def map_fit(
    logs: Sequence[LogArrays],
    mapper: Mapper,
    exc: Excitation,
    options: MapOptions,
    *,
    on_eval: Callable[[int], None] | None = None,
    notes: list[str],
) -> Posterior:
    """MAP estimate and posterior of the free coordinates of ``exc`` on ``logs``."""
    problem_kw, loss, f_scale = options.problem_kw, options.loss, options.f_scale
    max_nfev, python = options.max_nfev, options.python
    x0_map, spike_notes = initial_coords(
        logs, mapper.geometry, mapper.base, exc.free, exc.ties, mapper.priors
    )
    notes += spike_notes
    free = list(exc.free)
    prob = Problem(logs, mapper, free, exc.ties, python=python, on_eval=on_eval, **problem_kw)
    x0 = np.array([x0_map[f] for f in free])
    s2, c = noise_scale(prob, prob.data_residuals(x0), len(free))
    prob.prior_weight = math.sqrt(s2 * c)

    def solve(pr: Problem, x: FloatArray, nfev: int) -> Any:
        return _solve(pr, x, exc.coupled, loss, f_scale, nfev)

    released = released_start(logs, mapper, exc, free)
    extra = [] if released is None else [released]
    res, converged, message = _map_point(prob, x0, extra, solve, max_nfev, notes)
    s2, c = noise_scale(prob, prob.data_residuals(np.asarray(res.x)), len(free))
    if not _balanced(prob, s2 * c):
        # the prior's weight rests on the residual scale, first estimated at the start point:
        # re-balance at the solution (a few steps from there)
        prob.prior_weight = math.sqrt(s2 * c)
        res = solve(prob, np.asarray(res.x), min(max_nfev, _REBALANCE_NFEV))
        message += " (then the prior weight was re-balanced at the solution)"
        s2, c = noise_scale(prob, prob.data_residuals(np.asarray(res.x)), len(free))
    jitter, timed, message, (s2, c) = _timing_pass(prob, res, solve, max_nfev, message, (s2, c))
    if timed is not res:
        res, converged = timed, converged and int(timed.status) != 0
    x = np.asarray(res.x)
    dropped = _drop_inactive_limits(prob, res, s2 * c, solve, notes, (loss, f_scale))
    keep = [j for j in range(len(free)) if j not in dropped]
    kept = tuple(free[j] for j in keep)
    ties = {k: v for k, v in exc.ties.items() if v in kept}
    final = Problem(logs, mapper, kept, ties, timing=prob.timing, **problem_kw)
    final.prior_weight = math.sqrt(s2 * c)
    if dropped:
        # the optimiser's Jacobian is the problem's with the dropped limits in place (where a
        # limit and a cap do the same job, the cap's column is zero): the final problem's own
        jac = _robust_jacobian(final, x[keep], exc.coupled, loss, f_scale)
    else:
        jac = np.asarray(res.jac)[: prob.n_data][:, keep]
    z, cov, info, cov_u, weak = _map_covariance(
        final, x[keep], jac, s2 * c, (loss, f_scale), problem_kw
    )
    return Posterior(
        free=kept,
        ties=ties,
        u=x[keep],
        cov_u=cov_u,
        z=z,
        cov=cov,
        info=info,
        weak=tuple(weak),
        params=final.params(x[keep]),
        problem=final,
        inflation=c,
        residuals=prob.data_residuals(x),
        converged=converged,
        message=message,
        cost=float(res.cost),
        evaluations=prob.n_evals,
        steps=prob.n_steps,
        coupled=exc.coupled,
        jitter=jitter,
    )


def _timing_pass(
    prob: Problem,
    res: Any,
    solve: Callable[[Problem, FloatArray, int], Any],
    nfev: int,
    message: str,
    scale: tuple[float, float],
) -> tuple[JitterEstimate, Any, str, tuple[float, float]]:
    """The commands' arrival-time jitter the residuals at ``res`` show
    (:func:`sysid._timing.arrival_whitener`) and, when they show it, the fit redone from
    ``res`` with the residuals whitened for it and the model's response averaged over it
    (``prob`` keeps the whitening; its prior weight is re-balanced on the whitened
    residuals). Returns the estimate, the fit, its
    message and the residuals' (s^2, c)."""
    x = np.asarray(res.x)
    est, timing = arrival_whitener(prob, prob.params(x), prob.data_residuals(x))
    if timing is None:
        return est, res, message, scale
    prob.set_timing(timing)
    s2, c = noise_scale(prob, prob.data_residuals(x), len(prob.free))
    prob.prior_weight = math.sqrt(s2 * c)
    res = solve(prob, x, nfev)
    message += (
        f" (then refitted for the commands' arrival-time jitter, {1e3 * est.sigma_t_s:.3g} ms)"
    )
    s2, c = noise_scale(prob, prob.data_residuals(np.asarray(res.x)), len(prob.free))
    return est, res, message, (s2, c)


def _robust_jacobian(
    prob: Problem, u: FloatArray, coupled: bool, loss: str, f_scale: float
) -> FloatArray:
    r"""Data Jacobian of ``prob`` at ``u`` scaled for the robust loss as ``least_squares``
    scales its own (row :math:`i` times :math:`\sqrt{\rho' + 2\rho'' z_i}`,
    :math:`z_i = (f_i/f_{scale})^2`)."""
    jac = prob.data_jacobian(u, coupled)
    z = (prob.data_residuals(u) / f_scale) ** 2
    rho = _rho(loss, z)
    out: FloatArray = jac * np.sqrt(np.maximum(rho[1] + 2.0 * rho[2] * z, 1e-30))[:, None]
    return out


def _map_covariance(
    final: Problem,
    u: FloatArray,
    jac: FloatArray,
    scale2: float,
    robust: tuple[str, float],
    problem_kw: dict[str, Any],
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, list[int]]:
    """Posterior (z, cov, info, cov_u, weak) of the final problem's coordinates at its MAP point
    ``u``: the sandwich covariance of the data, the prior, and the model's time-step bias.
    ``jac`` is the final problem's data Jacobian at ``u``, scaled for the robust loss."""
    loss, f_scale = robust
    f = final.data_residuals(u)
    with threadpool_limits(limits=1):
        sizes = [g.meas_t_s.size for g in final.logs]
        meat = score_covariance(sizes, _row_scores(jac, f, loss, f_scale), _bandwidth(final, f))
        info_u = data_information(jac, meat)
        # the population (sysid._fleet) weighs sessions by the Gauss-Newton information with
        # the autocorrelation factor, as it was tuned on; the sandwich is this log's posterior
        session_info = jac.T @ jac / scale2
        z, cov, info, cov_u, weak = _posterior_cov(info_u, final, u, session_info)
    bias = _discretisation_bias(final, u, jac, problem_kw)
    bias[list(weak)] = 0.0
    _, g = final.schema_coords(u)
    gp = g[final.prior_idx]
    bias = bounded_bias(bias, info_u, gp.T @ (gp / final.prior_sd[:, None] ** 2))
    cov_u += np.outer(bias, bias)
    cov += np.outer(g @ bias, g @ bias)
    _timing_floor(final, z, cov, cov_u)
    return z, cov, info, cov_u, weak
