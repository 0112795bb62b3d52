r"""Fit the spread of a params file's randomisation to a validation log, by likelihood.

A sysid fit gives a distribution of robots (``randomization:`` block: a Gaussian in fit
coordinates plus an odometry-noise model). Whether it is as wide as the real robot varies can
only be judged on a log the fit did not use. :func:`calibrate` fits the *spread* of that
distribution to such a validation log, in the spirit of DROPO (Tiboni et al., 2023, "DROPO:
Sim-to-real transfer with offline domain randomization"): maximise the likelihood of the real
trace under the predictive distribution of the randomised simulation.

Model
-----
The covariance becomes :math:`\Sigma(a, b) = a^2 \Sigma_f + b^2 \Sigma_s`: the file's
covariance :math:`\Sigma_f` (posterior plus the between-session spread the fit estimated)
scaled by a dynamics factor *a*, plus the robot spec's default between-session covariance
:math:`\Sigma_s = \mathrm{diag}(\text{session\_sd}^2)` (payload, floor, battery and latency
change from day to day) scaled by *b*. The second block matters because a between-session
covariance estimated from a few sessions is itself uncertain and often too small in some
direction (e.g. latency); the likelihood of held-out sessions decides how much of the spec's
belief to add. For given (a, b), *N* robots are drawn (common random numbers: the same seed
for every (a, b)) and the log is replayed with each. At every active measurement time
:math:`t_k` and per axis the predictive distribution is Gaussian with the members' mean
:math:`m_k` and variance

.. math:: V_k = (1 + 1/N)\,\widehat{\mathrm{var}}_k + \sigma^2 + q^2/12,

the sample variance of the members (inflated for a new draw), the odometry white noise
:math:`\sigma` and the quantisation :math:`q` of the noise model. The objective is the mean
Gaussian log-likelihood of the real :math:`v_k` and :math:`\omega_k` over the active samples.
:math:`\sigma_v` and :math:`\sigma_\omega` are maximised by bounded 1-D searches for each
(a, b); (a, b) by a grid refined with Nelder-Mead. The mean (the point estimate) is kept.

Sessions, not samples
---------------------
The likelihood sums thousands of samples, but what (a, b) mostly judge, the between-session
spread, was drawn once per validation *session*. Taken alone, the optimum of two validation
sessions that happen to look alike shrinks the spread (a = 0.05-0.31 in 7 of 27 synthetic
Kobuki-sized fleets) and a later session unlike them falls far outside the band; two unlike
ones widen it past any robot (a = 1.3-1.6 in 9, bands up to 0.33 m/s wide). So the optimum is pooled with the file's own spread by degrees of freedom
(:func:`pooled_factors`): the file's spread counts as many sessions as the fit saw (plus the
spec prior's pseudo-sessions), the optimum as many as there are validation logs.

Noise: steady samples, a robust scale
-------------------------------------
Odometry white noise shows where the robot drives steadily; near a command step the residual
is timing and transients (a delay off by 50 ms misses a 1 rad/s step by 0.05 rad/s for as
long as the step takes), which a Gaussian likelihood covers by widening :math:`\sigma` many
times over. So the noise std of each axis is estimated on the samples at least
:data:`STEADY_AFTER_STEP_S` after a command step (all of them when fewer than
:data:`MIN_STEADY` are), by a median-based scale that a minority of large misses cannot move
(:func:`robust_noise_std`), and the likelihood of (a, b) is evaluated with that std fixed.
That scale is taken no larger than the residuals' scatter within their steady stretches
(:func:`stretch_noise_std`): a model's miss held over a stretch (a P wheel loop's steady-state
error on a slow turn) moves all its samples alike, which independent odometry noise does not;
it is the dynamics spread's to cover.
Where the members' spread already explains the residuals, the samples cannot tell a noise std
of 0 from the file's; so the variance is weighted by the share :math:`\rho` of a noise-only
log's Fisher information on :math:`\sigma^2` that the samples hold
(:func:`noise_information_share`) and the file's variance by :math:`1 - \rho`
(:func:`shrunk_noise_std`): the identified noise.

Coverage matching
-----------------
The last steps check the band itself, built as ``agree --ensemble`` builds it
(:func:`sim2real.agreement.figures.predictive_band`). With (a, b) kept, the central
:data:`MATCH_LEVEL` band with the identified noise should cover between the level and halfway
to 100 % of the steady samples (:func:`match_range`: 90-95 % for a 90 % band); outside that
range each axis's noise std is scaled by the factor :math:`c` at which the coverage reaches the
range's nearer end (split-conformal calibration of the band's scale, Angelopoulos & Bates
2021, "A gentle introduction to conformal prediction", sec. 1, with a margin because another
session differs from the validation ones), found by bisection in :data:`NOISE_SCALE_RANGE`
(common random numbers: coverage nearly always rises with :math:`c`), never below what the
logs show of their noise: the samples' robust std beyond the spread, and the logs' own scatter
about the level of their steady stretches (:func:`sim2real.agreement.latency.log_noise`, no
model involved); a log without such stretches cannot tell its noise from the spread, and its
noise is not narrowed. Where the end of that range moves the coverage by less than its
binomial standard error, the noise has no effect on the band: the identified std is kept and a
note says so. Command steps are read on the command clipped to the robot's limits (a log that
commands 2 then 3 m/s to a base capped at 0.3 m/s makes no step).

A band that, with that noise, still covers more than the top of :func:`match_range` of all the
samples is too wide by its dynamics spread. The spread is then narrowed where it makes the
over-covered axis wide: the varying parameters are split into those that move v more than w,
those that move w more (each one's share of its axis's member variance, drawn alone:
:func:`sim2real.agreement.sources.source_variances`) and the command latency, which moves both
at every step; each group's sds are scaled by the factor, found by bisection down to
:data:`NARROW_MIN`, at which its axis (both for the latency) reaches the top of the range while
the other axis stays at or above it (the same split-conformal scaling, applied to the spread
that makes the width rather than to one factor shared by both axes). That scale, judged on the
validation sessions, is pooled with the file's spread by sessions as the factors are
(:func:`pooled_narrowing`): a fleet's between-session spread, estimated on several fitted
sessions, is narrowed by one or two alike validation sessions only as far as they weigh against
it (the band must hold the next session, not the one it was calibrated on). A parameter
whose spread moves the validation members by less than the odometry noise moves the readings
is not measured by that scaling (the samples cannot tell its spread from the noise): it is
narrowed no further than the spec prior's between-session sd (:func:`narrowing_floor`), the
spread by which the next session or unit varies and which one session cannot show.
Then, where the band covers less than the level of *all* the samples on either axis (the
misses near command steps), the session factor b is raised by bisection up to
:data:`SESSION_MAX` until both axes reach it: a session unlike the fit's (latency, load,
floor) is the between-session spread's to cover. It is raised on one group of parameters:
of the unions of the latency, the v and the w parameters whose widening reaches the level, the
one with the narrowest band (:meth:`_FactorSearch.widened`; sharpness subject to calibration,
Gneiting, Balabdaoui & Raftery 2007, "Probabilistic forecasts, calibration and sharpness").
Where no b does, the noise std of the failing
axis is widened on every sample until it does (the band is then wider than the odometry
noise, by what the model lacks). The factors, noise
stds, the likelihood before and after and the validation coverage before and after go into a
``calibration:`` block, with the model's share of the noise judged on these logs, which the fit
never saw (:func:`held_out_model_noise`): ``agree``'s band sets it beside a checked log's own
noise (:func:`sim2real.agreement.latency.band_noise`). Calibrate on logs of sessions the fit did not see; several sessions
estimate the between-session spread better than one.

Engines
-------
The likelihood search replays hundreds of ensembles; an engine that follows a faster one's
replays (MuJoCo follows the reduced model it is exported from) leaves the search to the
faster one (:data:`SEARCH_ENGINE`) and replays its own ensembles only for what the band is
made of: the identified noise, the coverage matching and the widening.

Examples
--------
>>> from sim2real.agreement.calibration import calibrate, write_calibrated
>>> result = calibrate("params.yaml", ["val.mcap"], robot="turtlebot2")  # doctest: +SKIP
>>> result.dynamics_factor  # doctest: +SKIP
2.3
>>> write_calibrated("params.yaml", "calibrated.yaml", result)  # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from scipy.optimize import brentq, minimize, minimize_scalar

from robots.errors import ParamsFileError
from robots.params import read_params_file
from robots.randomization import DriveDistribution, cap_spread
from robots.spec import load_spec
from sim2real._arrays import BoolArray, FloatArray, IntArray
from sim2real._io import atomic_write, check_not_an_input
from sim2real.agreement.figures import (
    band_coverage,
    band_noise_draws,
    check_band_level,
    check_tolerances,
    ensemble_members,
    predictive_band,
    since_command_step_s,
)
from sim2real.agreement.latency import band_log_noise, fit_model_share, log_noise, replay_rate
from sim2real.agreement.replay import replay, resolve_robot
from sim2real.agreement.sources import source_variances
from sim2real.errors import Sim2RealValueError
from sim2real.logs import ReadOptions, read_for_robot
from sysid import held_speeds, spread_degrees_of_freedom
from sysid.metrics import active_mask
from sysid.steady import pooled_steady_noise, steady_stretches

__all__ = [
    "CALIBRATION_METHOD",
    "CalibrationResult",
    "calibrate",
    "calibrate_traces",
    "held_lower_bounds",
    "held_out_model_noise",
    "match_noise_scale",
    "match_range",
    "narrowing_floor",
    "noise_information_share",
    "pooled_factors",
    "pooled_narrowing",
    "predictive_log_likelihood",
    "robust_noise_std",
    "shrunk_noise_std",
    "stretch_noise_std",
    "write_calibrated",
]


#: Name of the method in the output file's ``calibration`` block.
CALIBRATION_METHOD = (
    "gaussian-predictive-likelihood/7 (DROPO-style, Tiboni et al. 2023), pooled with the fit's "
    "spread by sessions, noise from the steady samples (robust scale, no larger than their "
    "scatter within their steady stretches) matched to the band's "
    "coverage of them no lower than the logs' own scatter, an over-covering axis's parameter "
    "spread narrowed (pooled with the fit's by sessions; what the samples cannot tell from the "
    "noise no further than the spec's between-session sd) and the session spread widened to "
    "cover the rest (split conformal)"
)
#: Search range of the dynamics factor.
FACTOR_RANGE = (0.05, 10.0)
#: Search range of the odometry noise stds (m/s or rad/s).
NOISE_RANGE = (1e-5, 1.0)
#: Points of the initial log-spaced grid of the dynamics factor.
GRID_POINTS = 7
#: Initial grid and upper bound of the session factor (times the spec's session spread).
SESSION_GRID = (0.0, 0.5, 1.0, 2.0)
SESSION_MAX = 4.0
#: Likelihood evaluations of the Nelder-Mead refinement after the grid.
REFINE_EVALUATIONS = 16
#: Default ensemble size of the calibration.
DEFAULT_N = 32
#: Band level whose coverage of the validation logs the noise stds are matched to.
MATCH_LEVEL = 0.9
#: Range of the noise-std scale of the coverage matching (times the likelihood's std).
NOISE_SCALE_RANGE = (0.1, 10.0)
#: Bisection steps of the widening of the session factor (:meth:`_FactorSearch.widened`):
#: to 1/64 of its span.
WIDEN_STEPS = 6
#: Smallest multiplier of the narrowing of an axis's parameters' spread
#: (:meth:`_FactorSearch.narrowed`).
NARROW_MIN = 0.1
#: Median of a chi-square variable with one degree of freedom: the median of the squared
#: standardised residual when the residuals are the predictive Gaussian's
#: (:func:`robust_noise_std`).
CHI2_1_MEDIAN = 0.454936423119572
#: The noise is calibrated on steady samples: at least this long after a command step (a
#: change larger than the agreement tolerance on either axis), s. Closer to a step, timing and
#: transient errors make the residual, which the dynamics spread (delay, time constants), not
#: white noise, is to cover.
STEADY_AFTER_STEP_S = 1.0
#: Fewer steady samples than this on an axis: the noise is calibrated on all the samples.
MIN_STEADY = 20
#: The engine whose replays search the spread's likelihood (hundreds of ensembles) for a
#: slower engine that follows it (``agree --engine mujoco`` is within 0.02 of the reduced
#: model's agreement); the noise, the band's coverage and the widening (about ten ensembles)
#: are the slower engine's own.
SEARCH_ENGINE = {"mujoco": "reduced", "mujoco-lifted": "reduced"}
#: Bisection steps of the coverage matching: the log scale between 1 and a bound of
#: :data:`NOISE_SCALE_RANGE` (a factor 10) to 2**-24 of its width, a scale to ~1e-7 relative.
MATCH_STEPS = 24


@dataclass(frozen=True, kw_only=True)
class CalibrationResult:
    r"""The fitted spread of a distribution and how much it improved the likelihood.

    Attributes
    ----------
    dynamics_factor : float
        Factor a on the file's covariance :math:`\Sigma_f` (calibrated covariance
        :math:`a^2 \Sigma_f + b^2 \Sigma_s`).
    session_factor : float
        Factor b on the spec's between-session covariance :math:`\Sigma_s`
        (:func:`session_covariance`), after the widening that makes the band cover the
        validation samples (module docstring), on the parameters in ``widened``.
    pooled_session_factor : float
        b as pooled by sessions, before that widening (the factor of the other parameters).
    widened : tuple of str
        The parameters whose between-session spread the widening acted on: of the groups
        that reach the coverage, the one with the narrowest band (all of them when no
        widening was needed).
    likelihood_dynamics_factor, likelihood_session_factor : float
        The validation likelihood's optimum, before it is pooled with the file's spread by
        sessions (:func:`pooled_factors`) into ``dynamics_factor`` and
        ``pooled_session_factor``.
    fit_sessions, validation_sessions : int
        Logs the file was fitted on and validation logs: the weights of that pooling.
    noise_std_v_mps, noise_std_w_radps : float
        Fitted odometry white-noise stds (after the coverage matching).
    noise_factor_v, noise_factor_w : float
        Fitted noise std / the file's (NaN when the file's std is 0).
    log_likelihood, log_likelihood_before : float
        Mean Gaussian predictive log-likelihood per active sample, v's and w's summed: at the
        pooled factors with the identified noise stds of the steady samples (before the
        coverage matching), and with the file's distribution as it was.
    noise_scale_v, noise_scale_w : float
        Coverage matching (module docstring): final noise std / the identified one (the
        steady samples' robust std, shrunk toward the file's by :func:`shrunk_noise_std`).
    match_level : float
        Band level of the matching.
    coverage_v_likelihood, coverage_w_likelihood : float
        Share of the validation logs' active samples inside the ``match_level`` band with the
        identified noise stds and the pooled factors.
    coverage_v, coverage_w : float
        The same with the calibrated distribution (matched noise, widened session factor).
    n_active : int
        Active samples over all validation logs.
    n, seed : int
        Ensemble size and seed of the calibration.
    engine : str
        Simulator of the calibration.
    odom_v_window_s : float
        Odometry window of the simulated v, s.
    distribution : DriveDistribution
        The calibrated distribution (mean unchanged).
    original : DriveDistribution
        The distribution as read.
    validation : tuple of (str, str)
        (file, sha256) of each validation log.
    notes : tuple of str
        What reading the logs repaired or chose (time source, velocities from the pose), one
        sentence each, prefixed by the file (:func:`calibrate` adds these), and what the noise
        calibration chose (steady samples, a noise std too weak to move the band's coverage);
        printed by the CLI.
    steady_v, steady_w : float
        Share of the validation samples the noise was calibrated on: those at least
        :data:`STEADY_AFTER_STEP_S` after a command step (all when fewer than
        :data:`MIN_STEADY`).
    narrowing : tuple of (str, float)
        (parameter, multiplier of its sd) of each parameter whose spread the over-covered
        band narrowed (module docstring); empty when none was.
    model_noise_std_v_mps, model_noise_std_w_radps : float
        The model's share of the noise where the replay runs steady, judged out of sample
        (:func:`held_out_model_noise`; NaN when the logs cannot tell their own measurement
        noise).
    model_noise_timing_v_s, model_noise_timing_w_s : float
        Its growth with the replay's rate of change, s
        (:class:`sim2real.agreement.latency.ModelShare`).
    """

    dynamics_factor: float
    session_factor: float
    pooled_session_factor: float = math.nan
    likelihood_dynamics_factor: float = math.nan
    likelihood_session_factor: float = math.nan
    fit_sessions: int = 1
    validation_sessions: int = 1
    noise_std_v_mps: float
    noise_std_w_radps: float
    noise_factor_v: float
    noise_factor_w: float
    log_likelihood: float
    log_likelihood_before: float
    noise_scale_v: float = 1.0
    noise_scale_w: float = 1.0
    match_level: float = MATCH_LEVEL
    coverage_v_likelihood: float = math.nan
    coverage_w_likelihood: float = math.nan
    coverage_v: float = math.nan
    coverage_w: float = math.nan
    n_active: int
    n: int
    seed: int
    engine: str
    odom_v_window_s: float
    distribution: Any
    original: Any
    validation: tuple[tuple[str, str], ...] = ()
    notes: tuple[str, ...] = ()
    steady_v: float = 1.0
    steady_w: float = 1.0
    narrowing: tuple[tuple[str, float], ...] = ()
    widened: tuple[str, ...] = ()
    model_noise_std_v_mps: float = math.nan
    model_noise_std_w_radps: float = math.nan
    model_noise_timing_v_s: float = math.nan
    model_noise_timing_w_s: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """The ``calibration`` block of the output file (plain YAML types)."""

        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {
            "method": CALIBRATION_METHOD,
            "dynamics_factor": float(self.dynamics_factor),
            "session_factor": float(self.session_factor),
            "pooled_session_factor": num(self.pooled_session_factor),
            "likelihood_dynamics_factor": num(self.likelihood_dynamics_factor),
            "likelihood_session_factor": num(self.likelihood_session_factor),
            "fit_sessions": int(self.fit_sessions),
            "validation_sessions": int(self.validation_sessions),
            "noise_std_v_mps": float(self.noise_std_v_mps),
            "noise_std_w_radps": float(self.noise_std_w_radps),
            "noise_factor_v": num(self.noise_factor_v),
            "noise_factor_w": num(self.noise_factor_w),
            "log_likelihood_per_sample": float(self.log_likelihood),
            "log_likelihood_per_sample_before": float(self.log_likelihood_before),
            "noise_scale_v": float(self.noise_scale_v),
            "noise_scale_w": float(self.noise_scale_w),
            "match_level": float(self.match_level),
            "validation_coverage_v_likelihood": num(self.coverage_v_likelihood),
            "validation_coverage_w_likelihood": num(self.coverage_w_likelihood),
            "validation_coverage_v": num(self.coverage_v),
            "validation_coverage_w": num(self.coverage_w),
            "validation_steady_share_v": float(self.steady_v),
            "validation_steady_share_w": float(self.steady_w),
            "spread_narrowing": {name: float(m) for name, m in self.narrowing},
            "session_factor_parameters": list(self.widened),
            "model_noise_std_v_mps": num(self.model_noise_std_v_mps),
            "model_noise_std_w_radps": num(self.model_noise_std_w_radps),
            "model_noise_timing_v_s": num(self.model_noise_timing_v_s),
            "model_noise_timing_w_s": num(self.model_noise_timing_w_s),
            "n_active": int(self.n_active),
            "ensemble_n": int(self.n),
            "seed": int(self.seed),
            "engine": self.engine,
            "odom_v_window_s": float(self.odom_v_window_s),
            "validation": [{"file": f, "sha256": h} for f, h in self.validation],
        }


def predictive_log_likelihood(real: FloatArray, members: FloatArray, noise_var: float) -> float:
    """Mean Gaussian log-likelihood of ``real`` under the members' predictive distribution.

    ``members`` has shape (n, samples); the predictive variance at each sample is
    ``(1 + 1/n) * var(members) + noise_var`` (see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> members = np.array([[0.0, 1.0], [0.2, 1.2], [0.1, 1.1]])
    >>> round(predictive_log_likelihood(np.array([0.1, 1.1]), members, 0.01), 3)
    0.96
    """
    n = members.shape[0]
    mean = members.mean(axis=0)
    var = (1.0 + 1.0 / n) * members.var(axis=0, ddof=1) + noise_var
    var = np.maximum(var, 1e-12)
    ll = -0.5 * (np.log(2.0 * math.pi * var) + (real - mean) ** 2 / var)
    return float(np.mean(ll))


@dataclass(frozen=True)
class _Log:
    """One validation log reduced to what the likelihood needs (active samples only)."""

    trace: Any
    active: BoolArray
    v: FloatArray
    w: FloatArray
    since_step_s: FloatArray  # time since the last command step, at the active samples


def _best_noise(
    real: FloatArray, members: FloatArray, quantum: float, span: tuple[float, float]
) -> tuple[float, float]:
    """The noise std maximising the likelihood (bounded search in log std): (std, loglik)."""
    q_var = quantum**2 / 12.0

    def neg(log_std: float) -> float:
        return -predictive_log_likelihood(real, members, math.exp(2 * log_std) + q_var)

    res = minimize_scalar(
        neg,
        bounds=(math.log(span[0]), math.log(span[1])),
        method="bounded",
        options={"xatol": 1e-3},
    )
    return math.exp(float(res.x)), -float(res.fun)


def match_range(level: float) -> tuple[float, float]:
    """Validation coverage a ``level`` band is left at: from ``level`` to ``(1 + level) / 2``.

    Below ``level`` the band is widened to it (a band that misses the validation sessions
    misses the robot); above the midpoint to 100 % it is narrowed to that midpoint, not to
    ``level``: the matching is fitted on the validation logs, and another session differs
    from them, so a margin above the level is kept (a band matched to exactly the level on
    the validation sessions covers less of a new one).

    Examples
    --------
    >>> match_range(0.9)
    (0.9, 0.95)
    """
    return level, 0.5 * (1.0 + level)


class _BandCoverage:
    """The ``level`` band's coverage of ``real`` with the noise std scaled by a factor, the
    band built as ``agree --ensemble`` builds it (as many noise draws per member; the same
    standard normal draws for every factor)."""

    def __init__(
        self,
        real: FloatArray,
        members: FloatArray,
        std: float,
        quantum: float,
        *,
        level: float,
        seed: int,
    ) -> None:
        self.real, self.std, self.quantum, self.level = real, std, quantum, level
        self.base = np.repeat(members, band_noise_draws(members.shape[0], level), axis=0)
        self.z = np.random.default_rng(seed).standard_normal(self.base.shape)

    def band(self, scale: float) -> tuple[FloatArray, FloatArray]:
        """The band's (lower, upper) edges with the noise std scaled by ``scale``."""
        draws = self.base + (scale * self.std) * self.z
        if self.quantum > 0:
            draws = np.round(draws / self.quantum) * self.quantum
        return predictive_band(draws, self.level)

    def __call__(self, scale: float) -> float:
        lo, hi = self.band(scale)
        return band_coverage(self.real, lo, hi, np.ones(self.real.shape, dtype=bool))

    def width(self, scale: float) -> float:
        """The band's median width with the noise std scaled by ``scale``."""
        lo, hi = self.band(scale)
        return float(np.median(hi - lo))


def match_noise_scale(
    real: FloatArray,
    members: FloatArray,
    std: float,
    quantum: float,
    *,
    level: float = MATCH_LEVEL,
    seed: int = 0,
    scale_range: tuple[float, float] = NOISE_SCALE_RANGE,
) -> tuple[float, float, float]:
    """The noise-std scale that brings the ``level`` band's coverage of ``real`` into range.

    The band is built as ``agree --ensemble`` builds it: each member (a row of ``members``,
    shape (n, samples)) observed through white noise of std ``scale * std`` (the same standard
    normal draws for every scale) and quantised to ``quantum``, and the central ``level`` band
    of those draws (:func:`sim2real.agreement.figures.predictive_band`). The scale is 1 when the
    coverage is inside :func:`match_range`; else the bisection (in log scale, within
    ``scale_range``) finds where it reaches the nearer end of that range; a bound of
    ``scale_range`` is returned where it cannot be reached. ``std`` 0 has nothing to scale: 1.

    Raises
    ------
    Sim2RealValueError
        If ``real`` is not a non-empty 1-D array, ``members`` not (n >= 1, ``real.size``),
        ``std`` or ``quantum`` not finite and >= 0, or ``scale_range`` does not hold 1.

    Returns
    -------
    (scale, coverage_at_1, coverage_at_scale) : tuple of float

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> real = 0.1 * rng.standard_normal(4000)  # noise 0.1 around members that are all 0
    >>> scale, before, after = match_noise_scale(real, np.zeros((20, 4000)), 0.3, 0.0)
    >>> before > 0.99, round(after, 2)  # narrowed to the top of the range (0.95)
    (True, 0.95)
    >>> match_noise_scale(real, np.zeros((20, 4000)), 0.11, 0.0)[0]  # inside: kept
    1.0
    """
    level = check_band_level(level)
    real, members = np.asarray(real, dtype=np.float64), np.asarray(members, dtype=np.float64)
    if not (real.ndim == 1 and real.size and members.ndim == 2 and members.shape[0] >= 1) or (
        members.shape[1] != real.size
    ):
        raise Sim2RealValueError(
            f"match_noise_scale needs real samples of shape (k,) with k >= 1 and members of "
            f"shape (n, k) with n >= 1; got real {real.shape} and members {members.shape}"
        )
    for name, value in (("std", std), ("quantum", quantum)):
        if not (math.isfinite(value) and value >= 0.0):
            raise Sim2RealValueError(
                f"match_noise_scale: {name} must be finite and >= 0 (m/s or rad/s), got {value!r}"
            )
    if not 0.0 < scale_range[0] <= 1.0 <= scale_range[1] < math.inf:
        raise Sim2RealValueError(
            f"match_noise_scale: scale_range must hold 1 between two positive finite bounds, "
            f"got {scale_range!r}; e.g. {NOISE_SCALE_RANGE}"
        )
    coverage = _BandCoverage(real, members, std, quantum, level=level, seed=seed)
    at_one = coverage(1.0)
    low, high = match_range(level)
    if std <= 0 or low <= at_one <= high:
        return 1.0, at_one, at_one
    goal, bound = (high, scale_range[0]) if at_one > high else (low, scale_range[1])
    at_bound = coverage(bound)
    if (at_bound > goal) if at_one > high else (at_bound < goal):
        return bound, at_one, at_bound
    # invariant: coverage(exp(lo_s)) < goal <= coverage(exp(hi_s)); the scale is the upper end
    lo_s, hi_s = sorted((0.0, math.log(bound)))
    for _ in range(MATCH_STEPS):
        mid = 0.5 * (lo_s + hi_s)
        if coverage(math.exp(mid)) >= goal:
            hi_s = mid
        else:
            lo_s = mid
    return math.exp(hi_s), at_one, coverage(math.exp(hi_s))


def _spread(members: FloatArray) -> FloatArray:
    """The members' predictive spread per sample, ``(1 + 1/n) var`` (0 for one member)."""
    n = members.shape[0]
    if n < 2:
        return np.zeros(members.shape[1])
    out: FloatArray = (1.0 + 1.0 / n) * members.var(axis=0, ddof=1)
    return out


def robust_noise_std(
    real: FloatArray, members: FloatArray, quantum: float, span: tuple[float, float] = NOISE_RANGE
) -> float:
    r"""The noise std at which the median squared standardised residual is a Gaussian's.

    With the members' mean :math:`m_k` and spread :math:`s_k` and the predictive variance
    :math:`V_k(\sigma) = s_k + \sigma^2 + q^2/12`, the std solves
    :math:`\mathrm{median}_k\,(r_k - m_k)^2 / V_k(\sigma) = \chi^2_{1,0.5}` (0.455): a
    median-based scale (Rousseeuw & Croux 1993, "Alternatives to the median absolute
    deviation") that a minority of large misses (timing errors at command changes) cannot move,
    where the Gaussian likelihood's std grows to cover them. It ends at ``span``'s floor where
    the spread alone makes the median small enough, at its top where no std does.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> real = 0.1 * rng.standard_normal(2000)
    >>> real[:200] += 3.0  # one sample in ten a large miss
    >>> round(robust_noise_std(real, np.zeros((8, 2000)), 0.0), 2)  # the Gaussian ML: ~0.9
    0.11
    """
    mean = members.mean(axis=0)
    r2 = (np.asarray(real, dtype=np.float64) - mean) ** 2
    base = _spread(members) + quantum**2 / 12.0

    def excess(log_std: float) -> float:
        var = np.maximum(base + math.exp(2.0 * log_std), 1e-24)
        return float(np.median(r2 / var)) - CHI2_1_MEDIAN

    lo, hi = math.log(span[0]), math.log(span[1])
    if excess(lo) <= 0.0:
        return span[0]
    if excess(hi) >= 0.0:
        return span[1]
    return math.exp(float(brentq(excess, lo, hi, xtol=1e-6)))


def stretch_noise_std(
    real: FloatArray, members: FloatArray, stretch: IntArray, quantum: float
) -> float:
    r"""The robust noise std of the samples' scatter within their steady stretches.

    A residual on a steady stretch is the model's miss there, held for the stretch (a wheel
    loop's steady-state error, a gain off), plus odometry noise, independent reading to
    reading. The first is the dynamics spread's to cover and moves every sample of the
    stretch alike; white noise does not. So each stretch's own level is taken out of the real
    samples and of every member (one-way decomposition: the pooled within-group scatter,
    each deviation scaled by :math:`\sqrt{n/(n-1)}` for the level its stretch of *n* spent),
    and :func:`robust_noise_std` is taken of what is left. Stretches of one sample tell
    nothing of it; NaN when fewer than :data:`MIN_STEADY` samples are in longer ones.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> stretch = np.repeat(np.arange(100), 10)
    >>> real = 0.1 * rng.standard_normal(100)[stretch] + 0.01 * rng.standard_normal(1000)
    >>> round(robust_noise_std(real, np.zeros((8, 1000)), 0.0), 2)  # the held misses too
    0.1
    >>> round(stretch_noise_std(real, np.zeros((8, 1000)), stretch, 0.0), 2)
    0.01
    """
    stretch = np.asarray(stretch)
    _, index, counts = np.unique(stretch, return_inverse=True, return_counts=True)
    keep = counts[index] >= 2
    if int(keep.sum()) < MIN_STEADY:
        return math.nan
    scale = np.sqrt(counts[index][keep] / (counts[index][keep] - 1.0))

    def within(x: FloatArray) -> FloatArray:
        level = np.bincount(index, weights=x, minlength=counts.size) / counts
        out: FloatArray = (x - level[index])[keep] * scale
        return out

    real_dev = within(np.asarray(real, dtype=np.float64))
    members_dev = np.stack([within(m) for m in np.asarray(members, dtype=np.float64)])
    return robust_noise_std(real_dev, members_dev, quantum)


def noise_information_share(members: FloatArray, std: float, quantum: float) -> float:
    r"""How much the validation samples say about the noise variance, per sample (0-1).

    With the members' spread :math:`s_k = (1 + 1/n)\,\widehat{\mathrm{var}}_k` and the
    predictive variance :math:`V_k = s_k + \sigma^2 + q^2/12`, one sample's Fisher information
    on :math:`\sigma^2` is :math:`1 / (2 V_k^2)`, a sample of pure noise's
    :math:`1 / (2 \sigma^4)`. Their ratio averaged over the samples,
    :math:`\rho = \overline{(\sigma^2 / V_k)^2}`, is the share of a noise-only log's
    information the log holds: near 1 where the noise dominates the predictive variance, near
    0 where the members' spread explains the residuals and the noise is not identified.

    Examples
    --------
    >>> import numpy as np
    >>> round(noise_information_share(np.zeros((4, 10)), 0.1, 0.0), 6)  # noise only
    1.0
    >>> members = np.tile([[0.0], [1.0]], (1, 10))  # spread 0.75 per sample
    >>> round(noise_information_share(members, 0.5, 0.0), 3)  # (0.25 / 1.0) ** 2
    0.062
    """
    n = members.shape[0]
    spread = (1.0 + 1.0 / n) * members.var(axis=0, ddof=1) if n > 1 else 0.0 * members[0]
    noise_var = std**2
    total = np.maximum(spread + noise_var + quantum**2 / 12.0, 1e-24)
    return float(np.mean((noise_var / total) ** 2))


def shrunk_noise_std(calibrated_std: float, file_std: float, share: float) -> float:
    r"""The noise std kept: the calibration's and the file's variances weighted by information.

    :math:`\sigma_c^2 = \rho\,\sigma_{cal}^2 + (1 - \rho)\,\sigma_f^2` with the share
    :math:`\rho` of :func:`noise_information_share`: a validation log whose residuals the
    members' spread already explains cannot tell a noise of 0 from the file's, and keeps the
    file's estimate; one whose residuals are noise replaces it.

    Examples
    --------
    >>> shrunk_noise_std(0.001, 0.02, 0.0), shrunk_noise_std(0.001, 0.02, 1.0)
    (0.02, 0.001)
    """
    rho = min(max(share, 0.0), 1.0)
    return math.sqrt(rho * calibrated_std**2 + (1.0 - rho) * file_std**2)


def _coverage_se(coverage: float, n: int) -> float:
    """The binomial standard error of a coverage measured on ``n`` samples (at least one
    sample's worth, 1/n): a change smaller than it is no effect."""
    return max(math.sqrt(coverage * (1.0 - coverage) / n), 1.0 / n)


def _steady_or_all(steady: BoolArray) -> BoolArray:
    """The steady samples, or all of them when fewer than :data:`MIN_STEADY` are steady."""
    return steady if int(steady.sum()) >= MIN_STEADY else np.ones_like(steady)


@dataclass(frozen=True, kw_only=True)
class _AxisNoise:
    """One axis's calibrated noise: on the steady samples, the robust std shrunk to the file's
    where they do not identify it, then matched to the band's coverage of them."""

    std: float
    identified_std: float
    scale: float
    coverage_identified: float
    coverage: float
    steady: float
    note: str = ""

    @staticmethod
    def identified(
        real: FloatArray,
        members: FloatArray,
        *,
        file_std: float,
        quantum: float,
        stretch: IntArray | None = None,
    ) -> tuple[float, float]:
        """(identified, robust): the robust noise std of these samples, no larger than their
        scatter within their steady stretches (:func:`stretch_noise_std`, where ``stretch``
        numbers them), and it shrunk to the file's where they do not identify it."""
        robust = robust_noise_std(real, members, quantum)
        if stretch is not None:
            within = stretch_noise_std(real, members, stretch, quantum)
            robust = min(robust, within) if math.isfinite(within) else robust
        share = noise_information_share(members, robust, quantum)
        return shrunk_noise_std(robust, file_std, share), robust

    @classmethod
    def matched(
        cls,
        axis: str,
        real: FloatArray,
        members: FloatArray,
        *,
        identified: tuple[float, float],
        quantum: float,
        seed: int,
        steady: BoolArray,
        own_std: float = math.nan,
    ) -> _AxisNoise:
        used = _steady_or_all(steady)
        real, members = real[used], members[:, used]
        std, robust = identified
        # narrowed no further than what the logs show of their noise: the samples' robust std
        # beyond the spread and the logs' own scatter about their steady levels; logs without
        # steady stretches cannot tell their noise from the spread, so it is not narrowed
        floor = max(robust, own_std if math.isfinite(own_std) else std) / std if std > 0 else 0.0
        span = (min(max(floor, NOISE_SCALE_RANGE[0]), 1.0), NOISE_SCALE_RANGE[1])
        scale, before, after = match_noise_scale(
            real, members, std, quantum, seed=seed, scale_range=span
        )
        notes = []
        if not used.all():
            notes.append(
                f"the odometry noise of {axis} is calibrated on the {int(used.sum())} of "
                f"{used.size} samples at least {STEADY_AFTER_STEP_S:g} s after a command step "
                "(closer to a step, timing and transients make the residual: the dynamics "
                "spread's to cover, not white noise's)"
            )
        if scale in span and abs(after - before) < _coverage_se(before, real.size):
            notes.append(
                f"the odometry noise std of {axis} has no effect on the {100 * MATCH_LEVEL:g} % "
                f"band's coverage of those samples ({100 * before:.1f} % at x1, "
                f"{100 * after:.1f} % at x{scale:g}, the end of its search range: less than the "
                "coverage's standard error): the dynamics spread makes the band's width, so the "
                "identified std is kept"
            )
            scale, after = 1.0, before
        return cls(
            std=std * scale,
            identified_std=std,
            scale=scale,
            coverage_identified=before,
            coverage=after,
            steady=float(used.mean()),
            note="; ".join(notes),
        )


def calibrate_traces(
    traces: Sequence[Any],
    *,
    robot: Any,
    distribution: Any,
    n: int = DEFAULT_N,
    seed: int = 0,
    engine: str = "reduced",
    odom_v_window_s: float = 0.0,
    tol_v: float = 0.02,
    tol_w: float = 0.1,
    fit_sessions: int = 1,
) -> CalibrationResult:
    """Fit the dynamics factor and the noise stds of ``distribution`` to ``traces``.

    See the module docstring for the model; :func:`calibrate` reads the files.

    Parameters
    ----------
    traces : sequence of Trace
        Validation logs (not used by the fit).
    robot : str or RobotSpec
        The robot.
    distribution : robots.randomization.DriveDistribution
        The distribution to calibrate.
    n, seed : int
        Ensemble size (>= 4) and seed (common random numbers for every factor).
    engine : {"reduced", "pybullet", "mujoco"}
        Simulator ("reduced": tens of ensembles are replayed). For ``"mujoco"`` the
        likelihood search replays the reduced model (:data:`SEARCH_ENGINE`) and the noise,
        the coverage matching and the widening replay MuJoCo (about ten ensembles); a note
        says so.
    odom_v_window_s : float
        Odometry window of the simulated v, s (as in the fit).
    tol_v, tol_w : float
        Tolerances of the active-sample mask.
    fit_sessions : int
        Logs (sessions) the distribution was fitted on: the weight of its spread against the
        validation sessions' (:func:`pooled_factors`).

    Returns
    -------
    CalibrationResult
    """
    _check_calibration_args(traces, n, tol_v, tol_w, fit_sessions)
    spec = resolve_robot(robot)
    original, (distribution, bound_notes) = distribution, held_lower_bounds(distribution, traces)
    search = _FactorSearch(
        _validation_logs(traces, spec, tol_v, tol_w),
        spec=spec,
        distribution=distribution,
        n=n,
        seed=seed,
        engine=SEARCH_ENGINE.get(engine, engine),
        odom_v_window_s=odom_v_window_s,
    )
    noise = distribution.noise
    steady = search.since_step_s >= STEADY_AFTER_STEP_S
    # the spread is judged with the noise the steady samples identify (robust): the
    # likelihood cannot then widen the noise to cover timing misses at command steps
    search.fix_noise(steady)
    lik_factor, lik_session = search.likelihood_optimum()
    factor, session_factor = pooled_factors(
        lik_factor, lik_session, fit_sessions=fit_sessions, validation_sessions=len(traces)
    )
    searched: tuple[str, ...] = ()
    if search.engine != engine:  # the band itself is the engine's own
        search.use_engine(engine, steady)
        searched = (
            f"the spread's likelihood search ran on the {search.searched_on} model, whose "
            f"replays follow the {engine} robot's; the noise, the band's coverage and its "
            f"widening are the {engine} robot's",
        )
    mvb, mwb, ll, _, _ = search.at(factor, session_factor)
    axes = search.matched_noise((mvb, mwb), steady)
    before = search.coverage(mvb, mwb, (axes[0].identified_std, axes[1].identified_std))
    ll_before = search.log_likelihood_before()  # the file's own spread: before any narrowing
    (mvb, mwb), narrow_note = search.narrowed(
        factor, session_factor, (axes[0].std, axes[1].std), sessions=(fit_sessions, len(traces))
    )
    widened, after, widen_note = search.widened(factor, session_factor, (mvb, mwb), axes)
    widen_note = "; ".join(n for n in (narrow_note, widen_note) if n)
    widened_noise = (0.0, 0.0)  # the noise std a failing axis had to be widened to
    if min(after) < MATCH_LEVEL:  # no spread covers the misses: the noise, as the last resort
        axes, after, last, widened_noise = _noise_last_resort(search, (mvb, mwb), axes, after)
        widen_note = f"{widen_note}; {last}"
    std_v, std_w = axes[0].std, axes[1].std
    model_v, model_w, timing_v, timing_w = held_out_model_noise(
        traces, robot=spec, distribution=distribution, engine=engine,
        odom_v_window_s=odom_v_window_s, tol_v=tol_v, tol_w=tol_w, at_least=widened_noise,
    )  # fmt: skip
    calibrated = dataclasses.replace(
        search.mixed(factor, search.widening if search.widening is not None else widened),
        noise=dataclasses.replace(noise, std_v_mps=std_v, std_w_radps=std_w),
    )
    return CalibrationResult(
        dynamics_factor=factor,
        session_factor=widened,
        pooled_session_factor=session_factor,
        likelihood_dynamics_factor=lik_factor,
        likelihood_session_factor=lik_session,
        fit_sessions=fit_sessions,
        validation_sessions=len(traces),
        noise_std_v_mps=std_v,
        noise_std_w_radps=std_w,
        noise_factor_v=std_v / noise.std_v_mps if noise.std_v_mps > 0 else math.nan,
        noise_factor_w=std_w / noise.std_w_radps if noise.std_w_radps > 0 else math.nan,
        log_likelihood=ll,
        log_likelihood_before=ll_before,
        noise_scale_v=axes[0].scale,
        noise_scale_w=axes[1].scale,
        coverage_v_likelihood=before[0],
        coverage_w_likelihood=before[1],
        coverage_v=after[0],
        coverage_w=after[1],
        n_active=search.n_active,
        n=n,
        seed=seed,
        engine=engine,
        odom_v_window_s=float(odom_v_window_s),
        distribution=calibrated,
        original=original,
        validation=_provenance(traces),
        steady_v=axes[0].steady,
        steady_w=axes[1].steady,
        narrowing=_narrowed(distribution.names, search.narrowing),
        widened=tuple(
            name
            for k, name in enumerate(distribution.names)
            if search.widening is None or search.widening[k] != session_factor
        ),
        notes=bound_notes
        + tuple(a.note for a in axes if a.note)
        + ((widen_note,) if widen_note else ())
        + searched,
        model_noise_std_v_mps=model_v,
        model_noise_std_w_radps=model_w,
        model_noise_timing_v_s=timing_v,
        model_noise_timing_w_s=timing_w,
    )


def held_lower_bounds(distribution: Any, traces: Sequence[Any]) -> tuple[Any, tuple[str, ...]]:
    """``distribution`` with the lower bounds of the speed limits the fit never reached
    (:attr:`robots.randomization.DriveDistribution.lower`) raised to what the validation logs
    deliver under a held command (:func:`sysid.held_speeds`), and a note per bound raised.

    A fit log that never drove at the top speed leaves the limit at its prior above what it
    needed; its draws below the speeds a calibration session held for a second or more are
    robots that session shows do not exist. Only bounds the file already has are raised: a
    limit the fit identified keeps its posterior.

    Examples
    --------
    >>> dist = DriveDistribution.from_params_file("params.yaml", robot="neato")  # doctest: +SKIP
    >>> raised, notes = held_lower_bounds(dist, [trace])  # doctest: +SKIP
    """
    lower, notes = dict(distribution.lower), []
    for trace in traces:
        cmd_v, cmd_w = trace.cmd_at_meas()
        held = held_speeds(
            trace.meas_t_s, cmd_v, cmd_w, trace.meas_v, trace.meas_w, distribution.geometry
        )
        for name, bound in lower.items():
            if held.get(name, 0.0) > bound:
                notes.append(
                    f"'{getattr(trace.meta, 'path', '') or 'trace'}' holds {name} at "
                    f"{held[name]:.4g} under a held command, above the fit logs' {bound:.4g}: "
                    "its lower bound is raised there"
                )
                lower[name] = held[name]
    if not notes:
        return distribution, ()
    return dataclasses.replace(distribution, lower=lower), tuple(notes)


def _provenance(traces: Sequence[Any]) -> tuple[tuple[str, str], ...]:
    """(file, sha256) of each trace ("" where it has none)."""
    return tuple(
        (str(getattr(t.meta, "path", "")), str(getattr(t.meta, "sha256", ""))) for t in traces
    )


def _narrowed(names: Sequence[str], multipliers: Any) -> tuple[tuple[str, float], ...]:
    """(parameter, multiplier of its sd) of each parameter whose spread was narrowed."""
    return tuple((name, float(m)) for name, m in zip(names, multipliers, strict=True) if m != 1.0)


def held_out_model_noise(
    traces: Sequence[Any],
    *,
    robot: Any,
    distribution: Any,
    engine: str = "reduced",
    odom_v_window_s: float = 0.0,
    tol_v: float = 0.02,
    tol_w: float = 0.1,
    at_least: tuple[float, float] = (0.0, 0.0),
) -> tuple[float, float, float, float]:
    r"""The model's misses that look like noise, judged on logs the fit never saw.

    The fitted point (the distribution's mean) replays each log; its residuals over the
    active samples of all the logs hold the logs' own measurement noise :math:`\sigma_m`
    (:func:`sim2real.agreement.latency.band_log_noise`: where no command is held long enough,
    what the fitted point's replay does not explain, as ``agree``'s band reads a checked log) and the model's share, which grows with the replay's rate of change
    :math:`a` (:class:`sim2real.agreement.latency.ModelShare`, :math:`\delta(a)^2 =
    \delta_0^2 + (\tau a)^2`): :func:`sim2real.agreement.latency.fit_model_share` fits
    :math:`\delta_0` and :math:`\tau` per axis to the robust variance (MAD, the fit's
    statistic for its residuals) of the residuals binned by :math:`a`. In sample, the fit's
    residuals hold less of it the more the loop form can absorb (integral wheel loops follow
    the fit log's own wiggles); held out, the share is what the band has to add on another
    session (:func:`sim2real.agreement.latency.band_sample_noise`). ``at_least`` (v m/s, w
    rad/s) stands in for the residuals' scale where the replay is steady where it is larger:
    the noise std a calibration had to widen an axis to on every sample, because no spread of
    the model covered those logs (the band carries what the model lacks to the next session).

    Returns
    -------
    (float, float, float, float)
        :math:`\delta_0` of v (m/s) and w (rad/s), :math:`\tau` of v and w (s); NaN when
        the logs cannot tell their own noise.

    Examples
    --------
    >>> held_out_model_noise([trace], robot="neato", distribution=dist)  # doctest: +SKIP
    (0.0021, 0.0058, 0.041, 0.037)
    """
    spec = resolve_robot(robot)
    point = distribution.mean_params()
    res: tuple[list[FloatArray], list[FloatArray]] = ([], [])
    rates: tuple[list[FloatArray], list[FloatArray]] = ([], [])
    noises = []
    for trace in traces:
        rep = replay(
            trace, robot=spec, params=point, engine=engine, odom_v_window_s=odom_v_window_s
        )
        noises.append(band_log_noise(trace, replayed=rep))
        real = (
            np.asarray(trace.meas_v, dtype=np.float64),
            np.asarray(trace.meas_w, dtype=np.float64),
        )
        cv, cw = trace.cmd_at_meas()
        active = active_mask(cv, cw, real[0], real[1], tol_v=tol_v, tol_w=tol_w)
        for k, sim in enumerate((rep.v, rep.w)):
            res[k].append((real[k] - sim)[active])
            rates[k].append(replay_rate(trace.meas_t_s, sim)[active])
    own = pooled_steady_noise(noises)
    if not own.measured:
        return math.nan, math.nan, math.nan, math.nan
    (d_v, tau_v), (d_w, tau_w) = (
        fit_model_share(
            np.concatenate(res[k]), np.concatenate(rates[k]), measurement_std=meas, at_least=floor
        )
        for k, (meas, floor) in enumerate(
            zip((own.std_v_mps, own.std_w_radps), at_least, strict=True)
        )
    )
    return d_v, d_w, tau_v, tau_w


def _noise_last_resort(
    search: _FactorSearch,
    members: tuple[FloatArray, FloatArray],
    axes: Sequence[_AxisNoise],
    coverage: tuple[float, float],
) -> tuple[list[_AxisNoise], tuple[float, float], str, tuple[float, float]]:
    """Each axis whose band covers less than :data:`MATCH_LEVEL` of all the validation
    samples gets its noise std scaled until it does (:func:`match_noise_scale` on every
    sample): the band is then wider than the odometry noise, by what the model lacks. Last:
    the widened std of each such axis (0 for the others)."""
    out, cov, said = list(axes), list(coverage), []
    widened = [0.0, 0.0]
    for k, (axis, real, _, quantum) in enumerate(search.axes()):
        if cov[k] >= MATCH_LEVEL:
            continue
        scale, _, cov[k] = match_noise_scale(
            real, members[k], out[k].std, quantum, seed=search.seed + k
        )
        out[k] = dataclasses.replace(out[k], std=out[k].std * scale, scale=out[k].scale * scale)
        widened[k] = out[k].std
        said.append(
            f"on {axis} to x{out[k].scale:.3g} the identified std ({out[k].std:.4g}, "
            f"{100 * cov[k]:.1f} %)"
        )
    return (
        out,
        (cov[0], cov[1]),
        (
            f"so the noise std is widened on every sample, {' and '.join(said)}: the band is wider "
            "than the odometry noise by what the model lacks"
        ),
        (widened[0], widened[1]),
    )


def _check_calibration_args(
    traces: Sequence[Any], n: int, tol_v: float, tol_w: float, fit_sessions: int
) -> None:
    check_tolerances(tol_v, tol_w)
    if isinstance(n, bool) or not isinstance(n, int) or n < 4:
        raise Sim2RealValueError(
            f"calibration ensemble size (--ensemble) must be an integer >= 4, got {n!r}; e.g. "
            f"--ensemble {DEFAULT_N}"
        )
    if not traces:
        raise Sim2RealValueError("calibrate needs at least one calibration log; pass one")
    if isinstance(fit_sessions, bool) or not isinstance(fit_sessions, int) or fit_sessions < 1:
        raise Sim2RealValueError(
            f"fit_sessions (the logs the params file was fitted on) must be an integer >= 1, "
            f"got {fit_sessions!r}; pass the fit's settings.sessions"
        )


def _own_noise(traces: Sequence[Any]) -> tuple[float, float]:
    """The logs' own odometry noise (v, w) about their steady levels
    (:func:`sim2real.agreement.latency.log_noise`), pooled by their steady samples
    (:func:`sysid.steady.pooled_steady_noise`); NaN when no log has enough of them."""
    own = pooled_steady_noise([log_noise(t) for t in traces])
    return own.std_v_mps, own.std_w_radps


def _validation_logs(traces: Sequence[Any], spec: Any, tol_v: float, tol_w: float) -> list[_Log]:
    """Each log's active samples and the time since the last step of the command clipped to
    ``spec``'s limits; refused when all of them hold fewer than 20."""
    logs = []
    for trace in traces:
        rv = np.asarray(trace.meas_v, dtype=np.float64)
        rw = np.asarray(trace.meas_w, dtype=np.float64)
        cv, cw = trace.cmd_at_meas()
        active = active_mask(cv, cw, rv, rw, tol_v=tol_v, tol_w=tol_w)
        limits = (spec.max_v_mps, spec.max_w_radps)
        since = since_command_step_s(trace, tol_v=tol_v, tol_w=tol_w, limits=limits)[active]
        logs.append(
            _Log(trace=trace, active=active, v=rv[active], w=rw[active], since_step_s=since)
        )
    n_active = sum(int(lg.active.sum()) for lg in logs)
    if n_active < 20:
        raise Sim2RealValueError(
            f"the calibration log(s) {_names(traces)} have {n_active} active samples; "
            "calibration needs at least 20 (a log in which the robot moves and turns)"
        )
    return logs


class _FactorSearch:
    """The predictive likelihood of the validation logs over (dynamics, session) factors.

    Every factor pair replays the same ``n`` draws (common random numbers); the noise stds are
    maximised inside each evaluation, and evaluations are cached by their rounded factors.
    """

    def __init__(
        self,
        logs: list[_Log],
        *,
        spec: Any,
        distribution: Any,
        n: int,
        seed: int,
        engine: str,
        odom_v_window_s: float,
    ) -> None:
        self.logs, self.spec, self.distribution = logs, spec, distribution
        self.n, self.seed, self.engine, self.odom_v_window_s = n, seed, engine, odom_v_window_s
        self.fitted = distribution.covariance_array
        self.session = session_covariance(distribution, spec)
        self.real_v = np.concatenate([lg.v for lg in logs])
        self.real_w = np.concatenate([lg.w for lg in logs])
        self.since_step_s = np.concatenate([lg.since_step_s for lg in logs])
        self.n_active = sum(int(lg.active.sum()) for lg in logs)
        self.cache: dict[tuple[float, float], tuple[float, float, float]] = {}
        #: noise stds (v, w) the likelihood is evaluated with; None: maximised at each point
        self.fixed_noise: tuple[float, float] | None = None
        #: (identified, robust) noise std of v and w (:meth:`fix_noise`)
        self.identified: list[tuple[float, float]] = []
        self.best_members: list[Any] = []  # [loglik, members v, members w] of the best point
        self.searched_on = engine
        self._memo: dict[tuple[float, float], tuple[FloatArray, FloatArray]] = {}
        self.own_noise = _own_noise([lg.trace for lg in logs])
        #: multiplier on each parameter's sd after the mixing (:meth:`narrowed`)
        self.narrowing = np.ones(len(distribution.names))
        #: per-parameter session factors of the widening (:meth:`widened`), None before it
        self.widening: FloatArray | None = None
        self.narrowing_base = self.narrowing

    def use_engine(self, engine: str, steady: BoolArray) -> None:
        """Replay with ``engine`` from now on: the likelihood cache is cleared and the noise
        identified again on its replays (:meth:`fix_noise`)."""
        self.engine = engine
        self.cache.clear()
        self.best_members.clear()
        self._memo.clear()
        self.fix_noise(steady)

    def mixed(self, factor: float, session_factor: float | FloatArray) -> Any:
        """The distribution with covariance ``factor^2 fitted + g session g``: ``g`` the
        ``session_factor``, one for every parameter or one per parameter (a diagonal scaling)."""
        g = np.broadcast_to(np.asarray(session_factor, dtype=np.float64), self.narrowing.shape)
        # a field the logs do not inform cannot be widened without bound (correlations kept)
        cov = cap_spread(
            (factor**2 * self.fitted + self.session * np.outer(g, g))
            * np.outer(self.narrowing, self.narrowing),
            self.distribution.names,
            self.distribution.geometry,
        )
        return dataclasses.replace(
            self.distribution, covariance=tuple(tuple(float(c) for c in row) for row in cov)
        )

    def members(
        self, factor: float, session_factor: float | FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """The ensembles' (v, w) at the active samples of every log, side by side."""
        plain = (
            np.ndim(session_factor) == 0
            and (factor, float(session_factor)) == (1.0, 0.0)
            and bool(np.all(self.narrowing == 1.0))
        )
        if plain and (1.0, 0.0) in self._memo:
            return self._memo[(1.0, 0.0)]  # the file's own spread: the noise and "before"
        out = self.members_of(self.mixed(factor, session_factor))
        if plain:
            self._memo[(1.0, 0.0)] = out
        return out

    def members_of(self, dist: Any, engine: str | None = None) -> tuple[FloatArray, FloatArray]:
        """The ensembles of ``dist``: (v, w) at the active samples of every log, side by side
        (replayed with ``engine``, by default the search's current one)."""
        vs, ws = [], []
        for lg in self.logs:
            _, mv, mw = ensemble_members(
                lg.trace,
                robot=self.spec,
                distribution=dist,
                n=self.n,
                seed=self.seed,
                engine=engine or self.engine,
                odom_v_window_s=self.odom_v_window_s,
            )
            vs.append(mv[:, lg.active])
            ws.append(mw[:, lg.active])
        return np.concatenate(vs, axis=1), np.concatenate(ws, axis=1)

    def _noise_fit(self, mv: FloatArray, mw: FloatArray) -> tuple[float, float, float]:
        """(loglik, std v, std w) with the noise stds :attr:`fixed_noise`, or where there are
        none, the stds maximising the likelihood."""
        noise = self.distribution.noise
        if self.fixed_noise is None:
            sv, llv = _best_noise(self.real_v, mv, noise.quantum_v_mps, NOISE_RANGE)
            sw, llw = _best_noise(self.real_w, mw, noise.quantum_w_radps, NOISE_RANGE)
            return llv + llw, sv, sw
        sv, sw = self.fixed_noise
        llv = predictive_log_likelihood(self.real_v, mv, sv**2 + noise.quantum_v_mps**2 / 12.0)
        llw = predictive_log_likelihood(self.real_w, mw, sw**2 + noise.quantum_w_radps**2 / 12.0)
        return llv + llw, sv, sw

    def axes(self) -> tuple[tuple[str, FloatArray, float, float], ...]:
        """(axis, real samples, the file's noise std, quantum) of v and w."""
        noise = self.distribution.noise
        return (
            ("v", self.real_v, noise.std_v_mps, noise.quantum_v_mps),
            ("w", self.real_w, noise.std_w_radps, noise.quantum_w_radps),
        )

    def fix_noise(self, steady: BoolArray) -> None:
        """Evaluate the likelihood with the noise stds the ``steady`` samples identify at the
        file's own spread (factors 1 and 0): :meth:`_AxisNoise.identified`, kept in
        :attr:`identified` for the coverage matching (before the spread moves)."""
        used = _steady_or_all(steady)
        members = self.members(1.0, 0.0)
        stretch = steady_stretches(self.since_step_s, used) if used is steady else None
        self.identified = [
            _AxisNoise.identified(real[used], m[:, used], file_std=std, quantum=q, stretch=stretch)
            for (_, real, std, q), m in zip(self.axes(), members, strict=True)
        ]
        self.fixed_noise = (self.identified[0][0], self.identified[1][0])

    def matched_noise(
        self, members: tuple[FloatArray, FloatArray], steady: BoolArray
    ) -> list[_AxisNoise]:
        """Each axis's noise matched on the steady samples (:meth:`_AxisNoise.matched`)."""
        return [
            _AxisNoise.matched(
                axis,
                real,
                m,
                identified=self.identified[k],
                quantum=q,
                seed=self.seed + k,
                steady=steady,
                own_std=self.own_noise[k],
            )
            for k, ((axis, real, _, q), m) in enumerate(zip(self.axes(), members, strict=True))
        ]

    def axis_groups(
        self, factor: float, session_factor: float
    ) -> tuple[tuple[BoolArray, BoolArray, BoolArray], FloatArray]:
        """The varying parameters whose spread moves v more than w, those that move w more,
        and the command latency (it moves both, at every command step): each parameter's share
        of its axis's member variance on the validation samples, with that parameter alone
        drawn from its marginal (common random numbers), replayed with the engine of the
        likelihood search (the reduced model where the band's engine is slower). Also those
        member variances themselves, shape (parameters, 2): v (m²/s²) and w (rad²/s²)."""
        dist = self.mixed(factor, session_factor)
        variances = source_variances(dist, lambda d: self.members_of(d, self.searched_on))
        shares = variances / np.maximum(variances.sum(axis=0), 1e-300)
        latency = np.array([n == "delay_s" for n in dist.names])
        moves = (shares.max(axis=1) > 0.0) & ~latency
        groups = (
            moves & (shares[:, 0] >= shares[:, 1]),
            moves & (shares[:, 0] < shares[:, 1]),
            latency & (shares.max(axis=1) > 0.0),
        )
        return groups, variances

    def narrowed(
        self,
        factor: float,
        session_factor: float,
        stds: tuple[float, float],
        sessions: tuple[int, int] = (1, 1),
    ) -> tuple[tuple[FloatArray, FloatArray], str]:
        """Narrow the spread of each axis's own parameters (:meth:`axis_groups`) while the
        band, with the matched noise stds, still covers the top of :func:`match_range` of
        every validation sample on that axis (and the other axis no less than that top or
        than it did): a band that over-covers one axis with the noise at what the logs show
        is too wide there by the spread of the parameters that move that axis (split-conformal
        scaling of that spread, down to :data:`NARROW_MIN`), pooled with the file's spread by
        ``sessions`` (fitted, validation: :func:`pooled_narrowing`); a parameter whose effect on
        these samples is below the noise's, no further than the spec's between-session sd
        (:func:`narrowing_floor`). Sets :attr:`narrowing`; returns the members at the result
        and a note ("" when nothing was narrowed)."""
        high = match_range(MATCH_LEVEL)[1]
        members = self.members(factor, session_factor)
        start = self.coverage(*members, stds)
        if max(start) <= high:
            return members, ""
        said, floored = [], []
        groups, variances = self.axis_groups(factor, session_factor)
        noise = self.distribution.noise
        floor = narrowing_floor(
            np.sqrt(np.diag(factor**2 * self.fitted + session_factor**2 * self.session)),
            np.sqrt(np.diag(self.session)),
            variances,
            (stds[0] ** 2 + noise.quantum_v_mps**2 / 12.0,
             stds[1] ** 2 + noise.quantum_w_radps**2 / 12.0),
        )  # fmt: skip
        for k, group in enumerate(groups):
            at = self.coverage(*members, stds)
            own = [k] if k < 2 else [0, 1]  # the latency's: both axes
            if min(at[i] for i in own) <= high or not group.any():
                continue
            keep = [min(high, c) for c in at]

            def ok(scale: float, group: BoolArray = group, keep: list[float] = keep) -> bool:
                self.narrowing = np.where(group, scale, self.narrowing_base)
                cov = self.coverage(*self.members(factor, session_factor), stds)
                return cov[0] >= keep[0] and cov[1] >= keep[1]

            self.narrowing_base = self.narrowing.copy()
            lo, hi = math.log(NARROW_MIN), 0.0
            if ok(NARROW_MIN):
                hi = lo
            for _ in range(WIDEN_STEPS if lo < hi else 0):
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if ok(math.exp(mid)) else (mid, hi)
            scale = pooled_narrowing(
                math.exp(hi), fit_sessions=sessions[0], validation_sessions=sessions[1]
            )
            self.narrowing = np.where(group, scale, self.narrowing_base)
            if scale < 1.0:
                names = ", ".join(
                    n for n, g in zip(self.distribution.names, group, strict=True) if g
                )
                floored += [
                    n
                    for n, g, f in zip(self.distribution.names, group, floor, strict=True)
                    if g and f > scale
                ]
                what = ("move v", "move w", "delay every command")[k]
                said.append(f"x{scale:.3g} on the parameters that {what} ({names})")
            members = self.members(factor, session_factor)
        if not said:
            return members, ""
        if floored:  # what these samples cannot tell keeps the next session's spread
            self.narrowing = np.where(self.narrowing < 1.0, np.maximum(self.narrowing, floor), 1.0)
            members = self.members(factor, session_factor)
        end = self.coverage(*members, stds)
        kept = (
            f"; {', '.join(floored)} no further than the spec's between-session sd (their "
            f"effect on these samples is below the odometry noise's: one session cannot tell "
            f"their spread, and the next session or unit varies by it)"
            if floored
            else ""
        )
        return members, (
            f"with the odometry noise at what the logs show, the pooled spread covers "
            f"{100 * start[0]:.1f} % (v) and {100 * start[1]:.1f} % (w) of the calibration "
            f"samples: too wide by its dynamics spread, so the spread is narrowed "
            f"{' and '.join(said)} ({100 * end[0]:.1f} % and {100 * end[1]:.1f} %){kept}"
        )

    def coverage(
        self, mv: FloatArray, mw: FloatArray, stds: tuple[float, float]
    ) -> tuple[float, float]:
        """The :data:`MATCH_LEVEL` band's coverage of every validation sample, (v, w)."""
        cv, cw = (
            _BandCoverage(real, m, sd, q, level=MATCH_LEVEL, seed=self.seed + k)(1.0)
            for k, ((_, real, _, q), m, sd) in enumerate(
                zip(self.axes(), (mv, mw), stds, strict=True)
            )
        )
        return cv, cw

    def widened(
        self,
        factor: float,
        session_factor: float,
        members: tuple[FloatArray, FloatArray],
        axes: Sequence[Any],
    ) -> tuple[float, tuple[float, float], str]:
        """The session factor at which the band, with the matched noise, covers
        :data:`MATCH_LEVEL` of every validation sample on both axes.

        Timing and transient misses at command steps are a session unlike the fit's (its
        latency, load, floor): the spec's between-session spread is theirs to cover, not white
        noise. ``session_factor`` when the band covers already; else the bisection up to
        :data:`SESSION_MAX`; ``session_factor``, with a note, when even that does not.
        Returns (session factor, coverage (v, w), note)."""
        stds = (axes[0].std, axes[1].std)
        at = self.coverage(*members, stds)
        if min(at) >= MATCH_LEVEL:
            return session_factor, at, ""
        top = self.coverage(*self.members(factor, SESSION_MAX), stds)
        if min(top) < MATCH_LEVEL:
            return (
                session_factor,
                at,
                (
                    f"the band covers {100 * at[0]:.1f} % (v) and {100 * at[1]:.1f} % (w) of the "
                    f"calibration samples, and no between-session spread up to x{SESSION_MAX:g} the "
                    f"spec's brings both to {100 * MATCH_LEVEL:g} % ({100 * top[0]:.1f} % and "
                    f"{100 * top[1]:.1f} % there): the model misses this log by more than the "
                    "spread of its parameters"
                ),
            )
        best: tuple[float, float, FloatArray, tuple[float, float], str] | None = None
        for what, group in self.widening_groups(factor, session_factor):
            grown = self._widen(factor, session_factor, group, stds)
            if grown is None:
                continue
            g, got = grown
            width = self.band_width(*self.members(factor, g), stds)
            if best is None or width < best[0]:
                best = (width, float(np.max(g)), g, got, what)
        assert best is not None  # every parameter reaches it at SESSION_MAX (checked above)
        _, hi, g, got, what = best
        self.widening = g
        return (
            hi,
            got,
            (
                f"with the pooled spread the band covers {100 * at[0]:.1f} % (v) and "
                f"{100 * at[1]:.1f} % (w) of the calibration samples; the misses near command steps "
                f"are a session unlike the fit's, so the spec's between-session spread of {what} "
                f"is widened (factor {session_factor:.3g} -> {hi:.3g}) until both reach "
                f"{100 * MATCH_LEVEL:g} %: of the spreads that reach it, the one with the "
                "narrowest band"
            ),
        )

    def widening_groups(self, factor: float, session_factor: float) -> list[tuple[str, BoolArray]]:
        """The parameter groups a widening may act on, each named: every union of the
        command latency, the parameters that move v and those that move w
        (:meth:`axis_groups`), and every parameter last (what :meth:`widened` checked reaches
        the level at :data:`SESSION_MAX`: a parameter with no share is in no other group)."""
        axes, _ = self.axis_groups(factor, session_factor)
        groups: tuple[BoolArray, ...] = (*axes, np.ones(axes[0].shape, dtype=bool))
        names = (
            "the parameters that move v",
            "the parameters that move w",
            "the command latency",
            "every parameter",
        )
        order = ((2,), (1,), (0,), (1, 2), (0, 2), (0, 1), (0, 1, 2), (3,))
        kept: list[tuple[str, BoolArray]] = []
        for pick in order:
            group = np.logical_or.reduce([groups[k] for k in pick])
            if group.any() and not any(np.array_equal(group, g) for _, g in kept):
                kept.append((" and ".join(names[k] for k in sorted(pick, reverse=True)), group))
        return kept

    def _widen(
        self, factor: float, session_factor: float, group: BoolArray, stds: tuple[float, float]
    ) -> tuple[FloatArray, tuple[float, float]] | None:
        """The per-parameter session factors (``group`` widened, the others at
        ``session_factor``) of the smallest widening by bisection up to :data:`SESSION_MAX`
        at which the band covers :data:`MATCH_LEVEL` on both axes, and that coverage; None when
        even :data:`SESSION_MAX` does not reach it."""

        def factors(x: float) -> FloatArray:
            return np.where(group, x, session_factor)

        got = self.coverage(*self.members(factor, factors(SESSION_MAX)), stds)
        if min(got) < MATCH_LEVEL:
            return None
        lo, hi = session_factor, SESSION_MAX
        for _ in range(WIDEN_STEPS):
            mid = 0.5 * (lo + hi)
            cov = self.coverage(*self.members(factor, factors(mid)), stds)
            if min(cov) >= MATCH_LEVEL:
                hi, got = mid, cov
            else:
                lo = mid
        return factors(hi), got

    def band_width(self, mv: FloatArray, mw: FloatArray, stds: tuple[float, float]) -> float:
        """The :data:`MATCH_LEVEL` band's median width per axis, over the robot's top speed
        and top yaw rate, summed (the band built as :meth:`coverage` builds it)."""
        tops = (float(self.spec.max_v_mps), float(self.spec.max_w_radps))
        total = 0.0
        for k, ((_, real, _, q), m, sd, top) in enumerate(
            zip(self.axes(), (mv, mw), stds, tops, strict=True)
        ):
            total += _BandCoverage(real, m, sd, q, level=MATCH_LEVEL, seed=self.seed + k).width(
                1.0
            ) / max(top, 1e-12)
        return total

    def evaluate(self, x: Sequence[float]) -> float:
        """-loglik at (log factor, session factor); noise stds maximised inside."""
        key = (round(float(x[0]), 6), round(min(max(float(x[1]), 0.0), SESSION_MAX), 6))
        if key not in self.cache:
            mv, mw = self.members(math.exp(key[0]), key[1])
            self.cache[key] = self._noise_fit(mv, mw)
            ll = self.cache[key][0]
            if not self.best_members or ll > self.best_members[0]:  # the coverage matching's
                self.best_members[:] = [ll, mv, mw]
        return -self.cache[key][0]

    def _best(self) -> tuple[float, float]:
        return min(self.cache, key=lambda k: -self.cache[k][0])

    def likelihood_optimum(self) -> tuple[float, float]:
        """(dynamics factor, session factor) of the largest likelihood: a grid, then
        Nelder-Mead from its best point."""
        log_lo, log_hi = math.log(FACTOR_RANGE[0]), math.log(FACTOR_RANGE[1])
        for lf in np.linspace(log_lo, log_hi, GRID_POINTS):
            for sf in SESSION_GRID:
                self.evaluate((float(lf), sf))
        best = self._best()
        minimize(
            self.evaluate,
            np.array(best),
            method="Nelder-Mead",
            bounds=[(log_lo, log_hi), (0.0, SESSION_MAX)],
            options={"maxfev": REFINE_EVALUATIONS, "xatol": 0.02, "fatol": 1e-4,
                     "initial_simplex": [best, (best[0] + 0.3, best[1]), (best[0], best[1] + 0.25)]},
        )  # fmt: skip
        best = self._best()
        return math.exp(best[0]), best[1]

    def at(
        self, factor: float, session_factor: float
    ) -> tuple[FloatArray, FloatArray, float, float, float]:
        """(members v, members w, loglik, std v, std w) at the calibrated factors: the
        likelihood optimum's when they are its (after :meth:`likelihood_optimum`)."""
        if self.cache:
            best = self._best()
            if (factor, session_factor) == (math.exp(best[0]), best[1]):
                _, mv, mw = self.best_members
                ll, std_v, std_w = self.cache[best]
                return mv, mw, ll, std_v, std_w
        mv, mw = self.members(factor, session_factor)
        ll, std_v, std_w = self._noise_fit(mv, mw)
        return mv, mw, ll, std_v, std_w

    def log_likelihood_before(self) -> float:
        """The likelihood of the file's own distribution (factors 1 and 0, its noise)."""
        noise = self.distribution.noise
        mv1, mw1 = self.members(1.0, 0.0)
        return predictive_log_likelihood(
            self.real_v, mv1, noise.std_v_mps**2 + noise.quantum_v_mps**2 / 12.0
        ) + predictive_log_likelihood(
            self.real_w, mw1, noise.std_w_radps**2 + noise.quantum_w_radps**2 / 12.0
        )


def pooled_factors(
    factor: float, session_factor: float, *, fit_sessions: int, validation_sessions: int
) -> tuple[float, float]:
    r"""The calibrated factors: the validation optimum pooled with the file's spread, by sessions.

    The likelihood of the validation logs is summed over thousands of samples, but the
    between-session spread it judges was drawn once per *session*: two validation sessions are
    two draws of it, whatever their length. The file's spread is an estimate worth
    :math:`\nu` sessions (:func:`sysid.spread_degrees_of_freedom`: the fitted logs less one,
    plus the spec prior's pseudo-sessions) and the validation optimum :math:`(a, b)` one worth
    :math:`m` (the validation logs), so the two variance estimates are pooled by their degrees
    of freedom, as a pooled variance is:

    .. math::

        a_c^2 = \frac{\nu + m a^2}{\nu + m}, \qquad b_c^2 = \frac{m b^2}{\nu + m}

    (the file stands for :math:`a = 1, b = 0`). A validation optimum judged on one or two
    sessions thus moves the band only as far as those sessions weigh against the file's
    (``benchmarks/bench_calibration.py`` measures the pooled and the unpooled bands on fleets
    of synthetic sessions).

    Examples
    --------
    >>> a, b = pooled_factors(0.2, 1.0, fit_sessions=3, validation_sessions=2)
    >>> round(a, 3), round(b, 3)
    (0.852, 0.535)
    """
    nu = spread_degrees_of_freedom(fit_sessions)
    m = float(validation_sessions)
    return (
        math.sqrt((nu + m * factor**2) / (nu + m)),
        math.sqrt(m * session_factor**2 / (nu + m)),
    )


def pooled_narrowing(scale: float, *, fit_sessions: int, validation_sessions: int) -> float:
    r"""The narrowing of a parameter group's spread, pooled with the file's spread by sessions.

    The coverage matching finds the multiplier :math:`s` on a group's sds at which the band
    covers the validation samples as it should (:meth:`_FactorSearch.narrowed`). Like the
    dynamics factor (:func:`pooled_factors`), that scale is judged on the validation
    *sessions*, :math:`m` draws of the between-session spread, whatever their length; what it
    narrows was estimated on :math:`\nu_d = n - 1` fitted sessions beyond the one spent on
    the mean (the spec prior's pseudo-sessions are a default, which the validation logs are
    there to overrule: a spread fitted on one log is all prior and estimation uncertainty).
    The two variance scales are pooled by those degrees of freedom:

    .. math:: s_c^2 = \frac{\nu_d + m s^2}{\nu_d + m}

    so a fleet's between-session spread, estimated on several sessions, is narrowed by one
    or two alike validation sessions only as far as they weigh against it; a one-log fit's
    spread takes the validation scale.

    Examples
    --------
    >>> round(pooled_narrowing(0.1, fit_sessions=3, validation_sessions=2), 3)
    0.711
    >>> round(pooled_narrowing(0.1, fit_sessions=1, validation_sessions=1), 3)
    0.1
    """
    nu = float(fit_sessions) - 1.0
    m = float(validation_sessions)
    return math.sqrt((nu + m * scale**2) / (nu + m))


def narrowing_floor(
    pooled_sd: Any, session_sd: Any, member_variance: Any, noise_variance: tuple[float, float]
) -> FloatArray:
    r"""The smallest multiplier the coverage matching may put on each parameter's sd.

    The narrowing (:meth:`_FactorSearch.narrowed`) measures on the validation samples how much
    of a group's spread the band needs. A parameter whose spread, drawn alone, moves the
    members by less than the odometry noise moves the readings (member variance below the
    noise variance on both axes) is not told apart from the noise by those samples: they
    measure nothing of its spread. Narrowing it anyway would take the band's spread of that
    parameter down to what one session happened not to need, while a new session (another
    day's floor, payload and battery; another unit) varies by at least the spec prior's
    between-session sd :math:`s_j`. Such a parameter is narrowed no further than that:

    .. math:: m_j \ge \min(1, s_j / \sigma_j)

    with :math:`\sigma_j` its pooled sd (coordinates); a parameter the samples inform may
    be narrowed to :data:`NARROW_MIN` (floor 0 here).

    Parameters
    ----------
    pooled_sd, session_sd : array_like
        Per parameter: the pooled spread's sd and the spec's between-session sd (coordinates).
    member_variance : array_like, shape (parameters, 2)
        The members' variance each parameter causes alone on the validation samples, v and w
        (m²/s², rad²/s²; :func:`sim2real.agreement.sources.source_variances`).
    noise_variance : (float, float)
        The band's odometry noise variance of v and w (the same units).

    Examples
    --------
    >>> floor = narrowing_floor([0.4, 0.2], [0.05, 0.05], [[1e-4, 0.0], [4e-6, 0.0]], (2.5e-5, 1e-4))
    >>> floor.tolist()  # the first moves v more than the noise does; the second does not
    [0.0, 0.25]
    """
    pooled = np.asarray(pooled_sd, dtype=np.float64)
    session = np.asarray(session_sd, dtype=np.float64)
    var = np.asarray(member_variance, dtype=np.float64).reshape(pooled.size, 2)
    told = np.any(var >= np.asarray(noise_variance, dtype=np.float64), axis=1)
    floor = np.minimum(1.0, np.divide(session, pooled, out=np.ones_like(pooled), where=pooled > 0))
    out: FloatArray = np.where(told, 0.0, floor)
    return out


def session_covariance(distribution: Any, robot: Any) -> FloatArray:
    """The spec's default between-session covariance of the varying fields (coordinates).

    ``diag(session_sd**2)`` of the robot spec's priors (payload, floor, battery and latency
    change from day to day; see ``robots/specs/*.yaml``); 0 for a field without a prior.
    """
    priors = getattr(robot, "priors", {}) or {}
    sd = [priors[n].session_sd if n in priors else 0.0 for n in distribution.names]
    out: FloatArray = np.diag(np.square(np.asarray(sd, dtype=np.float64)))
    return out


def _logs_of_role(document: Any, role: str = "fit") -> set[str]:
    """SHA-256 of the logs of one ``role`` in a params file's ``data`` entries: ``fit`` (an
    entry without a role counts as one), or ``validation`` (scored, and the judges of the
    wheel loops' integral term, :func:`sysid.fit.fit_drive`)."""
    entries = document.get("data") if isinstance(document, dict) else None
    out = set()
    for entry in entries if isinstance(entries, list) else []:
        if (
            isinstance(entry, dict)
            and isinstance(entry.get("sha256"), str)
            and entry.get("role", "fit") == role
        ):
            out.add(entry["sha256"])
    return out


def _sessions_of(document: Any, path: str | Path) -> int:
    """Logs a params file was fitted on (``settings.sessions``; 1 when the file has none).

    Raises :class:`robots.errors.ParamsFileError` for a count that is not a whole number
    >= 1: the calibration weighs the file's spread by it.
    """
    settings = document.get("settings") if isinstance(document, dict) else None
    if not isinstance(settings, dict) or "sessions" not in settings:
        return 1
    value = settings["sessions"]
    if isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= 10_000:
        return value
    raise ParamsFileError(
        f"params file '{path}': settings.sessions (the logs it was fitted on) must be a whole "
        f"number from 1 to 10000, got {value!r}; write the fit's count or delete the key"
    )


def _window_of(document: Any) -> float:
    settings = document.get("settings") if isinstance(document, dict) else None
    value = settings.get("odom_v_window_s") if isinstance(settings, dict) else None
    if isinstance(value, int | float) and math.isfinite(value) and 0 <= value <= 1:
        return float(value)
    return 0.0


def calibrate(
    params_path: str | Path,
    logs: Sequence[str | Path],
    *,
    robot: str,
    n: int = DEFAULT_N,
    seed: int = 0,
    engine: str = "reduced",
    odom_v_window_s: float | None = None,
    tol_v: float = 0.02,
    tol_w: float = 0.1,
    read: ReadOptions | None = None,
) -> CalibrationResult:
    """Read a params file and validation logs and fit the spread (:func:`calibrate_traces`).

    The odometry window defaults to the fit's (``settings.odom_v_window_s`` of the file). A
    validation log the params file was fitted on is refused: a spread fitted to the fit's own
    residuals is too narrow for any other session. The logs are read as ``sysid fit`` and
    ``agree`` read them, with ``read`` (:class:`sim2real.logs.ReadOptions`; default:
    auto-detected topics, header stamps unless they run on another clock, velocities from the
    pose when the twist is junk, and the unattended samples left out with a note).
    """
    spec = load_spec(robot)
    params_file = read_params_file(params_path)  # read once: the spread and the settings
    distribution = DriveDistribution.from_params_file(params_file, robot=spec.name)
    document = params_file.document
    fitted_on, validated_on = _logs_of_role(document), _logs_of_role(document, "validation")
    screened = [read_for_robot(path, spec, read) for path in logs]
    traces = [trace for trace, _ in screened]
    for path, trace in zip(logs, traces, strict=True):
        if getattr(trace.meta, "sha256", None) in fitted_on:
            raise Sim2RealValueError(
                f"calibration log '{path}' is one of the logs params file '{params_path}' was "
                "fitted on; calibrate on a log (session) the fit never saw"
            )
    notes = tuple(
        f"{path}: {note}"
        for path, trace in zip(logs, traces, strict=True)
        for note in (trace.meta.time_note, *trace.meta.warnings)
        if note
    ) + tuple(note for _, note in screened if note)
    notes += tuple(
        f"calibration log '{path}' also validated the fit (the validation logs judge its wheel "
        "loops' structure): the coverage judged on it may be a little optimistic; check on a "
        "log neither saw"
        for path, trace in zip(logs, traces, strict=True)
        if getattr(trace.meta, "sha256", None) in validated_on
    )
    window = _window_of(document) if odom_v_window_s is None else odom_v_window_s
    result = calibrate_traces(
        traces,
        robot=spec,
        distribution=distribution,
        n=n,
        seed=seed,
        engine=engine,
        odom_v_window_s=window,
        tol_v=tol_v,
        tol_w=tol_w,
        fit_sessions=_sessions_of(document, params_path),
    )
    short = _short_data_note(traces, result.n_active)
    return dataclasses.replace(result, notes=notes + ((short,) if short else ()) + result.notes)


#: Active validation data (s) below which ``calibrate`` says the spread is judged on little
#: (``benchmarks/bench_novel_robots.py`` measures new sessions' coverage against it).
SHORT_VALIDATION_S = 120.0


def _names(traces: Sequence[Any]) -> str:
    """The traces' files, quoted and comma-separated (as a sentence names them)."""
    return ", ".join(f"'{getattr(t.meta, 'path', '') or 'trace'}'" for t in traces)


def _short_data_note(traces: Sequence[Any], n_active: int) -> str | None:
    """One sentence when the validation logs hold under :data:`SHORT_VALIDATION_S` of active
    samples (their count times the logs' median odometry interval), else None."""
    steps = [np.diff(np.asarray(t.meas_t_s, dtype=np.float64)) for t in traces]
    steps = [d[np.isfinite(d) & (d > 0)] for d in steps]
    if not any(d.size for d in steps):
        return None
    active_s = n_active * float(np.median(np.concatenate(steps)))
    if active_s >= SHORT_VALIDATION_S:
        return None
    return (
        f"the calibration logs hold {active_s:.0f} s of active samples: a spread judged on less "
        f"than {SHORT_VALIDATION_S:.0f} s may be too narrow for a new session (see "
        "docs/benchmarks.md, bench_novel_robots, for how such bands cover new sessions); "
        "calibrate on more or longer sessions"
    )


def write_calibrated(
    params_path: str | Path, out_path: str | Path, result: CalibrationResult
) -> Path:
    """Write ``params_path`` with the calibrated ``randomization`` and a ``calibration`` block.

    Everything else (the point estimate, scores, provenance) is copied unchanged; the file is
    written to a temp file and renamed.
    """
    check_not_an_input(out_path, [params_path], what="calibrated params file (-o)")
    document = dict(read_params_file(params_path).document)
    document["randomization"] = result.distribution.to_dict()
    document["calibration"] = result.to_dict()
    text = yaml.safe_dump(document, sort_keys=False, default_flow_style=None, width=100)
    with atomic_write(out_path, "w", what="calibrated params file (-o)") as fh:
        fh.write(text)
    return Path(out_path)
