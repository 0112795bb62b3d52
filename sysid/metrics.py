r"""Scores that compare a simulated velocity trace with a measured one.

Used by sysid (validation scores) and by :mod:`sim2real.agreement.figures` (the agreement report).

- :func:`fit_percent` — MATLAB ``compare`` FIT %:
  :math:`100\,(1 - \lVert y - \hat y\rVert / \lVert y - \bar y\rVert)`.
- :func:`active_mask` and :func:`agreement_fraction` — the share of *active* samples where the
  simulated (v, w) are within tolerance of the real ones (Liang et al. (2020) report "over 80 %").
- :func:`xcorr_lag_s` — the lag of the simulated trace behind the real one by cross-correlation.

Examples
--------
>>> import numpy as np
>>> y = np.array([0.0, 1.0, 2.0, 3.0])
>>> fit_percent(y, y)
100.0
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sysid.definitions import FIT_PERCENT_DEFINITION
from sysid.errors import SysidValueError

__all__ = [
    "DEFAULT_TOL_V",
    "DEFAULT_TOL_W",
    "FIT_PERCENT_DEFINITION",
    "active_mask",
    "agreement_fraction",
    "fit_percent",
    "rmse",
    "xcorr_lag_s",
]

#: Default agreement tolerance on forward velocity, m/s.
DEFAULT_TOL_V = 0.02
#: Default agreement tolerance on yaw rate, rad/s.
DEFAULT_TOL_W = 0.1
#: A command is "held" (non-zero) above this magnitude (m/s or rad/s).
CMD_EPS = 1e-3


def _pair(y: ArrayLike, y_hat: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    a = np.asarray(y, dtype=np.float64)
    b = np.asarray(y_hat, dtype=np.float64)
    if a.shape != b.shape:
        raise SysidValueError(
            f"measured and simulated traces differ in shape: {a.shape} vs {b.shape}"
        )
    return a, b


def fit_percent(y: ArrayLike, y_hat: ArrayLike) -> float:
    r"""MATLAB ``compare`` fit: :math:`100 (1 - \lVert y-\hat y\rVert / \lVert y-\bar y\rVert)`.

    100 is a perfect fit, 0 is no better than the mean, negative is worse than the mean.
    Returns NaN when ``y`` is constant (the score is undefined).

    Examples
    --------
    >>> round(fit_percent([0.0, 2.0], [0.0, 1.0]), 6)
    29.289322
    """
    a, b = _pair(y, y_hat)
    denom = float(np.linalg.norm(a - a.mean())) if a.size else 0.0
    # a constant y (up to rounding of its mean) leaves the score undefined
    if denom <= 1e-9 * max(float(np.linalg.norm(a)), 1e-300):
        return math.nan
    return 100.0 * (1.0 - float(np.linalg.norm(a - b)) / denom)


def rmse(y: ArrayLike, y_hat: ArrayLike) -> float:
    """Root-mean-square error (same unit as the inputs); NaN for empty inputs."""
    a, b = _pair(y, y_hat)
    return float(np.sqrt(np.mean((a - b) ** 2))) if a.size else math.nan


def _check_tol(name: str, tol: float) -> None:
    if not (math.isfinite(tol) and tol > 0):
        raise SysidValueError(f"{name} must be a finite number > 0, got {tol!r}; e.g. {name}=0.02")


def active_mask(
    cmd_v: ArrayLike,
    cmd_w: ArrayLike,
    meas_v: ArrayLike,
    meas_w: ArrayLike,
    *,
    tol_v: float = DEFAULT_TOL_V,
    tol_w: float = DEFAULT_TOL_W,
) -> NDArray[np.bool_]:
    """Samples where the robot is commanded to move or is moving.

    A sample is active when ``|cmd_v| > 1e-3`` or ``|cmd_w| > 1e-3`` (the command held at that
    time) or ``|meas_v| > tol_v`` or ``|meas_w| > tol_w``. Idle samples are excluded from the
    agreement so that parked time cannot inflate it.
    """
    _check_tol("tol_v", tol_v)
    _check_tol("tol_w", tol_w)
    cv, cw = np.asarray(cmd_v, float), np.asarray(cmd_w, float)
    mv, mw = np.asarray(meas_v, float), np.asarray(meas_w, float)
    mask: NDArray[np.bool_] = (
        (np.abs(cv) > CMD_EPS)
        | (np.abs(cw) > CMD_EPS)
        | (np.abs(mv) > tol_v)
        | (np.abs(mw) > tol_w)
    )
    return mask


def agreement_fraction(
    err_v: ArrayLike,
    err_w: ArrayLike,
    active: ArrayLike,
    *,
    tol_v: float = DEFAULT_TOL_V,
    tol_w: float = DEFAULT_TOL_W,
) -> tuple[float, float, float]:
    """Fractions of active samples within tolerance: (both axes, v only, w only).

    ``err_v = v_sim - v_real`` and ``err_w = w_sim - w_real`` at the measurement times.
    Returns NaNs when no sample is active.

    Examples
    --------
    >>> agreement_fraction([0.0, 0.5], [0.0, 0.0], [True, True])
    (0.5, 0.5, 1.0)
    """
    _check_tol("tol_v", tol_v)
    _check_tol("tol_w", tol_w)
    ev, ew = _pair(err_v, err_w)
    act = np.asarray(active, dtype=bool)
    if act.shape != ev.shape:
        raise SysidValueError(f"active mask shape {act.shape} differs from errors {ev.shape}")
    n = int(act.sum())
    if n == 0:
        return math.nan, math.nan, math.nan
    ok_v = np.abs(ev[act]) <= tol_v
    ok_w = np.abs(ew[act]) <= tol_w
    return float(np.mean(ok_v & ok_w)), float(np.mean(ok_v)), float(np.mean(ok_w))


def _overlap_corr(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    a = a - a.mean()
    b = b - b.mean()
    den = float(np.sqrt(np.dot(a, a) * np.dot(b, b)))
    return float(np.dot(a, b)) / den if den > 0 else 0.0


def _overlap_corr_all(
    a: NDArray[np.float64], b: NDArray[np.float64], max_k: int
) -> NDArray[np.float64]:
    """:func:`_overlap_corr` of ``a[i]`` with ``b[i + k]`` for every lag ``k`` in ``±max_k``.

    All lags at once: the products summed by one FFT cross-correlation (numpy's pocketfft, no
    threaded BLAS call per lag), the overlap sums and sums of squares from cumulative sums.
    """
    n = a.size
    size = 1 << int(2 * n - 1).bit_length()
    cross = np.fft.irfft(np.conj(np.fft.rfft(a, size)) * np.fft.rfft(b, size), size)
    lags = np.arange(-max_k, max_k + 1)
    s_ab = cross[lags % size]
    ca = np.concatenate(([0.0], np.cumsum(a)))
    ca2 = np.concatenate(([0.0], np.cumsum(a * a)))
    cb = np.concatenate(([0.0], np.cumsum(b)))
    cb2 = np.concatenate(([0.0], np.cumsum(b * b)))
    a_lo, a_hi = np.maximum(0, -lags), n - np.maximum(0, lags)
    b_lo, b_hi = np.maximum(0, lags), n - np.maximum(0, -lags)
    m = (a_hi - a_lo).astype(np.float64)
    sa, sb = ca[a_hi] - ca[a_lo], cb[b_hi] - cb[b_lo]
    cov = s_ab - sa * sb / m
    var_a = ca2[a_hi] - ca2[a_lo] - sa * sa / m
    var_b = cb2[b_hi] - cb2[b_lo] - sb * sb / m
    den = np.sqrt(np.maximum(var_a, 0.0) * np.maximum(var_b, 0.0))
    out = np.zeros(lags.size)
    ok = den > 0
    out[ok] = cov[ok] / den[ok]
    return out


def _close_gaps(t: NDArray[np.float64], longest_s: float) -> NDArray[np.float64]:
    """``t`` with every step longer than ``longest_s`` shortened to the median step."""
    if t.size < 3:
        return t
    steps = np.diff(t)
    long = steps > longest_s
    if not np.any(long):
        return t
    excess = np.where(long, steps - float(np.median(steps)), 0.0)
    return t - np.concatenate(([0.0], np.cumsum(excess)))


def xcorr_lag_s(
    t_s: ArrayLike, real: ArrayLike, sim: ArrayLike, *, max_lag_s: float = 1.0, dt_s: float = 0.01
) -> float:
    """Lag of ``sim`` behind ``real`` (s, positive = sim late) by cross-correlation.

    Both signals are resampled on a uniform grid of step ``dt_s``; at each lag within
    ``±max_lag_s`` the correlation coefficient of the overlapping parts is computed, and its
    peak is refined by a parabola through its neighbours (sub-sample). Returns NaN when either
    signal is constant. A pause in ``t_s`` longer than ``2 max_lag_s`` is closed to one median
    step first (the parts either side cannot inform each other's lag), so the grid follows
    the samples, never the time span of a log with a long gap.
    """
    t = _close_gaps(np.asarray(t_s, dtype=np.float64), 2.0 * max_lag_s)
    a, b = _pair(real, sim)
    if t.size < 3 or t[-1] - t[0] < 4 * dt_s:
        return math.nan
    grid = np.arange(t[0], t[-1], dt_s)
    ra = np.interp(grid, t, a)
    sb = np.interp(grid, t, b)
    ra -= ra.mean()
    sb -= sb.mean()
    if not (np.any(ra) and np.any(sb)):
        return math.nan
    max_k = min(round(max_lag_s / dt_s), int(grid.size) - 2)
    lag_list = list(range(-max_k, max_k + 1))
    lags = np.asarray(lag_list, dtype=np.float64)
    # Pearson correlation of the overlapping parts at each lag: the plain sum over fewer
    # overlapping samples at larger |lag| would bias the peak towards zero lag
    corr = _overlap_corr_all(ra, sb, max_k)
    i = int(np.argmax(corr))
    shift = 0.0
    if 0 < i < lags.size - 1:
        c0, c1, c2 = corr[i - 1], corr[i], corr[i + 1]
        denom = c0 - 2 * c1 + c2
        if denom != 0:
            shift = 0.5 * (c0 - c2) / denom
    return float((lags[i] + shift) * dt_s)
