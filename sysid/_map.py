r"""MAP fit of one set of logs: robust data residuals plus prior residuals, and the posterior.

The objective is :math:`\sum_i \rho(f_i) + \sum_j w_p^2 ((z_j - \mu_j)/\sigma_j)^2` with
:math:`f_i` the scaled output errors, :math:`\rho` the robust loss and :math:`w_p^2 = s^2 c`
the data residuals' variance (robust MAD scale :math:`s`) times the autocorrelation factor
:math:`c = (1+\rho_1)/(1-\rho_1)`: up to a constant the negative log posterior, with correlated
residuals counted as the fewer independent samples they are worth. The posterior covariance is
the inverse Gauss-Newton Hessian :math:`(J^T J / (s^2 c) + \Sigma_p^{-1})^{-1}`: where the log is
informative it is narrow, where not it is the prior.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

from robots.params import DriveParams
from sysid._coords import Mapper
from sysid._excitation import Excitation
from sysid._initial import busiest_window, initial_coords
from sysid._logs import LogArrays, crop_log
from sysid._problem import Problem

__all__ = ["Posterior", "map_fit", "noise_scale"]

FloatArray = NDArray[np.float64]

#: Logs longer than this (s, in total) are first fitted on their busiest windows.
_COARSE_SPAN_S = 150.0
#: Residual-evaluation cap of the polishing pass on all the data.
_POLISH_NFEV = 3
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
class Posterior:
    """Outcome of :func:`map_fit`.

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
    info : ndarray
        Data information :math:`G^{-T} J^T J G^{-1}/(s^2 c)` in schema coordinates.
    weak : tuple of int
        Indices of coordinates that neither the data nor a prior determine.
    params : DriveParams
        Parameters at the MAP point.
    problem : Problem
        The problem over :attr:`free` (for derived quantities and scoring).
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
    """

    free: tuple[str, ...]
    ties: dict[str, str]
    u: FloatArray
    cov_u: FloatArray
    z: FloatArray
    cov: FloatArray
    info: FloatArray
    weak: tuple[int, ...]
    params: DriveParams
    problem: Problem
    inflation: float
    residuals: FloatArray
    converged: bool
    message: str
    cost: float
    evaluations: int
    steps: int
    coupled: bool


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


def noise_scale(prob: Problem, f: FloatArray, n_params: int) -> tuple[float, float]:
    """Robust residual variance :math:`s^2` and the autocorrelation factor :math:`c`."""
    n = f.size
    s2 = (1.4826 * float(np.median(np.abs(f - np.median(f))))) ** 2 * n / max(n - n_params, 1)
    rho = []
    for rows in (prob.rows["v"], prob.rows["w"]):
        r = f[rows] - np.mean(f[rows])
        den = float(np.dot(r, r))
        if den > 0:
            rho.append(float(np.dot(r[1:], r[:-1]) / den))
    rho1 = float(np.clip(np.mean(rho) if rho else 0.0, 0.0, 0.98))
    return max(s2, 1e-12), (1.0 + rho1) / (1.0 - rho1)


def _span(log: LogArrays) -> float:
    return float(log.meas_t_s[-1] - log.meas_t_s[0])


def _optimise(
    prob: Problem, x0: FloatArray, solve: Callable[[Problem, FloatArray, int], Any], nfev: int
) -> tuple[Any, bool]:
    """Least squares on all the data; long logs first converge on their busiest windows.

    Returns the result and whether the main pass converged (did not hit ``nfev``)."""
    logs = prob.logs
    total_s = sum(_span(g) for g in logs)
    if total_s <= _COARSE_SPAN_S:
        res = solve(prob, x0, nfev)
        return res, res.status != 0
    windows = []
    for g in logs:
        rate = g.meas_t_s.size / max(_span(g), 1e-9)
        n = max(int(rate * _COARSE_SPAN_S * _span(g) / total_s), 10)
        windows.append(crop_log(g, *busiest_window(g, n)))
    coarse = prob.like(windows)
    first = solve(coarse, x0, nfev)
    prob.n_evals, prob.n_steps = coarse.n_evals, coarse.n_steps
    return solve(prob, np.asarray(first.x), min(nfev, _POLISH_NFEV)), first.status != 0


def _drop_inactive_limits(prob: Problem, x: FloatArray, notes: list[str]) -> list[int]:
    """Limits without a prior that never shape the response are not identified: they stay
    at "no limit" (their prior). Returns the indices of the coordinates to drop."""
    params = prob.params(x)
    ref = prob.scaled_sim(params)
    dropped = []
    for j, field in enumerate(prob.free):
        if field not in _LIMITS or prob.mapper.prior(field) is not None:
            continue
        unlimited = prob.scaled_sim(params.replace(**{field: math.inf}))
        if float(np.max(np.abs(unlimited - ref))) < 0.1:
            dropped.append(j)
            notes.append(
                f"{field} never limited the response in the log (fitted "
                f"{getattr(params, field):.3g} is not identifiable): its prior, "
                f"{getattr(prob.mapper.base, field):g} (no limit), is kept"
            )
    return dropped


def _posterior_cov(
    jac: FloatArray, prob: Problem, u: FloatArray, s2c: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, list[int]]:
    r"""Posterior from the data Jacobian in internal coordinates.

    Returns (z, cov_z, info_z, cov_u, undetermined columns): the Gauss-Newton precision is
    :math:`J^T J/(s^2 c) + G_p^T \Sigma_p^{-1} G_p` in :math:`u`, mapped to the schema
    coordinates with :math:`G = \partial z/\partial u`.
    """
    info_u = jac.T @ jac / s2c
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
    info = g_inv.T @ info_u @ g_inv
    for j in weak:
        cov_u[j, j] = math.inf
        cov[j, j] = math.inf
    return z, cov, 0.5 * (info + info.T), cov_u, weak


def map_fit(
    logs: Sequence[LogArrays],
    mapper: Mapper,
    exc: Excitation,
    *,
    problem_kw: dict[str, Any],
    loss: str,
    f_scale: float,
    max_nfev: int,
    python: bool = False,
    on_eval: Callable[[int], None] | None = None,
    notes: list[str],
) -> Posterior:
    """MAP estimate and posterior of the free coordinates of ``exc`` on ``logs``."""
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

    res, converged = _optimise(prob, x0, solve, max_nfev)
    s2, c = noise_scale(prob, prob.data_residuals(np.asarray(res.x)), len(free))
    if not 2.0 / 3.0 <= math.sqrt(s2 * c) / prob.prior_weight <= 1.5:
        # the prior's weight rests on the residual scale: re-balance at the solution
        prob.prior_weight = math.sqrt(s2 * c)
        res = solve(prob, np.asarray(res.x), min(max_nfev, 10))
        s2, c = noise_scale(prob, prob.data_residuals(np.asarray(res.x)), len(free))
    x = np.asarray(res.x)
    dropped = _drop_inactive_limits(prob, x, notes)
    keep = [j for j in range(len(free)) if j not in dropped]
    kept = tuple(free[j] for j in keep)
    ties = {k: v for k, v in exc.ties.items() if v in kept}
    final = Problem(logs, mapper, kept, ties, **problem_kw)
    final.prior_weight = math.sqrt(s2 * c)
    jac = np.asarray(res.jac)[: prob.n_data][:, keep]
    with threadpool_limits(limits=1):
        z, cov, info, cov_u, weak = _posterior_cov(jac, final, x[keep], s2 * c)
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
        message=str(res.message),
        cost=float(res.cost),
        evaluations=prob.n_evals,
        steps=prob.n_steps,
        coupled=exc.coupled,
    )
