r"""Sim-vs-real velocity agreement: how often the simulated base moves like the real one.

Liang et al. (2020) judged its simulator by the share of time the simulated robot's velocities
matched the real robot's ("over 80 % of the time"). This module makes that measurement exact
and repeatable.

Definition
----------
Let :math:`t_k` be the measurement (odometry) times of a log, :math:`(v_k, \omega_k)` the
measured velocities, :math:`(\hat v_k, \hat\omega_k)` the simulated ones at the same times
(:func:`sim2real.agreement.replay.replay`), and :math:`(u^v_k, u^\omega_k)` the command held at
:math:`t_k` (zero-order hold of the logged commands; 0 before the first command).

- **Active samples** (:func:`sysid.metrics.active_mask`): sample *k* is active when
  :math:`|u^v_k| > 10^{-3}` or :math:`|u^\omega_k| > 10^{-3}` or :math:`|v_k| > tol_v` or
  :math:`|\omega_k| > tol_w`. Idle samples are excluded so parked time cannot inflate the
  score.
- A sample **agrees** when :math:`|\hat v_k - v_k| \le tol_v` and
  :math:`|\hat\omega_k - \omega_k| \le tol_w` (defaults ``tol_v = 0.02`` m/s,
  ``tol_w = 0.1`` rad/s).
- ``agreement`` is the fraction of active samples that agree on both axes; ``agreement_v``
  and ``agreement_w`` count one axis each.
- ``fit_percent_v`` / ``fit_percent_w``: MATLAB ``compare`` FIT %,
  :math:`100(1 - \lVert y - \hat y\rVert / \lVert y - \bar y\rVert)`, over the active samples.
- ``rmse_v`` (m/s) / ``rmse_w`` (rad/s): root-mean-square error over the active samples.
- ``lag_s_v`` / ``lag_s_w``: lag of the simulated trace behind the real one (s, positive =
  simulation late) from the cross-correlation peak of the whole traces
  (:func:`sysid.metrics.xcorr_lag_s`).
- ``n_samples`` (all measurement samples), ``n_active``, ``tol_v``, ``tol_w``, ``robot``,
  ``params_file`` (``None`` for spec defaults), ``log_file`` and ``log_sha256`` (the JSON
  keys, :data:`AGREEMENT_KEYS`); the report also carries ``odom_v_window_s`` (below).

Odometry v window
-----------------
Wheel-encoder odometry reports v as the encoder tick difference over one odometry period
:math:`W` (1/30 s on a TurtleBot3), i.e. the mean speed over :math:`[t_k - W, t_k]`: a lag of
:math:`W/2` and some smoothing. Comparing the instantaneous simulated :math:`\hat v_k` with it
shows a spurious lag of about :math:`-W/2` and lowers FIT % v. With
``replay(..., odom_v_window_s=W)`` (``sim2real agree --odom-v-window S|auto``) the simulated v
goes through the same sensor model (:func:`sysid.odometry.window_mean`, exact on the
simulation's integration grid), like-for-like with ``sysid fit --odom-v-window``; w stays
instantaneous (gyro or wheel difference at the stamp). The window used is recorded in
:attr:`AgreementReport.odom_v_window_s` and in the HTML report's provenance; the JSON keys stay
exactly :data:`AGREEMENT_KEYS`.

Figures that are undefined (no active sample, constant signal) are NaN (``null`` in JSON).

Predictive band and coverage
----------------------------
:func:`run_ensemble` replays the log with *N* robots drawn from a params file's
randomisation (:meth:`robots.randomization.DriveDistribution.sample`, the sampler
``randomizers.DynamicsRandomizer.from_sysid`` uses in training: same seed, same robots), adds
*K* odometry-noise realisations to each simulated trace
(:meth:`robots.randomization.ObservationNoise.apply`, the rule of
``randomizers.VelocityObservationNoise``), and takes the central ``band_level`` band of the
:math:`N K` traces at every measurement time (:func:`predictive_band`). The band is thus the
predictive distribution of what the odometry of a randomised robot would report.

- ``coverage_v`` / ``coverage_w``: fraction of active real samples whose v / w lies inside
  its band; ``coverage``: both at once.
- ``band_width_v_mps`` / ``band_width_w_radps``: median band width over the active samples.
- ``coverage_by_level``: the coverage of the central band at each level of
  :data:`COVERAGE_LEVELS` (a calibrated band covers about its level at every level).

A calibrated 90 % band covers 80-99 % (:func:`calibrated_range`); :func:`band_verdict` says in
one sentence whether it is too narrow, calibrated or too wide and what to do.
``sim2real agree --ensemble N --json`` adds :data:`BAND_KEYS` after :data:`AGREEMENT_KEYS`.

Examples
--------
>>> import numpy as np
>>> rep = agreement_from_arrays(
...     t_s=np.arange(4) * 0.1, cmd_v=np.array([0.0, 0.2, 0.2, 0.0]), cmd_w=np.zeros(4),
...     real_v=np.array([0.0, 0.1, 0.2, 0.0]), real_w=np.zeros(4),
...     sim_v=np.array([0.0, 0.15, 0.2, 0.0]), sim_w=np.zeros(4), robot="demo")
>>> rep.n_active, rep.agreement
(2, 0.5)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robots.params import DriveParams
from robots.units import seconds
from sim2real._arrays import BoolArray, FloatArray
from sim2real.agreement.replay import ReplayResult, TraceLike, replay, resolve_robot
from sim2real.errors import Sim2RealValueError
from sysid.metrics import (
    DEFAULT_TOL_V,
    DEFAULT_TOL_W,
    active_mask,
    agreement_fraction,
    fit_percent,
    rmse,
    xcorr_lag_s,
)
from sysid.steady import difference_sd

__all__ = [
    "AGREEMENT_KEYS",
    "BAND_KEYS",
    "COVERAGE_LEVELS",
    "DEFAULT_BAND_LEVEL",
    "DEFAULT_TOL_V",
    "DEFAULT_TOL_W",
    "DYNAMICS_STREAM",
    "MAX_ENSEMBLE",
    "NOISE_DRAWS",
    "NOISE_STREAM",
    "AgreementReport",
    "EnsembleResult",
    "agreement_from_arrays",
    "band_coverage",
    "band_noise_draws",
    "band_verdict",
    "calibrated_range",
    "check_band_level",
    "check_ensemble_size",
    "check_tolerances",
    "ensemble_members",
    "ensemble_of_members",
    "lag_phrase",
    "measure_agreement",
    "predictive_band",
    "predictive_samples",
    "run_ensemble",
    "since_command_step_s",
]

#: Largest ensemble (``--ensemble``): each member is one full replay of the log.
MAX_ENSEMBLE = 10_000


@dataclass(frozen=True, kw_only=True)
class AgreementReport:
    """Agreement figures of one replay (see the module docstring for the definitions).

    Attributes
    ----------
    agreement, agreement_v, agreement_w : float
        Fractions (0..1) of active samples within tolerance on both axes / v / w.
    fit_percent_v, fit_percent_w : float
        FIT % over the active samples.
    rmse_v, rmse_w : float
        RMS error over the active samples, m/s and rad/s.
    lag_s_v, lag_s_w : float
        Cross-correlation lag of the simulation behind the real log, s.
    n_samples, n_active : int
        Number of measurement samples and of active ones.
    tol_v, tol_w : float
        Tolerances used, m/s and rad/s.
    robot : str
        Robot (spec) name.
    params_file, log_file, log_sha256 : str or None
        Provenance: the params file (None = spec defaults), the log and its SHA-256.
    odom_v_window_s : float
        Odometry window the simulated v was averaged over, s (0 = instantaneous); not one of
        the :data:`AGREEMENT_KEYS`.
    """

    agreement: float
    agreement_v: float
    agreement_w: float
    fit_percent_v: float
    fit_percent_w: float
    rmse_v: float
    rmse_w: float
    lag_s_v: float
    lag_s_w: float
    n_samples: int
    n_active: int
    tol_v: float
    tol_w: float
    robot: str
    params_file: str | None
    log_file: str | None
    log_sha256: str | None
    odom_v_window_s: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """The figures under exactly :data:`AGREEMENT_KEYS` (NaN becomes ``None``)."""
        out: dict[str, Any] = {}
        for name in AGREEMENT_KEYS:
            value = getattr(self, name)
            if isinstance(value, float) and not math.isfinite(value):
                value = None
            out[name] = value
        return out


#: The keys of :meth:`AgreementReport.to_dict` (and of ``sim2real agree --json``), in order:
#: the report's fields but its odometry window.
AGREEMENT_KEYS: tuple[str, ...] = tuple(
    f.name for f in fields(AgreementReport) if f.name != "odom_v_window_s"
)


def check_tolerances(tol_v: float, tol_w: float) -> None:
    """Raise :class:`~sim2real.errors.Sim2RealValueError` unless both tolerances are > 0."""
    for name, flag, tol in (("tol_v", "--tol-v", tol_v), ("tol_w", "--tol-w", tol_w)):
        if (
            isinstance(tol, bool)
            or not isinstance(tol, int | float)
            or not (math.isfinite(tol) and tol > 0)
        ):
            raise Sim2RealValueError(
                f"tolerance {name} ({flag}) must be a finite number > 0, got {tol!r}; "
                f"e.g. {flag} {DEFAULT_TOL_V if name == 'tol_v' else DEFAULT_TOL_W}"
            )


#: Default central probability of the predictive band (``sim2real agree --band-level``).
DEFAULT_BAND_LEVEL = 0.9


def check_band_level(level: float) -> float:
    """Return ``level`` as a float after checking it lies strictly between 0 and 1.

    Examples
    --------
    >>> check_band_level(0.9)
    0.9
    """
    if (
        isinstance(level, bool)
        or not isinstance(level, int | float)
        or not (math.isfinite(level) and 0.0 < level < 1.0)
    ):
        raise Sim2RealValueError(
            f"band level (--band-level) must be a probability strictly between 0 and 1, got "
            f"{level!r}; e.g. --band-level {DEFAULT_BAND_LEVEL}"
        )
    return float(level)


def agreement_from_arrays(
    *,
    t_s: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    real_v: FloatArray,
    real_w: FloatArray,
    sim_v: FloatArray,
    sim_w: FloatArray,
    tol_v: float = DEFAULT_TOL_V,
    tol_w: float = DEFAULT_TOL_W,
    robot: str,
    params_file: str | None = None,
    log_file: str | None = None,
    log_sha256: str | None = None,
    odom_v_window_s: float = 0.0,
) -> AgreementReport:
    """Agreement of simulated and real velocities sampled at the same times ``t_s``.

    Parameters
    ----------
    t_s : ndarray
        Measurement times, s (sorted).
    cmd_v, cmd_w : ndarray
        Command held at each measurement time, m/s and rad/s.
    real_v, real_w, sim_v, sim_w : ndarray
        Measured and simulated forward (m/s) and yaw (rad/s) velocity at ``t_s``.
    tol_v, tol_w : float
        Agreement tolerances, m/s and rad/s (> 0).
    robot, params_file, log_file, log_sha256 : str
        Provenance copied into the report.
    odom_v_window_s : float
        Odometry window of ``sim_v``, s (provenance, copied into the report).

    Returns
    -------
    AgreementReport
    """
    check_tolerances(tol_v, tol_w)
    arrays = [np.asarray(a, dtype=np.float64) for a in (t_s, cmd_v, cmd_w, real_v, real_w)]
    sv, sw = np.asarray(sim_v, dtype=np.float64), np.asarray(sim_w, dtype=np.float64)
    t, cv, cw, rv, rw = arrays
    if any(a.shape != t.shape for a in (*arrays, sv, sw)) or t.ndim != 1:
        raise Sim2RealValueError(
            "t_s, commands, real and simulated velocities must be 1-D arrays of one length; "
            f"got shapes {[a.shape for a in (*arrays, sv, sw)]}"
        )
    active = active_mask(cv, cw, rv, rw, tol_v=tol_v, tol_w=tol_w)
    both, ag_v, ag_w = agreement_fraction(sv - rv, sw - rw, active, tol_v=tol_v, tol_w=tol_w)
    n_active = int(active.sum())
    if n_active:
        fit_v = _fit_of_varied(rv[active], sv[active], tol_v)
        fit_w = _fit_of_varied(rw[active], sw[active], tol_w)
        rmse_v, rmse_w = rmse(rv[active], sv[active]), rmse(rw[active], sw[active])
    else:
        fit_v = fit_w = rmse_v = rmse_w = math.nan
    return AgreementReport(
        agreement=both,
        agreement_v=ag_v,
        agreement_w=ag_w,
        fit_percent_v=fit_v,
        fit_percent_w=fit_w,
        rmse_v=rmse_v,
        rmse_w=rmse_w,
        lag_s_v=_lag_of_varied(t, rv, sv, active, tol_v),
        lag_s_w=_lag_of_varied(t, rw, sw, active, tol_w),
        n_samples=int(t.size),
        n_active=n_active,
        tol_v=float(tol_v),
        tol_w=float(tol_w),
        robot=robot,
        params_file=params_file,
        log_file=log_file,
        log_sha256=log_sha256,
        odom_v_window_s=float(odom_v_window_s),
    )


def _varies(
    real: FloatArray, sim: FloatArray, tol: float, *, above_noise: bool = False
) -> tuple[bool, bool]:
    """Whether the real and the simulated velocity vary by ``tol`` or more; the real one by
    its central 95 % (a spike does not count) and, with ``above_noise``, by more than 4x
    its sample noise (the median absolute change between samples, robust to steps), so a
    steady, noisy signal does not count as varied."""
    sim_varies = bool(sim.size) and float(np.ptp(sim)) >= tol
    if real.size < 3:
        return False, sim_varies
    floor = tol
    if above_noise:
        floor = max(tol, 4.0 * difference_sd(real))
    spread = float(np.percentile(real, 97.5) - np.percentile(real, 2.5))
    return spread >= floor, sim_varies


def _fit_of_varied(real: FloatArray, sim: FloatArray, tol: float) -> float:
    """FIT % of an axis; NaN when neither the real nor the simulated velocity varies by
    ``tol`` (the v of a spin in place: a score of odometry noise against its own mean)."""
    return fit_percent(real, sim) if any(_varies(real, sim, tol)) else math.nan


def _lag_of_varied(
    t: FloatArray, real: FloatArray, sim: FloatArray, active: BoolArray, tol: float
) -> float:
    """Lag of ``sim`` behind ``real`` (s); NaN when either varies by less than ``tol`` over
    the active samples (the v of a spin in place, the w of a steady spin): a cross-correlation
    of odometry noise has a peak, but not at any latency."""
    if active.any() and not all(_varies(real[active], sim[active], tol, above_noise=True)):
        return math.nan
    return xcorr_lag_s(t, real, sim)


def _trace_file(trace: TraceLike) -> tuple[str | None, str | None]:
    meta = getattr(trace, "meta", None)
    path = getattr(meta, "path", None)
    sha = getattr(meta, "sha256", None)
    return (str(path) if path else None, str(sha) if sha else None)


def measure_agreement(
    trace: TraceLike,
    sim: ReplayResult,
    *,
    tol_v: float = DEFAULT_TOL_V,
    tol_w: float = DEFAULT_TOL_W,
    params_file: str | None = None,
) -> AgreementReport:
    """Agreement of a replay with the log it replayed.

    The simulated v is compared as the replay reported it: replay with
    ``odom_v_window_s=1 / odometry rate`` to compare it like the encoder odometry reports v
    (see "Odometry v window" in the module docstring); the window is copied into the report.

    Examples
    --------
    >>> from sim2real.logs import read_trace  # doctest: +SKIP
    >>> trace = read_trace("val.mcap")  # doctest: +SKIP
    >>> sim = replay(trace, robot="turtlebot3_burger", engine="reduced")  # doctest: +SKIP
    >>> measure_agreement(trace, sim).agreement  # doctest: +SKIP
    0.93
    """
    cmd_v, cmd_w = trace.cmd_at_meas()
    log_file, sha = _trace_file(trace)
    return agreement_from_arrays(
        t_s=np.asarray(trace.meas_t_s, dtype=np.float64),
        cmd_v=np.asarray(cmd_v, dtype=np.float64),
        cmd_w=np.asarray(cmd_w, dtype=np.float64),
        real_v=np.asarray(trace.meas_v, dtype=np.float64),
        real_w=np.asarray(trace.meas_w, dtype=np.float64),
        sim_v=sim.v,
        sim_w=sim.w,
        tol_v=tol_v,
        tol_w=tol_w,
        robot=sim.robot,
        params_file=params_file,
        log_file=log_file,
        log_sha256=sha,
        odom_v_window_s=sim.odom_v_window_s,
    )


# --- ensemble and predictive band ------------------------------------------------------------

#: Odometry-noise realisations drawn per ensemble member (the band is taken over N x K traces);
#: more when N x NOISE_DRAWS draws could not span the widest band of :data:`COVERAGE_LEVELS`.
NOISE_DRAWS = 4
#: Band levels of the coverage-vs-level curve (:attr:`EnsembleResult.coverage_by_level`).
COVERAGE_LEVELS: tuple[float, ...] = (0.5, 0.6, 0.7, 0.8, 0.9, 0.95)
#: Names of the random streams of the ensemble: the streams of a default-named
#: :class:`randomizers.DynamicsRandomizer` and :class:`randomizers.VelocityObservationNoise`
#: reset with the same seed (same seed, same robots as in training).
DYNAMICS_STREAM = "DynamicsRandomizer"
NOISE_STREAM = "VelocityObservationNoise"


@dataclass(frozen=True, kw_only=True)
class EnsembleResult:
    """Replays drawn from a params file's randomisation, their predictive band and its coverage.

    Attributes
    ----------
    n, seed : int
        Ensemble size and the seed of the draws.
    spread : float
        Multiplier applied to every standard deviation (dynamics and noise).
    band_level : float
        Central probability of the band.
    noise_draws : int
        Odometry-noise realisations per member.
    t_s : ndarray
        Measurement times, s since the log start.
    lo_v, hi_v, lo_w, hi_w : ndarray
        The band of v (m/s) and w (rad/s) at ``t_s``.
    coverage : float
        Fraction of active real samples inside the band on both axes (NaN if none active).
    coverage_v, coverage_w : float
        The same per axis.
    band_width_v_mps, band_width_w_radps : float
        Median band width over the active samples.
    coverage_by_level : tuple of (level, coverage_v, coverage_w)
        Coverage of the central band at each of :data:`COVERAGE_LEVELS` (a calibrated band
        covers about ``level``).
    params : tuple of DriveParams
        The drawn parameter sets.
    sampled : tuple of str
        Parameters that vary in the distribution.
    members_v, members_w : ndarray
        Noise-free simulated v and w of each member, shape (n, samples).
    active : ndarray of bool
        The active-sample mask the coverage counts.
    """

    n: int
    seed: int
    spread: float
    band_level: float
    noise_draws: int
    t_s: FloatArray
    lo_v: FloatArray
    hi_v: FloatArray
    lo_w: FloatArray
    hi_w: FloatArray
    coverage: float
    coverage_v: float
    coverage_w: float
    band_width_v_mps: float
    band_width_w_radps: float
    coverage_by_level: tuple[tuple[float, float, float], ...]
    params: tuple[DriveParams, ...]
    sampled: tuple[str, ...]
    members_v: FloatArray
    members_w: FloatArray
    active: NDArray[np.bool_]

    def band_figures(self) -> dict[str, Any]:
        """The band's JSON keys (:data:`BAND_KEYS`), NaN as ``None``."""
        out: dict[str, Any] = {}
        for key in BAND_KEYS:
            if key == "coverage_by_level":
                value: Any = [
                    {"level": lv, "coverage_v": _finite(cv), "coverage_w": _finite(cw)}
                    for lv, cv, cw in self.coverage_by_level
                ]
            elif key == "ensemble_n":
                value = self.n
            else:
                value = _finite(getattr(self, key))
            out[key] = value
        return out


#: The keys ``sim2real agree --ensemble N --json`` adds after :data:`AGREEMENT_KEYS`.
BAND_KEYS: tuple[str, ...] = (
    "coverage",
    "coverage_v",
    "coverage_w",
    "band_level",
    "band_width_v_mps",
    "band_width_w_radps",
    "ensemble_n",
    "coverage_by_level",
)


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def predictive_samples(
    members_v: FloatArray,
    members_w: FloatArray,
    noise: Any,
    rng: np.random.Generator,
    *,
    noise_draws: int = NOISE_DRAWS,
    spread: float = 1.0,
) -> tuple[FloatArray, FloatArray]:
    """Odometry as each member would report it: ``noise_draws`` noisy copies per member.

    ``noise`` is a :class:`robots.randomization.ObservationNoise`; its
    :meth:`~robots.randomization.ObservationNoise.apply` (white noise, then quantisation) is
    the rule :class:`randomizers.VelocityObservationNoise` applies in training. Returns arrays
    of shape (n * noise_draws, samples).
    """
    mv = np.repeat(np.atleast_2d(members_v), noise_draws, axis=0)
    mw = np.repeat(np.atleast_2d(members_w), noise_draws, axis=0)
    v, w = noise.apply(rng, mv, mw, spread=spread)
    return v, w


def predictive_band(samples: FloatArray, level: float) -> tuple[FloatArray, FloatArray]:
    r"""Central ``level`` band of draws (rows) at each sample (columns).

    The quantiles use the Weibull plotting position :math:`p\,(m + 1)` of *m* draws: the
    interval between those order statistics contains a further draw of the same distribution
    with probability ``level`` (Hyndman & Fan 1996, definition 6), whereas plain sample
    quantiles give a band that is too narrow for small ensembles (about 81 % instead of 90 %
    with 20 draws).

    Examples
    --------
    >>> import numpy as np
    >>> lo, hi = predictive_band(np.arange(19.0).reshape(19, 1), 0.9)
    >>> float(lo[0]), float(hi[0])
    (0.0, 18.0)
    """
    level = check_band_level(level)
    q = (0.5 * (1.0 - level), 0.5 * (1.0 + level))
    lo, hi = np.quantile(samples, q, axis=0, method="weibull")
    return lo, hi


#: A real sample this close to a band edge counts as inside it. Quantised odometry puts real
#: samples and band edges on the same lattice (k x quantum), computed in different ways (tick
#: arithmetic vs rounding with the quantum read from the params file), so an edge sample may
#: differ from the edge by round-off only; 1e-9 (m/s or rad/s) is far below any sensor's
#: resolution.
EDGE_TOL = 1e-9


def _within(real: FloatArray, lo: FloatArray, hi: FloatArray) -> NDArray[np.bool_]:
    return (real >= lo - EDGE_TOL) & (real <= hi + EDGE_TOL)


def band_coverage(
    real: FloatArray, lo: FloatArray, hi: FloatArray, active: NDArray[np.bool_]
) -> float:
    """Fraction of the active ``real`` samples inside ``[lo, hi]`` (NaN when none is active).

    A sample within :data:`EDGE_TOL` of an edge is inside (round-off on a quantised lattice).

    Examples
    --------
    >>> q = 0.5 * 0.033 * (2 * np.pi / 4096) * 30.0  # one encoder quantum of v, m/s
    >>> real = np.array([3 * q, 0.1])
    >>> edge = np.full(2, np.round(3 * q / 0.00075932049) * 0.00075932049)  # a rounded quantum
    >>> bool(real[0] > edge[0]), band_coverage(real, -edge, edge, np.ones(2, bool))
    (True, 0.5)
    """
    if not active.any():
        return math.nan
    return float(np.mean(_within(real, lo, hi)[active]))


def _median_width(lo: FloatArray, hi: FloatArray, active: NDArray[np.bool_]) -> float:
    return float(np.median((hi - lo)[active])) if active.any() else math.nan


def check_ensemble_size(n: Any) -> None:
    """Refuse an ensemble size that is not a whole number from 2 to :data:`MAX_ENSEMBLE`.

    Examples
    --------
    >>> check_ensemble_size(20)
    """
    if isinstance(n, bool) or not isinstance(n, int) or not 2 <= n <= MAX_ENSEMBLE:
        raise Sim2RealValueError(
            f"ensemble size (--ensemble) must be a whole number from 2 to {MAX_ENSEMBLE} (each "
            "member is one full replay of the log; a 90 % band needs 19, and its quantiles "
            f"settle within a few hundred), got {n!r}; e.g. --ensemble 20"
        )


def _check_ensemble_args(n: Any, spread: Any, noise_draws: Any) -> None:
    check_ensemble_size(n)
    if isinstance(spread, bool) or not (
        isinstance(spread, int | float) and math.isfinite(spread) and spread >= 0
    ):
        raise Sim2RealValueError(
            f"ensemble spread (--spread) must be a finite number >= 0, got {spread!r}; e.g. 1"
        )
    if isinstance(noise_draws, bool) or not isinstance(noise_draws, int) or noise_draws < 1:
        raise Sim2RealValueError(
            f"noise_draws must be an integer >= 1, got {noise_draws!r}; e.g. {NOISE_DRAWS}"
        )


def band_noise_draws(n: int, level: float, at_least: int = NOISE_DRAWS) -> int:
    """Noise draws per member for an ``n``-member band that can report every level.

    *m* draws span at most a (m - 1)/(m + 1) band, so the draws are raised until ``n`` x draws
    span the widest of :data:`COVERAGE_LEVELS` and ``level``.

    Examples
    --------
    >>> band_noise_draws(32, 0.9), band_noise_draws(8, 0.9)
    (4, 5)
    """
    widest = max(*COVERAGE_LEVELS, level)
    return max(at_least, math.ceil((2.0 / (1.0 - widest) - 1.0) / n))


def _stream(seed: int, name: str) -> np.random.Generator:
    """The generator of the randomizer called ``name`` reset with ``seed``
    (:func:`randomizers.stream_generator`; imported here: the randomizers load gymnasium)."""
    from randomizers._dynamics import stream_generator

    return stream_generator(seed, name)


def ensemble_members(
    trace: TraceLike,
    *,
    robot: Any,
    distribution: Any,
    n: int,
    seed: int,
    engine: str = "reduced",
    spread: float = 1.0,
    odom_v_window_s: float = 0.0,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[list[DriveParams], FloatArray, FloatArray]:
    """Draw ``n`` parameter sets and replay ``trace`` with each: ``(params, v, w)``.

    The draws are ``distribution.sample(stream_generator(seed, "DynamicsRandomizer"), n,
    spread=spread)`` -- the parameter sets of the first ``n`` episodes of a
    ``DynamicsRandomizer.from_sysid`` reset with ``seed``. ``v`` and ``w`` have shape
    (n, samples). ``progress(done, n)`` is called after each replay (a progress bar).
    """
    _check_ensemble_args(n, spread, 1)
    drawn = distribution.sample(_stream(seed, DYNAMICS_STREAM), n, spread=spread)
    sims = []
    for k, p in enumerate(drawn):
        sims.append(
            replay(trace, robot=robot, params=p, engine=engine, odom_v_window_s=odom_v_window_s)
        )
        if progress is not None:
            progress(k + 1, n)
    return drawn, np.stack([s.v for s in sims]), np.stack([s.w for s in sims])


def _coverage_curve(
    rv: FloatArray,
    rw: FloatArray,
    sv: FloatArray,
    sw: FloatArray,
    active: NDArray[np.bool_],
    level: float,
) -> tuple[tuple[float, float, float], ...]:
    """(level, coverage v, coverage w) of the bands of :data:`COVERAGE_LEVELS` and ``level``
    drawn from the predictive samples ``sv``, ``sw``."""
    curve = []
    for lv in sorted({*COVERAGE_LEVELS, level}):
        lo_v, hi_v = predictive_band(sv, lv)
        lo_w, hi_w = predictive_band(sw, lv)
        curve.append(
            (lv, band_coverage(rv, lo_v, hi_v, active), band_coverage(rw, lo_w, hi_w, active))
        )
    return tuple(curve)


def run_ensemble(
    trace: TraceLike,
    *,
    robot: Any,
    distribution: Any,
    n: int,
    seed: int,
    engine: str = "reduced",
    spread: float = 1.0,
    tol_v: float = DEFAULT_TOL_V,
    tol_w: float = DEFAULT_TOL_W,
    odom_v_window_s: float = 0.0,
    band_level: float = DEFAULT_BAND_LEVEL,
    noise_draws: int = NOISE_DRAWS,
    progress: Callable[[int, int], None] | None = None,
    noise: Any = None,
) -> EnsembleResult:
    """Replay ``trace`` with ``n`` robots drawn from ``distribution``; band and coverage.

    Parameters
    ----------
    trace : Trace
        The real log.
    robot : str or RobotSpec
        The robot, as for :func:`sim2real.agreement.replay.replay`.
    distribution : robots.randomization.DriveDistribution
        The randomisation (``DriveDistribution.from_params_file``).
    n, seed : int
        Ensemble size (>= 2) and seed (see :func:`ensemble_members`; the noise comes from the
        stream of a default-named ``VelocityObservationNoise`` reset with ``seed``).
    engine : {"reduced", "pybullet"}
        Simulation engine of every member.
    spread : float
        Multiplier on every standard deviation, dynamics and noise (1 = the file's).
    tol_v, tol_w : float
        Tolerances of the active-sample mask, m/s and rad/s.
    odom_v_window_s : float
        Odometry window of every member's v, s (see :func:`sim2real.agreement.replay.replay`).
    band_level : float
        Central probability of the band, in (0, 1).
    noise_draws : int
        Odometry-noise realisations per member (the band is over ``n * noise_draws`` traces);
        raised so that the traces can span the widest band of :data:`COVERAGE_LEVELS` (*m*
        draws span at most an :math:`(m - 1)/(m + 1)` band). Where the dynamics dominate the
        band, only ``n`` decides: use ``n >= 2 / (1 - band_level) - 1`` (19 for 90 %).
    noise : ObservationNoise or SampleNoise, optional
        The band's odometry noise (:func:`sim2real.agreement.latency.band_sample_noise`: an
        sd per sample); default ``distribution.noise``.

    Examples
    --------
    >>> dist = DriveDistribution.from_params_file("params.yaml", robot="turtlebot2")
    ... # doctest: +SKIP
    >>> ens = run_ensemble(trace, robot="turtlebot2", distribution=dist, n=20, seed=0)
    ... # doctest: +SKIP
    >>> ens.coverage_v, ens.band_width_v_mps  # doctest: +SKIP
    (0.91, 0.05)
    """
    check_tolerances(tol_v, tol_w)
    level = check_band_level(band_level)
    _check_ensemble_args(n, spread, noise_draws)
    spec = resolve_robot(robot)
    drawn, mv, mw = ensemble_members(
        trace,
        robot=spec,
        distribution=distribution,
        n=n,
        seed=seed,
        engine=engine,
        spread=spread,
        odom_v_window_s=odom_v_window_s,
        progress=progress,
    )
    return ensemble_of_members(
        trace,
        (mv, mw),
        noise=distribution.noise if noise is None else noise,
        seed=seed,
        params=tuple(drawn),
        sampled=tuple(distribution.names),
        spread=spread,
        tol_v=tol_v,
        tol_w=tol_w,
        band_level=level,
        noise_draws=noise_draws,
    )


def ensemble_of_members(
    trace: TraceLike,
    members: tuple[FloatArray, FloatArray],
    *,
    noise: Any,
    seed: int,
    params: tuple[DriveParams, ...] = (),
    sampled: tuple[str, ...] = (),
    spread: float = 1.0,
    tol_v: float = DEFAULT_TOL_V,
    tol_w: float = DEFAULT_TOL_W,
    band_level: float = DEFAULT_BAND_LEVEL,
    noise_draws: int = NOISE_DRAWS,
) -> EnsembleResult:
    """The predictive band of replays already made, and its coverage of ``trace``.

    ``members`` = (v, w), each of shape (n, samples): the replays of ``n`` robots at the
    measurement times of ``trace`` (e.g. :func:`ensemble_members`, or draws of another
    toolbox's confidence region replayed with :func:`sim2real.agreement.replay.replay`).
    ``noise`` (a :class:`robots.randomization.ObservationNoise`) and ``seed`` add the
    odometry noise as :func:`run_ensemble` does; ``params`` and ``sampled`` are recorded.

    Examples
    --------
    >>> ens = ensemble_of_members(trace, (mv, mw), noise=ObservationNoise(0.01, 0.05), seed=0)
    ... # doctest: +SKIP
    >>> ens.coverage_v  # doctest: +SKIP
    0.9
    """
    check_tolerances(tol_v, tol_w)
    level = check_band_level(band_level)
    mv, mw = (np.atleast_2d(np.asarray(m, dtype=np.float64)) for m in members)
    n = mv.shape[0]
    _check_ensemble_args(n, spread, noise_draws)
    noise_draws = band_noise_draws(n, level, noise_draws)
    sv, sw = predictive_samples(
        mv,
        mw,
        noise,
        _stream(seed, NOISE_STREAM),
        noise_draws=noise_draws,
        spread=spread,
    )
    rv = np.asarray(trace.meas_v, dtype=np.float64)
    rw = np.asarray(trace.meas_w, dtype=np.float64)
    cmd_v, cmd_w = trace.cmd_at_meas()
    active = active_mask(cmd_v, cmd_w, rv, rw, tol_v=tol_v, tol_w=tol_w)
    curve = _coverage_curve(rv, rw, sv, sw, active, level)
    lo_v, hi_v = predictive_band(sv, level)
    lo_w, hi_w = predictive_band(sw, level)
    inside = _within(rv, lo_v, hi_v) & _within(rw, lo_w, hi_w)
    return EnsembleResult(
        n=n,
        seed=seed,
        spread=float(spread),
        band_level=level,
        noise_draws=noise_draws,
        t_s=np.asarray(trace.meas_t_s, dtype=np.float64),
        lo_v=lo_v,
        hi_v=hi_v,
        lo_w=lo_w,
        hi_w=hi_w,
        coverage=float(np.mean(inside[active])) if active.any() else math.nan,
        coverage_v=band_coverage(rv, lo_v, hi_v, active),
        coverage_w=band_coverage(rw, lo_w, hi_w, active),
        band_width_v_mps=_median_width(lo_v, hi_v, active),
        band_width_w_radps=_median_width(lo_w, hi_w, active),
        coverage_by_level=curve,
        params=params,
        sampled=sampled,
        members_v=mv,
        members_w=mw,
        active=active,
    )


# --- verdict ----------------------------------------------------------------------------------


def calibrated_range(level: float) -> tuple[float, float]:
    """Coverage range in which a ``level`` band counts as calibrated.

    From ``level - 0.1`` (misses up to 10 points more than it should) to
    ``level + 0.9 (1 - level)`` (misses at least a tenth of what it should): 80-99 % for a
    90 % band.

    Examples
    --------
    >>> tuple(round(x, 3) for x in calibrated_range(0.9))
    (0.8, 0.99)
    """
    level = check_band_level(level)
    return level - 0.1, level + 0.9 * (1.0 - level)


def _axis_state(coverage: float, level: float) -> str:
    lo, hi = calibrated_range(level)
    if not math.isfinite(coverage):
        return "unknown"
    if coverage < lo:
        return "narrow"
    if coverage > hi:
        return "wide"
    return "ok"


def lag_phrase(lag_s: float) -> str:
    """``"sim lags real by 0.120 s"`` (sim late), ``"sim leads real by 0.038 s"`` (sim early).

    Examples
    --------
    >>> lag_phrase(0.12), lag_phrase(-0.0381), lag_phrase(0.001)
    ('sim lags real by 0.120 s', 'sim leads real by 0.038 s', 'sim and real in step (< 5 ms)')
    """
    if not math.isfinite(lag_s):
        return "lag unknown (a constant signal)"
    if abs(lag_s) < 0.005:
        return "sim and real in step (< 5 ms)"
    return f"sim {'lags' if lag_s > 0 else 'leads'} real by {abs(lag_s):.3f} s"


def band_verdict(
    *,
    coverage_v: float,
    coverage_w: float,
    band_level: float = DEFAULT_BAND_LEVEL,
    band_width_v_mps: float = math.nan,
    band_width_w_radps: float = math.nan,
) -> str:
    """One sentence: is the predictive band too narrow, calibrated or too wide, and what to do.

    A band is calibrated when the coverage of both v and w lies in :func:`calibrated_range`.

    Examples
    --------
    >>> band_verdict(coverage_v=0.42, coverage_w=0.9).split(":")[0]
    'The 90 % band is too narrow on v'
    >>> band_verdict(coverage_v=0.9, coverage_w=0.93).split(":")[0]
    'The 90 % band is calibrated'
    """
    level = check_band_level(band_level)
    lo, hi = calibrated_range(level)
    states = {"v": _axis_state(coverage_v, level), "w": _axis_state(coverage_w, level)}
    pct = f"{100 * level:g} %"
    cov = f"it covers {_pct(coverage_v)} of the active real v samples and {_pct(coverage_w)} of w"
    target = f"(calibrated: {100 * lo:.0f}-{100 * hi:.0f} %)"
    calibrate = (
        "'sim2real sysid calibrate PARAMS.yaml VALIDATION.mcap -o CALIBRATED.yaml' on a log the "
        "fit did not use"
    )
    if "unknown" in states.values():
        return (
            f"The {pct} band cannot be judged: the log has no active sample on one axis; record "
            "a log in which the robot moves and turns"
        ) + "."
    if set(states.values()) == {"ok"}:
        widths = ""
        if math.isfinite(band_width_v_mps) and math.isfinite(band_width_w_radps):
            widths = (
                f", {band_width_v_mps:.3g} m/s and {band_width_w_radps:.3g} rad/s wide (median)"
            )
        return (
            f"The {pct} band is calibrated: {cov} {target}{widths}; train with this "
            "randomisation (randomizers.DynamicsRandomizer.from_sysid and "
            "VelocityObservationNoise.from_sysid of the same params file)."
        )
    if "narrow" in states.values() and "wide" in states.values():
        narrow = next(a for a, s in states.items() if s == "narrow")
        wide = next(a for a, s in states.items() if s == "wide")
        return (
            f"The {pct} band is too narrow on {narrow} and too wide on {wide}: {cov} {target}; "
            f"fit its spread per axis with {calibrate}."
        )
    if "narrow" in states.values():
        axes = " and ".join(a for a, s in states.items() if s == "narrow")
        return (
            f"The {pct} band is too narrow on {axes}: {cov} {target}, so the randomisation "
            f"does not contain the real robot; widen it with {calibrate}, or fit several "
            "sessions at once (sysid fit a.mcap b.mcap ...) so the between-session spread is "
            "estimated."
        )
    axes = " and ".join(a for a, s in states.items() if s == "wide")
    return (
        f"The {pct} band is too wide on {axes}: {cov} {target}, so training randomises more "
        f"than the real robot varies; shrink it with {calibrate}."
    )


def _pct(x: float) -> str:
    return f"{100 * x:.1f} %" if math.isfinite(x) else "n/a"


def since_command_step_s(
    trace: Any,
    *,
    tol_v: float,
    tol_w: float,
    limits: tuple[float, float] = (math.inf, math.inf),
) -> FloatArray:
    """Seconds from the last command step to each measurement (inf before the first command).

    A step is a change of the command by more than ``tol_v`` in v or ``tol_w`` in w: the
    agreement's tolerances, so a controller's small corrections are not steps. The command is
    first clipped to the robot's ``limits`` (top speed m/s, top yaw rate rad/s): a log that commands
    2 then 3 m/s to a base capped at 0.3 m/s makes no step (the robot runs at its cap through
    both).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> tr = SimpleNamespace(cmd_t_ns=np.array([0, 10**9]), cmd_v=np.array([0.0, 0.2]),
    ...                      cmd_w=np.zeros(2), meas_t_ns=np.array([5 * 10**8, 15 * 10**8]))
    >>> since_command_step_s(tr, tol_v=0.02, tol_w=0.1).tolist()
    [0.5, 0.5]
    >>> over = SimpleNamespace(**{**vars(tr), "cmd_v": np.array([2.0, 3.0])})  # a 0.3 m/s cap
    >>> since_command_step_s(over, tol_v=0.02, tol_w=0.1, limits=(0.3, 2.0)).tolist()
    [0.5, 1.5]
    """
    cmd_t = seconds(np.asarray(trace.cmd_t_ns))
    cv = np.clip(np.asarray(trace.cmd_v, dtype=np.float64), -limits[0], limits[0])
    cw = np.clip(np.asarray(trace.cmd_w, dtype=np.float64), -limits[1], limits[1])
    changed = np.ones(cmd_t.size, dtype=bool)
    changed[1:] = (np.abs(np.diff(cv)) > tol_v) | (np.abs(np.diff(cw)) > tol_w)
    change_t = cmd_t[changed]
    meas_t = seconds(np.asarray(trace.meas_t_ns))
    i = np.searchsorted(change_t, meas_t, side="right") - 1
    out: FloatArray = np.where(i >= 0, meas_t - change_t[np.maximum(i, 0)], np.inf)
    return out
