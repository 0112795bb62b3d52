"""From fitted coordinates to what a result reports: estimates of every field, identifiable
combinations, the randomisation distribution and the odometry noise model."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robots.arrays import FloatArray
from robots.params import SCHEMA, DriveParams
from robots.randomization import DriveDistribution, ObservationNoise, cap_spread
from sysid._coords import Mapper
from sysid._excitation import active_samples
from sysid._fleet import new_session_factor
from sysid._logs import LogArrays
from sysid._map import FittedCoords
from sysid._problem import Problem
from sysid.result import ParameterEstimate
from sysid.steady import robust_sd

__all__ = [
    "Z95",
    "FitSummary",
    "distribution",
    "estimate_noise",
    "field_estimates",
    "identifiable_estimates",
    "quantum",
]


#: Two-sided 95 % quantile of the standard normal distribution.
Z95 = 1.959963984540054


@dataclass(frozen=True, kw_only=True)
class FitSummary(FittedCoords):
    """What a result reports about the fitted coordinates (one log or a population): those of
    the one log's posterior, or the population's mean and its ``between``-session covariance
    (None for one log)."""

    between: FloatArray | None


def _estimate(
    mapper: Mapper,
    name: str,
    z: float,
    sd: float,
    status: str,
    value: float | None = None,
    *,
    params: DriveParams | None = None,
    total_moments: tuple[float, float] = (0.0, 0.0),
) -> ParameterEstimate:
    r"""A field's estimate from its coordinate ``z`` and coordinate sd (interval mapped back).

    A friction per unit of the total mass or inertia, :math:`F = z\,T` with
    :math:`T = e^{z_T}`, takes its total from ``params`` and its interval from the delta
    method over both, ``total_moments`` = (var :math:`z_T`, cov(:math:`z, z_T`)):
    :math:`\mathrm{var}\,F = T^2 \mathrm{var}\,z + F^2 \mathrm{var}\,z_T + 2TF\,\mathrm{cov}`.
    """
    f = SCHEMA[name]
    v = mapper.value(name, z, params) if value is None else value
    prior = mapper.priors[name]
    if not math.isfinite(sd):
        ci, std = (-math.inf, math.inf), math.inf
    elif f.per_field is not None:
        t = f.total_of(mapper.geometry, getattr(params or mapper.base, f.per_field))
        var_t, cov_zt = total_moments
        var = t * t * sd * sd + v * v * var_t + 2.0 * t * v * cov_zt
        std = math.sqrt(max(var, 0.0))
        lo, hi = mapper.bounds(name)
        ci = (max(v - Z95 * std, lo * t), min(v + Z95 * std, hi * t))
    else:
        lo, hi = mapper.bounds(name)
        a = mapper.value(name, float(np.clip(z - Z95 * sd, lo, hi)))
        b = mapper.value(name, float(np.clip(z + Z95 * sd, lo, hi)))
        ci = (min(a, b), max(a, b))
        std = abs(f.derivative(v, mapper.geometry)) * sd
    return ParameterEstimate(
        name=name,
        value=v,
        std=std,
        ci95_low=ci[0],
        ci95_high=ci[1],
        unit=f.unit,
        status=status,
        coord=f.coord,
        coord_std=sd,
        prior_sd=prior.sd if prior.informative else None,
    )


def field_estimates(mapper: Mapper, fitted: FittedCoords) -> tuple[ParameterEstimate, ...]:
    """Every DriveParams field: fitted (from the fit's ``z``, ``cov``), prior, tied or fixed."""
    params, free, z, cov, ties = fitted.params, fitted.free, fitted.z, fitted.cov, fitted.ties
    out = []
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None)) if len(free) else np.zeros(0)
    for name in DriveParams.names():
        source = ties.get(name, name)
        per = SCHEMA[name].per_field
        if source in free:
            j = list(free).index(source)
            status = "tied" if name in ties else "fitted"
            value = float(getattr(params, name))
            moments = (0.0, 0.0)
            if per is not None and per in free:
                k = list(free).index(per)
                moments = (float(cov[k, k]), float(cov[j, k]))
            out.append(
                _estimate(
                    mapper,
                    name,
                    float(z[j]),
                    float(sd[j]),
                    status,
                    value,
                    params=params,
                    total_moments=moments,
                )
            )
        elif mapper.priors[name].informative:
            p = mapper.priors[name]
            z0 = p.mean(mapper.geometry)
            value = p.nominal if per is None else mapper.value(name, z0, params)
            out.append(_estimate(mapper, name, z0, p.sd, "prior", value, params=params))
        else:
            f = SCHEMA[name]
            out.append(
                ParameterEstimate(
                    name=name,
                    value=float(getattr(params, name)),
                    std=None,
                    ci95_low=None,
                    ci95_high=None,
                    unit=f.unit,
                    status="fixed",
                    coord=f.coord,
                    coord_std=None,
                    prior_sd=None,
                )
            )
    return tuple(out)


def _plain_estimate(name: str, value: float, unit: str) -> ParameterEstimate:
    return ParameterEstimate(
        name=name, value=value, std=None, ci95_low=None, ci95_high=None, unit=unit, status="fixed"
    )


def identifiable_estimates(
    prob: Problem, x: FloatArray, cov: FloatArray, weak: Sequence[int]
) -> tuple[ParameterEstimate, ...]:
    """Delta-method uncertainty of the identifiable combinations (no simulation needed)."""
    mapper = prob.mapper
    cov = np.where(np.isfinite(cov), cov, 0.0)
    base = mapper.identifiable(prob.params(x))
    keys = list(base)
    grads = np.zeros((len(base), x.size))
    for j in range(x.size):
        h = 1e-6 * max(1.0, abs(float(x[j])))
        xp, xm = x.copy(), x.copy()
        xp[j] = min(float(x[j]) + h, float(prob.upper[j]))
        xm[j] = max(float(x[j]) - h, float(prob.lower[j]))
        vp, vm = mapper.identifiable(prob.params(xp)), mapper.identifiable(prob.params(xm))
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
            out.append(_plain_estimate(k, value, unit))
            continue
        std = float(math.sqrt(max(float(g @ cov @ g), 0.0)))
        if any(g[j] != 0 for j in weak):
            std = math.inf
        if value > 0 and std < value:  # positive quantity: interval symmetric in log space
            lo, hi = value * math.exp(-Z95 * std / value), value * math.exp(Z95 * std / value)
        else:
            lo, hi = value - Z95 * std, value + Z95 * std
            lo = max(lo, 0.0) if value >= 0 else lo
        status = "fitted" if k == "delay_s" else "derived"
        out.append(
            ParameterEstimate(
                name=k, value=value, std=std, ci95_low=lo, ci95_high=hi, unit=unit, status=status
            )
        )
    return tuple(out)


def distribution(
    robot: str, mapper: Mapper, summary: FitSummary, noise: ObservationNoise, *, sessions: int = 1
) -> DriveDistribution:
    r"""The ``randomization`` distribution: the predictive of a *new* session.

    A new session is :math:`\theta_{new} = \mu + b_{new}`, :math:`b \sim N(0, T)`.
    Several logs (``summary.between`` = the population's :math:`T`, ``cov`` = the covariance of its
    mean :math:`\hat\mu`): ``cov`` + :math:`f T`. One log (``summary.between`` None): ``cov`` is the
    posterior of *that* session, :math:`\theta_1 = \mu + b_1`, so the mean is uncertain by
    :math:`T` more, and :math:`T` is the spec's default between-session spread :math:`S_0`:
    ``cov`` + :math:`(1 + f) S_0`. :math:`f` (:func:`sysid._fleet.new_session_factor`) widens
    the Gaussian to the Student-t predictive of a spread known from few sessions (2.05 for
    one, 1.5 for three, 1.17 for ten). Fields the fit did not free but whose prior is
    informative: prior mean, prior variance + :math:`f` x default session variance. Tied fields
    copy their source's row. Everything else (known exactly, "no limit", undetermined
    coordinates) is fixed at its value in ``params``.
    """
    params, free, z, cov, ties = summary.params, summary.free, summary.z, summary.cov, summary.ties
    between = summary.between
    geo = mapper.geometry
    factor = new_session_factor(sessions)
    finite = [j for j, f in enumerate(free) if math.isfinite(float(cov[j, j]))]
    names = [free[j] for j in finite]
    session = np.array([mapper.priors[n].session_sd ** 2 for n in names])
    # a field the log barely informs (a limit that acted once) can have a posterior wider than
    # any robot of its kind: capped at the block's absurd-spread limit rather than refused (a
    # between-session spread that wide is not capped: it is refused, the fit is broken)
    block = cap_spread(cov[np.ix_(finite, finite)], names, geo) + (
        (1.0 + factor) * np.diag(session)
        if between is None
        else factor * between[np.ix_(finite, finite)]
    )
    means = [float(z[j]) for j in finite]
    extra = [
        n
        for n in DriveParams.names()
        if n not in free and n not in ties and mapper.priors[n].informative
    ]
    k0, k1 = len(names), len(names) + len(extra)
    full = np.zeros((k1, k1))
    full[:k0, :k0] = block
    for i, n in enumerate(extra, start=k0):
        p = mapper.priors[n]
        full[i, i] = p.sd**2 + factor * p.session_sd**2
        means.append(p.mean(geo))
    names += extra
    tied = [(n, s) for n, s in ties.items() if s in names]
    for n, s in tied:  # a tied field moves with its source: a duplicated row and column
        j = names.index(s)
        full = np.pad(full, ((0, 1), (0, 1)))
        full[-1, :] = full[j, :]
        full[:, -1] = full[:, j]
        full[-1, -1] = full[j, j]
        names.append(n)
        means.append(means[j])
    fixed = {n: float(getattr(params, n)) for n in DriveParams.names() if n not in names}
    return DriveDistribution(
        robot=robot,
        geometry=geo,
        names=tuple(names),
        mean=tuple(means),
        covariance=tuple(tuple(float(c) for c in row) for row in 0.5 * (full + full.T)),
        fixed=fixed,
        noise=noise,
    )


def quantum(values: FloatArray) -> float:
    """Resolution of a lattice the measured values sit on (an encoder tick per period), 0 if none.

    Examples
    --------
    >>> import numpy as np
    >>> quantum(np.round(np.random.default_rng(0).normal(0, 0.1, 500) / 0.004) * 0.004)
    0.004
    """
    nz = np.abs(values[np.abs(values) > 1e-9])
    if nz.size < 20:
        return 0.0
    uniq = np.unique(np.round(nz, 12))
    if uniq.size > 0.5 * nz.size:
        return 0.0
    gaps = np.diff(uniq)
    gaps = gaps[gaps > 1e-9]
    if gaps.size == 0:
        return 0.0
    q = float(np.min(gaps))
    on_lattice = np.abs(nz / q - np.round(nz / q)) < 1e-3
    return round(q, 12) if float(np.mean(on_lattice)) >= 0.95 else 0.0


def _active(logs: Sequence[LogArrays]) -> NDArray[np.bool_]:
    """Samples of all logs where the robot is commanded to move or moves (the samples the
    band's coverage is measured on: :func:`sysid.metrics.active_mask`)."""
    parts = [active_samples(g) for g in logs]
    return np.concatenate(parts) if parts else np.zeros(0, dtype=bool)


def estimate_noise(
    logs: Sequence[LogArrays], residuals_v: FloatArray, residuals_w: FloatArray
) -> ObservationNoise:
    """Odometry noise: robust (MAD) sd of the fit residuals per channel over the active
    samples, and the lattice of the measured values (encoder quantisation) when there is one.

    A parked robot's odometry is often exactly zero, and so is the model's: counting those
    samples shrinks the MAD towards zero (one real TurtleBot3 log: 0.6 mm/s parked-and-moving
    against 3.5 mm/s while moving) and the band, which is judged on active samples only,
    becomes far too narrow. The residuals while moving also hold the model error that no
    parameter draw reproduces, which the band has to cover too.
    """

    def mad(r: FloatArray) -> float:
        return robust_sd(r) if r.size else 0.0

    active = _active(logs)
    if active.size == residuals_v.size and int(active.sum()) >= 20:
        residuals_v, residuals_w = residuals_v[active], residuals_w[active]
    meas_v = np.concatenate([g.meas_v for g in logs])
    meas_w = np.concatenate([g.meas_w for g in logs])
    return ObservationNoise(
        std_v_mps=min(mad(residuals_v), 1.0),
        std_w_radps=min(mad(residuals_w), 5.0),
        quantum_v_mps=min(quantum(meas_v), 1.0),
        quantum_w_radps=min(quantum(meas_w), 5.0),
    )
