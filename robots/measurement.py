r"""The measurement operator of a log: how its measured velocity is made from the robot's.

A log's measured velocity is not the robot's velocity at the stamp. Two operators are common on
real bases, and a fit or a replay that compares the model's instantaneous velocity with them
mistakes the operator for dynamics:

- ``"pose"``: the velocity is the local-linear (first-order Savitzky-Golay) slope of the
  odometry pose over a centred window of width :math:`W`, fitted on the pose updates and
  interpolated between them (:mod:`sim2real.logs`, when the odometry twist is zero or spiky).
  With the pose the integral of the velocity, the slope at an update :math:`t_k` is
  :math:`\sum_j c_{kj}\,x(t_j)`, a weighted mean of the velocity over :math:`t_k \pm W/2`
  (an Epanechnikov kernel for dense updates). The window is centred: the measured signal
  starts to rise :math:`W/2` before the robot does, which a causal model can only follow
  with a delay that is too short.
- ``"hold"``: the reading updates every few samples and repeats its last value in between
  (a slow zero-order hold: the Husky's and Warthog's wheel speeds). The value at a sample is
  the robot's velocity at the last update, on average half an update period old.

In both, a reading repeated for more than two update periods is a fresh measurement of a robot
that does not change (standing still, or a steady speed read to the same value): those samples
are updates of their own (:func:`fresh_readings`).

:meth:`MeasurementModel.operator` turns the operator into query times :math:`t_q` and a linear
map: the measured velocities are ``op.apply(u(t_q))`` for a model velocity :math:`u`. The fit (:func:`sysid.fit_drive`) and the replay
(:func:`sim2real.agreement.replay.replay`) apply the same matrix to v and to w, so both compare
like with like. For v the operator differentiates the path length instead of the pose's
projection on the heading: they differ by the chord-to-arc ratio,
:math:`1 - (\omega W)^2/24` (under 2 % at 1 rad/s over 0.7 s).

Examples
--------
>>> import numpy as np
>>> t = np.arange(0.0, 2.0, 0.1)
>>> model = pose_model(t, np.ones(t.size, dtype=bool), 0.5)
>>> op = model.operator(t)
>>> bool(np.allclose(op.apply(0.3 * np.ones(op.t_query.size)), 0.3))  # a steady speed
True
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robots.arrays import BoolArray, FloatArray
from robots.errors import RobotsValueError

if TYPE_CHECKING:  # annotations only: reading a log imports this module, and must not import yaml
    from robots.params import DriveParams

__all__ = [
    "W_SOURCES",
    "MeasurementModel",
    "ReadOperator",
    "fresh_readings",
    "hold_model",
    "pose_model",
    "yaw_reading_factor",
]


#: Where a base's odometry yaw rate comes from (``odometry.w_source`` of a robot spec).
W_SOURCES = ("imu", "wheels")
#: Kinds of :class:`MeasurementModel`.
MEASUREMENT_KINDS = ("pose", "hold")
#: Share of the moving samples whose (v, w) repeats the previous one exactly beyond which the
#: reading is a zero-order hold (a measured float of a moving robot does not repeat otherwise).
HOLD_SHARE = 1.0 / 3.0
_MOVING_V, _MOVING_W = 0.05, 0.2
_MIN_MOVING = 20
#: Simpson panels per interval between two updates (the interval integrals of the pose model).
_PANELS = 2


def yaw_reading_factor(w_source: str, params: DriveParams) -> float:
    r"""The odometry's yaw rate over the model's body yaw rate.

    A gyro (``w_source`` ``"imu"``) reads the body's rate: 1. Wheel encoders (``"wheels"``)
    read the wheels' differential speed over the track the driver drives them by,
    :math:`r(\omega_r - \omega_l)/(\chi_d L)` (ROS ``diff_drive_controller`` applies its
    ``wheel_separation_multiplier`` :math:`\chi_d`, ``driver_track_factor``, to its wheel
    targets and to its odometry alike), while the drive model links the wheels to the body
    through the effective track :math:`\chi L` (``track_factor``: a skid steer's treads slip
    sideways in a turn; Mandow et al. 2007). So they read :math:`\chi/\chi_d` times the body
    rate: the wheels' speeds, whatever the slip. A differential drive's factors are 1, so both
    sources read the same. The fit and every replay engine compare a log's yaw rate with the
    model's body rate times this factor.

    Examples
    --------
    >>> from robots.params import DriveParams
    >>> p = DriveParams(track_factor=1.6, driver_track_factor=1.0)
    >>> yaw_reading_factor("wheels", p), yaw_reading_factor("imu", p)
    (1.6, 1.0)
    """
    if w_source not in W_SOURCES:
        raise RobotsValueError(
            f"w_source must be one of {list(W_SOURCES)}, got {w_source!r}; use 'imu' for a "
            "gyro's yaw rate, 'wheels' for the wheel encoders'"
        )
    if w_source == "imu":
        return 1.0
    return float(params.track_factor / params.driver_track_factor)


def fresh_readings(t: NDArray[Any], changed: BoolArray) -> tuple[BoolArray, float]:
    """The samples that carry a fresh reading, and the update period (the median time between
    changes, in the unit of ``t``; 0 with fewer than two changes).

    A fresh reading is each change, and each repeat held for more than two update periods.
    ``t`` is sorted (any unit); ``changed[i]`` says that sample ``i`` differs from sample
    ``i - 1`` (the first sample always counts as a change).

    Examples
    --------
    >>> changed = np.array([1, 0, 1, 0, 1, 0, 0, 0, 0, 0], dtype=bool)
    >>> fresh, period = fresh_readings(np.arange(10.0), changed)
    >>> np.flatnonzero(fresh).tolist(), period
    ([0, 2, 4, 9], 2.0)
    """
    new = np.asarray(changed, dtype=bool).copy()
    new[:1] = True
    idx = np.flatnonzero(new)
    if idx.size < 2:
        return new, 0.0
    t_update = t[idx]
    period = float(np.median(np.diff(t_update)))
    since = t - t_update[np.searchsorted(t_update, t, "right") - 1]
    out: BoolArray = new | (since > 2.0 * period)
    return out, period


@dataclass(frozen=True, kw_only=True)
class MeasurementModel:
    """How a log's measured velocities are made from the robot's (module docstring).

    Attributes
    ----------
    kind : {"pose", "hold"}
        Local-linear pose derivative, or a zero-order hold of slow readings.
    window_s : float
        The pose derivative's centred window, s (0 for ``"hold"``).
    update_period_s : float
        Median time between updates of the reading, s.
    fresh : ndarray of bool
        Per measurement sample: a fresh reading (:func:`fresh_readings`); the others are
        interpolated (``"pose"``) or held (``"hold"``).
    """

    kind: str
    window_s: float = 0.0
    update_period_s: float = 0.0
    fresh: BoolArray = field(repr=False, default_factory=lambda: np.ones(0, dtype=bool))

    def __post_init__(self) -> None:
        if self.kind not in MEASUREMENT_KINDS:
            raise RobotsValueError(
                f"measurement kind must be one of {list(MEASUREMENT_KINDS)}, got {self.kind!r}"
            )
        if not (math.isfinite(self.window_s) and self.window_s >= 0):
            raise RobotsValueError(f"measurement window_s must be >= 0 s, got {self.window_s!r}")
        fresh = np.array(self.fresh, dtype=bool)
        if fresh.size:
            fresh[0] = True  # the first sample is always a reading
        fresh.setflags(write=False)
        object.__setattr__(self, "fresh", fresh)

    def sliced(self, keep: slice | NDArray[np.bool_]) -> MeasurementModel:
        """The model of the samples ``keep`` picks (a crop of the log)."""
        return MeasurementModel(
            kind=self.kind,
            window_s=self.window_s,
            update_period_s=self.update_period_s,
            fresh=self.fresh[keep],
        )

    def describe(self) -> dict[str, float | str]:
        """The operator in a params file: kind, update period and (pose) window, s."""
        out: dict[str, float | str] = {
            "kind": self.kind,
            "update_period_s": round(self.update_period_s, 4),
        }
        if self.kind == "pose":
            out["window_s"] = round(self.window_s, 4)
        return out

    def sentence(self) -> str:
        """One sentence naming the operator applied to the simulated velocity."""
        if self.kind == "pose":
            return (
                f"the measured velocities are a centred pose derivative over {self.window_s:.2f}"
                f" s windows (pose updates every {self.update_period_s:.3f} s), so the simulated"
                " ones are read through the same derivative"
            )
        return (
            "the measured velocities are held between readings (a zero-order hold, updates "
            f"every {self.update_period_s:.3f} s), so the simulated ones are read at the "
            "readings and held alike"
        )

    def operator(self, meas_t_s: FloatArray) -> ReadOperator:
        """The operator on the log's measurement times ``meas_t_s`` (s): the measured
        velocities of a model velocity ``u`` are ``op.apply(u(op.t_query))``."""
        t = np.asarray(meas_t_s, dtype=np.float64)
        if t.size != self.fresh.size:
            raise RobotsValueError(
                f"the measurement model has {self.fresh.size} samples but the log has {t.size}; "
                "slice the model with the log (MeasurementModel.sliced)"
            )
        if self.kind == "hold":
            return _hold_operator(t, self.fresh)
        fresh = np.asarray(self.fresh, dtype=bool)
        return _shared_pose_operator(t.tobytes(), fresh.tobytes(), float(self.window_s))


def pose_model(t_s: FloatArray, changed: BoolArray, window_s: float) -> MeasurementModel:
    """The ``"pose"`` model: a local-linear derivative over ``window_s`` (s) on the fresh
    readings of a pose that changes at the samples ``changed`` (times ``t_s``, s)."""
    fresh, period = fresh_readings(np.asarray(t_s, dtype=np.float64), changed)
    return MeasurementModel(
        kind="pose", window_s=float(window_s), update_period_s=period, fresh=fresh
    )


def hold_model(t_s: FloatArray, v: FloatArray, w: FloatArray) -> MeasurementModel | None:
    """The ``"hold"`` model when (v, w) repeats exactly in more than :data:`HOLD_SHARE` of the
    samples where the robot moves (at least 20 of them), else None.

    Examples
    --------
    >>> t = np.arange(0.0, 10.0, 0.05)
    >>> v = np.repeat(np.linspace(0.1, 1.0, 50), 4)  # a new value every fourth sample
    >>> hold_model(t, v, 0 * v).kind
    'hold'
    >>> hold_model(t, t, 0 * t) is None
    True
    """
    v = np.asarray(v, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    if v.size < 2:
        return None
    changed = np.ones(v.size, dtype=bool)
    changed[1:] = (np.diff(v) != 0) | (np.diff(w) != 0)
    moving = (np.abs(v) > _MOVING_V) | (np.abs(w) > _MOVING_W)
    n = int(np.count_nonzero(moving))
    if n < _MIN_MOVING or np.count_nonzero(~changed & moving) <= HOLD_SHARE * n:
        return None
    fresh, period = fresh_readings(np.asarray(t_s, dtype=np.float64), changed)
    return MeasurementModel(kind="hold", update_period_s=period, fresh=fresh)


@dataclass(frozen=True, kw_only=True)
class ReadOperator:
    """A measurement operator on one log: read the model at ``t_query``, then :meth:`apply`.

    Attributes
    ----------
    t_query : ndarray
        Query times, s (sorted, unique).
    """

    t_query: FloatArray
    _hold: NDArray[np.intp] | None = None
    _pose: _PoseParts | None = None

    def apply(self, u: FloatArray) -> FloatArray:
        """The measured velocities, shape ``(..., samples)``, of model velocities ``u`` read at
        :attr:`t_query` (shape ``(..., queries)``)."""
        u = np.asarray(u, dtype=np.float64)
        if self._pose is None:
            held: FloatArray = u[..., self._hold]
            return held
        p = self._pose
        integrals = (u[..., p.inv] @ _SIMPSON) * p.h  # (..., intervals)
        slopes = (integrals[..., p.cols] * p.weights).sum(axis=-1)  # (..., fresh)
        out: FloatArray = slopes[..., p.j] * (1.0 - p.f) + slopes[..., p.j + 1] * p.f
        return out


@dataclass(frozen=True)
class _PoseParts:
    """The pose operator's pieces: Simpson query indices per interval ``inv`` and interval
    lengths ``h``; padded slope weights ``cols``/``weights``; interpolation ``j``, ``f``."""

    inv: NDArray[np.intp]
    h: FloatArray
    cols: NDArray[np.intp]
    weights: FloatArray
    j: NDArray[np.intp]
    f: FloatArray


def _simpson_weights() -> FloatArray:
    """Composite Simpson weights over one interval of unit length, :data:`_PANELS` panels."""
    w = np.ones(2 * _PANELS + 1)
    w[1:-1:2], w[2:-1:2] = 4.0, 2.0
    out: FloatArray = w / (3.0 * 2 * _PANELS)
    return out


_SIMPSON = _simpson_weights()


def _hold_operator(t: FloatArray, fresh: BoolArray) -> ReadOperator:
    """Each sample reads the model at its last fresh reading."""
    return ReadOperator(t_query=t[fresh], _hold=np.cumsum(fresh) - 1)


@functools.lru_cache(maxsize=16)
def _shared_pose_operator(t_bytes: bytes, fresh_bytes: bytes, window_s: float) -> ReadOperator:
    """:func:`_pose_operator` of the times and fresh flags in these bytes, built once per log:
    an ensemble or a calibration replays one log thousands of times through the same operator
    (its slope weights are a loop over the pose updates). Its arrays are read only."""
    t = np.frombuffer(t_bytes, dtype=np.float64)
    op = _pose_operator(t, np.frombuffer(fresh_bytes, dtype=bool), window_s)
    arrays = [op.t_query, op._hold]
    if op._pose is not None:
        arrays += [getattr(op._pose, name) for name in ("inv", "h", "cols", "weights", "j", "f")]
    for array in arrays:
        if array is not None:
            array.flags.writeable = False
    return op


def _pose_operator(t: FloatArray, fresh: BoolArray, window_s: float) -> ReadOperator:
    """Local-linear slopes of the model's path over ``window_s`` at the fresh samples,
    interpolated at every sample (see the module docstring)."""
    tk = t[fresh]
    if tk.size < 2:  # no interval: a single reading has no slope
        return ReadOperator(t_query=tk, _hold=np.zeros(t.size, dtype=np.intp))
    h = np.diff(tk)
    pts = tk[:-1, None] + h[:, None] * np.linspace(0.0, 1.0, _SIMPSON.size)[None, :]
    tq, inv = np.unique(pts.ravel(), return_inverse=True)
    cols, weights = _slope_weights(tk, 0.5 * window_s)
    j = np.clip(np.searchsorted(tk, t, "right") - 1, 0, tk.size - 2)
    f = np.clip((t - tk[j]) / (tk[j + 1] - tk[j]), 0.0, 1.0)
    parts = _PoseParts(inv=inv.reshape(pts.shape), h=h, cols=cols, weights=weights, j=j, f=f)
    return ReadOperator(t_query=tq, _pose=parts)


def _slope_weights(tk: FloatArray, half: float) -> tuple[NDArray[np.intp], FloatArray]:
    """Padded ``(cols, weights)``, shape ``(fresh, L)``: the slope at ``tk[k]`` is
    ``sum(weights[k] * I[cols[k]])`` for the interval integrals ``I_i`` of the path
    (``x_j = sum_{i<j} I_i``; the local-linear weights ``c_kj`` sum to zero, so the weight of
    ``I_i`` is ``-sum_{j <= i} c_kj`` within the window)."""
    nk = tk.size
    lo = np.searchsorted(tk, tk - half, "left")
    hi = np.searchsorted(tk, tk + half, "right")
    width = max(int(np.max(hi - lo)) - 1, 1)
    cols = np.zeros((nk, width), dtype=np.intp)
    weights = np.zeros((nk, width))
    for k in range(nk):
        a, b = int(lo[k]), int(hi[k])
        n = b - a
        tc = tk[a:b] - tk[k]
        den = n * float(tc @ tc) - float(tc.sum()) ** 2
        if n < 2 or den <= 1e-12 * n * n:
            continue  # one sample has no slope
        c = (n * tc - tc.sum()) / den
        cols[k, : n - 1] = np.arange(a, b - 1)
        weights[k, : n - 1] = -np.cumsum(c)[:-1]
    return cols, weights
