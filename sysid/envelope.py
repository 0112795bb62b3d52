"""The envelope a fit saw: how fast, how sharply and how far its logs drove the robot.

A drive model is fitted where its logs drove the robot; elsewhere it extrapolates. The
:class:`Envelope` of the fitting logs (``sysid fit`` writes it into the params file) holds,
over their active samples, the largest magnitude of the measured velocities after a running
median over 5 samples (which keeps every step and drops odometry spikes of one or two
samples), of

- forward speed ``|v|`` (m/s) and yaw rate ``|w|`` (rad/s),
- turning while driving ``|v w|`` (m rad/s^2; zero for a log that only spins in place or
  only drives straight),
- forward and yaw accelerations ``|dv/dt|`` (m/s^2) and ``|dw/dt|`` (rad/s^2), the
  velocity change over 0.2 s (longer than one odometry period, so quantisation and jitter
  do not pose as acceleration).

:func:`check_envelope` measures a checked log the same way and says, for each quantity, how
far beyond the envelope it goes (its own largest magnitude), for what share of its active
samples, and which drive parameters that leaves uncertain. A sample is outside when it
exceeds the envelope by 10 % plus a floor (the agreement tolerance of that quantity), so the
noise of two recordings of the same driving does not count.

Examples
--------
>>> import numpy as np
>>> from sysid import LogArrays
>>> t = np.arange(0, 20, 0.05)
>>> fit = LogArrays(cmd_t_s=t, cmd_v=np.full(t.size, 0.2), cmd_w=np.zeros(t.size),
...                 meas_t_s=t, meas_v=np.full(t.size, 0.2), meas_w=np.zeros(t.size))
>>> env = envelope_of([fit])
>>> round(env.v_mps, 2), env.vw
(0.2, 0.0)
>>> arc = LogArrays(cmd_t_s=t, cmd_v=np.full(t.size, 0.2), cmd_w=np.full(t.size, 0.8),
...                 meas_t_s=t, meas_v=np.full(t.size, 0.2), meas_w=np.full(t.size, 0.8))
>>> check = check_envelope(env, arc)
>>> round(check.share_outside, 2), check.sentence.split(":")[0]
(1.0, 'this log leaves the envelope the fit saw for 100.0 % of its active samples')
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from robots.arrays import FloatArray
from sysid._excitation import active_samples
from sysid._logs import as_log_arrays
from sysid.metrics import DEFAULT_TOL_V, DEFAULT_TOL_W

__all__ = [
    "ACCEL_WINDOW_S",
    "QUANTITIES",
    "Envelope",
    "EnvelopeCheck",
    "Excess",
    "check_envelope",
    "envelope_of",
    "unknown_envelope",
]


#: Velocity change window of the accelerations, s.
ACCEL_WINDOW_S = 0.2
#: Samples of the running median that the velocities go through (spikes do not count).
MEDIAN_SAMPLES = 5
#: A checked sample is outside when it exceeds the envelope by this factor plus the floor.
MARGIN = 1.1

#: ``(field, what it is, unit, floor, parameters it leaves uncertain)`` per quantity.
QUANTITIES: tuple[tuple[str, str, str, float, tuple[str, ...]], ...] = (
    (
        "v_mps",
        "|v|",
        "m/s",
        DEFAULT_TOL_V,
        ("speed_lim_v_mps", "wheel_speed_max_radps", "viscous_v_ns_per_m"),
    ),
    (
        "w_radps",
        "|w|",
        "rad/s",
        DEFAULT_TOL_W,
        ("speed_lim_w_radps", "wheel_speed_max_radps", "viscous_w_nms_per_rad"),
    ),
    (
        "vw",
        "|v w| (turning while driving)",
        "m rad/s^2",
        DEFAULT_TOL_V * 0.5,
        ("wheel_speed_max_radps", "track_factor", "driver_track_factor"),
    ),
    (
        "dv_mps2",
        "|dv/dt|",
        "m/s^2",
        0.5,
        ("accel_lim_v_mps2", "wheel_torque_max_nm", "added_mass_kg"),
    ),
    (
        "dw_radps2",
        "|dw/dt|",
        "rad/s^2",
        2.5,
        ("accel_lim_w_radps2", "wheel_torque_max_nm", "added_yaw_inertia_kgm2"),
    ),
)


@dataclass(frozen=True, kw_only=True)
class Envelope:
    """The largest magnitudes of the fitting logs' motion over their active samples.

    Attributes
    ----------
    v_mps, w_radps : float
        Forward speed (m/s) and yaw rate (rad/s) magnitudes.
    vw : float
        Turning while driving, ``|v w|`` (m rad/s^2).
    dv_mps2, dw_radps2 : float
        Forward (m/s^2) and yaw (rad/s^2) acceleration magnitudes.
    """

    v_mps: float
    w_radps: float
    vw: float
    dv_mps2: float
    dw_radps2: float

    def to_dict(self) -> dict[str, float]:
        """The ``envelope`` block of a params file (rounded to 4 significant digits)."""
        return {k: float(f"{v:.4g}") for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> Envelope | None:
        """The envelope of a params file's block, or None when it is absent or incomplete."""
        try:
            values = {q[0]: float(doc[q[0]]) for q in QUANTITIES}
        except (KeyError, TypeError, ValueError):
            return None
        if not all(math.isfinite(v) and v >= 0 for v in values.values()):
            return None
        return cls(**values)


@dataclass(frozen=True, kw_only=True)
class Excess:
    """How far a checked log goes beyond one quantity of the envelope.

    Attributes
    ----------
    quantity, label, unit : str
        The :class:`Envelope` field, what it measures and its unit.
    fitted, checked : float
        The envelope's value and the checked log's largest magnitude.
    share : float
        Share of the checked log's active samples beyond the envelope (0..1).
    parameters : tuple of str
        Drive parameters this extrapolation leaves uncertain.
    """

    quantity: str
    label: str
    unit: str
    fitted: float
    checked: float
    share: float
    parameters: tuple[str, ...]


@dataclass(frozen=True, kw_only=True)
class EnvelopeCheck:
    """A checked log against the envelope of a fit.

    Attributes
    ----------
    known : bool
        False when the params file holds no envelope (then nothing else is known).
    share_outside : float
        Share of the active samples beyond the envelope on any quantity (0..1).
    excesses : tuple of Excess
        The quantities the log leaves, largest share first.
    uncertain : tuple of str
        The drive parameters those excursions leave uncertain.
    sentence : str
        One sentence saying all that ("" when the log stays inside).
    """

    known: bool
    share_outside: float
    excesses: tuple[Excess, ...]
    uncertain: tuple[str, ...]
    sentence: str


def _running_median(x: FloatArray) -> FloatArray:
    """Running median over :data:`MEDIAN_SAMPLES` samples (edges padded with the end values)."""
    k = MEDIAN_SAMPLES // 2
    if x.size <= 2 * k:
        return x
    padded = np.concatenate((np.full(k, x[0]), x, np.full(k, x[-1])))
    windows = np.lib.stride_tricks.sliding_window_view(padded, MEDIAN_SAMPLES)
    return np.asarray(np.median(windows, axis=1), dtype=np.float64)


def _motion(log: Any, tol_v: float, tol_w: float) -> tuple[dict[str, FloatArray], FloatArray]:
    """Each quantity's magnitude at the active samples of ``log``, and their times."""
    g = as_log_arrays(log)
    active = active_samples(g, tol_v=tol_v, tol_w=tol_w)
    t, v, w = g.meas_t_s, _running_median(g.meas_v), _running_median(g.meas_w)
    earlier = np.clip(t - ACCEL_WINDOW_S, t[0], None)
    span = np.maximum(t - earlier, 1e-9)
    dv = (v - np.interp(earlier, t, v)) / span
    dw = (w - np.interp(earlier, t, w)) / span
    short = t - t[0] < 0.5 * ACCEL_WINDOW_S  # no window behind these yet
    dv[short], dw[short] = 0.0, 0.0
    values = {"v_mps": v, "w_radps": w, "vw": v * w, "dv_mps2": dv, "dw_radps2": dw}
    return {k: np.abs(x[active]) for k, x in values.items()}, t[active]


def envelope_of(
    logs: Sequence[Any], *, tol_v: float = DEFAULT_TOL_V, tol_w: float = DEFAULT_TOL_W
) -> Envelope:
    """The envelope of ``logs`` (velocity logs, e.g. the fitting logs of ``sysid fit``)."""
    parts = [_motion(g, tol_v, tol_w)[0] for g in logs]
    out = {}
    for name, *_ in QUANTITIES:
        x = np.concatenate([p[name] for p in parts]) if parts else np.zeros(0)
        out[name] = float(x.max()) if x.size else 0.0
    return Envelope(**out)


def unknown_envelope(params_file: str) -> EnvelopeCheck:
    """The check of a params file without an ``envelope`` block (an older ``sysid fit``)."""
    return EnvelopeCheck(
        known=False,
        share_outside=math.nan,
        excesses=(),
        uncertain=(),
        sentence=(
            f"the envelope the fit saw is unknown (params file '{params_file}' has no "
            "'envelope' block; refit with 'sim2real sysid fit' to record it), so nothing says "
            "whether this log drives where the fit never did"
        ),
    )


def check_envelope(
    envelope: Envelope,
    log: Any,
    *,
    tol_v: float = DEFAULT_TOL_V,
    tol_w: float = DEFAULT_TOL_W,
) -> EnvelopeCheck:
    """Where ``log`` leaves ``envelope``: by how much, for what share, what it leaves open."""
    values, _ = _motion(log, tol_v, tol_w)
    n = next(iter(values.values())).size
    outside_any = np.zeros(n, dtype=bool)
    excesses = []
    for name, label, unit, floor, params in QUANTITIES:
        x = values[name]
        limit = MARGIN * getattr(envelope, name) + floor
        outside = x > limit
        outside_any |= outside
        if outside.any():
            excesses.append(
                Excess(
                    quantity=name,
                    label=label,
                    unit=unit,
                    fitted=getattr(envelope, name),
                    checked=float(x.max()),
                    share=float(outside.mean()),
                    parameters=params,
                )
            )
    excesses.sort(key=lambda e: -e.share)
    share = float(outside_any.mean()) if n else 0.0
    uncertain = tuple(dict.fromkeys(p for e in excesses for p in e.parameters))
    return EnvelopeCheck(
        known=True,
        share_outside=share,
        excesses=tuple(excesses),
        uncertain=uncertain,
        sentence=_sentence(share, excesses, uncertain),
    )


def _sentence(share: float, excesses: Sequence[Excess], uncertain: Sequence[str]) -> str:
    if not excesses:
        return ""
    parts = [
        f"{e.label} up to {e.checked:.3g} {e.unit} where the fit saw {e.fitted:.3g} "
        f"({100 * e.share:.1f} % of the samples)"
        for e in excesses
    ]
    return (
        f"this log leaves the envelope the fit saw for {100 * share:.1f} % of its active "
        f"samples: {'; '.join(parts)}; that leaves {', '.join(uncertain)} uncertain"
    )
