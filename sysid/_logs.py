"""Velocity logs as sysid sees them: a structural protocol, a plain container, checks, crops."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from robots.arrays import FloatArray
from robots.measurement import MeasurementModel
from sysid.errors import SysidValueError

__all__ = [
    "LogArrays",
    "VelocityLog",
    "as_log_arrays",
    "crop_log",
    "log_name",
    "log_sha256",
    "log_warnings",
]


_FIELDS = ("cmd_t_s", "cmd_v", "cmd_w", "meas_t_s", "meas_v", "meas_w")


@runtime_checkable
class VelocityLog(Protocol):
    """What sysid needs from a log (``sim2real.logs.Trace`` satisfies it structurally).

    Attributes
    ----------
    cmd_t_s, cmd_v, cmd_w : ndarray
        Command times (s, sorted), commanded forward (m/s) and yaw (rad/s) velocity.
    meas_t_s, meas_v, meas_w : ndarray
        Measurement times (s, same clock), measured forward (m/s) and yaw (rad/s) velocity.
    """

    cmd_t_s: FloatArray
    cmd_v: FloatArray
    cmd_w: FloatArray
    meas_t_s: FloatArray
    meas_v: FloatArray
    meas_w: FloatArray


@dataclass(frozen=True, kw_only=True)
class LogArrays:
    """A checked, plain-array velocity log (satisfies :class:`VelocityLog`).

    ``name`` and ``sha256`` identify the source file in result files (may be empty/None);
    ``measurement`` is how the measured velocities are made from the robot's
    (:mod:`robots.measurement`; None: as they are).

    Examples
    --------
    >>> import numpy as np
    >>> log = LogArrays(cmd_t_s=np.array([0.0]), cmd_v=np.array([0.1]), cmd_w=np.array([0.0]),
    ...                 meas_t_s=np.array([0.0, 0.1]), meas_v=np.zeros(2), meas_w=np.zeros(2))
    >>> isinstance(log, VelocityLog)
    True
    """

    cmd_t_s: FloatArray
    cmd_v: FloatArray
    cmd_w: FloatArray
    meas_t_s: FloatArray
    meas_v: FloatArray
    meas_w: FloatArray
    name: str = ""
    sha256: str | None = None
    measurement: MeasurementModel | None = None


def log_name(log: object, index: int) -> str:
    """A human name for ``log``: its file path when known, else ``log #index``."""
    meta = getattr(log, "meta", None)
    path = getattr(meta, "path", None) if meta is not None else None
    name = getattr(log, "name", None)
    if path:
        return str(path)
    if isinstance(name, str) and name:
        return name
    return f"log #{index}"


def log_sha256(log: object) -> str | None:
    """The sha256 of the log's source file when the log carries one."""
    meta = getattr(log, "meta", None)
    sha = getattr(meta, "sha256", None) if meta is not None else getattr(log, "sha256", None)
    return str(sha) if sha else None


def log_warnings(log: object) -> tuple[str, ...]:
    """Warnings the log reader attached to the log (``meta.warnings``), if any."""
    meta = getattr(log, "meta", None)
    found = getattr(meta, "warnings", ()) if meta is not None else ()
    return tuple(str(w) for w in found) if isinstance(found, tuple | list) else ()


def as_log_arrays(log: object, index: int = 0) -> LogArrays:
    """Check a :class:`VelocityLog` and copy it into float64 :class:`LogArrays`.

    Raises :class:`~sysid.errors.SysidValueError` for missing attributes, length mismatches,
    NaN/inf values, unsorted times or empty arrays.
    """
    name = log_name(log, index)
    arrays: dict[str, FloatArray] = {}
    for field in _FIELDS:
        if not hasattr(log, field):
            raise SysidValueError(
                f"{name} has no attribute '{field}'; a sysid log needs {list(_FIELDS)} "
                "(e.g. a sim2real.logs.Trace)"
            )
        arr = np.asarray(getattr(log, field), dtype=np.float64)
        if arr.ndim != 1:
            raise SysidValueError(f"{name}: '{field}' must be 1-D, got shape {arr.shape}")
        bad = ~np.isfinite(arr)
        if np.any(bad):
            raise SysidValueError(
                f"{name}: '{field}' holds {int(bad.sum())} NaN/inf value(s) (first at index "
                f"{int(np.argmax(bad))}); drop or repair those samples before fitting"
            )
        arrays[field] = arr
    for prefix, keys in (("cmd", ("cmd_v", "cmd_w")), ("meas", ("meas_v", "meas_w"))):
        t = arrays[f"{prefix}_t_s"]
        if t.size == 0:
            raise SysidValueError(f"{name} has no {prefix} samples; sysid needs both topics")
        for key in keys:
            if arrays[key].shape != t.shape:
                raise SysidValueError(
                    f"{name}: '{key}' has {arrays[key].size} samples but '{prefix}_t_s' has "
                    f"{t.size}; they must match"
                )
        if np.any(np.diff(t) < 0):
            raise SysidValueError(
                f"{name}: '{prefix}_t_s' is not sorted in time; sort the samples first"
            )
    model = getattr(log, "measurement", None)
    if model is not None and model.fresh.size != arrays["meas_t_s"].size:
        raise SysidValueError(
            f"{name}: its measurement model has {model.fresh.size} samples but the log has "
            f"{arrays['meas_t_s'].size}; slice the model with the log"
        )
    return LogArrays(**arrays, name=name, sha256=log_sha256(log), measurement=model)


def crop_log(log: object, start_s: float, end_s: float, *, lead_s: float = 2.0) -> LogArrays:
    """The part of ``log`` with measurements in ``[start_s, end_s)`` (s, the log's clock).

    Commands from ``lead_s`` before ``start_s`` are kept so the delayed command is right at the
    window start. Use it to fit on one part of a log and validate on another.

    Examples
    --------
    >>> import numpy as np
    >>> log = LogArrays(cmd_t_s=np.arange(10.0), cmd_v=np.ones(10), cmd_w=np.zeros(10),
    ...                 meas_t_s=np.arange(10.0), meas_v=np.ones(10), meas_w=np.zeros(10))
    >>> crop_log(log, 2.0, 5.0).meas_t_s
    array([2., 3., 4.])
    """
    full = as_log_arrays(log)
    if not (math.isfinite(start_s) and math.isfinite(end_s) and end_s > start_s):
        raise SysidValueError(
            f"window {start_s}:{end_s} of {full.name} is empty or not finite; give START:END "
            "in seconds with END > START"
        )
    m = (full.meas_t_s >= start_s) & (full.meas_t_s < end_s)
    c = (full.cmd_t_s >= start_s - lead_s) & (full.cmd_t_s < end_s)
    if not np.any(m):
        span = f"{full.meas_t_s[0]:.2f}..{full.meas_t_s[-1]:.2f} s"
        raise SysidValueError(
            f"window {start_s:g}:{end_s:g} s of {full.name} holds no measurement (the log spans "
            f"{span}); choose a window inside the log"
        )
    # keep the command held at the window start even when it was sent long before
    before = np.flatnonzero(full.cmd_t_s < start_s - lead_s)
    if before.size:
        c[before[-1]] = True
    kept = {f: getattr(full, f)[c if f.startswith("cmd") else m] for f in _FIELDS}
    return LogArrays(
        **kept,
        name=f"{full.name}[{start_s:g}:{end_s:g}]",
        sha256=full.sha256,
        measurement=None if full.measurement is None else full.measurement.sliced(m),
    )
