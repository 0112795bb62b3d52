"""Decode a log's segments as they stream past, keeping only typed arrays (private).

:func:`add_segment` is the sink of the streamed MCAP scan (:func:`sim2real.logs._mcap.stream_mcap`)
and of the bag readers: for every segment (the messages of one chunk) it keeps each channel's
log times, and for the channels a trace can be built from (Twist, TwistStamped, Odometry,
JointState) it decodes the fixed-layout CDR/ROS 1 types at once with the numpy bulk
decoders and copies the fields into the channel's whole-log arrays (:class:`Columns`, sized
from the message counts of the MCAP summary when it states them); the chunk's bytes are then
free to go. So memory follows the output, not the file, with no join of many small arrays at
the end. Payloads that need a generic decoder (JointState, big-endian CDR, JSON) are
copied out compactly and decoded when the channel is asked for. A channel whose messages do
not fit their layout records the error, raised only if that channel is read.
"""

from __future__ import annotations

import numpy as np

from sim2real.logs import _cdr
from sim2real.logs._mcap import Buf, Columns, Container, Segment
from sim2real.logs._ros1 import BULK_ROS1
from sim2real.logs._schemas import JOINT_STATE, ODOMETRY, TWIST, TWIST_STAMPED, normalize_type

__all__ = ["BULK_CDR", "DRIVE_TYPES", "add_segment", "channel_times", "times_only", "with_yaw"]

#: Message types a trace is built from; other channels only keep their log times.
DRIVE_TYPES = (TWIST, TWIST_STAMPED, ODOMETRY, JOINT_STATE)
BULK_CDR = {
    TWIST: _cdr.decode_twist,
    TWIST_STAMPED: _cdr.decode_twist_stamped,
    ODOMETRY: _cdr.decode_odometry,
}


def _plan(container: Container, cid: int) -> str:
    """How the messages of channel ``cid`` are kept: "skip", "bulk" or "raw"."""
    rec = container.channels[cid]
    schema = container.schemas.get(rec.schema_id)
    type_name = normalize_type(schema.name) if schema is not None else ""
    enc = rec.message_encoding
    if enc == "json" and not type_name:
        return "raw"  # its type is guessed from a payload
    if container.times_only or type_name not in (*DRIVE_TYPES, *container.keep_types):
        return "skip"
    if (enc == "cdr" and type_name in BULK_CDR) or (enc == "ros1" and type_name in BULK_ROS1):
        return "bulk"
    return "raw"


def add_segment(container: Container, seg: Segment) -> None:
    """Keep the log times of every message of ``seg`` and decode the wanted channels now.

    The log times of a bulk-decoded channel are kept once, in its columns (``log_ns``); those
    of the channels that are not decoded, for the whole segment at once, in
    ``container.skipped`` (one array, a span per channel); the rest in ``container.times``.
    """
    ids = seg.channel_id
    if ids.size == 0:
        return
    per = np.bincount(ids)  # channel ids are u16 (MCAP) or small ints (bags)
    uniq = np.flatnonzero(per).tolist()
    plans, failed = container.plans, container.failed
    for cid in uniq:
        if cid not in plans:
            plans[cid] = _plan(container, cid)
    skip = {cid for cid in uniq if plans[cid] == "skip" or cid in failed}
    if len(uniq) == 1:
        if skip:
            container.skipped.append((seg.log_time_ns, {uniq[0]: (0, int(ids.size))}))
            return
        _decode(container, uniq[0], seg, None, seg.log_time_ns)
        return
    # the messages grouped by channel, file order kept within each (a stable sort: a radix
    # sort on u16 ids), so each channel is a slice instead of a mask over all
    keys = ids.astype(np.uint16) if per.size <= 1 << 16 else ids
    order = np.argsort(keys, kind="stable")
    all_times = seg.log_time_ns[order]
    counts = per[uniq].tolist()
    if skip:
        if len(skip) < len(uniq):  # keep the skipped channels' times only
            is_skip = np.zeros(per.size, dtype=bool)
            is_skip[list(skip)] = True
            skip_times = all_times[is_skip[keys[order]]]
        else:
            skip_times = all_times
        spans, start = {}, 0
        for cid, n in zip(uniq, counts, strict=True):
            if cid in skip:
                spans[cid] = (start, start + n)
                start += n
        container.skipped.append((skip_times, spans))
    start = 0
    for cid, n in zip(uniq, counts, strict=True):
        end = start + n
        if cid not in skip:
            _decode(container, cid, seg, order[start:end], all_times[start:end])
        start = end


def _decode(
    container: Container, cid: int, seg: Segment, idx: np.ndarray | None, times: np.ndarray
) -> None:
    """Decode (bulk) or keep (raw payloads) the messages ``idx`` of ``seg`` (all: None), all on
    channel ``cid``, with their log times."""
    counts = container.counts
    before = counts.get(cid, 0)
    counts[cid] = before + int(times.size)
    off = seg.payload_off if idx is None else seg.payload_off[idx]
    ln = seg.payload_len if idx is None else seg.payload_len[idx]
    part = _bulk(container, cid, seg, off, ln, before) if container.plans[cid] == "bulk" else None
    if part is not None:
        part = with_yaw(part)
        part["log_ns"] = times
        _keep(container, cid, part, before)
        return
    container.times.setdefault(cid, []).append(times)
    if cid not in container.failed:
        container.parts.setdefault(cid, []).append(_compact(seg.buf, off, ln, times, cid))


def channel_times(container: Container, cid: int) -> list[np.ndarray]:
    """The log-time arrays of channel ``cid`` (unsorted pieces, in no particular order)."""
    pieces = list(container.times.get(cid, []))
    for item in container.parts.get(cid, []):
        if isinstance(item, Columns):
            pieces.append(item.log_times())
    for times, spans in container.skipped:
        span = spans.get(cid)
        if span is not None:
            pieces.append(times[span[0] : span[1]])
    return pieces


def _keep(container: Container, cid: int, part: dict[str, np.ndarray], before: int) -> None:
    """Append a decoded part to the channel's current run of columns (or start a run sized
    from the summary's count of the messages still to come)."""
    items = container.parts.setdefault(cid, [])
    last = items[-1] if items else None
    if isinstance(last, Columns) and last.fits(part):
        last.add(part)
        return
    items.append(Columns(part, container.expected.get(cid, 0) - before))


def _bulk(
    container: Container, cid: int, seg: Segment, off: np.ndarray, ln: np.ndarray, before: int
) -> dict[str, np.ndarray] | None:
    """The bulk-decoded part, or None when it needs the generic decoder (big-endian CDR)."""
    rec = container.channels[cid]
    schema = container.schemas.get(rec.schema_id)
    type_name = normalize_type(schema.name) if schema is not None else ""
    u8 = seg.u8
    try:
        if rec.message_encoding == "ros1":
            return BULK_ROS1[type_name](u8, off, ln)
        if not _cdr.is_little_endian(u8, off, ln):
            return None
        return BULK_CDR[type_name](u8, off, ln)
    except _cdr.CdrLayoutError as exc:
        container.failed[cid] = (
            f"message {before + exc.index} of topic '{rec.topic}' in log file "
            f"'{container.name}' does not fit the {type_name} layout (it {exc.reason}); the "
            "file is corrupt or its schema is wrong"
        )
        for item in container.parts.pop(cid, []):  # its log times stay (counts, rates)
            if isinstance(item, Columns):
                container.times.setdefault(cid, []).append(item.log_times())
        return None


def with_yaw(part: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """An Odometry part with its quaternion replaced by the yaw (rotation about z, ZYX
    convention): one array kept per message instead of four."""
    if "qw" not in part:
        return part
    qx, qy, qz, qw = (part.pop(k) for k in ("qx", "qy", "qz", "qw"))
    part["yaw"] = np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    return part


def _compact(buf: Buf, off: np.ndarray, ln: np.ndarray, times: np.ndarray, cid: int) -> Segment:
    """The payloads at ``off``/``ln`` copied into one small buffer of their own."""
    view = memoryview(buf)
    data = b"".join(view[o : o + n] for o, n in zip(off.tolist(), ln.tolist(), strict=True))
    new_off = np.concatenate(([0], np.cumsum(ln)[:-1])).astype(np.int64)
    return Segment(
        buf=data,
        channel_id=np.full(ln.size, cid, dtype=np.int64),
        log_time_ns=times,
        payload_off=new_off,
        payload_len=ln.astype(np.int64),
    )


def times_only(container: Container, entries: list[tuple[int, np.ndarray]]) -> None:
    """Count messages known only by their log times (bag channels that are never decoded)."""
    for cid, t in entries:
        container.times.setdefault(cid, []).append(t.astype(np.int64))
        container.count += int(t.size)
