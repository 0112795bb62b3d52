"""``read_trace``: MCAP velocity log -> :class:`~sim2real.logs.trace.Trace` (private)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from robots.units import seconds
from sim2real.errors import (
    LogFormatError,
    LogValueError,
    Sim2RealValueError,
)
from sim2real.logs._bags import existing_log, open_log_source, source_kind
from sim2real.logs._channels import Chan, channel_table, choose_topic
from sim2real.logs._decode import decode_channel, infer_json_type
from sim2real.logs._digest import FileDigest
from sim2real.logs._mcap import Container, Segment
from sim2real.logs._pose_velocity import WINDOW_KEY, velocities_from_pose
from sim2real.logs._schemas import JOINT_STATE, ODOMETRY
from sim2real.logs._timeline import (
    GAP_FACTOR,
    GAP_MIN_S,
    MIN_SEGMENT_SAMPLES,
    drop_far_commands,
    drop_outliers,
    gap_threshold_ns,
    scratch_median,
    segment_bounds,
)
from sim2real.logs.trace import Trace, trace_from_columns

__all__ = ["TIME_SOURCES", "load_log", "read_trace"]

#: Values of ``time_source`` (CLI ``--time-source``).
TIME_SOURCES = ("auto", "header", "log")
#: Header stamps further than this from the log time come from another clock (s).
_CLOCK_GAP_S = 0.5


@dataclass(frozen=True)
class LoadedLog:
    """A scanned log: its file digest (computed when called), container and channel table."""

    name: str
    size_bytes: int
    digest: FileDigest
    container: Container
    chans: list[Chan]

    @property
    def sha256(self) -> str:
        """Hex SHA-256 of the file's bytes (hashes the file now)."""
        return self.digest()


def load_log(
    path: str | Path,
    *,
    decode: bool = True,
    sort_times: bool = True,
    keep_types: tuple[str, ...] = (),
) -> LoadedLog:
    """Stream a log through its reader: MCAP file, ROS 1 bag or rosbag2 folder.

    The messages of the channels a trace can use are decoded chunk by chunk as they stream
    past (``decode=False``: only log times are kept, for ``logs info``). ``sort_times=False``
    leaves each channel's log times unsorted (a caller that needs only the counts).
    ``keep_types`` keeps the raw payloads of more message types (e.g. LaserScan). Bad
    files give one clear error.
    """
    p = existing_log(path)
    source = open_log_source(p)  # the factory picks the reader (MCAP, ROS 1 bag, rosbag2)
    if source.kind == "csv":
        raise LogFormatError(
            f"log file '{p}' is a CSV trace, which has no channels to list; read it with "
            "read_trace (sysid fit, agree) instead"
        )
    digest = FileDigest(source.digest_paths, name=str(p))  # hashed only if someone asks
    container = source.scan(times_only=not decode, keep_types=keep_types)
    if container.warnings and container.message_count() == 0:
        raise LogFormatError(
            f"{container.warnings[-1]}, and no complete message remains before the cut; "
            "the file holds no usable data"
        )
    chans = channel_table(container, sort=sort_times)
    chans = [_with_json_type(c, container) for c in chans]
    return LoadedLog(
        name=str(p),
        size_bytes=sum(f.stat().st_size for f in source.digest_paths),
        digest=digest,
        container=container,
        chans=chans,
    )


def _with_json_type(chan: Chan, container: Container) -> Chan:
    """Give schema-less JSON channels the type their first message's keys suggest."""
    if chan.type or chan.encoding != "json" or chan.count == 0:
        return chan
    for seg in container.parts.get(chan.record.id, []):
        if isinstance(seg, Segment) and seg.payload_off.size:
            o, n = int(seg.payload_off[0]), int(seg.payload_len[0])
            guess = infer_json_type(bytes(seg.buf[o : o + n]))
            return Chan(chan.record, chan.schema, guess, chan.log_time_ns)
    return chan


def read_trace(
    path: str | Path,
    *,
    cmd_topic: str | None = None,
    odom_topic: str | None = None,
    time_source: str = "header",
    wheel_radius_m: float | None = None,
    wheel_separation_m: float | None = None,
    wheel_joints: tuple[str, str] | None = None,
    odom_velocity: str = "auto",
) -> Trace:
    """Read the commanded and measured velocities of an MCAP log.

    See :mod:`sim2real.logs` for the conventions (units, time base, topic detection).

    Parameters
    ----------
    path : str or Path
        The ``.mcap`` file (ROS 2 CDR or JSON messages).
    cmd_topic, odom_topic : str, optional
        Override the auto-detected command / measurement topics.
    time_source : {"header", "log", "auto"}
        ``"header"`` uses ``header.stamp`` where the message has one (Twist never does);
        ``"log"`` uses the recorder's log time for every stream; ``"auto"`` uses the header
        stamps unless they are on another clock than the times they are compared with
        (median offset > 0.5 s), then log times, and says which in ``meta.time_note``.
    wheel_radius_m, wheel_separation_m : float, optional
        Needed when the measurement is ``sensor_msgs/msg/JointState`` wheel speeds (m).
    wheel_joints : (str, str), optional
        Left and right wheel joint names of a JointState topic (default: the joints whose
        names contain "left" / "right").
    odom_velocity : {"auto", "twist", "pose"}
        Where measured velocities come from: the Odometry twist, its pose (smoothed
        differentiation, :mod:`sim2real.logs._pose_velocity`), or ``"auto"``: the pose when
        the twist is zero or spiky while the pose moves (said in ``meta.warnings``).

    Returns
    -------
    Trace
        Sorted, de-duplicated, finite samples; repairs are listed in ``meta.warnings``.

    Examples
    --------
    >>> tr = read_trace("run.mcap")  # doctest: +SKIP
    >>> tr.meta.cmd_topic, tr.meta.meas_rate_hz  # doctest: +SKIP
    ('/cmd_vel', 23.0)
    """
    if time_source not in TIME_SOURCES:
        raise Sim2RealValueError(
            f"time_source must be 'header', 'log' or 'auto', got {time_source!r}; use "
            "'header' (default), 'log' or 'auto'"
        )
    if Path(path).is_file() and source_kind(Path(path)) == "csv":
        from sim2real.logs._csv import read_csv_trace

        return read_csv_trace(path)
    decoded = _decode_streams(
        path, cmd_topic, odom_topic, wheel_radius_m, wheel_separation_m, wheel_joints
    )
    name, digest, cmd, meas, cmd_raw, meas_raw, warnings = decoded
    del decoded  # the columns below keep what they need of the decoded arrays
    time_note = ""
    source = time_source
    if time_source == "auto":
        source, time_note = _auto_source(cmd_raw, meas_raw, cmd, meas)
    cmd_t, cmd_src = _times(cmd_raw, source, cmd.topic, warnings)
    meas_t, meas_src = _times(meas_raw, source, meas.topic, warnings)
    if cmd_src != meas_src and time_source != "auto":
        _check_clocks(cmd_raw if cmd_src == "header" else meas_raw, cmd, meas, warnings)
    meas_cols = _meas_columns(meas_raw, meas.type, wheel_radius_m, wheel_separation_m)
    cmd_cols = {"v": cmd_raw["v"], "w": cmd_raw["w"]}
    del cmd_raw, meas_raw  # the columns keep what they need
    cmd_t, cmd_cols = _clean(cmd_t, cmd_cols, cmd.topic, warnings, name=name)
    meas_t, meas_cols = _clean(meas_t, meas_cols, meas.topic, warnings, name=name)
    meas_t, meas_cols = drop_outliers(meas_t, meas_cols, meas.topic, warnings)
    cmd_t, cmd_cols = _drop_far_commands(cmd_t, cmd_cols, meas_t, cmd.topic, warnings)
    _note_gaps(meas_t, meas.topic, warnings)
    meas_cols = velocities_from_pose(meas_t, meas_cols, meas.topic, warnings, mode=odom_velocity)
    pose_window = meas_cols.pop(WINDOW_KEY, None)
    # the arrays are handed over, not copied: nothing else refers to them
    return trace_from_columns(
        cmd_t,
        cmd_cols,
        meas_t,
        meas_cols,
        path=name,
        sha256=digest,
        time_source=time_source,
        cmd_topic=cmd.topic,
        cmd_type=cmd.type,
        cmd_time_source=cmd_src,
        meas_topic=meas.topic,
        meas_type=meas.type,
        meas_time_source=meas_src,
        encoding=meas.encoding,
        warnings=tuple(warnings),
        time_note=time_note,
        pose_window_s=0.0 if pose_window is None else float(pose_window),
    )


def _decode_streams(
    path: str | Path,
    cmd_topic: str | None,
    odom_topic: str | None,
    wheel_radius_m: float | None,
    wheel_separation_m: float | None,
    wheel_joints: tuple[str, str] | None,
) -> tuple[str, FileDigest, Chan, Chan, dict[str, np.ndarray], dict[str, np.ndarray], list[str]]:
    """The log's name and digest, the chosen command and measurement channels (their log
    times let go), their decoded arrays and the reader's warnings so far.

    Only the decoded arrays outlive this call: the channel table and the log times of every
    channel go with the log (memory follows the output).
    """
    log = load_log(path, sort_times=False)  # the channels' counts and types are used, not times
    warnings = list(log.container.warnings)
    cmd = choose_topic(log.chans, "command", cmd_topic, name=log.name)
    meas = choose_topic(log.chans, "measurement", odom_topic, name=log.name)
    for chan, role in ((cmd, "command"), (meas, "measurement")):
        if chan.count == 0:
            raise LogValueError(
                f"{role} topic '{chan.topic}' of log file '{log.name}' has no messages; "
                "record the topic or choose another one"
            )
    if meas.type == JOINT_STATE:
        _check_wheels(wheel_radius_m, wheel_separation_m, meas.topic)
    cmd_raw = decode_channel(log.container, cmd, name=log.name, type_name=cmd.type, release=True)
    meas_raw = decode_channel(
        log.container,
        meas,
        name=log.name,
        type_name=meas.type,
        wheel_joints=wheel_joints,
        release=True,
    )
    # (a new empty array: a [:0] slice would keep the whole sorted times alive as its base)
    cmd, meas = (replace(c, log_time_ns=np.zeros(0, np.int64)) for c in (cmd, meas))
    return log.name, log.digest, cmd, meas, cmd_raw, meas_raw, warnings


def _check_wheels(radius: float | None, separation: float | None, topic: str) -> None:
    for label, value in (("wheel_radius_m", radius), ("wheel_separation_m", separation)):
        if value is None or not np.isfinite(value) or value <= 0:
            raise Sim2RealValueError(
                f"measurement topic '{topic}' is sensor_msgs/msg/JointState, so {label} must "
                f"be a positive number of metres, got {value}; pass it (see the robot's spec) "
                "or choose an Odometry topic with --odom-topic"
            )


def _times(
    raw: dict[str, np.ndarray], time_source: str, topic: str, warnings: list[str]
) -> tuple[np.ndarray, str]:
    """The time array of one stream and which clock it is ("header" or "log")."""
    if time_source == "log" or "stamp_ns" not in raw:
        return raw["log_ns"], "log"
    stamps = raw["stamp_ns"]
    if (stamps <= 0).any():
        warnings.append(
            f"topic '{topic}' has {int(np.sum(stamps <= 0))} header stamps that are zero or "
            "negative (publisher did not stamp), so its log times are used instead"
        )
        return raw["log_ns"], "log"
    return stamps, "header"


def _check_clocks(raw: dict[str, np.ndarray], cmd: Chan, meas: Chan, warnings: list[str]) -> None:
    diff = raw["log_ns"] - raw["stamp_ns"]
    gap_s = seconds(float(scratch_median(diff)))  # scratch: no second copy
    if abs(gap_s) > _CLOCK_GAP_S:
        warnings.append(
            f"header stamps are {gap_s:+.3f} s (median) away from log times, so they come "
            f"from another clock than the log times used for the other stream ({cmd.topic} "
            f"vs {meas.topic}); read with time_source='log' to put both on one clock"
        )


def _offset_s(raw: dict[str, np.ndarray]) -> float | None:
    """Median of (log time - header stamp) over the stamped samples, s (None: no stamps)."""
    if "stamp_ns" not in raw:
        return None
    stamps = raw["stamp_ns"]
    ok = stamps > 0
    if not ok.any():
        return None
    diff = raw["log_ns"][ok]
    diff -= stamps[ok]
    return seconds(float(scratch_median(diff)))  # scratch: no second copy


def _auto_source(
    cmd_raw: dict[str, np.ndarray], meas_raw: dict[str, np.ndarray], cmd: Chan, meas: Chan
) -> tuple[str, str]:
    """``time_source="auto"``: header stamps unless they sit on another clock; and why."""
    off_cmd, off_meas = _offset_s(cmd_raw), _offset_s(meas_raw)
    if off_cmd is None and off_meas is None:
        return "log", "time source auto: log times (no stream carries header stamps)"
    if off_cmd is not None and off_meas is not None:
        diff = off_meas - off_cmd
        if abs(diff) <= _CLOCK_GAP_S:
            return "header", (
                f"time source auto: header stamps (the stamps of '{cmd.topic}' and "
                f"'{meas.topic}' agree within {abs(diff):.3f} s, median)"
            )
        return "log", (
            f"time source auto: log times, because the header stamps of '{meas.topic}' are "
            f"{-diff:+.3f} s (median) off those of '{cmd.topic}' (two clocks)"
        )
    stamped, other = (meas, cmd) if off_meas is not None else (cmd, meas)
    offset = float(off_meas if off_meas is not None else off_cmd)  # type: ignore[arg-type]
    if abs(offset) <= _CLOCK_GAP_S:
        return "header", (
            f"time source auto: header stamps of '{stamped.topic}' (they agree with the "
            f"recording clock within {abs(offset):.3f} s, median), log times of "
            f"'{other.topic}' (it has no header)"
        )
    return "log", (
        f"time source auto: log times, because the header stamps of '{stamped.topic}' are "
        f"{-offset:+.3f} s (median) off the recording clock that times '{other.topic}'"
    )


def _drop_far_commands(
    t: np.ndarray,
    cols: dict[str, np.ndarray],
    meas_t: np.ndarray,
    topic: str,
    warnings: list[str],
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Drop commands too far from every measurement segment to act on it (with a note)."""
    keep = drop_far_commands(t, meas_t)
    if keep.all():
        return t, cols
    bad = int(keep.size - np.count_nonzero(keep))
    warnings.append(
        f"dropped {bad} of {keep.size} samples of topic '{topic}' that lie more than 60 s "
        "away from every measurement (a corrupt stamp, or commands sent while nothing was "
        "measured)"
    )
    return t[keep], {k: v[keep] for k, v in cols.items()}


def _note_gaps(meas_t: np.ndarray, topic: str, warnings: list[str]) -> None:
    bounds = segment_bounds(meas_t)
    if len(bounds) <= 1:
        return
    gaps = [seconds(meas_t[a] - meas_t[a - 1]) for a, _ in bounds[1:]]
    warnings.append(
        f"topic '{topic}' pauses {len(gaps)} time(s) for longer than max({GAP_MIN_S:g} s, "
        f"{GAP_FACTOR:g} sampling steps) (longest {max(gaps):.3g} s), so the log is used as "
        f"{len(bounds)} separate segments (replayed and fitted one by one)"
    )


def _meas_columns(
    raw: dict[str, np.ndarray], type_name: str, radius: float | None, separation: float | None
) -> dict[str, np.ndarray]:
    if type_name == JOINT_STATE:
        r, b = float(radius or 0.0), float(separation or 0.0)
        # Differential drive: v = r (wR + wL) / 2, w = r (wR - wL) / b.
        return {
            "v": r * (raw["right"] + raw["left"]) / 2.0,
            "w": r * (raw["right"] - raw["left"]) / b,
        }
    cols = {"v": raw["v"], "w": raw["w"]}
    if type_name == ODOMETRY:  # the decoder turned the quaternion into the yaw
        cols["x"], cols["y"], cols["yaw"] = raw["x"], raw["y"], raw["yaw"]
    return cols


def _clean(
    t: np.ndarray, cols: dict[str, np.ndarray], topic: str, warnings: list[str], *, name: str
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Drop non-finite samples, sort by time and keep the last of duplicate stamps."""
    n = t.size
    finite = np.ones(n, dtype=bool)
    for values in cols.values():
        finite &= np.isfinite(values)
    if not finite.all():
        bad = int(n - np.count_nonzero(finite))
        if bad == n:
            raise LogValueError(
                f"every one of the {n} samples of topic '{topic}' of log file '{name}' has a "
                "NaN or infinite value, so nothing usable remains; check the publisher or "
                "choose another topic"
            )
        warnings.append(f"dropped {bad} of {n} samples of topic '{topic}' with NaN/inf values")
        t = t[finite]
        cols = {k: v[finite] for k, v in cols.items()}
    t = _unwind_clock_resets(t, topic, warnings)
    steps = np.diff(t)
    if (steps < 0).any():
        warnings.append(
            f"topic '{topic}' has {int(np.sum(steps < 0))} time steps that go backwards; "
            "samples were sorted by time"
        )
        order = np.argsort(t, kind="stable")
        t = t[order]
        cols = {k: v[order] for k, v in cols.items()}
        steps = np.diff(t)
    dup = steps == 0
    if dup.any():
        keep = np.append(~dup, True)  # the last sample of each run of equal stamps
        warnings.append(
            f"topic '{topic}' has {int(np.sum(dup))} duplicate timestamps; kept the last "
            "sample of each"
        )
        t = t[keep]
        cols = {k: v[keep] for k, v in cols.items()}
    return t, cols


#: A clock that steps back is unwound by a whole number of these, ns (the same for every topic
#: stamped by that clock, so commands and odometry stay aligned).
_RESET_QUANTUM_NS = 86_400 * 10**9


def _unwind_clock_resets(t: np.ndarray, topic: str, warnings: list[str]) -> np.ndarray:
    """Times in file order with each step of the clock back (a reset) unwound into a pause.

    A step back longer than the gap threshold (:func:`gap_threshold_ns`) with the
    :data:`MIN_SEGMENT_SAMPLES` samples after it all below the as many before it is a clock
    that was set back (an NTP step, a restarted driver); sorting would interleave the
    stretches before and after it. Every later sample is moved forward by the next whole day
    above the step, so the stretches follow each other after a pause and are used as separate
    segments. A single stamp far ahead or behind (a flipped byte) is left to the sort and the
    outlier rules.
    """
    if t.size < 2 * MIN_SEGMENT_SAMPLES:
        return t
    limit = gap_threshold_ns(np.sort(t))
    backs = np.flatnonzero(np.diff(t) < -limit)
    if backs.size == 0:
        return t
    out = t.astype(np.int64, copy=True)
    unwound = []
    for k in backs:
        before = out[max(0, k + 1 - MIN_SEGMENT_SAMPLES) : k + 1]
        after = out[k + 1 : k + 1 + MIN_SEGMENT_SAMPLES]
        if min(before.size, after.size) < MIN_SEGMENT_SAMPLES or after.max() >= before.min():
            continue
        jump = int(out[k] - out[k + 1])
        out[k + 1 :] += _RESET_QUANTUM_NS * (jump // _RESET_QUANTUM_NS + 1)
        unwound.append(seconds(jump))
    if unwound:
        warnings.append(
            f"the clock of topic '{topic}' steps back {len(unwound)} time(s) (by "
            f"{', '.join(f'{j:.3g} s' for j in unwound)}), so the stretches on either side are "
            "used as separate segments instead of being interleaved (the times after each step "
            "are moved a whole day forward)"
        )
    return out
