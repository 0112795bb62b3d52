"""``inspect_log``: what is in an MCAP log and which topics a read would use (private)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sim2real.errors import MissingTopicError
from sim2real.logs._channels import Chan, choose_topic
from sim2real.logs._reader import load_log

__all__ = ["NO_CHECKSUMS", "LogInfo", "TopicInfo", "inspect_log"]

#: The note of a log without any CRC (chunk or data section).
NO_CHECKSUMS = "this file has no checksums; corruption cannot be detected"


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
    rate_hz : float
        Mean rate by log time, ``(n - 1) / (t_last - t_first)`` (0 below 2 messages).
    first_ns, last_ns : int
        First and last log time (ns since the epoch; 0 when empty).
    """

    topic: str
    type: str
    message_encoding: str
    schema_encoding: str
    count: int
    rate_hz: float
    first_ns: int
    last_ns: int


@dataclass(frozen=True, kw_only=True)
class LogInfo:
    """Summary of an MCAP log: topics, counts, rates and the topics a read would use.

    Attributes
    ----------
    path, sha256 : str
        The file and the hex SHA-256 of its bytes.
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
        ``(end_ns - start_ns) / 1e9``.
    cmd_topic, meas_topic : str or None
        The topics :func:`~sim2real.logs.read_trace` would use (None when there is none).
    cmd_note, meas_note : str
        Why a topic is None (the error a read would raise), else "".
    warnings : tuple of str
        Repairs or problems met while scanning (e.g. a truncated file).
    """

    path: str
    sha256: str
    size_bytes: int
    profile: str
    library: str
    topics: tuple[TopicInfo, ...]
    message_count: int
    start_ns: int
    end_ns: int
    duration_s: float
    cmd_topic: str | None
    meas_topic: str | None
    cmd_note: str = ""
    meas_note: str = ""
    warnings: tuple[str, ...] = field(default_factory=tuple)

    def topic(self, name: str) -> TopicInfo:
        """The :class:`TopicInfo` of topic ``name`` (KeyError when absent)."""
        for t in self.topics:
            if t.topic == name:
                return t
        raise KeyError(name)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict."""
        return asdict(self)


def _topic_info(chan: Chan) -> TopicInfo:
    t = chan.log_time_ns
    span = float(t[-1] - t[0]) / 1e9 if t.size else 0.0
    return TopicInfo(
        topic=chan.topic,
        type=chan.type,
        message_encoding=chan.encoding,
        schema_encoding=chan.schema.encoding if chan.schema is not None else "",
        count=chan.count,
        rate_hz=(t.size - 1) / span if span > 0 else 0.0,
        first_ns=int(t[0]) if t.size else 0,
        last_ns=int(t[-1]) if t.size else 0,
    )


def inspect_log(
    path: str | Path, *, cmd_topic: str | None = None, odom_topic: str | None = None
) -> LogInfo:
    """Scan an MCAP log and describe it (no message payload is decoded).

    An explicit ``cmd_topic``/``odom_topic`` that does not exist or has the wrong type raises
    :class:`~sim2real.errors.MissingTopicError`; when auto-detection finds no topic the info
    says why in ``cmd_note``/``meas_note`` instead.

    Examples
    --------
    >>> info = inspect_log("run.mcap")  # doctest: +SKIP
    >>> info.topic("/odom").count  # doctest: +SKIP
    893
    """
    log = load_log(path)
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
    warnings = list(log.container.warnings)
    if not log.container.checksums:
        warnings.append(NO_CHECKSUMS)
    for role, topic in chosen.items():
        if topic is not None and not any(c.count for c in log.chans if c.topic == topic):
            warnings.append(
                f"the {role} topic '{topic}' has no messages, so reading this log as a trace "
                "(sysid fit, agree) will fail; record the topic or choose another one"
            )
    times = [c.log_time_ns for c in log.chans if c.count]
    start = int(min(int(t[0]) for t in times)) if times else 0
    end = int(max(int(t[-1]) for t in times)) if times else 0
    return LogInfo(
        path=log.name,
        sha256=log.sha256,
        size_bytes=log.size_bytes,
        profile=log.container.profile,
        library=log.container.library,
        topics=tuple(sorted((_topic_info(c) for c in log.chans), key=lambda t: t.topic)),
        message_count=int(np.sum([c.count for c in log.chans])) if log.chans else 0,
        start_ns=start,
        end_ns=end,
        duration_s=(end - start) / 1e9,
        cmd_topic=chosen["command"],
        meas_topic=chosen["measurement"],
        cmd_note=notes["command"],
        meas_note=notes["measurement"],
        warnings=tuple(warnings),
    )
