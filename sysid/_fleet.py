r"""Population of several recording sessions: a random-effects model in fit coordinates.

Each session :math:`i` has its own parameters :math:`\theta_i = \mu + b_i`,
:math:`b_i \sim \mathcal N(0, T)` (payload, floor, battery and latency change from day to day),
and its log carries the information :math:`L_i` (the data part of the fit's Gauss-Newton
Hessian, zero where the log says nothing) with information vector :math:`\eta_i`
(:math:`L_i \hat\theta^{data}_i`, recovered from the MAP point as
:math:`L_i\hat\theta_i + P(\hat\theta_i - \mu_p)`). The prior :math:`\mathcal N(\mu_p, P^{-1})`
is counted once, for :math:`\mu`:

.. math::

    \Lambda_\mu = P + \sum_i (I + L_i T)^{-1} L_i, \qquad
    \hat\mu = \Lambda_\mu^{-1}\big(P\mu_p + \sum_i (I + L_i T)^{-1}\eta_i\big)

(the marginal of each session, :math:`(L_i^{-1} + T)^{-1}`, written so that a singular
:math:`L_i` is fine). :math:`T` is estimated by EM -- :math:`\hat b_i` and
:math:`V_i = (I + T L_i)^{-1} T` are the posterior mean and covariance of each session's
deviation -- and shrunk toward the spec's default between-session spread :math:`S_0` with
:data:`PRIOR_SESSIONS` pseudo-sessions (an inverse-Wishart-like prior), so a fleet of two logs
does not claim a zero or a huge spread; the result is projected onto the PSD cone.

Each session only speaks where its data inform: :math:`L_i` and :math:`\eta_i` are first
restricted to the directions in which the data carry at least :data:`MIN_INFO_RATIO` of the
prior precision (eigen-directions of :math:`L_i` whitened by the prior). A short log (one
segment of a paused recording) leaves nearly flat directions in which its MAP point still sits off the prior (a
bound, an unconverged step): recovering a data estimate there divides that offset by an
information near zero, puts the session astronomically far away and makes the EM estimate of
:math:`T` grow without bound. Restricted, the session is treated as saying nothing there,
which is what its data say.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from robots.arrays import FloatArray

__all__ = [
    "BAND_LEVEL",
    "MIN_INFO_RATIO",
    "PRIOR_SESSIONS",
    "Population",
    "SessionInfo",
    "new_session_factor",
    "population",
    "spread_degrees_of_freedom",
]


#: Weight (in sessions) of the spec's default between-session spread in the estimate of T.
PRIOR_SESSIONS = 3.0
_EM_ITERATIONS = 200
#: Central probability at which a new session's Student-t predictive is matched by the Gaussian
#: the randomisation block stores (the default band of ``agree --ensemble``).
BAND_LEVEL = 0.90


def new_session_factor(
    n_sessions: int, *, prior_sessions: float = PRIOR_SESSIONS, level: float = BAND_LEVEL
) -> float:
    r"""Variance factor on the between-session covariance :math:`T` for a *new* session.

    :math:`T` is estimated from ``n_sessions`` sessions plus ``prior_sessions`` pseudo-sessions
    of the spec's default spread (the inverse-Wishart-like prior of :func:`population`), one
    degree of freedom going to the mean: :math:`\nu = n - 1 + n_0`. With :math:`T` known only
    to that many degrees of freedom the predictive of a new session's deviation is a Student-t
    with :math:`\nu` degrees of freedom (Gelman et al., *Bayesian Data Analysis*, 3rd ed.,
    sec. 3.6), heavier-tailed than the Gaussian the ``randomization`` block stores; the factor
    :math:`(t_{\nu,q}/z_q)^2`, :math:`q = (1 + \text{level})/2`, gives the Gaussian the same
    central ``level`` interval. It falls toward 1 as sessions accumulate.

    Examples
    --------
    >>> round(new_session_factor(1), 2), round(new_session_factor(5), 2)
    (2.05, 1.33)
    """
    from scipy.special import ndtri, stdtrit  # scipy only when asked: light commands load sysid

    dof = spread_degrees_of_freedom(n_sessions, prior_sessions=prior_sessions)
    q = 0.5 * (1.0 + level)
    return float((stdtrit(dof, q) / ndtri(q)) ** 2)


def spread_degrees_of_freedom(n_sessions: int, *, prior_sessions: float = PRIOR_SESSIONS) -> float:
    r"""Degrees of freedom of the between-session spread a fit of ``n_sessions`` logs stores.

    :math:`\nu = n - 1 + n_0` (at least 1): the sessions less the one spent on the mean, plus
    the :data:`PRIOR_SESSIONS` pseudo-sessions of the spec's default spread. It is the weight,
    in sessions, of that spread against any later evidence about it
    (:func:`sim2real.agreement.calibration.calibrate_traces` pools validation sessions with it).

    Examples
    --------
    >>> spread_degrees_of_freedom(1), spread_degrees_of_freedom(3)
    (3.0, 5.0)
    """
    return max(float(n_sessions) - 1.0 + prior_sessions, 1.0)


#: A session's data count in a direction only where they carry at least this fraction of the
#: reference precision there (whitened eigenvalue); below it the session is blind there.
MIN_INFO_RATIO = 0.05


@dataclass(frozen=True, kw_only=True)
class SessionInfo:
    """What one session's fit says, in the population's coordinates (length k).

    Attributes
    ----------
    z : ndarray
        The session's MAP coordinates (prior mean where the log did not fit a field).
    info : ndarray
        (k, k) data information :math:`L_i` (zero rows/columns for fields not fitted).
    """

    z: FloatArray
    info: FloatArray


@dataclass(frozen=True, kw_only=True)
class Population:
    """Outcome of :func:`population`.

    Attributes
    ----------
    mean : ndarray
        :math:`\\hat\\mu`, coordinates.
    mean_cov : ndarray
        Covariance of :math:`\\hat\\mu` (uncertainty of the mean).
    between : ndarray
        Between-session covariance :math:`T` (shrunk, PSD).
    iterations : int
        EM iterations run.
    """

    mean: FloatArray
    mean_cov: FloatArray
    between: FloatArray
    iterations: int


def psd(a: FloatArray, floor: float = 0.0) -> FloatArray:
    """Nearest symmetric matrix with eigenvalues >= ``floor``."""
    sym = 0.5 * (a + a.T)
    w, v = np.linalg.eigh(sym)
    out: FloatArray = (v * np.maximum(w, floor)) @ v.T
    return out


@dataclass(frozen=True)
class _Data:
    r"""A session's data part restricted to the directions it informs: :math:`L_i, \eta_i`."""

    info: FloatArray
    eta: FloatArray


def _data_part(s: SessionInfo, prior_mu: FloatArray, prior_prec: FloatArray) -> _Data:
    r""":math:`L_i` and :math:`\eta_i = L_i\hat\theta_i + P(\hat\theta_i - \mu_p)` of ``s``,
    restricted to the eigen-directions of :math:`D^{-1} L_i D^{-1}` with an eigenvalue of at
    least :data:`MIN_INFO_RATIO`; :math:`D^2` is the prior precision (the session's own
    information for a field without a prior: no pull, nothing to amplify)."""
    fitted = np.any(s.info != 0, axis=0)
    pull = np.where(fitted, prior_prec * (s.z - prior_mu), 0.0)
    d = np.sqrt(np.where(prior_prec > 0, prior_prec, np.maximum(np.diag(s.info), 1e-300)))
    w, v = np.linalg.eigh(0.5 * (s.info + s.info.T) / np.outer(d, d))
    vk = v[:, w >= MIN_INFO_RATIO]
    info = ((vk * w[w >= MIN_INFO_RATIO]) @ vk.T) * np.outer(d, d)
    eta = info @ s.z + d * (vk @ (vk.T @ (pull / d)))
    return _Data(info=info, eta=eta)


def _mean(
    data: Sequence[_Data], t: FloatArray, prior_mu: FloatArray, prior_prec: FloatArray
) -> tuple[FloatArray, FloatArray]:
    k = prior_mu.size
    lam = np.diag(prior_prec).astype(np.float64)
    eta = prior_prec * prior_mu
    for s in data:
        a = np.linalg.solve(np.eye(k) + s.info @ t, np.eye(k))  # (I + L T)^-1
        lam = lam + a @ s.info
        eta = eta + a @ s.eta
    lam = 0.5 * (lam + lam.T)
    cov = np.linalg.pinv(lam, hermitian=True)
    return cov @ eta, cov


def _at_most_prior(t: FloatArray, prior_prec: FloatArray) -> FloatArray:
    r""":math:`T` with its eigenvalues in prior-whitened coordinates capped at 1, i.e.
    :math:`T \preceq P^{-1}` on the fields with a prior.

    The spec's prior covers every base of the type in every condition; one base's
    day-to-day spread cannot exceed it. Without the cap, a few sessions that disagree in a
    direction their data barely inform (a MAP point just off the prior, recovered as a data
    estimate far away) drive the EM estimate without bound.
    """
    has = prior_prec > 0
    if not np.any(has):
        return t
    d = np.sqrt(prior_prec[has])
    sub = t[np.ix_(has, has)] * np.outer(d, d)
    w, v = np.linalg.eigh(0.5 * (sub + sub.T))
    if float(w[-1]) <= 1.0:
        return t
    capped = (v * np.clip(w, 0.0, 1.0)) @ v.T / np.outer(d, d)
    out = t.copy()
    out[np.ix_(has, has)] = 0.5 * (capped + capped.T)
    # a capped block keeps no cross terms with the prior-less fields (stays PSD)
    out[np.ix_(has, ~has)] = 0.0
    out[np.ix_(~has, has)] = 0.0
    return out


def population(
    sessions: Sequence[SessionInfo],
    *,
    prior_mu: FloatArray,
    prior_prec: FloatArray,
    session_cov: FloatArray,
    prior_sessions: float = PRIOR_SESSIONS,
) -> Population:
    """Precision-weighted mean and between-session covariance of several sessions.

    ``prior_prec`` is the diagonal prior precision (0 for fields without a prior),
    ``session_cov`` the default between-session covariance :math:`S_0` (diagonal).

    Examples
    --------
    >>> import numpy as np
    >>> s = [SessionInfo(z=np.array([x]), info=np.array([[1e6]])) for x in (1.0, 2.0, 3.0)]
    >>> pop = population(s, prior_mu=np.zeros(1), prior_prec=np.zeros(1),
    ...                  session_cov=np.eye(1), prior_sessions=0.0)
    >>> round(float(pop.mean[0]), 3), round(float(pop.between[0, 0]), 2)
    (2.0, 0.67)
    """
    k = prior_mu.size
    s0 = np.asarray(session_cov, dtype=np.float64)
    t = s0.copy()
    n = len(sessions)
    data = [_data_part(s, prior_mu, prior_prec) for s in sessions]
    iterations = 0
    for step in range(1, _EM_ITERATIONS + 1):
        iterations = step
        mu, _ = _mean(data, t, prior_mu, prior_prec)
        acc = np.zeros((k, k))
        for s in data:
            inv = np.linalg.solve(np.eye(k) + t @ s.info, np.eye(k))  # (I + T L)^-1
            v = inv @ t
            b = inv @ (t @ (s.eta - s.info @ mu))
            acc += np.outer(b, b) + v
        if not np.isfinite(acc).all():  # a session informed beyond float range: keep the last T
            break
        t_new = _at_most_prior(psd((acc + prior_sessions * s0) / (n + prior_sessions)), prior_prec)
        done = np.allclose(t_new, t, rtol=1e-6, atol=1e-14)
        t = t_new
        if done:
            break
    mu, mean_cov = _mean(data, t, prior_mu, prior_prec)
    return Population(mean=mu, mean_cov=psd(mean_cov), between=t, iterations=iterations)
