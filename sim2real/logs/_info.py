"""``inspect_log``: what is in an MCAP log and which topics a read would use (private)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from robots.units import seconds
from sim2real.errors import MissingTopicError
from sim2real.logs._bags import existing_log, source_kind
from sim2real.logs._channels import Chan, choose_topic
from sim2real.logs._digest import FileDigest, LazyText
from sim2real.logs._reader import load_log
from sim2real.logs._schemas import normalize_type
from sim2real.logs._summary import SummaryView, read_summary
from sim2real.logs._timeline import drop_far_commands, drop_isolated, segment_bounds

__all__ = [
    "NO_CHECKSUMS",
    "ROS1_NO_CHECKSUMS",
    "ROSBAG2_MCAP_NO_CHECKSUMS",
    "ROSBAG2_NO_CHECKSUMS",
    "LogInfo",
    "TopicInfo",
    "inspect_log",
    "topic_rate_hz",
]

#: A topic's rate is given from this many messages spanning at least this long (s) on.
MIN_RATE_MESSAGES, MIN_RATE_SPAN_S = 10, 1.0
#: Messages per step of the local rate, and how far (factor) it may stray from the mean rate
#: before the topic counts as bursty (messages bunched in time, e.g. a startup burst of
#: /rosout or a teleop that publishes only while a key is held).
RATE_STEP, BURST_FACTOR = 5, 2.0

#: The note of an MCAP log without any CRC (chunk or data section).
NO_CHECKSUMS = "this file has no checksums; corruption cannot be detected"
#: The note of a ROS 1 bag: the format has no checksums at all.
ROS1_NO_CHECKSUMS = (
    "ROS 1 bags carry no checksums (the format has none); corruption of message data "
    "cannot be detected"
)
#: The note of a rosbag2 bag with sqlite3 storage (sqlite3 keeps no checksum of a row).
ROSBAG2_NO_CHECKSUMS = (
    "this rosbag2 bag's sqlite3 storage carries no checksums of its messages; corruption of "
    "message data cannot be detected"
)
#: The note of a rosbag2 bag whose mcap storage files were written without CRCs.
ROSBAG2_MCAP_NO_CHECKSUMS = (
    "this rosbag2 bag's mcap storage files have no checksums; corruption cannot be detected"
)


@dataclass(frozen=True, kw_only=True)
class TopicInfo:
    """One topic of a log.

    Attributes
    ----------
    topic, type : str
        Topic name and ROS 2 message type (``pkg/msg/Type``; "" without schema).
    message_encoding, schema_encoding : str
        E.g. ``cdr`` / ``ros2msg`` or ``json`` / ``jsonschema``.
    count : int
        Number of messages.
    rate_hz : float or None
        Mean rate by log time, ``(n - 1) / (t_last - t_first)``; None when that is no rate
        (:func:`topic_rate_hz`: too few messages, or bursty).
    first_ns, last_ns : int
        First and last log time (ns since the epoch; 0 when empty).
    """

    topic: str
    type: str
    message_encoding: str
    schema_encoding: str
    count: int
    rate_hz: float | None
    first_ns: int
    last_ns: int


@dataclass(frozen=True, kw_only=True)
class LogInfo:
    """Summary of an MCAP log: topics, counts, rates and the topics a read would use.

    Attributes
    ----------
    path : str
        The file.
    sha256 : str
        Hex SHA-256 of its bytes, computed on first access (``logs info --sha256``).
    size_bytes : int
        File size.
    profile, library : str
        From the MCAP header (``ros2`` / the writing library).
    topics : tuple of TopicInfo
        Every channel, sorted by topic name.
    message_count : int
        Messages over all topics.
    start_ns, end_ns : int
        First and last log time over all topics (ns).
    duration_s : float
        ``seconds(end_ns - start_ns)`` (:func:`robots.units.seconds`).
    cmd_topic, meas_topic : str or None
        The topics :func:`~sim2real.logs.read_trace` would use (None when there is none).
    cmd_note, meas_note : str
        Why a topic is None (the error a read would raise), else "".
    warnings : tuple of str
        Repairs or problems met while scanning (e.g. a truncated file), and one line each
        for the pauses and the far-outlier stamps below.
    source : str
        ``"summary"`` when the answer comes from the MCAP summary section and message indexes
        (no chunk decompressed, so chunk CRCs were not checked), ``"scan"`` when every
        record was read.
    segments : int
        Runs of the measurement topic split by its pauses (by log time; 0 without one);
        ``sysid fit`` and ``agree`` use each on its own.
    pauses_s : tuple of float
        Length of each pause that splits the measurement topic, s.
    far_stamps : dict
        ``{topic: count}`` of the measurement and command stamps (log time) that lie far
        outside the recording; reading the log drops them.
    """

    path: str
    sha256: LazyText = LazyText()  # noqa: RUF009 (a descriptor, see _digest)
    size_bytes: int = 0
    profile: str = ""
    library: str = ""
    topics: tuple[TopicInfo, ...] = ()
    message_count: int = 0
    start_ns: int = 0
    end_ns: int = 0
    duration_s: float = 0.0
    cmd_topic: str | None = None
    meas_topic: str | None = None
    cmd_note: str = ""
    meas_note: str = ""
    warnings: tuple[str, ...] = field(default_factory=tuple)
    source: str = "scan"
    segments: int = 0
    pauses_s: tuple[float, ...] = ()
    far_stamps: dict[str, int] = field(default_factory=dict)

    def topic(self, name: str) -> TopicInfo:
        """The :class:`TopicInfo` of topic ``name`` (KeyError when absent)."""
        for t in self.topics:
            if t.topic == name:
                return t
        raise KeyError(name)

    def to_dict(self, *, sha256: bool = True) -> dict[str, Any]:
        """Plain JSON-ready dict (``sha256=False``: its ``sha256`` is None, the file unhashed)."""
        out = asdict(replace(self, sha256=""))
        out["sha256"] = self.sha256 if sha256 else None
        return out


def topic_rate_hz(log_time_ns: np.ndarray) -> float | None:
    """The mean rate of a topic's messages, ``(n - 1) / span``, or None when it is no rate.

    None below :data:`MIN_RATE_MESSAGES` messages or a :data:`MIN_RATE_SPAN_S` span, and when
    the topic is bursty: its median local rate (over :data:`RATE_STEP` messages) differs from
    the mean by more than :data:`BURST_FACTOR` times. Regular pairs or groups (two bonds
    published together) keep their mean rate.

    Examples
    --------
    >>> t = np.arange(0, 10**10, 10**8)  # 100 messages at 10 Hz
    >>> round(topic_rate_hz(t), 2)
    10.0
    >>> burst = np.arange(13) * 17 * 10**6  # 13 messages in 0.2 s
    >>> topic_rate_hz(burst) is None
    True
    """
    t = np.sort(np.asarray(log_time_ns, dtype=np.int64))
    span = seconds(float(t[-1] - t[0])) if t.size else 0.0
    if t.size < MIN_RATE_MESSAGES or span < MIN_RATE_SPAN_S:
        return None
    mean = (t.size - 1) / span
    step_s = seconds(np.median(t[RATE_STEP:] - t[:-RATE_STEP]).item()) / RATE_STEP
    local = 1.0 / step_s if step_s > 0 else float("inf")
    return mean if mean / BURST_FACTOR <= local <= mean * BURST_FACTOR else None


def _topic_info(chan: Chan) -> TopicInfo:
    t = chan.log_time_ns
    return TopicInfo(
        topic=chan.topic,
        type=chan.type,
        message_encoding=chan.encoding,
        schema_encoding=chan.schema.encoding if chan.schema is not None else "",
        count=chan.count,
        rate_hz=topic_rate_hz(t),
        first_ns=int(t[0]) if t.size else 0,
        last_ns=int(t[-1]) if t.size else 0,
    )


@dataclass(frozen=True)
class _Scanned:
    """What :func:`inspect_log` needs of a log, however it was read."""

    name: str
    size_bytes: int
    digest: FileDigest
    profile: str
    library: str
    chans: list[Chan]
    warnings: list[str]
    source: str


def _from_summary(path: Path) -> _Scanned | None:
    """The MCAP summary-section answer (None: not an MCAP file with a usable summary)."""
    if not path.is_file() or source_kind(path) != "mcap":
        return None
    view = read_summary(path)
    if view is None:
        return None
    chans = []
    for cid, rec in sorted(view.channels.items()):
        schema = view.schemas.get(rec.schema_id)
        type_name = normalize_type(schema.name) if schema is not None else ""
        chans.append(
            Chan(record=rec, schema=schema, type=type_name, log_time_ns=view.log_times[cid])
        )
    return _Scanned(
        name=str(path),
        size_bytes=path.stat().st_size,
        digest=FileDigest((path,), name=str(path)),
        profile=view.profile,
        library=view.library,
        chans=chans,
        warnings=_summary_notes(view),
        source="summary",
    )


def _summary_notes(view: SummaryView) -> list[str]:
    if not view.checksums:
        return [NO_CHECKSUMS]
    if view.unchecked_chunks:
        return [
            f"the CRCs of its {view.unchecked_chunks} compressed chunk(s) were not checked "
            "(logs info reads the summary section and decompresses nothing); reading the log "
            "(sysid fit, agree) checks them"
        ]
    return []


def _from_scan(path: Path) -> _Scanned:
    log = load_log(path)
    warnings = list(log.container.warnings)
    note = _checksum_note(path, log.container.format, log.container.checksums)
    if note:
        warnings.append(note)
    return _Scanned(
        name=log.name,
        size_bytes=log.size_bytes,
        digest=log.digest,
        profile=log.container.profile,
        library=log.container.library,
        chans=log.chans,
        warnings=warnings,
        source="scan",
    )


def _checksum_note(path: Path, kind: str, checksums: bool) -> str:
    """The sentence saying that a log cannot be checked for corruption, in its format's terms
    ("" when it can)."""
    if kind == "ros1":
        return ROS1_NO_CHECKSUMS
    if kind == "rosbag2":
        storage = [p for p in path.iterdir() if p.suffix in (".db3", ".mcap")]
        if any(p.suffix == ".db3" for p in storage):
            return ROSBAG2_NO_CHECKSUMS
        views = [read_summary(p) for p in storage]  # rosbags checks chunk CRCs where present
        return (
            ""
            if views and all(v is not None and v.checksums for v in views)
            else (ROSBAG2_MCAP_NO_CHECKSUMS)
        )
    return "" if checksums else NO_CHECKSUMS


@dataclass(frozen=True)
class _Timeline:
    segments: int = 0
    pauses_s: tuple[float, ...] = ()
    far_stamps: dict[str, int] = field(default_factory=dict)


def _duration_text(seconds: float) -> str:
    for unit, size in (("d", 86_400.0), ("h", 3_600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def _timeline(
    chans: list[Chan], cmd: str | None, meas: str | None, warnings: list[str]
) -> _Timeline:
    """Pauses and far-outlier stamps (by log time) of the topics a read would use, with notes.

    The rules are the reader's (:mod:`sim2real.logs._timeline`).
    """

    def times(topic: str | None) -> np.ndarray:
        found = [c.log_time_ns for c in chans if c.topic == topic and c.count]
        return (
            np.sort(np.concatenate(found), kind="stable").astype(np.int64)
            if found
            else np.zeros(0, np.int64)
        )

    t_meas, t_cmd = times(meas), times(cmd)
    if t_meas.size == 0:
        return _Timeline()
    keep = drop_isolated(t_meas)
    far = {meas: int(keep.size - keep.sum())} if meas else {}
    if t_cmd.size:
        keep_cmd = drop_far_commands(t_cmd, t_meas[keep])
        far[str(cmd)] = int(keep_cmd.size - keep_cmd.sum())
    far = {topic: n for topic, n in far.items() if n}
    for topic, n in far.items():
        total = (t_meas if topic == meas else t_cmd).size
        warnings.append(
            f"{n} of {total} log times of '{topic}' lie far outside the recording (a corrupt "
            "stamp); reading the log drops them"
        )
    kept = t_meas[keep]
    bounds = segment_bounds(kept)
    pauses = tuple(seconds(float(kept[a] - kept[a - 1])) for a, _ in bounds[1:])
    if pauses:
        warnings.append(
            f"'{meas}' pauses {len(pauses)} time(s) "
            f"({', '.join(_duration_text(p) for p in pauses)}), splitting the log into "
            f"{len(bounds)} segments that sysid fit and agree use one by one"
        )
    return _Timeline(segments=len(bounds), pauses_s=pauses, far_stamps=far)


def inspect_log(
    path: str | Path, *, cmd_topic: str | None = None, odom_topic: str | None = None
) -> LogInfo:
    """Describe a log: topics, types, counts, rates, time range, the topics a read would use.

    An MCAP file with a summary section is answered from it and its message indexes, without
    decompressing a chunk or decoding a payload (``info.source == "summary"``); other files
    and formats are scanned. The file's SHA-256 is only computed when ``info.sha256`` is read.

    An explicit ``cmd_topic``/``odom_topic`` that does not exist or has the wrong type raises
    :class:`~sim2real.errors.MissingTopicError`; when auto-detection finds no topic the info
    says why in ``cmd_note``/``meas_note`` instead.

    Examples
    --------
    >>> info = inspect_log("run.mcap")  # doctest: +SKIP
    >>> info.topic("/odom").count  # doctest: +SKIP
    893
    """
    p = existing_log(path)
    log = _from_summary(p) or _from_scan(p)
    chosen: dict[str, str | None] = {}
    notes: dict[str, str] = {}
    for role, explicit in (("command", cmd_topic), ("measurement", odom_topic)):
        try:
            chosen[role] = choose_topic(log.chans, role, explicit, name=log.name).topic
            notes[role] = ""
        except MissingTopicError as exc:
            if explicit is not None:
                raise
            chosen[role], notes[role] = None, str(exc)
    warnings = list(log.warnings)
    for role, topic in chosen.items():
        if topic is not None and not any(c.count for c in log.chans if c.topic == topic):
            warnings.append(
                f"the {role} topic '{topic}' has no messages, so reading this log as a trace "
                "(sysid fit, agree) will fail; record the topic or choose another one"
            )
    timeline = _timeline(log.chans, chosen["command"], chosen["measurement"], warnings)
    times = [c.log_time_ns for c in log.chans if c.count]
    start = int(min(int(t[0]) for t in times)) if times else 0
    end = int(max(int(t[-1]) for t in times)) if times else 0
    return LogInfo(
        path=log.name,
        sha256=log.digest,
        size_bytes=log.size_bytes,
        profile=log.profile,
        library=log.library,
        topics=tuple(sorted((_topic_info(c) for c in log.chans), key=lambda t: t.topic)),
        message_count=int(np.sum([c.count for c in log.chans])) if log.chans else 0,
        start_ns=start,
        end_ns=end,
        duration_s=seconds(end - start),
        cmd_topic=chosen["command"],
        meas_topic=chosen["measurement"],
        cmd_note=notes["command"],
        meas_note=notes["measurement"],
        warnings=tuple(warnings),
        source=log.source,
        segments=timeline.segments,
        pauses_s=timeline.pauses_s,
        far_stamps=timeline.far_stamps,
    )
