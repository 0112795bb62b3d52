r"""What the fitted logs needed of each limit: the lower bounds of limits they never reached.

A limit that never acted in a log is not identified by it, but the log still proves a lower
bound: the robot delivered what the log asked of it, so its limit is at least that. At the
fitted point the model is replayed on the fit logs (noise-free) and for each limit the
largest demand is taken:

- ``wheel_speed_max_radps``: :math:`\max (|v| + |\omega| b/2)/r` (the outer wheel);
- ``speed_lim_v_mps``, ``speed_lim_w_radps``: :math:`\max|v|`, :math:`\max|\omega|`;
- ``accel_lim_v_mps2``, ``accel_lim_w_radps2``: the largest rate of change between two
  measurement times (a secant slope: never above the true peak);
- ``wheel_torque_max_nm``: the largest wheel torque of the base dynamics,
  :math:`r\,[(M|\dot v| + F_c + b_v|v|)/2 + (J|\dot\omega| + T_c + b_\omega|\omega|)/b]`
  (total mass :math:`M`, yaw inertia :math:`J`, Coulomb and viscous friction of the fitted
  point).

A limit whose demand comes within :data:`REACHED_SHARE` of its fitted value acted in the log:
the log identifies it, and it gets no bound. The others keep their prior (and posterior) only
above the demand (:attr:`robots.randomization.DriveDistribution.lower`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robots.arrays import FloatArray
from robots.params import BaseGeometry, DriveParams
from sysid.steady import MIN_STRETCH, steady_samples

__all__ = [
    "BEYOND_PRIOR_FACTOR",
    "MEASURED_PERCENTILE",
    "REACHED_SHARE",
    "held_speeds",
    "limit_needs",
    "lower_bounds",
    "measured_speeds",
]


#: A demand of at least this share of a limit's fitted value means the limit acted.
REACHED_SHARE = 0.9

#: Percentile of the measured speeds taken as what a log proves of a speed limit (single
#: odometry spikes stay above it).
MEASURED_PERCENTILE = 99.0

#: A measured speed this many times a speed limit's prior centre or more contradicts the
#: prior; below it, noisy or pose-derived odometry and the prior's own spread cover the gap.
BEYOND_PRIOR_FACTOR = 1.25


def _rate(t: FloatArray, y: FloatArray) -> float:
    dt = np.diff(t)
    ok = dt > 0
    return float(np.max(np.abs(np.diff(y)[ok] / dt[ok]), initial=0.0))


def limit_needs(
    times: Sequence[FloatArray],
    vs: Sequence[FloatArray],
    ws: Sequence[FloatArray],
    params: DriveParams,
    geometry: BaseGeometry,
) -> dict[str, float]:
    """The largest demand on each limit of the model's ``(v, w)`` at the measurement times.

    Parameters
    ----------
    times, vs, ws : sequences of ndarray
        Per log: measurement times (s) and the fitted model's v (m/s) and w (rad/s).
    params : DriveParams
        The fitted point (masses and friction for the torque).
    geometry : BaseGeometry
        The base geometry.

    Returns
    -------
    dict
        ``{limit field: demand}`` in the field's unit.

    Examples
    --------
    >>> geo = BaseGeometry(mass_kg=1.0, yaw_inertia_kgm2=0.01, wheel_radius_m=0.05,
    ...                    wheel_separation_m=0.2)
    >>> t = np.array([0.0, 0.5, 1.0])
    >>> needs = limit_needs([t], [np.array([0.0, 0.1, 0.1])], [np.zeros(3)], DriveParams(), geo)
    >>> round(needs["wheel_speed_max_radps"], 3), round(needs["accel_lim_v_mps2"], 3)
    (2.0, 0.2)
    """
    r, b = geometry.wheel_radius_m, geometry.wheel_separation_m
    mass = params.total_mass_kg(geometry)
    inertia = params.total_yaw_inertia_kgm2(geometry)
    out = dict.fromkeys(
        ("wheel_speed_max_radps", "speed_lim_v_mps", "speed_lim_w_radps", "accel_lim_v_mps2",
         "accel_lim_w_radps2", "wheel_torque_max_nm"),
        0.0,
    )  # fmt: skip
    coulomb_v = max(params.coulomb_v_fwd_n, params.coulomb_v_bwd_n)
    for t, v, w in zip(times, vs, ws, strict=True):
        if t.size < 2:
            continue
        av, aw = np.abs(np.gradient(v, t)), np.abs(np.gradient(w, t))
        torque = r * (
            (mass * av + coulomb_v * (np.abs(v) > 1e-3) + params.viscous_v_ns_per_m * np.abs(v)) / 2
            + (inertia * aw + params.coulomb_w_nm * (np.abs(w) > 1e-3)
               + params.viscous_w_nms_per_rad * np.abs(w)) / b
        )  # fmt: skip
        demands = {
            "wheel_speed_max_radps": float(np.max((np.abs(v) + np.abs(w) * b / 2) / r)),
            "speed_lim_v_mps": float(np.max(np.abs(v))),
            "speed_lim_w_radps": float(np.max(np.abs(w))),
            "accel_lim_v_mps2": _rate(t, v),
            "accel_lim_w_radps2": _rate(t, w),
            "wheel_torque_max_nm": float(np.max(torque)),
        }
        out = {k: max(out[k], demands[k]) for k in out}
    return out


def lower_bounds(
    needs: dict[str, float], params: DriveParams, varying: Sequence[str]
) -> dict[str, float]:
    """``{field: demand}`` of the varying limits the logs never reached (demand > 0 and
    below :data:`REACHED_SHARE` of the fitted value).

    Examples
    --------
    >>> p = DriveParams(wheel_speed_max_radps=10.0, accel_lim_v_mps2=1.0)
    >>> lower_bounds({"wheel_speed_max_radps": 4.0, "accel_lim_v_mps2": 0.95}, p,
    ...              ["wheel_speed_max_radps", "accel_lim_v_mps2"])
    {'wheel_speed_max_radps': 4.0}
    """
    out = {}
    for name, need in needs.items():
        limit = float(getattr(params, name))
        if name in varying and need > 0 and need < REACHED_SHARE * limit:
            out[name] = need
    return out


def measured_speeds(
    meas_v: Sequence[FloatArray], meas_w: Sequence[FloatArray], geometry: BaseGeometry
) -> dict[str, float]:
    r"""What measured velocities prove of the speed limits: the :data:`MEASURED_PERCENTILE`
    percentile of each limit's demand over all rows (0 without finite rows).

    - ``wheel_speed_max_radps``: :math:`(|v| + |\omega| b/2)/r` (the outer wheel on the
      geometric track; a skid steer's wheels turn faster still, on its effective track);
    - ``speed_lim_v_mps``, ``speed_lim_w_radps``: :math:`|v|`, :math:`|\omega|`.

    A robot measured at a speed has a limit at least that high, whatever a prior says.

    Examples
    --------
    >>> geo = BaseGeometry(mass_kg=1.0, yaw_inertia_kgm2=0.01, wheel_radius_m=0.1,
    ...                    wheel_separation_m=0.4)
    >>> out = measured_speeds([np.full(50, 1.0)], [np.full(50, 2.0)], geo)
    >>> round(out["wheel_speed_max_radps"], 3), round(out["speed_lim_w_radps"], 3)
    (14.0, 2.0)
    """
    r, b = geometry.wheel_radius_m, geometry.wheel_separation_m
    v = np.abs(np.concatenate([np.asarray(x, dtype=np.float64) for x in meas_v] or [np.zeros(0)]))
    w = np.abs(np.concatenate([np.asarray(x, dtype=np.float64) for x in meas_w] or [np.zeros(0)]))
    ok = np.isfinite(v) & np.isfinite(w)
    if not np.any(ok):
        return dict.fromkeys(("wheel_speed_max_radps", "speed_lim_v_mps", "speed_lim_w_radps"), 0.0)
    v, w = v[ok], w[ok]
    demands = {
        "wheel_speed_max_radps": (v + w * b / 2) / r,
        "speed_lim_v_mps": v,
        "speed_lim_w_radps": w,
    }
    return {k: float(np.percentile(x, MEASURED_PERCENTILE)) for k, x in demands.items()}


def held_speeds(
    meas_t_s: FloatArray,
    cmd_v: FloatArray,
    cmd_w: FloatArray,
    meas_v: FloatArray,
    meas_w: FloatArray,
    geometry: BaseGeometry,
) -> dict[str, float]:
    r"""What a log proves of the speed limits where it holds a command: per steady stretch
    (:func:`sysid.steady.steady_samples`: a non-zero command held past the rise, at least
    :data:`sysid.steady.MIN_STRETCH` samples) the median of each limit's demand, and the largest
    such median over the stretches (0 where there is none).

    The demands are those of :func:`measured_speeds`. A median over a held stretch is what the
    robot delivered for a second or more, whatever the odometry's noise: unlike a percentile of
    single readings, noise does not raise it above the robot's speed, so it is a lower bound of
    the limit that holds for a log no fit used (a calibration session).

    Parameters
    ----------
    meas_t_s, cmd_v, cmd_w, meas_v, meas_w : ndarray
        Per measurement: its time (s, increasing), the command held then (m/s, rad/s) and the
        measured v (m/s) and w (rad/s).
    geometry : BaseGeometry
        The base geometry (wheel radius and separation).

    Returns
    -------
    dict
        ``{"wheel_speed_max_radps": ..., "speed_lim_v_mps": ..., "speed_lim_w_radps": ...}``.

    Examples
    --------
    >>> geo = BaseGeometry(mass_kg=1.0, yaw_inertia_kgm2=0.01, wheel_radius_m=0.1,
    ...                    wheel_separation_m=0.4)
    >>> t = np.arange(0.0, 4.0, 0.1)
    >>> cmd = np.where(t < 1.0, 0.1, 0.3)
    >>> v = np.where(t < 1.3, 0.1, 0.29) + np.random.default_rng(0).normal(0, 0.01, t.size)
    >>> round(held_speeds(t, cmd, 0 * t, v, 0 * t, geo)["speed_lim_v_mps"], 2)
    0.29
    """
    keys = ("wheel_speed_max_radps", "speed_lim_v_mps", "speed_lim_w_radps")
    t, cv, cw, v, w = (
        np.asarray(x, dtype=np.float64) for x in (meas_t_s, cmd_v, cmd_w, meas_v, meas_w)
    )
    steady, labels = steady_samples(t, cv, cw)
    v, w = np.abs(v[steady]), np.abs(w[steady])
    ok = np.isfinite(v) & np.isfinite(w)
    v, w, labels = v[ok], w[ok], labels[ok]
    r, b = geometry.wheel_radius_m, geometry.wheel_separation_m
    demands = ((v + w * b / 2) / r, v, w)
    out = dict.fromkeys(keys, 0.0)
    for label in np.unique(labels):
        mine = labels == label
        if np.count_nonzero(mine) < MIN_STRETCH:
            continue
        for key, demand in zip(keys, demands, strict=True):
            out[key] = max(out[key], float(np.median(demand[mine])))
    return out
