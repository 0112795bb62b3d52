"""The :class:`Trace` of a velocity log: commands and measured velocities as numpy arrays.

Times are integer nanoseconds (``int64``) so no precision is lost on epoch stamps; the
``*_t_s`` views are float64 seconds since :attr:`Trace.t0_ns`.

Examples
--------
>>> import numpy as np
>>> tr = Trace(
...     cmd_t_ns=np.array([0, 100_000_000]), cmd_v=np.array([0.2, 0.0]), cmd_w=np.zeros(2),
...     meas_t_ns=np.array([50_000_000, 150_000_000]), meas_v=np.array([0.1, 0.2]),
...     meas_w=np.zeros(2), meta=TraceMeta(path="x.mcap"),
... )
>>> tr.cmd_at_meas()[0]
array([0.2, 0. ])
"""

from __future__ import annotations

from collections.abc import Mapping
from contextvars import ContextVar
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from robots.measurement import MeasurementModel, hold_model, pose_model
from robots.units import nanoseconds, seconds
from sim2real.errors import LogValueError, Sim2RealValueError
from sim2real.logs._digest import LazyText, lazy_value
from sim2real.logs._pose_velocity import pose_changes
from sim2real.logs._timeline import command_windows, segment_bounds

__all__ = ["ABSURD_FACTOR", "MIN_MEAS_SAMPLES", "Trace", "TraceMeta"]

#: Velocities beyond this many times the robot's spec limits are physically absurd.
ABSURD_FACTOR = 10.0
#: Fewer measurement samples than this cannot be fitted or compared.
MIN_MEAS_SAMPLES = 10


@dataclass(frozen=True, kw_only=True)
class TraceMeta:
    """Where a :class:`Trace` came from and how it was read.

    Attributes
    ----------
    path : str
        The log file ("" for a trace built in memory); a segment made by
        :meth:`Trace.segments` is named ``"<file> (segment k/n)"``.
    sha256 : str
        Hex SHA-256 of the file bytes, computed on first access (reading a log does not hash
        it; only what writes the digest pays for it). May be given as a str or as a
        zero-argument callable returning it.
    cmd_topic, cmd_type, meas_topic, meas_type : str
        Topics used for commands and measurements and their ROS 2 message types.
    cmd_count, meas_count : int
        Samples kept after cleaning (NaN drop, de-duplication).
    cmd_rate_hz, meas_rate_hz : float
        Mean sample rates, ``(n - 1) / (t_last - t_first)`` (0 with fewer than 2 samples).
    time_source : str
        The requested time base, ``"header"``, ``"log"`` or ``"auto"``.
    cmd_time_source, meas_time_source : str
        What each stream really uses (a ``Twist`` has no header, so always ``"log"``).
    time_note : str
        With ``time_source="auto"``: one sentence saying which time base was chosen and why.
    segment : str
        ``"k/n"`` for the k-th of n segments made by :meth:`Trace.segments`, else "".
    encoding : str
        Message encoding of the measurement channel (``"cdr"`` or ``"json"``).
    warnings : tuple of str
        Repairs made while reading (dropped NaN samples, re-sorted or duplicate stamps, ...).
    pose_window_s : float
        When the measured velocities were derived from the odometry pose: the centred window of
        the derivative, s (0 when they are the odometry's own); see :attr:`Trace.measurement`.
    """

    path: str = ""
    sha256: LazyText = LazyText()  # noqa: RUF009 (a descriptor, see _digest)
    cmd_topic: str = ""
    cmd_type: str = ""
    meas_topic: str = ""
    meas_type: str = ""
    cmd_count: int = 0
    meas_count: int = 0
    cmd_rate_hz: float = 0.0
    meas_rate_hz: float = 0.0
    time_source: str = "header"
    cmd_time_source: str = "log"
    meas_time_source: str = "header"
    encoding: str = "cdr"
    warnings: tuple[str, ...] = field(default_factory=tuple)
    time_note: str = ""
    segment: str = ""
    pose_window_s: float = 0.0


def _meta_replace(meta: TraceMeta, **changes: object) -> TraceMeta:
    """``dataclasses.replace`` that keeps a not yet computed digest lazy."""
    return replace(meta, sha256=lazy_value(meta, "sha256"), **changes)  # type: ignore[arg-type]


#: True while :func:`adopt_trace` builds a Trace: arrays that own their data are kept as they are.
_ADOPT: ContextVar[bool] = ContextVar("_ADOPT", default=False)


def adopt_trace(**fields: object) -> Trace:
    """A :class:`Trace` that takes over the given arrays instead of copying them (private).

    For a reader handing over arrays nothing else refers to: each array that owns its data,
    is 1-D and already has the field's dtype is made read-only and kept (no second copy of
    the output at its peak); any other value is copied as :class:`Trace` always does.
    """
    token = _ADOPT.set(True)
    try:
        return Trace(**fields)  # type: ignore[arg-type]
    finally:
        _ADOPT.reset(token)


def trace_from_columns(
    cmd_t_ns: np.ndarray,
    cmd_cols: Mapping[str, np.ndarray],
    meas_t_ns: np.ndarray,
    meas_cols: Mapping[str, np.ndarray],
    **meta: Any,
) -> Trace:
    """A log reader's :class:`Trace`, taking over its arrays as :func:`adopt_trace` does (private).

    Commands ``cmd_cols["v"]``, ``cmd_cols["w"]`` at ``cmd_t_ns``; measurements
    ``meas_cols["v"]``, ``meas_cols["w"]`` and the pose ``"x"``, ``"y"``, ``"yaw"`` when present,
    at ``meas_t_ns``. The :class:`TraceMeta` counts and mean rates come from the times, its
    other fields from ``meta``.
    """
    return adopt_trace(
        cmd_t_ns=cmd_t_ns,
        cmd_v=cmd_cols["v"],
        cmd_w=cmd_cols["w"],
        meas_t_ns=meas_t_ns,
        meas_v=meas_cols["v"],
        meas_w=meas_cols["w"],
        pose_x=meas_cols.get("x"),
        pose_y=meas_cols.get("y"),
        pose_yaw=meas_cols.get("yaw"),
        meta=TraceMeta(
            cmd_count=int(cmd_t_ns.size),
            meas_count=int(meas_t_ns.size),
            cmd_rate_hz=_mean_rate_hz(cmd_t_ns),
            meas_rate_hz=_mean_rate_hz(meas_t_ns),
            **meta,
        ),
    )


def _mean_rate_hz(t_ns: np.ndarray) -> float:
    """Mean rate of sorted times in ns, ``(n - 1) / (t_last - t_first)`` (0 with < 2 samples)."""
    if t_ns.size < 2 or t_ns[-1] == t_ns[0]:
        return 0.0
    return float((t_ns.size - 1) / seconds(t_ns[-1] - t_ns[0]))


def _frozen(a: np.ndarray | None, dtype: type, name: str) -> np.ndarray | None:
    if a is None:
        return None
    if (
        _ADOPT.get()
        and isinstance(a, np.ndarray)
        and a.dtype == dtype
        and a.ndim == 1
        and a.base is None
        and a.flags.owndata
    ):
        a.setflags(write=False)
        return a
    raw = np.asarray(a)
    if dtype is np.int64 and raw.dtype.kind == "f" and not np.all(np.mod(raw, 1) == 0):
        raise Sim2RealValueError(
            f"Trace field {name} must hold integer nanoseconds, got fractional values such as "
            f"{raw.ravel()[np.argmax(np.mod(raw.ravel(), 1) != 0)]}; convert seconds with "
            "robots.units.nanoseconds(t_s)"
        )
    arr: np.ndarray = np.array(raw, dtype=dtype)  # always a private copy
    if arr.ndim != 1:
        raise Sim2RealValueError(f"Trace field {name} must be 1-D, got shape {arr.shape}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, kw_only=True)
class Trace:
    """Commanded and measured planar velocities of one log.

    Attributes
    ----------
    cmd_t_ns : ndarray of int64
        Command times (ns, sorted, unique).
    cmd_v, cmd_w : ndarray of float64
        Commanded forward speed (m/s) and yaw rate (rad/s).
    meas_t_ns : ndarray of int64
        Measurement times (ns, sorted, unique).
    meas_v, meas_w : ndarray of float64
        Measured forward speed (m/s) and yaw rate (rad/s).
    pose_x, pose_y, pose_yaw : ndarray of float64 or None
        Odometry pose at the measurement times (m, m, rad); None when the source has no pose.
    meta : TraceMeta
        Provenance and the warnings raised while reading.

    Arrays are copied and made read-only on construction.
    """

    cmd_t_ns: np.ndarray
    cmd_v: np.ndarray
    cmd_w: np.ndarray
    meas_t_ns: np.ndarray
    meas_v: np.ndarray
    meas_w: np.ndarray
    pose_x: np.ndarray | None = None
    pose_y: np.ndarray | None = None
    pose_yaw: np.ndarray | None = None
    meta: TraceMeta = field(default_factory=TraceMeta)

    def __post_init__(self) -> None:
        for name in ("cmd_t_ns", "meas_t_ns"):
            object.__setattr__(self, name, _frozen(getattr(self, name), np.int64, name))
        for name in ("cmd_v", "cmd_w", "meas_v", "meas_w", "pose_x", "pose_y", "pose_yaw"):
            object.__setattr__(self, name, _frozen(getattr(self, name), np.float64, name))
        self._check_lengths()

    def _check_lengths(self) -> None:
        n_cmd, n_meas = self.cmd_t_ns.size, self.meas_t_ns.size
        for name, n in (("cmd_v", n_cmd), ("cmd_w", n_cmd), ("meas_v", n_meas), ("meas_w", n_meas)):
            if getattr(self, name).size != n:
                raise Sim2RealValueError(
                    f"Trace field {name} has {getattr(self, name).size} samples but its time "
                    f"array has {n}; give arrays of equal length"
                )
        poses = [self.pose_x, self.pose_y, self.pose_yaw]
        if any(p is not None for p in poses) and not all(
            p is not None and p.size == n_meas for p in poses
        ):
            raise Sim2RealValueError(
                "Trace pose_x, pose_y and pose_yaw must all be given with one value per "
                "measurement, or all be None"
            )

    # ------------------------------------------------------------------------ time views
    @property
    def t0_ns(self) -> int:
        """Time origin: the earlier of the first command and the first measurement (ns)."""
        firsts = [int(a[0]) for a in (self.cmd_t_ns, self.meas_t_ns) if a.size]
        return min(firsts) if firsts else 0

    @property
    def cmd_t_s(self) -> np.ndarray:
        """Command times in seconds since :attr:`t0_ns` (float64)."""
        return seconds((self.cmd_t_ns - self.t0_ns).astype(np.float64))

    @property
    def meas_t_s(self) -> np.ndarray:
        """Measurement times in seconds since :attr:`t0_ns` (float64)."""
        return seconds((self.meas_t_ns - self.t0_ns).astype(np.float64))

    @property
    def duration_s(self) -> float:
        """Seconds from :attr:`t0_ns` to the last command or measurement."""
        lasts = [int(a[-1]) for a in (self.cmd_t_ns, self.meas_t_ns) if a.size]
        return seconds(max(lasts) - self.t0_ns) if lasts else 0.0

    @property
    def has_pose(self) -> bool:
        """True when the measurement source carried a pose."""
        return self.pose_x is not None

    @property
    def measurement(self) -> MeasurementModel | None:
        """How the measured velocities are made from the robot's (:mod:`robots.measurement`).

        ``"pose"`` when they were derived from the pose (:attr:`TraceMeta.pose_window_s`);
        ``"hold"`` when the readings repeat like a slow zero-order hold
        (:func:`robots.measurement.hold_model`); None when they are read as they are. A fit and
        a replay apply it to the simulated velocity.
        """
        if self.meta.pose_window_s > 0 and self.pose_x is not None:
            pose = (self.pose_x, self.pose_y, self.pose_yaw)
            return pose_model(self.meas_t_s, pose_changes(pose), self.meta.pose_window_s)  # type: ignore[arg-type]
        return hold_model(self.meas_t_s, self.meas_v, self.meas_w)

    # ------------------------------------------------------------------------ segments
    def segments(self) -> tuple[Trace, ...]:
        """The trace split at its measurement gaps (see :mod:`sim2real.logs`, "Gaps").

        A pause longer than ``max(2 s, 20 x the median odometry step)`` ends a segment; each
        segment keeps the commands on its side of the gap (within 60 s of its measurements).
        A trace without such a gap is returned whole, as ``(self,)``. The reader's warnings
        travel with the first segment only.

        Examples
        --------
        >>> tr = Trace(cmd_t_ns=[0], cmd_v=[0.1], cmd_w=[0.0],
        ...            meas_t_ns=[0, 10**8, 2 * 10**8, 10**12, 10**12 + 10**8],
        ...            meas_v=[0.0] * 5, meas_w=[0.0] * 5)
        >>> [s.meas_t_ns.size for s in tr.segments()]
        [3, 2]
        """
        bounds = segment_bounds(self.meas_t_ns)
        if len(bounds) <= 1:
            return (self,)
        cmds = command_windows(self.cmd_t_ns, self.meas_t_ns)
        n = len(bounds)
        return tuple(
            self._slice(slice(a, b), slice(c0, c1), segment=f"{k + 1}/{n}")
            for k, ((a, b), (c0, c1)) in enumerate(zip(bounds, cmds, strict=True))
        )

    def _slice(
        self,
        meas: slice | np.ndarray,
        cmd: slice | np.ndarray,
        *,
        segment: str | None = None,
    ) -> Trace:
        """The samples picked by ``meas``/``cmd`` (slices or boolean masks), counts updated."""
        pose = {
            k: (None if getattr(self, k) is None else getattr(self, k)[meas])
            for k in ("pose_x", "pose_y", "pose_yaw")
        }
        meta = _meta_replace(
            self.meta,
            cmd_count=int(self.cmd_t_ns[cmd].size),
            meas_count=int(self.meas_t_ns[meas].size),
        )
        if segment is not None:
            first = segment.startswith("1/")
            meta = _meta_replace(
                meta,
                segment=segment,
                path=f"{self.meta.path or 'trace'} (segment {segment})",
                warnings=self.meta.warnings if first else (),  # said once, not n times
            )
        return replace(
            self,
            cmd_t_ns=self.cmd_t_ns[cmd],
            cmd_v=self.cmd_v[cmd],
            cmd_w=self.cmd_w[cmd],
            meas_t_ns=self.meas_t_ns[meas],
            meas_v=self.meas_v[meas],
            meas_w=self.meas_w[meas],
            meta=meta,
            **pose,
        )

    # ------------------------------------------------------------------------ values
    def without_absurd(
        self, *, max_v_mps: float, max_w_radps: float, factor: float = ABSURD_FACTOR
    ) -> Trace:
        """Drop samples whose velocities exceed ``factor`` x the robot's limits, with a note.

        A sample (command or measurement) with ``|v| > factor * max_v_mps`` or
        ``|w| > factor * max_w_radps`` cannot come from the robot (a corrupt value, a wrong
        unit or another robot's log); it is dropped and ``meta.warnings`` says how many were.

        Raises
        ------
        LogValueError
            When more than half the samples of a stream are absurd (a unit or robot mistake,
            not a glitch) or fewer than 10 measurement samples remain.

        Examples
        --------
        >>> tr = Trace(cmd_t_ns=[0], cmd_v=[0.1], cmd_w=[0.0], meas_t_ns=list(range(12)),
        ...            meas_v=[0.1] * 11 + [4.5e306], meas_w=[0.0] * 12)
        >>> tr.without_absurd(max_v_mps=0.22, max_w_radps=2.84).meas_v.size
        11
        """
        lim_v, lim_w = factor * max_v_mps, factor * max_w_radps
        notes = list(self.meta.warnings)
        keep = {}
        for role, v, w in (
            ("command", self.cmd_v, self.cmd_w),
            ("measurement", self.meas_v, self.meas_w),
        ):
            ok = (np.abs(v) <= lim_v) & (np.abs(w) <= lim_w)
            bad = int(ok.size - np.count_nonzero(ok))
            if bad and 2 * bad > ok.size:
                raise LogValueError(self._absurd_message(role, bad, ok.size, lim_v, lim_w))
            if bad:
                notes.append(
                    f"dropped {bad} of {ok.size} {role} samples with |v| > {lim_v:.3g} m/s or "
                    f"|w| > {lim_w:.3g} rad/s ({factor:g}x the robot's limits: not physical)"
                )
            keep[role] = ok
        if all(np.all(k) for k in keep.values()):
            return self
        out = self._mask(keep["command"], keep["measurement"])
        out = replace(out, meta=_meta_replace(out.meta, warnings=tuple(notes)))
        out.check_enough()
        return out

    def _absurd_message(self, role: str, bad: int, n: int, lim_v: float, lim_w: float) -> str:
        where = self.meta.path or "the trace"
        topic = self.meta.cmd_topic if role == "command" else self.meta.meas_topic
        on = f" (topic '{topic}')" if topic else ""
        return (
            f"{bad} of {n} {role} samples of log file '{where}'{on} have |v| > {lim_v:.3g} m/s "
            f"or |w| > {lim_w:.3g} rad/s, 10x the robot's limits, so the values are in another "
            "unit or come from another robot; check --robot and the topic (--cmd-topic / "
            "--odom-topic)"
        )

    def _mask(self, cmd_keep: np.ndarray, meas_keep: np.ndarray) -> Trace:
        return self._slice(meas_keep, cmd_keep)

    def check_enough(self) -> None:
        """Raise :class:`~sim2real.errors.LogValueError` when too little data is left.

        A trace needs at least one command and 10 measurement samples to be replayed, fitted
        or compared.
        """
        where = self.meta.path or "the trace"
        if self.meas_t_ns.size < MIN_MEAS_SAMPLES:
            raise LogValueError(
                f"log file '{where}' has only {self.meas_t_ns.size} usable measurement samples "
                f"after cleaning (at least {MIN_MEAS_SAMPLES} are needed); see its warnings "
                "(`sim2real logs info`) and record a longer log or choose another --odom-topic"
            )
        if self.cmd_t_ns.size == 0:
            raise LogValueError(
                f"log file '{where}' has no usable command sample after cleaning; record the "
                "command topic or choose another one with --cmd-topic"
            )

    # ------------------------------------------------------------------------ operations
    def cmd_at_meas(self) -> tuple[np.ndarray, np.ndarray]:
        """Zero-order hold of the commands onto the measurement times.

        The value at a measurement time ``t`` is the last command with time ``<= t``; before
        the first command it is 0 (the robot is assumed idle).

        Returns
        -------
        v, w : ndarray of float64
            Held commanded speed (m/s) and yaw rate (rad/s), one per measurement.
        """
        idx = np.searchsorted(self.cmd_t_ns, self.meas_t_ns, side="right") - 1
        valid = idx >= 0
        safe = np.where(valid, idx, 0)
        if self.cmd_t_ns.size == 0:
            zeros = np.zeros(self.meas_t_ns.size)
            return zeros, zeros.copy()
        v = np.where(valid, self.cmd_v[safe], 0.0)
        w = np.where(valid, self.cmd_w[safe], 0.0)
        return v, w

    def window(self, start_s: float, end_s: float) -> Trace:
        """The part of the trace with times in ``[start_s, end_s)`` seconds since :attr:`t0_ns`.

        The command in force at ``start_s`` (the last one before it) is kept at its own time,
        so the zero-order hold inside the window is unchanged; the window's own ``t0_ns`` is
        therefore that command's time when it is earlier than the first kept measurement.

        Raises
        ------
        Sim2RealValueError
            When the bounds are not finite, not increasing, or hold no measurement.
        """
        if not (np.isfinite(start_s) and np.isfinite(end_s) and end_s > start_s):
            raise Sim2RealValueError(
                f"window bounds must be finite with end_s > start_s, got start_s={start_s} "
                f"and end_s={end_s}; pick seconds in [0, {self.duration_s:.3f}]"
            )
        t0 = self.t0_ns
        lo, hi = t0 + nanoseconds(start_s), t0 + nanoseconds(end_s)
        m0, m1 = np.searchsorted(self.meas_t_ns, [lo, hi], side="left")
        if m1 <= m0:
            raise Sim2RealValueError(
                f"window [{start_s}, {end_s}) s holds no measurement (the trace spans "
                f"0 to {self.duration_s:.3f} s); pick a window that overlaps the data"
            )
        c0 = max(int(np.searchsorted(self.cmd_t_ns, lo, side="right")) - 1, 0)
        c1 = int(np.searchsorted(self.cmd_t_ns, hi, side="left"))
        return self._slice(slice(int(m0), int(m1)), slice(int(c0), int(c1)))
