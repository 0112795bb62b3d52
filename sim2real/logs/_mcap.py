"""Low-level MCAP container scan (private): records, chunks and message offsets.

The scan walks the records of the file itself (``opcode u8, length u64, body``, MCAP spec
"Records") instead of going through :class:`mcap.reader.McapReader`, for two reasons: message
records are located with one light loop per chunk and their fields gathered with numpy (no
Python object per message), and every length is checked against the bytes that are really
there, so a truncated or corrupt file gives a precise error instead of a short read.

Chunks are read through their ``MessageIndex`` records (written right after each chunk; they
list every message's offset in the decompressed chunk) when these check out: every listed
offset must start a Message record inside the chunk, consecutive records must tile the chunk
and the few records between them (Schema, Channel) are walked and must not be messages, so the
result is exactly what a full walk gives, without a Python step per message. A chunk whose
index is missing, partial or wrong is walked record by record as before.

Integrity: chunk CRCs (``uncompressed_crc``) and the data-section CRC (``DataEnd``) are checked
when the writer filled them in (non-zero). Without a data CRC the message count is checked
against the ``Statistics`` record of the summary when there is one. A file with no CRC at all
(what rosbags and several recorders write) is flagged (``Container.checksums`` is False, and
``logs info`` says that corruption cannot be detected). A message whose channel id no Channel
record defines is an error naming its byte offset (it used to be dropped silently).
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

from sim2real.errors import LogFormatError
from sim2real.logs._cdr import gather

__all__ = ["MAGIC", "ChannelRecord", "Container", "SchemaRecord", "Segment", "scan_mcap"]

MAGIC = b"\x89MCAP0\r\n"

_HEADER, _FOOTER, _SCHEMA, _CHANNEL, _MESSAGE, _CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
_MESSAGE_INDEX, _STATISTICS, _DATA_END = 0x07, 0x0B, 0x0F
_MESSAGE_FIXED = 22  # channel_id u16, sequence u32, log_time u64, publish_time u64
_OP_LEN = struct.Struct("<BQ")


@dataclass(frozen=True)
class SchemaRecord:
    """One MCAP Schema record."""

    id: int
    name: str
    encoding: str
    data: bytes


@dataclass(frozen=True)
class ChannelRecord:
    """One MCAP Channel record."""

    id: int
    schema_id: int
    topic: str
    message_encoding: str


@dataclass
class Segment:
    """Message records found in one buffer (a decompressed chunk, or the file itself for
    uncompressed chunks and messages outside chunks).

    ``payload_off`` and ``payload_len`` locate each message's payload inside ``buf``.
    """

    buf: bytes
    channel_id: np.ndarray
    log_time_ns: np.ndarray
    payload_off: np.ndarray
    payload_len: np.ndarray

    @property
    def u8(self) -> np.ndarray:
        """The buffer as a read-only uint8 array (no copy)."""
        return np.frombuffer(self.buf, dtype=np.uint8)


@dataclass
class Container:
    """What a scan of an MCAP file found."""

    profile: str = ""
    library: str = ""
    schemas: dict[int, SchemaRecord] = field(default_factory=dict)
    channels: dict[int, ChannelRecord] = field(default_factory=dict)
    segments: list[Segment] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    #: True when the file carries a data-section CRC or a CRC on every chunk it has.
    checksums: bool = False
    #: The container format: "mcap", "ros1" (ROS 1 bag) or "rosbag2".
    format: str = "mcap"

    def message_count(self) -> int:
        """Total number of message records found."""
        return int(sum(s.channel_id.size for s in self.segments))


class _Corrupt(Exception):
    """Internal: a record breaks the format rules (turned into LogFormatError by the caller)."""


class _Cursor:
    """Bounded little-endian reader over ``buf[pos:end]``; overruns raise ``_Corrupt``."""

    def __init__(self, buf: bytes, pos: int, end: int) -> None:
        self.buf, self.pos, self.end = buf, pos, end

    def take(self, n: int) -> bytes:
        if n < 0 or self.pos + n > self.end:
            raise _Corrupt(f"a field of {n} bytes runs past its record end")
        out = self.buf[self.pos : self.pos + n]
        self.pos += n
        return out

    def u16(self) -> int:
        return int(struct.unpack("<H", self.take(2))[0])

    def u32(self) -> int:
        return int(struct.unpack("<I", self.take(4))[0])

    def u64(self) -> int:
        return int(struct.unpack("<Q", self.take(8))[0])

    def string(self) -> str:
        raw = self.take(self.u32())
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise _Corrupt("a string field is not valid UTF-8") from exc


def _schema(buf: bytes, pos: int, end: int) -> SchemaRecord:
    c = _Cursor(buf, pos, end)
    sid, name, enc = c.u16(), c.string(), c.string()
    return SchemaRecord(id=sid, name=name, encoding=enc, data=c.take(c.u32()))


def _channel(buf: bytes, pos: int, end: int) -> ChannelRecord:
    c = _Cursor(buf, pos, end)
    cid, sid, topic, enc = c.u16(), c.u16(), c.string(), c.string()
    return ChannelRecord(id=cid, schema_id=sid, topic=topic, message_encoding=enc)


def _decompress(compression: str, data: bytes, size: int) -> bytes:
    try:
        if compression == "zstd":
            import zstandard

            return bytes(zstandard.ZstdDecompressor().decompress(data, max_output_size=size))
        if compression == "lz4":
            import lz4.frame  # type: ignore[import-untyped]

            return bytes(lz4.frame.decompress(data))
    except Exception as exc:  # the codecs raise their own error types on corrupt input
        raise _Corrupt(f"its {compression} data does not decompress ({exc})") from exc
    raise _Corrupt(f"it uses compression '{compression}', which is not zstd, lz4 or none")


def _chunk_records(buf: bytes, pos: int, end: int) -> tuple[bytes, int, int, bool]:
    """The records of the Chunk record ``buf[pos:end]`` as ``(records_buf, lo, hi, has_crc)``.

    Uncompressed records stay where they are in ``buf`` (no copy); compressed ones are
    decompressed into a new buffer (``lo = 0``).
    """
    c = _Cursor(buf, pos, end)
    c.take(16)  # message start/end time
    size, crc = c.u64(), c.u32()
    compression = c.string()
    stored = c.u64()
    lo = c.pos
    if stored > end - lo:
        raise _Corrupt(f"a field of {stored} bytes runs past its record end")
    if compression == "":
        data, hi = buf, lo + stored
    else:
        data = _decompress(compression, buf[lo : lo + stored], size)
        lo, hi = 0, len(data)
    if hi - lo != size:
        raise _Corrupt(f"it holds {hi - lo} bytes of records but says {size}")
    if crc != 0 and zlib.crc32(memoryview(data)[lo:hi]) != crc:
        raise _Corrupt("its CRC does not match its records")
    return data, lo, hi, crc != 0


def _segment(buf: bytes, starts: list[int]) -> Segment:
    """Gather the fixed message fields of the message records starting at ``starts``."""
    u8 = np.frombuffer(buf, dtype=np.uint8)
    pos = np.asarray(starts, dtype=np.int64)
    length = gather(u8, pos + 1, "<u8").astype(np.int64)
    if np.any(length < _MESSAGE_FIXED):
        raise _Corrupt("a message record is shorter than its fixed fields")
    body = pos + 9
    return Segment(
        buf=buf,
        channel_id=gather(u8, body, "<u2").astype(np.int64),
        log_time_ns=gather(u8, body + 6, "<u8").astype(np.int64),
        payload_off=body + _MESSAGE_FIXED,
        payload_len=length - _MESSAGE_FIXED,
    )


def _scan_chunk(buf: bytes, lo: int, hi: int, out: Container) -> None:
    """Walk the records of one chunk, ``buf[lo:hi]``, one by one.

    The hot loop only records where message records start; a record running past the chunk
    end can only be the last one, so one check after the loop covers every length.
    """
    pos, head_end = lo, hi - 9  # the last position where a record header fits
    starts: list[int] = []
    append, unpack = starts.append, _OP_LEN.unpack_from
    while pos < hi:
        if pos > head_end:
            raise _Corrupt("a record inside it is cut short")
        op, length = unpack(buf, pos)
        if op == 5:  # Message
            append(pos)
        elif op in (_SCHEMA, _CHANNEL):
            _chunk_meta(buf, op, pos, hi, out)
        pos += 9 + length
    if pos != hi:
        raise _Corrupt("a record inside it runs past the chunk end")
    if starts:
        out.segments.append(_segment(buf, starts))


def _index_offsets(data: bytes, pos: int, end: int) -> np.ndarray | None:
    """Message offsets listed by the MessageIndex record ``data[pos:end]`` (None if malformed).

    Body: ``channel_id u16, records_len u32, (log_time u64, offset u64) * k``.
    """
    body = end - pos - 9
    if body < 6:
        return None
    size = int(struct.unpack_from("<I", data, pos + 11)[0])
    if size % 16 or 6 + size != body:
        return None
    pairs = np.frombuffer(data, dtype="<u8", count=size // 8, offset=pos + 15)
    return pairs[1::2]


def _scan_chunk_indexed(
    buf: bytes, lo: int, hi: int, offsets: list[np.ndarray], out: Container
) -> bool:
    """Read one chunk, ``buf[lo:hi]``, through its message index; False if that does not check out.

    ``offsets`` are the indexed message offsets, relative to ``lo``. Accepted only when the
    indexed Message records and the records walked between them tile the chunk exactly as
    :func:`_scan_chunk` would walk it, and no walked record is a message: then the outcome
    (records found, errors raised) is the same as the full walk's. ``out`` is untouched when
    False is returned.
    """
    n = hi - lo
    rel = np.sort(np.concatenate(offsets))
    if rel.size == 0 or n < 9 + _MESSAGE_FIXED or int(rel[-1]) > n - 9 - _MESSAGE_FIXED:
        return False  # (also rejects offsets that would overflow int64 below)
    starts = rel.astype(np.int64) + lo
    rows = _fixed_fields(buf, starts)
    length = rows["length"]
    if not (np.all(rows["op"] == _MESSAGE) and np.all(length <= n)):
        return False
    gap_lo = np.concatenate(([lo], starts + 9 + length.astype(np.int64)))
    gap_hi = np.concatenate((starts, [hi]))
    if np.any(gap_lo > gap_hi):
        return False  # overlapping or duplicate entries, or a record past the chunk end
    gaps = gap_lo < gap_hi
    meta: list[tuple[int, int]] = []
    for a, b in zip(gap_lo[gaps].tolist(), gap_hi[gaps].tolist(), strict=True):
        if not _walk_gap(buf, a, b, meta):
            return False
    for op, pos in meta:
        _chunk_meta(buf, op, pos, hi, out)
    length = length.astype(np.int64)
    if np.any(length < _MESSAGE_FIXED):
        raise _Corrupt("a message record is shorter than its fixed fields")  # as _segment
    out.segments.append(
        Segment(
            buf=buf,
            channel_id=rows["channel_id"].astype(np.int64),
            log_time_ns=rows["log_time"].astype(np.int64),
            payload_off=starts + 9 + _MESSAGE_FIXED,
            payload_len=length - _MESSAGE_FIXED,
        )
    )
    return True


#: The fixed head of a Message record: opcode, record length, channel id, sequence, log time.
_FIXED_HEAD = np.dtype(
    {
        "names": ["op", "length", "channel_id", "log_time"],
        "formats": ["u1", "<u8", "<u2", "<u8"],
        "offsets": [0, 1, 9, 15],
        "itemsize": 9 + 14,
    }
)


def _fixed_fields(buf: bytes, starts: np.ndarray) -> np.ndarray:
    """The :data:`_FIXED_HEAD` fields of the records at ``starts`` (each needs 23 bytes in buf).

    One row copy per record through a sliding window of the buffer, instead of one gather
    per field.
    """
    u8 = np.frombuffer(buf, dtype=np.uint8)
    size = _FIXED_HEAD.itemsize
    window = np.lib.stride_tricks.as_strided(
        u8, shape=(u8.size - size + 1, size), strides=(1, 1), writeable=False
    )
    return window[starts].view(_FIXED_HEAD).reshape(-1)


def _walk_gap(buf: bytes, pos: int, end: int, meta: list[tuple[int, int]]) -> bool:
    """Walk the records of ``buf[pos:end]``; False on a message or when they do not fit."""
    while pos < end:
        if pos + 9 > end:
            return False
        op, length = _OP_LEN.unpack_from(buf, pos)
        if op == _MESSAGE:
            return False  # a message the index does not list
        if op in (_SCHEMA, _CHANNEL):
            meta.append((op, pos))
        pos += 9 + length
    return pos == end


def _chunk_meta(buf: bytes, op: int, pos: int, hi: int, out: Container) -> None:
    end = pos + 9 + _OP_LEN.unpack_from(buf, pos)[1]
    if end > hi:
        raise _Corrupt("a record inside it runs past the chunk end")
    if op == _SCHEMA:
        _add_schema(out, _schema(buf, pos + 9, end))
    else:
        _add_channel(out, _channel(buf, pos + 9, end))


def _add_schema(out: Container, rec: SchemaRecord) -> None:
    old = out.schemas.get(rec.id)
    if old is not None and old != rec:
        raise _Corrupt(f"schema id {rec.id} is defined twice with different content")
    out.schemas[rec.id] = rec


def _add_channel(out: Container, rec: ChannelRecord) -> None:
    old = out.channels.get(rec.id)
    if old is not None and old != rec:
        raise _Corrupt(f"channel id {rec.id} is defined twice with different content")
    out.channels[rec.id] = rec


def scan_mcap(data: bytes, *, name: str) -> Container:
    """Scan the bytes of an MCAP file; raise :class:`LogFormatError` when they are not safe.

    A file cut short (a recorder killed mid-write) keeps every complete record before the cut,
    with a warning; any other broken record makes the whole file unusable.
    """
    if len(data) == 0:
        raise LogFormatError(
            f"log file '{name}' is empty (0 bytes); record a log or pick another file"
        )
    if data[: len(MAGIC)] != MAGIC:
        raise LogFormatError(
            f"log file '{name}' is not an MCAP file (its first bytes are {data[:8]!r}, an MCAP "
            f"file starts with {MAGIC!r}); convert it with `ros2 bag convert` or "
            "`rosbags-convert --dst-storage mcap`"
        )
    out, pos, n = Container(), len(MAGIC), len(data)
    top_starts: list[int] = []
    data_end: int | None = None
    data_crc = 0
    stats_count: int | None = None
    pending: list[_Pending] = []
    origins: list[_Origin] = []
    chunk_crcs: list[bool] = []
    while True:
        if pos + 9 > n:
            _truncated(out, name, pos, n, data_end)
            break
        op, length = _OP_LEN.unpack_from(data, pos)
        end = pos + 9 + length
        if end > n:
            _truncated(out, name, pos, n, data_end)
            break
        try:
            if data_end is None and op == _MESSAGE_INDEX:
                _add_index(pending, data, pos, end)
            elif data_end is None:
                _flush(pending, out, name, origins, chunk_crcs)
                data_crc = _data_record(data, op, pos, end, out, top_starts, pending)
            elif op == _STATISTICS:
                stats_count = _Cursor(data, pos + 9, end).u64()
        except _Corrupt as exc:
            raise LogFormatError(
                f"log file '{name}' is corrupt: the record at byte {pos} is broken ({exc}); "
                "the file cannot be read safely, re-export or re-record it"
            ) from None
        if op == _DATA_END and data_end is None:
            data_end = pos
            if data_crc != 0 and zlib.crc32(memoryview(data)[:pos]) != data_crc:
                raise LogFormatError(
                    f"log file '{name}' is corrupt: its data section does not match its CRC; "
                    "the file cannot be read safely, re-export or re-record it"
                )
        if op == _FOOTER:
            break
        pos = end
    _flush(pending, out, name, origins, chunk_crcs)
    if top_starts:
        out.segments.append(_segment_safe(data, top_starts, name))
        origins.append(_Origin(-1, 0, data))
    _check_channel_ids(out, origins, data, name)
    out.checksums = data_crc != 0 or (bool(chunk_crcs) and all(chunk_crcs))
    if data_end is not None and data_crc == 0 and stats_count is not None:
        found = out.message_count()
        if found != stats_count:
            raise LogFormatError(
                f"log file '{name}' is corrupt: its summary counts {stats_count} messages but "
                f"its data section holds {found}; re-export or re-record it"
            )
    out.segments = _merged(out.segments)
    return out


def _merged(segments: list[Segment]) -> list[Segment]:
    """Join neighbouring segments over the same buffer (in-place chunks of one file), in order.

    Fewer, longer segments keep the per-segment numpy work of the decoders small.
    """
    runs: list[list[Segment]] = []
    for seg in segments:
        if runs and runs[-1][0].buf is seg.buf:
            runs[-1].append(seg)
        else:
            runs.append([seg])
    return [run[0] if len(run) == 1 else _join(run) for run in runs]


def _join(run: list[Segment]) -> Segment:
    def cat(key: str) -> np.ndarray:
        return np.concatenate([getattr(s, key) for s in run])

    return Segment(
        buf=run[0].buf,
        channel_id=cat("channel_id"),
        log_time_ns=cat("log_time_ns"),
        payload_off=cat("payload_off"),
        payload_len=cat("payload_len"),
    )


def _segment_safe(data: bytes, starts: list[int], name: str) -> Segment:
    try:
        return _segment(data, starts)
    except _Corrupt as exc:
        raise LogFormatError(f"log file '{name}' is corrupt ({exc}); re-export it") from None


@dataclass
class _Pending:
    """A decompressed chunk waiting for the MessageIndex records that follow it."""

    pos: int
    buf: bytes
    lo: int
    hi: int
    offsets: list[np.ndarray] = field(default_factory=list)
    usable: bool = True
    has_crc: bool = False


def _add_index(pending: list[_Pending], data: bytes, pos: int, end: int) -> None:
    """Attach a MessageIndex record to the chunk before it (a malformed one disables the index)."""
    if not pending:
        return
    offsets = _index_offsets(data, pos, end)
    if offsets is None:
        pending[-1].usable = False
    else:
        pending[-1].offsets.append(offsets)


def _flush(
    pending: list[_Pending], out: Container, name: str, origins: list[_Origin], crcs: list[bool]
) -> None:
    """Scan the pending chunks: through their index when it checks out, else record by record.

    Each new segment's origin (the chunk's file offset) goes to ``origins``, each chunk's
    CRC presence to ``crcs``.
    """
    for chunk in pending:
        before = len(out.segments)
        crcs.append(chunk.has_crc)
        try:
            if not (chunk.usable and chunk.offsets) or not _scan_chunk_indexed(
                chunk.buf, chunk.lo, chunk.hi, chunk.offsets, out
            ):
                _scan_chunk(chunk.buf, chunk.lo, chunk.hi, out)
        except _Corrupt as exc:
            raise LogFormatError(
                f"log file '{name}' is corrupt: the record at byte {chunk.pos} is broken ({exc}); "
                "the file cannot be read safely, re-export or re-record it"
            ) from None
        origins.extend(_Origin(chunk.pos, chunk.lo, chunk.buf) for _ in out.segments[before:])
    pending.clear()


@dataclass(frozen=True)
class _Origin:
    """Where a segment's records are: in the chunk record at ``chunk_pos`` (``lo`` is where the
    chunk's records start in ``buf``), or outside chunks (``chunk_pos`` -1, ``buf`` the file)."""

    chunk_pos: int
    lo: int
    buf: bytes


def _check_channel_ids(out: Container, origins: list[_Origin], data: bytes, name: str) -> None:
    """Every message names a defined channel; else a LogFormatError naming its byte offset."""
    known = np.fromiter(out.channels, dtype=np.int64, count=len(out.channels))
    for seg, origin in zip(out.segments, origins, strict=True):
        bad = np.flatnonzero(~np.isin(seg.channel_id, known))
        if bad.size == 0:
            continue
        i = int(bad[0])
        record = int(seg.payload_off[i]) - 9 - _MESSAGE_FIXED
        if origin.buf is data:
            where = f"the message record at byte {record}"
        else:
            where = (
                f"the message record at byte {record - origin.lo} of the decompressed chunk "
                f"at byte {origin.chunk_pos}"
            )
        raise LogFormatError(
            f"log file '{name}' is corrupt: {where} names channel id {int(seg.channel_id[i])}, "
            f"which no Channel record defines ({bad.size} such message(s)); the file cannot be "
            "read safely, re-export or re-record it"
        )


def _data_record(
    data: bytes,
    op: int,
    pos: int,
    end: int,
    out: Container,
    top_starts: list[int],
    pending: list[_Pending],
) -> int:
    """Handle one record of the data section; return the data CRC when it is DataEnd.

    A chunk is decompressed and checked now, and scanned by :func:`_flush` once the
    MessageIndex records after it are known.
    """
    if op == _MESSAGE:
        top_starts.append(pos)
    elif op == _CHUNK:
        buf, lo, hi, has_crc = _chunk_records(data, pos + 9, end)
        pending.append(_Pending(pos, buf, lo, hi, has_crc=has_crc))
    elif op == _SCHEMA:
        _add_schema(out, _schema(data, pos + 9, end))
    elif op == _CHANNEL:
        _add_channel(out, _channel(data, pos + 9, end))
    elif op == _HEADER:
        c = _Cursor(data, pos + 9, end)
        out.profile, out.library = c.string(), c.string()
    elif op == _DATA_END:
        return _Cursor(data, pos + 9, end).u32()
    return 0


def _truncated(out: Container, name: str, pos: int, n: int, data_end: int | None) -> None:
    if data_end is not None:
        out.warnings.append(
            f"log file '{name}' ends inside its summary section (byte {pos} of {n}); "
            "every message was read, only the index is missing"
        )
        return
    out.warnings.append(
        f"log file '{name}' is truncated at byte {n} (the recording stopped mid-write); "
        f"read the complete records before byte {pos} and dropped the rest"
    )
