"""Unattended segments of a recording: motion without a command in force, commands ignored.

A velocity log pairs what was commanded with what the robot did. Two kinds of segment break
that pairing, and a fit or a comparison that keeps them learns the wrong robot:

- **motion with no command in force**: the robot moves while the recorded command is zero, or
  while the command stream, regular elsewhere, has fallen silent (another controller, a
  joystick or a teleop node publishing on a topic the recording did not hold);
- **a command held while the wheels stay stopped**: a non-zero command stays in force while
  the robot does not move (the driver disabled, an e-stop, the end of a script whose last
  command the logger keeps repeating).

:func:`find_unattended` marks the measurement samples of both kinds and
:func:`without_unattended` leaves them out with one note (their share of the active samples
and their time ranges), or refuses a recording made mostly of them.

Rules, on the measurement samples (velocities median-filtered over 3 samples so a single
odometry spike is not motion):

- *moving*: ``|v| > move_v`` or ``|w| > move_w``, thresholds ``max(tolerance, 4 x noise)``
  with the noise from the median absolute sample-to-sample change;
- *unattended motion*: moving while the held command is zero on both axes, more than
  ``settle_s`` after the command last asked for motion (so a robot still coasting to a stop
  is kept) and more than 0.5 s before the next command asks for it (a velocity derived from
  the pose over a centred window starts a little early);
- *held while stopped*: a command asking for motion (above twice the thresholds) in force
  while the robot does not move, in a run longer than ``settle_s`` (a start-up delay is
  shorter);
- *silent command stream*: when the commands arrive at a regular rate (intervals within
  2.5 x the median span at least 60 % of the stream; a teleop node that publishes only while
  a key is held is not regular), an interval longer than ``max(0.5 s, 5 x the median)`` is a
  silence; its samples where the robot moves or a command is held have no command in force.
  A base with a command timeout that has stopped within the timeout plus 1 s of the silence's
  start does what its firmware does: that silence is kept. A held command older than the
  timeout is not in force, so the base standing still under it is not flagged either.

Examples
--------
>>> import numpy as np
>>> from sim2real.logs import Trace
>>> t = np.arange(0, 200) * 100_000_000
>>> v = np.where((t > 5e9) & (t < 12e9), 0.3, 0.0)  # driven by hand from 5 s to 12 s
>>> tr = Trace(cmd_t_ns=t, cmd_v=np.zeros(200), cmd_w=np.zeros(200), meas_t_ns=t,
...            meas_v=v, meas_w=np.zeros(200))
>>> found = find_unattended(tr)
>>> found.ranges_s[0]
(5.1, 11.9)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim2real._arrays import BoolArray, FloatArray
from sim2real.errors import LogValueError
from sim2real.logs.trace import Trace

__all__ = [
    "MOSTLY_UNATTENDED",
    "SETTLE_S",
    "Unattended",
    "find_unattended",
    "without_unattended",
]


#: A robot answers a command change within this long (delay, ramp, a slow odometry hold), s.
SETTLE_S = 2.0
#: A recording whose active samples are more than this share unattended is refused.
MOSTLY_UNATTENDED = 0.5
#: Motion this long before a command asks for it is that command's (a velocity derived from
#: the pose over a centred window, or stamps a little off between the two streams), s.
LEAD_S = 0.5
#: A base with a command timeout has stopped this long after it, s.
STOP_S = 1.0
#: A command magnitude at or below this is zero (m/s or rad/s).
CMD_ZERO = 1e-3
#: The floors of the motion thresholds (the agreement tolerances), m/s and rad/s.
MOVE_V_FLOOR, MOVE_W_FLOOR = 0.02, 0.1
#: A silence of the command stream lasts at least this long, s, ...
SILENCE_MIN_S = 0.5
#: ... and this many median command intervals.
SILENCE_FACTOR = 5.0
#: A command stream is regular when intervals within 2.5x the median span this share of it.
REGULAR_SHARE = 0.6
#: Ranges closer than this are one range in the note, s.
MERGE_S = 1.0


@dataclass(frozen=True, kw_only=True)
class Unattended:
    """The unattended samples of a recording.

    Attributes
    ----------
    motion, stopped : ndarray of bool
        Per measurement sample: moving with no command in force; a command held while the
        robot stays stopped.
    active : ndarray of bool
        The samples where a command asks for motion or the robot moves.
    ranges_s : tuple of (float, float)
        The flagged time ranges, s since the trace's start (merged when closer than 1 s).
    share : float
        Share of the active samples that are flagged (0..1; 0 with no active sample).
    """

    motion: BoolArray
    stopped: BoolArray
    active: BoolArray
    ranges_s: tuple[tuple[float, float], ...]
    share: float

    @property
    def flagged(self) -> BoolArray:
        """Samples of either kind."""
        return self.motion | self.stopped

    def note(self, where: str) -> str:
        """One sentence: what was left out of ``where``, its share and time ranges."""
        kinds = []
        if self.motion.any():
            kinds.append("the robot moved with no command in force")
        if self.stopped.any():
            kinds.append("a command was held while the wheels stayed stopped")
        return (
            f"left out {int(self.flagged.sum())} samples of '{where}' ({100 * self.share:.1f} % "
            f"of the active ones) where {' or '.join(kinds)}, at {_ranges_text(self.ranges_s)}; "
            "--keep-all keeps them"
        )


def _ranges_text(ranges: tuple[tuple[float, float], ...], most: int = 6) -> str:
    parts = [f"{a:.1f}-{b:.1f} s" for a, b in ranges[:most]]
    if len(ranges) > most:
        parts.append(f"{len(ranges) - most} more")
    return ", ".join(parts)


def _median3(x: FloatArray) -> FloatArray:
    if x.size < 3:
        return x.copy()
    padded = np.concatenate(([x[0]], x, [x[-1]]))
    stacked = np.stack([padded[:-2], padded[1:-1], padded[2:]])
    return np.asarray(np.median(stacked, axis=0), dtype=np.float64)


def _noise(x: FloatArray) -> float:
    """Sample noise std from the median absolute change between samples (robust to steps)."""
    if x.size < 3:
        return 0.0
    return float(1.4826 * np.median(np.abs(np.diff(x))) / math.sqrt(2.0))


def _runs(mask: BoolArray) -> list[tuple[int, int]]:
    """``[(start, stop), ...]`` of the runs of True in ``mask`` (stop exclusive)."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _until_motion_asked(trace: Trace) -> FloatArray:
    """Seconds until the next command asking for motion, at each measurement (inf: none)."""
    cmd_t, t = trace.cmd_t_s, trace.meas_t_s
    asks = (np.abs(trace.cmd_v) > CMD_ZERO) | (np.abs(trace.cmd_w) > CMD_ZERO)
    times = np.append(cmd_t[asks], np.inf)  # none after the last: never
    return np.asarray(times[np.searchsorted(times, t, side="left")] - t, dtype=np.float64)


def _since_motion_asked(trace: Trace) -> FloatArray:
    """Seconds since a command last asked for motion, at each measurement.

    A command asks until the next command replaces it, so a robot still coasting after the
    stop command is counted from that stop command's time; before any asking command, from
    the first sample (the recording may begin while an earlier command is still answered).
    """
    cmd_t, t = trace.cmd_t_s, trace.meas_t_s
    asks = np.flatnonzero((np.abs(trace.cmd_v) > CMD_ZERO) | (np.abs(trace.cmd_w) > CMD_ZERO))
    start = float(t[0]) if t.size else 0.0  # a command may have been in force before it
    if asks.size == 0:
        return np.asarray(t - start, dtype=np.float64)
    ends = np.append(cmd_t, np.inf)[asks + 1]  # when each asking command was replaced
    idx = np.searchsorted(cmd_t[asks], t, side="right") - 1
    last_end = np.where(idx >= 0, ends[np.clip(idx, 0, None)], start)
    return np.asarray(t - last_end, dtype=np.float64)


def _silences(cmd_t: FloatArray) -> list[tuple[float, float]]:
    """The silences of a regular command stream (none when the stream is irregular)."""
    if cmd_t.size < 10:
        return []
    gaps = np.diff(cmd_t)
    median = float(np.median(gaps))
    regular = gaps <= 2.5 * median
    if median <= 0 or gaps[regular].sum() < REGULAR_SHARE * gaps.sum():
        return []  # bursts (a teleop publishing while a key is held): silence is normal
    limit = max(SILENCE_MIN_S, SILENCE_FACTOR * median)
    return [
        (float(cmd_t[k] + 1.2 * median), float(cmd_t[k + 1])) for k in np.flatnonzero(gaps > limit)
    ]


def _merged(t: FloatArray, mask: BoolArray) -> tuple[tuple[float, float], ...]:
    out: list[tuple[float, float]] = []
    for a, b in _runs(mask):
        lo, hi = float(t[a]), float(t[b - 1])
        if out and lo - out[-1][1] < MERGE_S:
            out[-1] = (out[-1][0], hi)
        else:
            out.append((lo, hi))
    return tuple((round(a, 1), round(b, 1)) for a, b in out)


def find_unattended(
    trace: Trace, *, settle_s: float = SETTLE_S, cmd_timeout_s: float = math.inf
) -> Unattended:
    """Mark the unattended samples of ``trace`` (see the module docstring for the rules).

    Parameters
    ----------
    trace : Trace
        The recording.
    settle_s : float
        How long the robot may take to answer a command change, s.
    cmd_timeout_s : float
        The base's command timeout, s (``DriveParams.cmd_timeout_s``; inf = none): a command
        older than this is not in force, so a base that stops in a silence of the command
        stream does what its firmware does.

    Returns
    -------
    Unattended
    """
    parts = trace.segments()  # a pause in the odometry: each side on its own
    if len(parts) > 1 and sum(p.meas_t_ns.size for p in parts) == trace.meas_t_ns.size:
        found = [_find(p, settle_s, cmd_timeout_s) for p in parts]
        motion = np.concatenate([f.motion for f in found])
        stopped = np.concatenate([f.stopped for f in found])
        active = np.concatenate([f.active for f in found])
        return _unattended(trace.meas_t_s, motion, stopped, active)
    return _find(trace, settle_s, cmd_timeout_s)


def _unattended(
    t: FloatArray, motion: BoolArray, stopped: BoolArray, active: BoolArray
) -> Unattended:
    flagged = motion | stopped
    n_active = int(active.sum())
    return Unattended(
        motion=motion,
        stopped=stopped,
        active=active,
        ranges_s=_merged(t, flagged),
        share=float(flagged[active].sum() / n_active) if n_active else 0.0,
    )


def _find(trace: Trace, settle_s: float, cmd_timeout_s: float) -> Unattended:
    """:func:`find_unattended` on one segment (no pause in its odometry)."""
    t = trace.meas_t_s
    cv, cw = trace.cmd_at_meas()
    v, w = _median3(trace.meas_v), _median3(trace.meas_w)
    move_v = max(MOVE_V_FLOOR, 4.0 * _noise(trace.meas_v))
    move_w = max(MOVE_W_FLOOR, 4.0 * _noise(trace.meas_w))
    moving = (np.abs(v) > move_v) | (np.abs(w) > move_w)
    zero = (np.abs(cv) <= CMD_ZERO) & (np.abs(cw) <= CMD_ZERO)
    in_force = _age(trace) <= cmd_timeout_s
    asks = (np.abs(cv) > 2 * move_v) | (np.abs(cw) > 2 * move_w)
    motion = moving & zero & (_since_motion_asked(trace) > settle_s)
    motion &= _until_motion_asked(trace) > LEAD_S  # a smoothed or early odometry stamp
    stopped = np.zeros(t.size, dtype=bool)
    for a, b in _runs(asks & in_force & ~moving):
        if t[b - 1] - t[a] > settle_s:
            stopped[a:b] = True
    for lo, hi in _silences(trace.cmd_t_s):
        inside = (t > lo) & (t < hi) & (moving | ~zero)
        late = (t > lo + cmd_timeout_s + STOP_S) & (t < hi)
        if math.isfinite(cmd_timeout_s) and not (late & moving).any():
            continue  # the base stopped on its timeout: what its firmware does
        motion |= inside & moving
        stopped |= inside & ~moving
    stopped &= ~motion
    return _unattended(t, motion, stopped, moving | asks | ~zero)


def _age(trace: Trace) -> FloatArray:
    """Seconds since the command held at each measurement arrived (inf before the first)."""
    cmd_t, t = trace.cmd_t_s, trace.meas_t_s
    idx = np.searchsorted(cmd_t, t, side="right") - 1
    last = np.where(idx >= 0, cmd_t[np.clip(idx, 0, None)] if cmd_t.size else 0.0, -np.inf)
    return np.asarray(t - last, dtype=np.float64)


def without_unattended(
    trace: Trace,
    *,
    keep_all: bool = False,
    settle_s: float = SETTLE_S,
    cmd_timeout_s: float = math.inf,
) -> tuple[Trace, str]:
    """``trace`` without its unattended samples, and the note saying so ("" when none).

    Parameters
    ----------
    trace : Trace
        The recording.
    keep_all : bool
        Keep every sample (no screening; the note is "").
    settle_s, cmd_timeout_s : float
        See :func:`find_unattended`.

    Returns
    -------
    trace : Trace
        The measurement samples left (every command is kept, so the hold is unchanged).
    note : str
        One sentence: how many samples were left out, their share and time ranges.

    Raises
    ------
    LogValueError
        When more than :data:`MOSTLY_UNATTENDED` of the active samples are unattended, or
        fewer than 10 samples remain.
    """
    if keep_all:
        return trace, ""
    found = find_unattended(trace, settle_s=settle_s, cmd_timeout_s=cmd_timeout_s)
    if not found.flagged.any():
        return trace, ""
    where = trace.meta.path or "the trace"
    if found.share > MOSTLY_UNATTENDED:
        hand = found.motion.sum() >= found.stopped.sum()
        fix = (
            "record the command topic that drives the robot (--cmd-topic)"
            if hand
            else "check that the odometry measures the robot (--odom-topic, --odom-velocity "
            "pose) and that its driver was enabled"
        )
        raise LogValueError(
            f"log file '{where}' is mostly unattended: {100 * found.share:.0f} % of its active "
            "samples have the robot moving with no command in force or a command held while "
            f"the wheels stay stopped (at {_ranges_text(found.ranges_s)}); {fix}, or pass "
            "--keep-all to use it as it is"
        )
    keep = ~found.flagged
    out = trace._slice(keep, np.ones(trace.cmd_t_ns.size, dtype=bool))
    out.check_enough()
    return out, found.note(where)
