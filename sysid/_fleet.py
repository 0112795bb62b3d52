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
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["PRIOR_SESSIONS", "Population", "SessionInfo", "population"]

FloatArray = NDArray[np.float64]

#: Weight (in sessions) of the spec's default between-session spread in the estimate of T.
PRIOR_SESSIONS = 3.0
_EM_ITERATIONS = 200


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


def _mean(
    sessions: Sequence[SessionInfo], t: FloatArray, prior_mu: FloatArray, prior_prec: FloatArray
) -> tuple[FloatArray, FloatArray]:
    k = prior_mu.size
    lam = np.diag(prior_prec).astype(np.float64)
    eta = prior_prec * prior_mu
    for s in sessions:
        a = np.linalg.solve(np.eye(k) + s.info @ t, np.eye(k))  # (I + L T)^-1
        lam = lam + a @ s.info
        eta = eta + a @ (s.info @ s.z + _prior_pull(s, prior_mu, prior_prec))
    lam = 0.5 * (lam + lam.T)
    cov = np.linalg.pinv(lam, hermitian=True)
    return cov @ eta, cov


def _prior_pull(s: SessionInfo, prior_mu: FloatArray, prior_prec: FloatArray) -> FloatArray:
    """:math:`P(\\hat\\theta_i - \\mu_p)` on the fields the session fitted (MAP condition)."""
    fitted = np.any(s.info != 0, axis=0)
    out: FloatArray = np.where(fitted, prior_prec * (s.z - prior_mu), 0.0)
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
    iterations = 0
    for step in range(1, _EM_ITERATIONS + 1):
        iterations = step
        mu, _ = _mean(sessions, t, prior_mu, prior_prec)
        acc = np.zeros((k, k))
        for s in sessions:
            inv = np.linalg.solve(np.eye(k) + t @ s.info, np.eye(k))  # (I + T L)^-1
            v = inv @ t
            b = inv @ (t @ (s.info @ s.z + _prior_pull(s, prior_mu, prior_prec) - s.info @ mu))
            acc += np.outer(b, b) + v
        t_new = psd((acc + prior_sessions * s0) / (n + prior_sessions))
        done = np.allclose(t_new, t, rtol=1e-6, atol=1e-14)
        t = t_new
        if done:
            break
    mu, mean_cov = _mean(sessions, t, prior_mu, prior_prec)
    return Population(mean=mu, mean_cov=psd(mean_cov), between=t, iterations=iterations)
