"""What every plant shares: its parameters' sign check, the command arrays checked, their
arrival at the firmware, the firmware's control tick and the odometry clock."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numba
import numpy as np

from sim2real._arrays import FloatArray
from sim2real.errors import Sim2RealValueError

__all__ = [
    "check_commands",
    "command_arrivals",
    "firmware_tick",
    "negative_field",
    "odometry_clock",
]


def negative_field(params: Any, *, text: tuple[str, ...] = ()) -> tuple[str, Any] | None:
    """The first field of the dataclass ``params`` that is not a number >= 0 (a tuple's every
    element is checked; NaN fails, inf passes) as ``(name, value)``, or None; the fields named
    in ``text`` hold text and are passed over.

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass
    ... class P:
    ...     mass_kg: float
    ...     friction_n: tuple[float, float]
    >>> negative_field(P(mass_kg=1.0, friction_n=(0.5, -0.1)))
    ('friction_n', (0.5, -0.1))
    """
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        values = value if isinstance(value, tuple) else (value,)
        if f.name not in text and not all(
            isinstance(x, int | float) and x >= 0 and not math.isnan(x) for x in values
        ):
            return f.name, value
    return None


def check_commands(
    cmd_t_s: Sequence[float] | FloatArray,
    cmd_v: Sequence[float] | FloatArray,
    cmd_w: Sequence[float] | FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The command times (s), v (m/s) and w (rad/s) as float arrays, checked.

    Examples
    --------
    >>> t, v, w = check_commands([0.0, 0.1], [0.1, 0.2], [0.0, 0.0])
    >>> t.dtype.name, v.tolist()
    ('float64', [0.1, 0.2])
    """
    t = np.asarray(cmd_t_s, dtype=np.float64)
    cv = np.asarray(cmd_v, dtype=np.float64)
    cw = np.asarray(cmd_w, dtype=np.float64)
    if not (t.ndim == 1 and t.size == cv.size == cw.size and np.all(np.diff(t) > 0)):
        raise Sim2RealValueError(
            "cmd_t_s, cmd_v and cmd_w must be 1-D of equal length with increasing times, got "
            f"sizes {t.size}, {cv.size}, {cw.size}"
        )
    return t, cv, cw


def command_arrivals(
    rng: np.random.Generator,
    cmd_t_s: FloatArray,
    latency_s: float,
    jitter_s: float,
    *,
    floor_s: float,
) -> FloatArray:
    """When each command reaches the firmware, s: its time plus its own latency, ``latency_s``
    plus ``jitter_s`` times a normal draw from ``rng`` (one per command), at least ``floor_s``;
    the order is kept (one serial link).

    Examples
    --------
    >>> command_arrivals(np.random.default_rng(0), np.array([0.0, 0.1]), 0.05, 0.0, floor_s=0.0)
    array([0.05, 0.15])
    """
    lat = np.maximum(latency_s + jitter_s * rng.standard_normal(cmd_t_s.size), floor_s)
    return np.maximum.accumulate(cmd_t_s + lat)


def odometry_clock(
    rng: np.random.Generator, rate_hz: float, duration_s: float
) -> tuple[float, FloatArray]:
    """(period s, tick times s) of an odometry clock at ``rate_hz`` over ``duration_s``: its
    phase is drawn from ``rng`` (one uniform draw), uniform over one period.

    Examples
    --------
    >>> period, ticks = odometry_clock(np.random.default_rng(0), 10.0, 1.0)
    >>> period, ticks.size
    (0.1, 10)
    """
    period = 1.0 / rate_hz
    phase = rng.uniform(0.0, period)
    n_ticks = int((duration_s - phase) / period) + 1
    return period, (phase + period * np.arange(n_ticks)).astype(np.float64)


@numba.njit(cache=True)
def firmware_tick(
    t: float,
    j: int,
    ref_v: float,
    ref_w: float,
    arr_t: FloatArray,
    arr_v: FloatArray,
    arr_w: FloatArray,
    limits: FloatArray,
    ctrl_dt: float,
    half_track_m: float,
    wheel_radius_m: float,
) -> tuple[int, float, float, float, float]:  # pragma: no cover - compiled
    """One control tick of a base's firmware at time ``t``, as ``(j, ref_v, ref_w, left,
    right)``.

    ``j`` is the last command arrived by ``t`` (``arr_t`` sorted; -1: none yet). Its velocity,
    clipped to the speed caps, is the target until ``timeout`` after its arrival (then 0); the
    references ``ref_v``, ``ref_w`` move towards it within the acceleration limits; the wheel
    speed targets (rad/s) of a track ``2 half_track_m`` are scaled down together to the wheel
    speed cap. ``limits`` holds (max v m/s, max w rad/s, accel v m/s^2, accel w rad/s^2,
    wheel speed cap rad/s, timeout s).
    """
    vmax, wmax, acc_v, acc_w = limits[0], limits[1], limits[2], limits[3]
    cap, timeout = limits[4], limits[5]
    while j + 1 < arr_t.size and arr_t[j + 1] <= t:
        j += 1
    tv, tw = 0.0, 0.0
    if j >= 0 and t - arr_t[j] <= timeout:
        tv = min(max(arr_v[j], -vmax), vmax)
        tw = min(max(arr_w[j], -wmax), wmax)
    ref_v += min(max(tv - ref_v, -acc_v * ctrl_dt), acc_v * ctrl_dt)
    ref_w += min(max(tw - ref_w, -acc_w * ctrl_dt), acc_w * ctrl_dt)
    left = (ref_v - half_track_m * ref_w) / wheel_radius_m
    right = (ref_v + half_track_m * ref_w) / wheel_radius_m
    big = max(abs(left), abs(right))
    if big > cap:
        left *= cap / big
        right *= cap / big
    return j, ref_v, ref_w, left, right
