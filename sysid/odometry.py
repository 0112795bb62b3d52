r"""The odometry sensor model of forward velocity: a mean over the preceding window.

Wheel-encoder odometry does not report the instantaneous base speed. The TurtleBot3 firmware,
for example, differences the encoder ticks over one odometry period (30 Hz), so the reported
:math:`v(t_k)` is the distance travelled over :math:`[t_k - W, t_k]` divided by :math:`W`:

.. math:: v_{\text{odom}}(t_k) = \frac{1}{W} \int_{t_k - W}^{t_k} v(\tau)\, d\tau,

a lag of :math:`W/2` plus smoothing. :func:`window_mean` evaluates that integral exactly for
a piecewise-linear signal (a simulation read at its integration grid, which is how the reduced
model and the pybullet robot report velocities between steps). sysid's fit
(``fit_drive(..., odom_v_window_s=W)``) uses the same model with a 3-point Simpson rule over
the window, which is cheaper inside the least-squares loop; :mod:`sim2real.agreement.replay` uses the
exact form.

Examples
--------
>>> import numpy as np
>>> t = np.array([0.0, 1.0])
>>> window_mean(t, 2.0 * t, np.array([1.0]), 0.5)  # mean of 2t over [0.5, 1]
array([1.5])
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from robots.arrays import FloatArray
from sysid.errors import SysidValueError

__all__ = ["running_integral", "window_mean"]


def _check(t: FloatArray, y: FloatArray) -> None:
    if t.ndim != 1 or t.shape != y.shape or t.size == 0:
        raise SysidValueError(
            f"t_s and y must be non-empty 1-D arrays of one length, got shapes {t.shape} and "
            f"{y.shape}"
        )
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(y))):
        raise SysidValueError("t_s and y must be finite (no NaN or inf); clean the signal first")
    if np.any(np.diff(t) < 0):
        raise SysidValueError("t_s must be sorted in time (non-decreasing)")


def running_integral(t_s: ArrayLike, y: ArrayLike, x_s: ArrayLike) -> FloatArray:
    r"""Exact :math:`\int_{t_0}^{x} y\,d\tau` of the piecewise-linear signal through (t_s, y).

    The signal holds ``y[0]`` before ``t_s[0]`` and ``y[-1]`` after ``t_s[-1]`` (so the
    integral is negative for ``x < t_s[0]``); repeated times are allowed.

    Parameters
    ----------
    t_s : array_like
        Sample times, s (sorted).
    y : array_like
        Samples (any unit u).
    x_s : array_like
        Upper limits, s (any order).

    Returns
    -------
    ndarray
        The integrals, u·s.

    Examples
    --------
    >>> running_integral([0.0, 2.0], [1.0, 3.0], [1.0, 3.0, -1.0])
    array([ 1.5,  7. , -1. ])
    """
    t = np.asarray(t_s, dtype=np.float64)
    v = np.asarray(y, dtype=np.float64)
    _check(t, v)
    x = np.asarray(x_s, dtype=np.float64)
    dt = np.diff(t)
    cum = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)))
    k = np.clip(np.searchsorted(t, x, side="right") - 1, 0, t.size - 1)
    h = x - t[k]
    slope = np.zeros_like(v)
    slope[:-1] = np.divide(v[1:] - v[:-1], dt, out=np.zeros_like(dt), where=dt > 0)
    inside = (x >= t[0]) & (k < t.size - 1)
    # within segment k the signal is y_k + slope_k h, integrated from t_k
    out = cum[k] + v[k] * h + np.where(inside, 0.5 * slope[k] * h * h, 0.0)
    before = x < t[0]
    out[before] = v[0] * (x[before] - t[0])
    return np.asarray(out, dtype=np.float64)


def window_mean(t_s: ArrayLike, y: ArrayLike, t_out_s: ArrayLike, window_s: float) -> FloatArray:
    r"""Mean of the piecewise-linear signal (t_s, y) over :math:`[t - W, t]` at each ``t_out_s``.

    This is the odometry model of the module docstring, exact for a piecewise-linear signal;
    the signal holds ``y[0]`` before ``t_s[0]`` and ``y[-1]`` after ``t_s[-1]``. ``window_s``
    0 returns the signal itself (linear interpolation).

    Parameters
    ----------
    t_s, y : array_like
        Sample times (s, sorted) and values (unit u) of the signal, e.g. a simulated v.
    t_out_s : array_like
        Report times, s.
    window_s : float
        Averaging window :math:`W`, s (>= 0; e.g. 1/30 for a 30 Hz encoder odometry).

    Returns
    -------
    ndarray
        The window means at ``t_out_s``, unit u.

    Examples
    --------
    >>> window_mean([0.0, 1.0, 1.0, 2.0], [0.0, 0.0, 1.0, 1.0], [1.1, 1.5], 0.2)
    array([0.5, 1. ])
    """
    if isinstance(window_s, bool) or not (
        isinstance(window_s, int | float) and math.isfinite(window_s) and window_s >= 0
    ):
        raise SysidValueError(
            f"window_s must be a finite number >= 0 s, got {window_s!r}; e.g. 1/30 for a 30 Hz "
            "encoder odometry, 0 for the instantaneous value"
        )
    x = np.asarray(t_out_s, dtype=np.float64)
    if window_s == 0:
        t = np.asarray(t_s, dtype=np.float64)
        v = np.asarray(y, dtype=np.float64)
        _check(t, v)
        return np.asarray(np.interp(x, t, v), dtype=np.float64)
    upper = running_integral(t_s, y, x)
    lower = running_integral(t_s, y, x - window_s)
    return np.asarray((upper - lower) / window_s, dtype=np.float64)
