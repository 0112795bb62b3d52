r"""Where a predictive band's width and its misses come from: noise, latency, each parameter.

A band drawn from a params file's randomisation (:func:`sim2real.agreement.figures.run_ensemble`)
is as wide as the odometry noise and the spread of every varying parameter make it. Which one
makes it wide, and whether a miss is a timing miss or a bias, decides what to change: the noise
model, the between-session latency spread, or the spread of one parameter.

:func:`source_variances` replays a log with each varying parameter drawn alone from its
marginal (the others at the mean; common random numbers) and returns the members' variance it
causes on each axis, averaged over the active samples. :func:`band_sources` sets it beside the
noise's variance :math:`\sigma^2 + q^2/12`: each source's share of the sum, and the width of the
90 % band it would make alone (:math:`3.29\sqrt{\mathrm{var}}` for a Gaussian; correlations
between parameters are left out, so the shares are of the sum, not of the band's variance).
Then the misses of the whole band: their share within
:data:`sim2real.agreement.verdict.STEP_WINDOW_S` of a command step (timing), their share above
the band (a robot faster than every member), and the band's coverage with every member's
command latency moved to the checked session's own best latency
(:func:`sim2real.agreement.latency.session_latency`): the misses a latency spread explains.

Examples
--------
>>> from sim2real.agreement.sources import band_sources
>>> why = band_sources(trace, robot=spec, distribution=dist, n=30, seed=0)  # doctest: +SKIP
>>> dict(zip(why.names, why.share_v))["wheel_speed_max_radps"]  # doctest: +SKIP
0.62
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from statistics import NormalDist
from typing import Any

import numpy as np

from robots.params import SCHEMA
from sim2real._arrays import FloatArray
from sim2real.agreement.figures import (
    DEFAULT_BAND_LEVEL,
    ensemble_members,
    run_ensemble,
    since_command_step_s,
)
from sim2real.agreement.latency import session_latency
from sim2real.agreement.replay import resolve_robot
from sim2real.agreement.verdict import STEP_WINDOW_S

#: The white-noise sd fields of a band's odometry noise (numbers, or one per sample).
_SDS = ("std_v_mps", "std_w_radps")

__all__ = ["BandSources", "band_sources", "marginal", "source_variances"]


@dataclass(frozen=True, kw_only=True)
class BandSources:
    """The sources of a band's width and its misses on one log (module docstring).

    Attributes
    ----------
    names : tuple of str
        ``"noise"``, then each varying parameter.
    share_v, share_w : tuple of float
        Each source's share of the summed variance, per axis (0-1).
    width_v_mps, width_w_radps : tuple of float
        The ``band_level`` band each source would make alone (Gaussian), m/s and rad/s.
    band_width_v_mps, band_width_w_radps : float
        The whole band's median width.
    coverage_v, coverage_w : float
        The whole band's coverage of the active samples.
    near_step_v, near_step_w : float
        Share of the misses within ``STEP_WINDOW_S`` of a command step (NaN with no miss).
    above_v, above_w : float
        Share of the misses above the band (NaN with no miss).
    own_delay_s : float
        The session's own best command latency, s.
    coverage_own_latency_v, coverage_own_latency_w : float
        The band's coverage with every member's latency moved to ``own_delay_s``.
    """

    names: tuple[str, ...]
    share_v: tuple[float, ...]
    width_v_mps: tuple[float, ...]
    band_width_v_mps: float
    share_w: tuple[float, ...]
    width_w_radps: tuple[float, ...]
    band_width_w_radps: float
    coverage_v: float
    coverage_w: float
    near_step_v: float
    near_step_w: float
    above_v: float
    above_w: float
    own_delay_s: float
    coverage_own_latency_v: float
    coverage_own_latency_w: float

    def largest(self, axis: str, k: int = 3) -> list[tuple[str, float, float]]:
        """The ``k`` sources with the largest share of ``axis`` ("v" or "w"):
        (name, share, width alone)."""
        share = self.share_v if axis == "v" else self.share_w
        width = self.width_v_mps if axis == "v" else self.width_w_radps
        order = np.argsort(share)[::-1][:k]
        return [(self.names[i], share[i], width[i]) for i in order]


def marginal(distribution: Any, name: str) -> Any:
    """``distribution`` with only ``name`` varying, by its marginal (others at the mean)."""
    cov = distribution.covariance_array
    j = distribution.names.index(name)
    alone = np.zeros_like(cov)
    alone[j, j] = cov[j, j]
    return dataclasses.replace(distribution, covariance=tuple(map(tuple, alone.tolist())))


def source_variances(
    distribution: Any, members_of: Callable[[Any], tuple[FloatArray, FloatArray]]
) -> FloatArray:
    """The members' variance each varying parameter causes alone, shape (k, 2): v and w.

    ``members_of(dist)`` replays the samples of interest with ``dist``'s draws and returns the
    members' (v, w), shape (n, samples) each; the variance is averaged over the samples. A
    parameter with no spread causes 0.
    """
    cov = distribution.covariance_array
    out = np.zeros((len(distribution.names), 2))
    for j, name in enumerate(distribution.names):
        if cov[j, j] > 0.0:
            out[j] = [
                float(np.mean(m.var(axis=0))) for m in members_of(marginal(distribution, name))
            ]
    return out


def _misses(
    real: FloatArray, lo: FloatArray, hi: FloatArray, since: FloatArray
) -> tuple[float, float]:
    """(share within STEP_WINDOW_S of a step, share above the band) of the misses."""
    below, above = real < lo, real > hi
    n = int((below | above).sum())
    if n == 0:
        return math.nan, math.nan
    near = float(((below | above) & (since <= STEP_WINDOW_S)).sum()) / n
    return near, float(above.sum()) / n


def _at_latency(distribution: Any, delay_s: float) -> Any:
    """``distribution`` with its mean command latency at ``delay_s``."""
    if "delay_s" not in distribution.names:
        return dataclasses.replace(distribution, fixed={**distribution.fixed, "delay_s": delay_s})
    j = distribution.names.index("delay_s")
    coord = SCHEMA["delay_s"].to_coord(delay_s, distribution.geometry, None)
    mean = list(distribution.mean)
    mean[j] = coord
    return dataclasses.replace(distribution, mean=tuple(mean))


def band_sources(
    trace: Any,
    *,
    robot: Any,
    distribution: Any,
    engine: str = "reduced",
    band_level: float = DEFAULT_BAND_LEVEL,
    n: int = 30,
    odom_v_window_s: float = 0.0,
    seed: int = 0,
    tol_v: float = 0.02,
    tol_w: float = 0.1,
    noise: Any = None,
) -> BandSources:
    """Measure where ``distribution``'s band on ``trace`` gets its width and its misses.

    Parameters are those of :func:`sim2real.agreement.figures.run_ensemble` (``noise``: the
    band's odometry noise, e.g. an sd per sample, default the distribution's; its variance
    counts as its mean over the active samples); the parameter replays use the same ``n`` and
    ``seed``. Returns :class:`BandSources`.
    """
    spec = resolve_robot(robot)
    kw: dict[str, Any] = {
        "robot": spec,
        "n": n,
        "seed": seed,
        "engine": engine,
        "odom_v_window_s": odom_v_window_s,
    }
    noise = distribution.noise if noise is None else noise
    kw["noise"] = noise
    ens = run_ensemble(trace, distribution=distribution, tol_v=tol_v, tol_w=tol_w,
                       band_level=band_level, **kw)  # fmt: skip
    act = ens.active

    def members_of(dist: Any) -> tuple[FloatArray, FloatArray]:
        _, mv, mw = ensemble_members(trace, distribution=dist, **replay_kw)
        return mv[:, act], mw[:, act]

    replay_kw = {k: v for k, v in kw.items() if k != "noise"}
    sd_v, sd_w = (np.broadcast_to(getattr(noise, f), act.shape)[act] for f in _SDS)
    var = np.vstack(
        [
            [float(np.mean(sd_v**2)) + noise.quantum_v_mps**2 / 12.0,
             float(np.mean(sd_w**2)) + noise.quantum_w_radps**2 / 12.0],
            source_variances(distribution, members_of),
        ]
    )  # fmt: skip
    share = var / np.maximum(var.sum(axis=0), 1e-300)
    z = 2.0 * NormalDist().inv_cdf(0.5 + band_level / 2.0)
    since = since_command_step_s(trace, tol_v=tol_v, tol_w=tol_w)[act]
    rv = np.asarray(trace.meas_v, dtype=np.float64)[act]
    rw = np.asarray(trace.meas_w, dtype=np.float64)[act]
    miss_v = _misses(rv, ens.lo_v[act], ens.hi_v[act], since)
    miss_w = _misses(rw, ens.lo_w[act], ens.hi_w[act], since)
    lat = session_latency(trace, robot=spec, params=distribution.mean_params(), engine="reduced",
                          odom_v_window_s=odom_v_window_s, tol_v=tol_v, tol_w=tol_w)  # fmt: skip
    own = run_ensemble(trace, distribution=_at_latency(distribution, lat.delay_s), tol_v=tol_v,
                       tol_w=tol_w, band_level=band_level, **kw)  # fmt: skip
    return BandSources(
        names=("noise", *distribution.names),
        share_v=tuple(share[:, 0].tolist()),
        share_w=tuple(share[:, 1].tolist()),
        width_v_mps=tuple((z * np.sqrt(var[:, 0])).tolist()),
        width_w_radps=tuple((z * np.sqrt(var[:, 1])).tolist()),
        band_width_v_mps=ens.band_width_v_mps,
        band_width_w_radps=ens.band_width_w_radps,
        coverage_v=ens.coverage_v,
        coverage_w=ens.coverage_w,
        near_step_v=miss_v[0],
        near_step_w=miss_w[0],
        above_v=miss_v[1],
        above_w=miss_w[1],
        own_delay_s=float(lat.delay_s),
        coverage_own_latency_v=own.coverage_v,
        coverage_own_latency_w=own.coverage_w,
    )
