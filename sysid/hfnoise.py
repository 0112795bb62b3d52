r"""A log's own odometry noise from the high-frequency part of its measurement, with no model.

A log that never holds a command (a wall follower, a person follower, a state machine) has no
steady stretch for :func:`sysid.steady.steady_noise`. Its noise still shows where the robot's
motion cannot: between successive readings. The robot's velocity is the output of a drive
whose time constant is longer than the odometry period, so over three successive readings
:math:`z_{i-1}, z_i, z_{i+1}` (times :math:`t_{i-1} < t_i < t_{i+1}`) it is close to a
straight line, and the residual of the middle reading from the chord through its neighbours,

.. math:: r_i = z_i - \big((1 - a_i)\,z_{i-1} + a_i\,z_{i+1}\big),
          \qquad a_i = \frac{t_i - t_{i-1}}{t_{i+1} - t_{i-1}},

is the noise: for white noise of sd :math:`\sigma` its sd is
:math:`\sigma\sqrt{1 + a_i^2 + (1 - a_i)^2}` (:math:`\sqrt{1.5}\,\sigma` at an even rate),
while a smooth signal leaves :math:`-\tfrac12 z''\,h^2` (:math:`h` the period). The
dynamics' share is taken out by how it grows with the stencil: over every other reading
(:math:`2h`) it is 4 times larger, the noise's the same, so with the robust variances
:math:`r_1^2` (stencil :math:`h`) and :math:`r_2^2` (stencil :math:`2h`) the noise variance
is :math:`(16 r_1^2 - r_2^2)/15`, never above :math:`r_1^2` nor below 0 (Richardson
extrapolation of the residual variance to a zero stencil). Command steps, where the robot's
motion is not smooth at this rate, are a minority of the stencils and the robust scale (MAD,
the statistic of :func:`sysid.steady.steady_noise` and of the fit's residuals) leaves them out.
Only stencils whose three readings are under a non-zero command count: at rest a wheel
odometry reads exact zeros, which say nothing of its noise while the robot moves; for the same
reason v is read on the stencils under a non-zero v command when there are
:data:`sysid.steady.MIN_STEADY_SAMPLES` of them (a spin in place reads v close to zero, as
:func:`sysid.steady.steady_noise` reads it). What the
drive does faster than the odometry period is read as noise too: commands that jump at every
message to a base whose wheel loops follow them within a period raise the estimate (never
lower it), and transients after command steps raise the robust scale by their share of the
stencils. Scatter slower than the odometry period (a filtered gyro, a level that wanders
under a held command) is the reverse: it is not seen. On a log that also holds commands,
:func:`sysid.steady.steady_noise` is the estimate to use.

Two measurements are read differently:

- velocities read as they are (an encoder twist, a gyro): :math:`z` is the measured v and w,
  at the fresh readings (a reading that repeats its predecessor, a slow zero-order hold, is no
  new measurement: ``fresh``, :func:`robots.measurement.fresh_readings`);
- velocities derived from the pose (the local-line slope over a centred window :math:`W`,
  :mod:`robots.measurement`): their noise is correlated over the window, so successive
  differences of them show little of it. The pose itself carries the white noise: :math:`z`
  is the path length along the heading and the unwrapped yaw at the pose updates, and the
  velocity noise is the pose noise times the slope's gain :math:`1/\sqrt{\sum_j (t_j -
  \bar t)^2}` over the updates within :math:`\pm W/2` (least squares: the slope of a line
  fitted to points of independent noise :math:`\sigma_p` has sd :math:`\sigma_p /
  \sqrt{\sum_j (t_j - \bar t)^2}`), its median over the moving updates.

Examples
--------
>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> t = np.arange(0.0, 30.0, 0.05)
>>> v = 0.2 * (1.0 - np.exp(-t / 0.3)) + 0.05 * np.sin(0.5 * t)  # a smooth response
>>> cmd = np.where(t > 0.0, 0.2 + 0.05 * rng.standard_normal(t.size), 0.0)  # never held
>>> own = highfreq_noise(t, cmd, np.zeros(t.size),
...                      v + rng.normal(0.0, 0.01, t.size), rng.normal(0.0, 0.03, t.size))
>>> own.measured, round(own.std_v_mps, 2), round(own.std_w_radps, 2)
(True, 0.01, 0.03)
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from robots.arrays import BoolArray, FloatArray
from robots.measurement import MeasurementModel
from sysid.steady import MIN_STEADY_SAMPLES, SteadyNoise, robust_sd

__all__ = ["HIGHFREQ_METHOD", "RESPONSE_METHOD", "highfreq_noise", "log_pose", "response_noise"]

#: :attr:`sysid.steady.SteadyNoise.method` of an estimate made by :func:`highfreq_noise`.
HIGHFREQ_METHOD = "high-frequency"
#: :attr:`sysid.steady.SteadyNoise.method` of an estimate made by :func:`response_noise`.
RESPONSE_METHOD = "response"


def _chord_residuals(t: FloatArray, z: FloatArray, step: int) -> FloatArray:
    """Per reading ``i`` (``step <= i < n - step``): the residual of ``z[i]`` from the chord
    through ``z[i - step]`` and ``z[i + step]``, divided by its white-noise sd factor."""
    t0, t1, t2 = t[: -2 * step], t[step:-step], t[2 * step :]
    a = (t1 - t0) / (t2 - t0)
    r = z[step:-step] - ((1.0 - a) * z[: -2 * step] + a * z[2 * step :])
    out: FloatArray = r / np.sqrt(1.0 + a * a + (1.0 - a) ** 2)
    return out


def _noise_var(t: FloatArray, z: FloatArray, moving: BoolArray) -> tuple[float, int]:
    """The white-noise variance of ``z(t)`` (module docstring) and the number of stencils."""
    variances, counts = [], []
    for step in (1, 2):
        if t.size < 2 * step + 1:
            return math.nan, 0
        ok = moving[: -2 * step] & moving[step:-step] & moving[2 * step :]
        res = _chord_residuals(t, z, step)[ok]
        if res.size < MIN_STEADY_SAMPLES:
            return math.nan, int(res.size)
        variances.append(robust_sd(res) ** 2)
        counts.append(int(res.size))
    r1, r2 = variances
    return min(max((16.0 * r1 - r2) / 15.0, 0.0), r1), counts[0]


def _slope_gain(t: FloatArray, window_s: float) -> FloatArray:
    """Per reading: the sd of the local-line slope over the readings within +-window/2 of it,
    per unit sd of their (independent) noise, 1/s (NaN for a window of one reading)."""
    half = 0.5 * window_s
    lo = np.searchsorted(t, t - half, "left")
    hi = np.searchsorted(t, t + half, "right")
    c1 = np.concatenate(([0.0], np.cumsum(t - t.mean())))
    c2 = np.concatenate(([0.0], np.cumsum((t - t.mean()) ** 2)))
    n = (hi - lo).astype(np.float64)
    s1, s2 = c1[hi] - c1[lo], c2[hi] - c2[lo]
    sxx = s2 - s1 * s1 / np.maximum(n, 1.0)
    out: FloatArray = np.where((n >= 2) & (sxx > 0), 1.0 / np.sqrt(np.maximum(sxx, 1e-300)), np.nan)
    return out


def _path(x: FloatArray, y: FloatArray, yaw: FloatArray) -> FloatArray:
    """The path length along the heading (m): the pose increments projected on the mean
    heading of each interval, summed."""
    mid = 0.5 * (yaw[1:] + yaw[:-1])
    ds = np.diff(x) * np.cos(mid) + np.diff(y) * np.sin(mid)
    return np.concatenate(([0.0], np.cumsum(ds)))


def _running_integral(t: FloatArray, y: FloatArray) -> FloatArray:
    """The trapezoid integral of ``y(t)`` from the first sample to each sample."""
    steps = 0.5 * (y[1:] + y[:-1]) * np.diff(t)
    out: FloatArray = np.concatenate(([0.0], np.cumsum(steps)))
    return out


def log_pose(log: object) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """The odometry pose of ``log`` (``pose_x``, ``pose_y``, ``pose_yaw``: m, m, rad, one per
    measurement, as a :class:`sim2real.logs.Trace` has it); None when it has none.

    Examples
    --------
    >>> log_pose(object()) is None
    True
    """
    parts = [getattr(log, f"pose_{k}", None) for k in ("x", "y", "yaw")]
    n = np.asarray(getattr(log, "meas_t_s", ())).size
    if any(p is None for p in parts):
        return None
    x, y, yaw = (np.asarray(p, dtype=np.float64) for p in parts)
    if not (x.size == y.size == yaw.size == n) or not np.all(np.isfinite(x + y + yaw)):
        return None
    return x, y, yaw


def highfreq_noise(
    meas_t_s: ArrayLike,
    cmd_v: ArrayLike,
    cmd_w: ArrayLike,
    meas_v: ArrayLike,
    meas_w: ArrayLike,
    *,
    measurement: MeasurementModel | None = None,
    pose: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
    explained: tuple[ArrayLike, ArrayLike] | None = None,
) -> SteadyNoise:
    """The odometry noise of one log from its high-frequency part (module docstring).

    Parameters
    ----------
    meas_t_s, cmd_v, cmd_w, meas_v, meas_w : array_like
        The log, as for :func:`sysid.steady.steady_noise`.
    measurement : robots.measurement.MeasurementModel, optional
        How the velocities are made from the robot's: its fresh readings are used (all when
        None), and with ``pose`` a ``"pose"`` model's window.
    pose : (x, y, yaw), optional
        Per measurement: the odometry pose (m, m, rad), read when ``measurement`` says the
        velocities are its local-line slope.
    explained : (v, w), optional
        Per measurement: what a model of the drive's response to the logged command predicts
        the readings to be (m/s, rad/s, read through the same measurement). It is taken out
        first (from the pose, its running integral): the stencils then see what the command
        does not explain, and a kink the command put in the motion is no longer read as noise.

    Returns
    -------
    SteadyNoise
        ``method`` :data:`HIGHFREQ_METHOD`; ``n_samples`` the stencils under a moving
        command; NaN sds when fewer than :data:`sysid.steady.MIN_STEADY_SAMPLES`.
    """
    t = np.asarray(meas_t_s, dtype=np.float64)
    keep = np.ones(t.size, dtype=bool) if measurement is None else measurement.fresh
    driving = np.asarray(cmd_v, dtype=np.float64) != 0
    moving = driving | (np.asarray(cmd_w, dtype=np.float64) != 0)
    tk, mk, dk = t[keep], moving[keep], driving[keep]
    model = [np.broadcast_to(np.asarray(e, dtype=np.float64), t.shape) for e in explained or (0, 0)]
    if pose is not None and measurement is not None and measurement.kind == "pose":
        x, y, yaw = (np.asarray(p, dtype=np.float64)[keep] for p in pose)
        yaw = np.unwrap(yaw)
        gain = _slope_gain(tk, measurement.window_s)[mk]
        g = float(np.nanmedian(gain)) if np.isfinite(gain).any() else math.nan
        path_m, turned = (_running_integral(t, m)[keep] for m in model)
        series: tuple[tuple[FloatArray, float], ...] = (
            (_path(x, y, yaw) - path_m, g),
            (yaw - turned, g),
        )
    else:
        series = tuple(
            ((np.asarray(z, dtype=np.float64) - m)[keep], 1.0)
            for z, m in zip((meas_v, meas_w), model, strict=True)
        )
    stds, counts = [], []
    for (z, gain_per_s), first in zip(series, (dk, mk), strict=True):
        var, count = _noise_var(tk, z, first)
        if not math.isfinite(var):  # too few stencils under a v command: every moving one
            var, count = _noise_var(tk, z, mk)
        stds.append(math.sqrt(var) * gain_per_s if math.isfinite(var) else math.nan)
        counts.append(count)
    n = min(counts)
    if n < MIN_STEADY_SAMPLES or not all(math.isfinite(s) for s in stds):
        return SteadyNoise(
            std_v_mps=math.nan, std_w_radps=math.nan, n_samples=n, method=HIGHFREQ_METHOD
        )
    return SteadyNoise(std_v_mps=stds[0], std_w_radps=stds[1], n_samples=n, method=HIGHFREQ_METHOD)


def response_noise(
    meas_t_s: ArrayLike,
    cmd_v: ArrayLike,
    cmd_w: ArrayLike,
    meas_v: ArrayLike,
    meas_w: ArrayLike,
    explained: tuple[ArrayLike, ArrayLike],
    *,
    measurement: MeasurementModel | None = None,
    pose: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
) -> SteadyNoise:
    r"""The odometry noise of a log whose commands never hold: the part of its readings that
    a model of the drive's response to the logged command does not explain, and that changes
    faster than the motion.

    ``explained`` is a model's replay of the logged commands read through the log's
    measurement (the fitted point's: :func:`sim2real.agreement.replay.replay`). Per axis, two
    figures bound the measurement noise from above, and the estimate is the smaller:

    - the robust sd (MAD) of the residual :math:`z - \hat z`: the noise and the model's
      misses are independent, so the residual's variance is the sum of theirs and never less
      than the noise's;
    - :func:`highfreq_noise` of the residual: its scatter between successive readings, with
      the kinks the command puts in the motion taken out by the model and the model's slow
      misses taken out by the stencils. It reads the model's misses faster than the odometry
      period as noise, and a pose-derived velocity's noise through the slope's gain, which
      holds only for a pose whose noise is white: where that fails, the first figure bounds it.

    On a log that holds commands :func:`sysid.steady.steady_noise` is the estimate to use; on
    the real Neato logs that have both, this one reads 0.8-1.3 times it on v while driving
    and on w (``benchmarks/bench_hfnoise.py``).

    Parameters
    ----------
    meas_t_s, cmd_v, cmd_w, meas_v, meas_w : array_like
        The log, as for :func:`sysid.steady.steady_noise`.
    explained : (v, w)
        Per measurement: the model's prediction of the readings, m/s and rad/s.
    measurement, pose
        As for :func:`highfreq_noise`.

    Returns
    -------
    SteadyNoise
        ``method`` :data:`RESPONSE_METHOD`; ``n_samples`` the smaller count of the two axes'
        readings; NaN sds when fewer than :data:`sysid.steady.MIN_STEADY_SAMPLES`.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(0.0, 30.0, 0.1)
    >>> cmd = 0.2 + 0.05 * np.sin(t)  # a new command at every reading
    >>> model = (cmd, 0.5 * cmd)  # a drive that follows it within a reading
    >>> own = response_noise(t, cmd, 0.5 * cmd, cmd + rng.normal(0.0, 0.01, t.size),
    ...                      0.5 * cmd + rng.normal(0.0, 0.02, t.size), model)
    >>> own.method, round(own.std_v_mps, 2), round(own.std_w_radps, 2)
    ('response', 0.01, 0.02)
    """
    t = np.asarray(meas_t_s, dtype=np.float64)
    high = highfreq_noise(
        t, cmd_v, cmd_w, meas_v, meas_w, measurement=measurement, pose=pose, explained=explained
    )
    keep = np.ones(t.size, dtype=bool) if measurement is None else measurement.fresh
    driving = np.asarray(cmd_v, dtype=np.float64) != 0
    moving = driving | (np.asarray(cmd_w, dtype=np.float64) != 0)
    if np.count_nonzero(driving & keep) < MIN_STEADY_SAMPLES:
        driving = moving  # too few readings under a v command: every moving one
    stds, counts = [], []
    for z, model, mask, hf in (
        (meas_v, explained[0], driving & keep, high.std_v_mps),
        (meas_w, explained[1], moving & keep, high.std_w_radps),
    ):
        residual = (np.asarray(z, dtype=np.float64) - np.asarray(model, dtype=np.float64))[mask]
        counts.append(int(residual.size))
        bounds = [b for b in (robust_sd(residual), hf) if math.isfinite(b)]
        stds.append(min(bounds) if bounds else math.nan)
    n = min(counts)
    if n < MIN_STEADY_SAMPLES or not all(math.isfinite(s) for s in stds):
        return SteadyNoise(
            std_v_mps=math.nan, std_w_radps=math.nan, n_samples=n, method=RESPONSE_METHOD
        )
    return SteadyNoise(std_v_mps=stds[0], std_w_radps=stds[1], n_samples=n, method=RESPONSE_METHOD)
