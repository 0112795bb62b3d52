"""Low-level MCAP container scan (private): records, chunks and message offsets, streamed.

The scan walks the records of the file itself (``opcode u8, length u64, body``, MCAP spec
"Records") instead of going through :class:`mcap.reader.McapReader`, for three reasons:
message records are located with one light loop per chunk and their fields gathered with
numpy (no Python object per message); every length is checked against the bytes that are
really there, so a truncated or corrupt file gives a precise error instead of a short read;
and the file is *streamed*: :func:`stream_mcap` reads it record by record and holds one chunk
at a time (mapped read-only when it is large, decompressed when it is compressed), hands the
chunk's messages to a sink as a :class:`Segment` and drops it. The reader's sink
(:func:`sim2real.logs._accum.add_segment`) decodes the wanted channels into small typed
arrays right away, so memory follows the output and the largest chunk, not the file.

Chunks are read through their ``MessageIndex`` records (written right after each chunk; they
list every message's offset in the decompressed chunk) when these check out: every listed
offset must start a Message record inside the chunk, consecutive records must tile the chunk
and the few records between them (Schema, Channel) are walked and must not be messages, so the
result is exactly what a full walk gives, without a Python step per message. A chunk whose
index is missing, partial or wrong is walked record by record as before.

Integrity: chunk CRCs (``uncompressed_crc``) and the data-section CRC (``DataEnd``) are checked
when the writer filled them in (non-zero); the data CRC runs over the bytes as they stream past
(the footer says up front whether there is one). Without a data CRC the message count is
checked against the ``Statistics`` record of the summary when there is one. A file with no
CRC at all (what rosbags and several recorders write) is flagged (``Container.checksums`` is
False, and ``logs info`` says that corruption cannot be detected). A message whose channel id
no Channel record defines is an error naming its byte offset (never dropped silently). A
record that runs past the end of the file is a recording cut short (its complete records are
kept, with a warning) only when the file's end is missing too: in a finished file (Footer and
closing magic intact) it is a broken length field, and an error.
"""

from __future__ import annotations

import io
import mmap
import struct
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, BinaryIO

import numpy as np

from sim2real.errors import LogFormatError
from sim2real.logs._cdr import gather, rows

__all__ = [
    "MAGIC",
    "ChannelRecord",
    "Columns",
    "Container",
    "LogRecords",
    "SchemaRecord",
    "Segment",
    "Sink",
    "scan_mcap",
    "stream_mcap",
]

MAGIC = b"\x89MCAP0\r\n"

_HEADER, _FOOTER, _SCHEMA, _CHANNEL, _MESSAGE, _CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
_MESSAGE_INDEX, _STATISTICS, _DATA_END = 0x07, 0x0B, 0x0F
_MESSAGE_FIXED = 22  # channel_id u16, sequence u32, log_time u64, publish_time u64
_OP_LEN = struct.Struct("<BQ")
#: A record buffer: bytes read from the file, or a read-only mapping of it (``mmap``).
Buf = bytes | memoryview


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

    buf: Buf
    channel_id: np.ndarray
    log_time_ns: np.ndarray
    payload_off: np.ndarray
    payload_len: np.ndarray

    @property
    def u8(self) -> np.ndarray:
        """The buffer as a read-only uint8 array (no copy)."""
        return np.frombuffer(self.buf, dtype=np.uint8)


class Columns:
    """The decoded fields of one channel's run of messages, written into whole arrays.

    The arrays are allocated once at the size the log's summary states for the channel
    (``capacity``), so the decoded chunks are copied straight into their final place instead
    of being kept as many small arrays and joined at the end (which left the small arrays'
    freed memory resident and doubled the peak). More messages than stated grow the arrays by
    doubling; fewer are trimmed by :meth:`take`. The result is the same either way.
    """

    __slots__ = ("arrays", "fill")

    def __init__(self, part: dict[str, np.ndarray], capacity: int) -> None:
        size = max(capacity, _part_size(part))
        self.arrays = {k: np.empty(size, dtype=v.dtype) for k, v in part.items()}
        self.fill = 0
        self.add(part)

    def fits(self, part: dict[str, np.ndarray]) -> bool:
        """True when ``part`` has this run's fields and dtypes (it can be appended)."""
        return part.keys() == self.arrays.keys() and all(
            part[k].dtype == a.dtype for k, a in self.arrays.items()
        )

    def add(self, part: dict[str, np.ndarray]) -> None:
        """Append ``part`` (same fields as the first part) after the messages so far."""
        n = _part_size(part)
        end = self.fill + n
        size = next(iter(self.arrays.values())).size
        if end > size:
            grown = max(2 * size, end)
            for k, a in self.arrays.items():
                new = np.empty(grown, dtype=a.dtype)
                new[: self.fill] = a[: self.fill]
                self.arrays[k] = new
        for k, a in self.arrays.items():
            a[self.fill : end] = part[k]
        self.fill = end

    def log_times(self) -> np.ndarray:
        """The ``log_ns`` field of the messages added so far (a view)."""
        return self.arrays["log_ns"][: self.fill]

    def take(self) -> dict[str, np.ndarray]:
        """The fields of the messages added so far (the arrays themselves when they are full)."""
        if all(a.size == self.fill for a in self.arrays.values()):
            return dict(self.arrays)
        return {k: a[: self.fill].copy() for k, a in self.arrays.items()}


def _part_size(part: dict[str, np.ndarray]) -> int:
    return int(next(iter(part.values())).size)


@dataclass
class LogRecords:
    """What every reading of a log holds: the header's profile and library, the schemas and
    the channels by id."""

    profile: str = ""
    library: str = ""
    schemas: dict[int, SchemaRecord] = field(default_factory=dict)
    channels: dict[int, ChannelRecord] = field(default_factory=dict)


@dataclass
class Container(LogRecords):
    """What a scan of an MCAP file found."""

    segments: list[Segment] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    #: True when the file carries a data-section CRC or a CRC on every chunk it has.
    checksums: bool = False
    #: The container format: "mcap", "ros1" (ROS 1 bag) or "rosbag2".
    format: str = "mcap"
    #: Message records found (with or without kept segments).
    count: int = 0
    #: Per channel id: its log-time arrays, one per segment (filled by a sink), except those
    #: kept in the channel's :class:`Columns` (see ``sim2real.logs._accum.channel_times``).
    times: dict[int, list[np.ndarray]] = field(default_factory=dict)
    #: Per segment: the log times of its channels that are not decoded, grouped by channel,
    #: and each such channel's span in them (filled by a sink; see ``channel_times``).
    skipped: list[tuple[np.ndarray, dict[int, tuple[int, int]]]] = field(default_factory=list)
    #: Per channel id: messages handed to the sink so far (the decoded channels).
    counts: dict[int, int] = field(default_factory=dict)
    #: Per channel id: its decoded runs (:class:`Columns`) or kept payload segments, in order.
    parts: dict[int, list[Columns | Segment]] = field(default_factory=dict)
    #: Per channel id: its message count as the summary states it (sizes :class:`Columns`).
    expected: dict[int, int] = field(default_factory=dict)
    #: Per channel id: why its messages cannot be decoded (raised when it is asked for).
    failed: dict[int, str] = field(default_factory=dict)
    #: Schema and Channel records already taken in, byte for byte (repeated in each chunk).
    seen_meta: set[bytes] = field(default_factory=set)
    #: Per channel id: how a sink keeps its messages (sink's own cache).
    plans: dict[int, str] = field(default_factory=dict)
    #: The log's name for messages (set by the reader).
    name: str = ""
    #: True: a sink keeps log times only (``logs info``), no payload is decoded.
    times_only: bool = False
    #: Message types whose payloads a sink keeps besides the drive types (e.g. LaserScan).
    keep_types: tuple[str, ...] = ()

    def message_count(self) -> int:
        """Total number of message records found."""
        return self.count


class _Corrupt(Exception):
    """Internal: a record breaks the format rules (turned into LogFormatError by the caller)."""


class _Cursor:
    """Bounded little-endian reader over ``buf[pos:end]``; overruns raise ``_Corrupt``."""

    def __init__(self, buf: Buf, pos: int, end: int) -> None:
        self.buf, self.pos, self.end = buf, pos, end

    def _at(self, n: int) -> int:
        """The position of the next ``n`` bytes (then skipped); overruns raise ``_Corrupt``."""
        at = self.pos
        if n < 0 or at + n > self.end:
            raise _Corrupt(f"a field of {n} bytes runs past its record end")
        self.pos = at + n
        return at

    def take(self, n: int) -> bytes:
        at = self._at(n)
        return bytes(self.buf[at : at + n])

    def u16(self) -> int:
        return int(_U16.unpack_from(self.buf, self._at(2))[0])

    def u32(self) -> int:
        return int(_U32.unpack_from(self.buf, self._at(4))[0])

    def u64(self) -> int:
        return int(_U64.unpack_from(self.buf, self._at(8))[0])

    def string(self) -> str:
        n = self.u32()
        at = self._at(n)
        try:
            return str(self.buf[at : at + n], "utf-8")
        except UnicodeDecodeError as exc:
            raise _Corrupt("a string field is not valid UTF-8") from exc


_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")
_U16_U32, _U16_U16_U32 = struct.Struct("<HI"), struct.Struct("<HHI")


def _schema(buf: Buf, pos: int, end: int) -> SchemaRecord:
    """The Schema record body ``buf[pos:end]``: ``id u16, name str, encoding str, data``."""
    try:  # the fields read straight; anything odd is left to the checked walk below
        sid, n = _U16_U32.unpack_from(buf, pos)
        a, b = pos + 6, pos + 6 + n
        c = b + 4
        d = c + _U32.unpack_from(buf, b)[0]
        e = d + 4
        f = e + _U32.unpack_from(buf, d)[0]
        if f <= end:  # every field inside the record (lengths are unsigned)
            name, enc = str(buf[a:b], "utf-8"), str(buf[c:d], "utf-8")
            return SchemaRecord(id=sid, name=name, encoding=enc, data=bytes(buf[e:f]))
    except (struct.error, UnicodeDecodeError):
        pass
    cur = _Cursor(buf, pos, end)  # raises the precise error
    sid, name, enc = cur.u16(), cur.string(), cur.string()
    return SchemaRecord(id=sid, name=name, encoding=enc, data=cur.take(cur.u32()))


def _channel(buf: Buf, pos: int, end: int) -> ChannelRecord:
    """The Channel record body ``buf[pos:end]``: ``id u16, schema_id u16, topic str,
    message_encoding str`` (its metadata map is not read)."""
    try:  # as in _schema
        cid, sid, n = _U16_U16_U32.unpack_from(buf, pos)
        a, b = pos + 8, pos + 8 + n
        c = b + 4
        d = c + _U32.unpack_from(buf, b)[0]
        if d <= end:
            topic, enc = str(buf[a:b], "utf-8"), str(buf[c:d], "utf-8")
            return ChannelRecord(id=cid, schema_id=sid, topic=topic, message_encoding=enc)
    except (struct.error, UnicodeDecodeError):
        pass
    cur = _Cursor(buf, pos, end)
    cid, sid, topic, enc = cur.u16(), cur.u16(), cur.string(), cur.string()
    return ChannelRecord(id=cid, schema_id=sid, topic=topic, message_encoding=enc)


def _codec(compression: str) -> Any:
    """The module of a chunk compression, imported on first use (compressed chunks only)."""
    if compression == "zstd":
        import zstandard

        return zstandard
    if compression == "lz4":
        import lz4.frame  # type: ignore[import-untyped]

        return lz4.frame
    raise _Corrupt(f"it uses compression '{compression}', which is not zstd, lz4 or none")


def _decompress(compression: str, data: Buf, size: int) -> bytes:
    codec = _codec(compression)
    try:
        if compression == "zstd":
            return bytes(codec.ZstdDecompressor().decompress(data, max_output_size=size))
        return bytes(codec.decompress(data))
    except Exception as exc:  # the codecs raise their own error types on corrupt input
        raise _Corrupt(f"its {compression} data does not decompress ({exc})") from exc


def _decompress_prefix(compression: str, data: Buf) -> bytes:
    """What the start of a cut compressed stream decompresses to (b"" when nothing does)."""
    try:
        codec = _codec(compression)
        if compression == "zstd":
            return bytes(codec.ZstdDecompressor().decompressobj().decompress(bytes(data)))
        return bytes(codec.LZ4FrameDecompressor().decompress(bytes(data)))
    except Exception:  # an unknown compression, or the codec's own error: the cut part is lost
        return b""


def _cut_chunk_records(buf: Buf) -> tuple[Buf, int, int] | None:
    """The complete records at the start of a Chunk record cut by the end of the file
    (``buf`` is its body up to the cut) as ``(records_buf, lo, hi)``; None when none is."""
    c = _Cursor(buf, 0, len(buf))
    try:
        c.take(16)  # message start/end time
        c.u64(), c.u32()  # records size and CRC: neither holds for a cut chunk
        compression = c.string()
        c.u64()
    except _Corrupt:
        return None
    lo, end, data = c.pos, len(buf), buf
    if compression:
        data = _decompress_prefix(compression, memoryview(buf)[lo:])
        lo, end = 0, len(data)
    hi = lo
    while hi + 9 <= end:
        length = _OP_LEN.unpack_from(data, hi)[1]
        if hi + 9 + length > end:
            break
        hi += 9 + length
    return (data, lo, hi) if hi > lo else None


def _chunk_records(buf: Buf, pos: int, end: int) -> tuple[Buf, int, int, bool]:
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


def _segment(buf: Buf, starts: list[int]) -> Segment:
    """Gather the fixed message fields of the message records starting at ``starts``."""
    u8 = np.frombuffer(buf, dtype=np.uint8)
    pos = np.asarray(starts, dtype=np.int64)
    length = gather(u8, pos + 1, "<u8").astype(np.int64)
    if (length < _MESSAGE_FIXED).any():
        raise _Corrupt("a message record is shorter than its fixed fields")
    body = pos + 9
    return Segment(
        buf=buf,
        channel_id=gather(u8, body, "<u2").astype(np.int64),
        log_time_ns=gather(u8, body + 6, "<u8").astype(np.int64),
        payload_off=body + _MESSAGE_FIXED,
        payload_len=length - _MESSAGE_FIXED,
    )


def _scan_chunk(buf: Buf, lo: int, hi: int, out: Container) -> None:
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
    return _index_body_offsets(data, pos + 9, end)


def _index_body_offsets(data: Buf, start: int, end: int) -> np.ndarray | None:
    """:func:`_index_offsets` of the record whose body is ``data[start:end]``."""
    body = end - start
    if body < 6:
        return None
    size = int(_U32.unpack_from(data, start + 2)[0])
    if size % 16 or 6 + size != body:
        return None
    pairs = np.frombuffer(data, dtype="<u8", count=size // 8, offset=start + 6)
    return pairs[1::2]


def _scan_chunk_indexed(
    buf: Buf, lo: int, hi: int, offsets: list[np.ndarray], out: Container
) -> bool:
    """Read one chunk, ``buf[lo:hi]``, through its message index; False if that does not check out.

    ``offsets`` are the indexed message offsets, relative to ``lo``. Accepted only when the
    indexed Message records and the records walked between them tile the chunk exactly as
    :func:`_scan_chunk` would walk it, and no walked record is a message: then the outcome
    (records found, errors raised) is the same as the full walk's. ``out`` is untouched when
    False is returned.
    """
    n = hi - lo
    rel = np.concatenate(offsets)
    rel.sort(kind="stable")  # timsort merges the sorted per-channel runs in linear time
    if rel.size == 0 or n < 9 + _MESSAGE_FIXED or int(rel[-1]) > n - 9 - _MESSAGE_FIXED:
        return False  # (also rejects offsets that would overflow int64 below)
    starts = rel.astype(np.int64)
    if lo:
        starts += lo
    head = _fixed_fields(buf, starts)
    length = head["length"]
    if not (head["op"] == _MESSAGE).all() or int(length.max()) > n:
        return False
    size = length.astype(np.int64)
    ends = starts + size
    ends += 9
    # gap[i]: bytes between the end of record i - 1 (the chunk start for i = 0) and the
    # start of record i (the chunk end for i = k); negative: overlapping or duplicate
    # entries, or a record past the chunk end
    k = starts.size
    gap = np.empty(k + 1, dtype=np.int64)
    gap[:k] = starts
    gap[k] = hi
    gap[1:] -= ends
    gap[0] -= lo
    if int(gap.min()) < 0:
        return False
    if gap.any():  # records that are not indexed (Schema, Channel) lie between them
        meta: list[tuple[int, int]] = []
        for i in np.flatnonzero(gap).tolist():
            a = lo if i == 0 else int(ends[i - 1])
            if not _walk_gap(buf, a, hi if i == k else int(starts[i]), meta):
                return False
        for op, pos in meta:
            _chunk_meta(buf, op, pos, hi, out)
    if int(length.min()) < _MESSAGE_FIXED:
        raise _Corrupt("a message record is shorter than its fixed fields")  # as _segment
    starts += 9 + _MESSAGE_FIXED  # now the payload offsets
    size -= _MESSAGE_FIXED  # now the payload lengths
    out.segments.append(
        Segment(
            buf=buf,
            channel_id=head["channel_id"].astype(np.int64),
            log_time_ns=head["log_time"].astype(np.int64),
            payload_off=starts,
            payload_len=size,
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


def _fixed_fields(buf: Buf, starts: np.ndarray) -> np.ndarray:
    """The :data:`_FIXED_HEAD` fields of the records at ``starts`` (each needs 23 bytes in buf).

    One row copy per record (:func:`sim2real.logs._cdr.rows`), instead of one gather per
    field.
    """
    return rows(np.frombuffer(buf, dtype=np.uint8), starts, _FIXED_HEAD)


def _walk_gap(buf: Buf, pos: int, end: int, meta: list[tuple[int, int]]) -> bool:
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


def _chunk_meta(buf: Buf, op: int, pos: int, hi: int, out: Container) -> None:
    end = pos + 9 + _OP_LEN.unpack_from(buf, pos)[1]
    if end > hi:
        raise _Corrupt("a record inside it runs past the chunk end")
    raw = bytes(buf[pos:end])
    if raw in out.seen_meta:
        return  # the same record again (writers repeat them in every chunk): nothing new
    if op == _SCHEMA:
        _add_schema(out, _schema(buf, pos + 9, end))
    else:
        _add_channel(out, _channel(buf, pos + 9, end))
    out.seen_meta.add(raw)


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


#: Receives each segment of a streamed scan (after its channel ids are checked).
Sink = Callable[[Container, Segment], None]
_BLOCK = 1 << 20
#: Messages outside chunks are batched into segments of about this many bytes.
_LOOSE_BATCH = 1 << 20


def scan_mcap(data: bytes, *, name: str) -> Container:
    """Scan the bytes of an MCAP file held in memory, keeping every segment in
    ``Container.segments`` (tools and tests; :func:`stream_mcap` is what reading uses)."""
    return stream_mcap(io.BytesIO(data), len(data), name=name)


def stream_mcap(
    fh: BinaryIO,
    size: int,
    *,
    name: str,
    sink: Sink | None = None,
    container: Container | None = None,
) -> Container:
    """Scan an MCAP file record by record from ``fh`` (``size`` bytes); raise
    :class:`LogFormatError` when it is not safe.

    Only one chunk is held at a time: it is read, decompressed, CRC-checked, its message
    records located (through its MessageIndex records when they check out), and each
    resulting :class:`Segment` is handed to ``sink`` and dropped. Without a sink the segments
    are kept in ``Container.segments``. A file cut short (a recorder killed mid-write) keeps
    every complete record before the cut, with a warning; any other broken record makes the
    whole file unusable.
    """
    out = container if container is not None else Container(name=name)
    head = fh.read(len(MAGIC))
    if size == 0:
        raise LogFormatError(
            f"log file '{name}' is empty (0 bytes); record a log or pick another file"
        )
    if head != MAGIC:
        raise LogFormatError(
            f"log file '{name}' is not an MCAP file (its first bytes are {head[:8]!r}, an MCAP "
            f"file starts with {MAGIC!r}); convert it with `ros2 bag convert` or "
            "`rosbags-convert --dst-storage mcap`"
        )
    scan = _Stream(fh, size, name, sink, out)
    scan.run(head)
    return scan.out


def _read_footer(fh: BinaryIO, size: int) -> tuple[bool, int | None]:
    """Whether the file ends with a Footer record and the closing magic (a file the writer
    finished, which the end of the file cannot have cut short), and the data-section CRC from
    the DataEnd record that footer leads to (None: not found)."""
    tail_at = size - len(MAGIC) - 29
    if tail_at < len(MAGIC):
        return False, None
    fh.seek(tail_at)
    tail = fh.read(29 + len(MAGIC))
    op, length, start = struct.unpack_from("<BQQ", tail)
    if op != _FOOTER or length != 20:
        return False, None
    finished = tail[29:] == MAGIC
    end_at = (start if start else tail_at) - 13
    if not len(MAGIC) <= end_at <= tail_at - 13:
        return finished, None
    fh.seek(end_at)
    op, length, crc = struct.unpack("<BQI", fh.read(13))
    return finished, (int(crc) if (op, length) == (_DATA_END, 4) else None)


class _Stream:
    """State of one streamed scan (see :func:`stream_mcap`)."""

    def __init__(
        self, fh: BinaryIO, size: int, name: str, sink: Sink | None, out: Container
    ) -> None:
        self.fh, self.size, self.name, self.sink = fh, size, name, sink
        self.out = out
        self.fileno = _fileno(fh)
        self.known = np.zeros(1 << 16, dtype=bool)
        self.n_known = 0
        self.pending: list[_Pending] = []
        self.loose: list[tuple[int, bytes]] = []  # (file offset, record) outside chunks
        self.loose_bytes = 0
        self.stray: list[tuple[Segment, _Origin, np.ndarray]] = []
        self.chunk_crcs: list[bool] = []
        self.data_end: int | None = None
        self.data_crc = 0
        self.stats_count: int | None = None
        self.kept: list[Segment] = []
        self.cut_bytes = 0  # records read from a chunk the end of the file cut

    def run(self, head: bytes) -> None:
        fh, n = self.fh, self.size
        finished, want_crc = _read_footer(fh, n)
        crc: int | None = zlib.crc32(head) if want_crc != 0 else None  # None: not computed
        fh.seek(len(MAGIC))
        pos = len(MAGIC)
        while True:
            if pos + 9 > n:
                self._truncated(pos)
                break
            rec_head = fh.read(9)
            op, length = _OP_LEN.unpack(rec_head)
            end = pos + 9 + length
            if end > n:
                if finished:  # not a recording cut short: the length field is broken
                    raise self._broken(
                        pos, _Corrupt(f"its length of {length} bytes runs past the file's footer")
                    )
                if op == _CHUNK and self.data_end is None:
                    self._cut_chunk(pos, _read_exact(fh, n - pos - 9))
                self._truncated(pos)
                break
            in_data = self.data_end is None
            body: bytes | memoryview
            if op in _SKIPPED and not (in_data and crc is not None):
                fh.seek(end)
                body = b""
            elif op == _CHUNK and in_data and self.fileno is not None and length >= _MAP_MIN:
                body = _mapped(self.fileno, pos + 9, length)  # no copy of the chunk
                fh.seek(end)
            else:
                body = _read_exact(fh, length)
            if in_data and crc is not None and op != _DATA_END:
                crc = zlib.crc32(body, zlib.crc32(rec_head, crc))
            try:
                if in_data:
                    self._data_record(op, pos, rec_head, body)
                elif op == _STATISTICS:
                    self.stats_count = _Cursor(body, 0, length).u64()
            except _Corrupt as exc:
                raise self._broken(pos, exc) from None
            if op == _DATA_END and in_data:
                self.data_end = pos
                self._check_data_crc(crc, pos)
                if n - end <= _TAIL_MAX:  # the summary section, read at once
                    self._tail(end)
                    break
            if op == _FOOTER:
                break
            pos = end
        self._flush_chunks()
        self._flush_loose()
        self._finish()

    def _broken(self, pos: int, exc: _Corrupt) -> LogFormatError:
        return LogFormatError(
            f"log file '{self.name}' is corrupt: the record at byte {pos} is broken "
            f"({exc}); the file cannot be read safely, re-export or re-record it"
        )

    def _tail(self, start: int) -> None:
        """The records after the DataEnd record, from file byte ``start`` on: the same walk as
        :meth:`run`'s over the summary section (only Statistics is read; a cut is a warning),
        on the bytes read in one go instead of record by record."""
        self.fh.seek(start)
        rest = _read_exact(self.fh, self.size - start)
        pos, n = 0, len(rest)
        while True:
            if pos + 9 > n:
                self._truncated(start + pos)
                return
            op, length = _OP_LEN.unpack_from(rest, pos)
            end = pos + 9 + length
            if end > n:
                self._truncated(start + pos)
                return
            if op == _STATISTICS:
                try:
                    self.stats_count = _Cursor(rest, pos + 9, end).u64()
                except _Corrupt as exc:
                    raise self._broken(start + pos, exc) from None
            if op == _FOOTER:
                return
            pos = end

    def _data_record(self, op: int, pos: int, rec_head: bytes, body: Buf) -> None:
        if op == _MESSAGE_INDEX:
            _add_index(self.pending, body)
            return
        self._flush_chunks()
        if op == _MESSAGE:
            self.loose.append((pos, rec_head + body))
            self.loose_bytes += 9 + len(body)
            if self.loose_bytes >= _LOOSE_BATCH:
                self._flush_loose()
            return
        if op == _CHUNK:
            self._flush_loose()  # keep the file order of the messages
            buf, lo, hi, has_crc = _chunk_records(body, 0, len(body))
            self.pending.append(_Pending(pos, buf, lo, hi, has_crc=has_crc, in_place=buf is body))
        elif op == _SCHEMA:
            _add_schema(self.out, _schema(body, 0, len(body)))
        elif op == _CHANNEL:
            _add_channel(self.out, _channel(body, 0, len(body)))
        elif op == _HEADER:
            c = _Cursor(body, 0, len(body))
            self.out.profile, self.out.library = c.string(), c.string()
        elif op == _DATA_END:
            self.data_crc = _Cursor(body, 0, len(body)).u32()

    def _check_data_crc(self, crc: int | None, pos: int) -> None:
        if self.data_crc == 0:
            return
        if crc is None:  # the footer did not lead to this DataEnd: hash the section now
            crc = _crc_range(self.fh, 0, pos)
            self.fh.seek(pos + 13)
        if crc != self.data_crc:
            raise LogFormatError(
                f"log file '{self.name}' is corrupt: its data section does not match its "
                "CRC; the file cannot be read safely, re-export or re-record it"
            )

    def _flush_chunks(self) -> None:
        """Scan the pending chunk (its MessageIndex records are complete) and emit it."""
        for chunk in self.pending:
            self.chunk_crcs.append(chunk.has_crc)
            try:
                if not (chunk.usable and chunk.offsets) or not _scan_chunk_indexed(
                    chunk.buf, chunk.lo, chunk.hi, chunk.offsets, self.out
                ):
                    _scan_chunk(chunk.buf, chunk.lo, chunk.hi, self.out)
            except _Corrupt as exc:
                raise LogFormatError(
                    f"log file '{self.name}' is corrupt: the record at byte {chunk.pos} is "
                    f"broken ({exc}); the file cannot be read safely, re-export or re-record it"
                ) from None
            # records of an in-place chunk are file bytes from pos + 9 on (the record body)
            origin = _Origin(chunk.pos, chunk.lo, chunk.pos + 9 if chunk.in_place else -1)
            self._emit(origin)
        self.pending.clear()

    def _flush_loose(self) -> None:
        if not self.loose:
            return
        buf = b"".join(rec for _, rec in self.loose)
        lens = np.fromiter((len(rec) for _, rec in self.loose), np.int64, len(self.loose))
        starts = np.concatenate(([0], np.cumsum(lens)[:-1]))
        files = np.fromiter((p for p, _ in self.loose), np.int64, len(self.loose))
        self.loose, self.loose_bytes = [], 0
        try:
            self.out.segments.append(_segment(buf, starts.tolist()))
        except _Corrupt as exc:
            raise LogFormatError(
                f"log file '{self.name}' is corrupt ({exc}); re-export it"
            ) from None
        self._emit(_Origin(-1, 0, -1, starts=starts, files=files))

    def _emit(self, origin: _Origin) -> None:
        """Check the staged segments' channel ids and hand them on (or keep them)."""
        staged, self.out.segments = self.out.segments, []
        for seg in staged:
            if len(self.out.channels) != self.n_known:  # a table of the defined channel ids
                self.known[list(self.out.channels)] = True
                self.n_known = len(self.out.channels)
            bad = ~self.known[seg.channel_id]  # ids are u16: always inside the table
            if bad.any():  # defined later in the file, or never (an error at the end)
                self.stray.append((_pick(seg, bad), origin, seg.payload_off[bad]))
                seg = _pick(seg, ~bad)
            self._deliver(seg)

    def _deliver(self, seg: Segment) -> None:
        self.out.count += int(seg.channel_id.size)
        if self.sink is None:
            self.kept.append(seg)
        elif seg.channel_id.size:
            self.sink(self.out, seg)

    def _finish(self) -> None:
        out = self.out
        known = np.fromiter(out.channels, np.int64, len(out.channels))
        for seg, origin, offs in self.stray:
            bad = np.flatnonzero(~np.isin(seg.channel_id, known))
            if bad.size:
                i = int(bad[0])
                raise LogFormatError(
                    f"log file '{self.name}' is corrupt: {origin.where(int(offs[i]))} names "
                    f"channel id {int(seg.channel_id[i])}, which no Channel record defines "
                    f"({bad.size} such message(s)); the file cannot be read safely, re-export "
                    "or re-record it"
                )
            self._deliver(seg)
        out.segments = self.kept
        out.checksums = self.data_crc != 0 or (bool(self.chunk_crcs) and all(self.chunk_crcs))
        counted = self.data_end is not None and self.data_crc == 0
        if counted and self.stats_count is not None and out.count != self.stats_count:
            raise LogFormatError(
                f"log file '{self.name}' is corrupt: its summary counts "
                f"{self.stats_count} messages but its data section holds {out.count}; "
                "re-export or re-record it"
            )

    def _cut_chunk(self, pos: int, body: bytes) -> None:
        """Keep the complete records of the chunk at ``pos`` that the end of the file cut
        (``body`` is what the file holds of it): a recording stopped mid-write keeps all it
        wrote, not only the chunks it finished."""
        cut = _cut_chunk_records(body)
        if cut is None:
            return
        data, lo, hi = cut
        self._flush_chunks()
        self._flush_loose()
        self.pending.append(_Pending(pos, data, lo, hi))
        self.cut_bytes = hi - lo

    def _truncated(self, pos: int) -> None:
        name, n = self.name, self.size
        if self.data_end is not None:
            self.out.warnings.append(
                f"log file '{name}' ends inside its summary section (byte {pos} of {n}); "
                "every message was read, only the index is missing"
            )
            return
        kept = (
            f" and the first {self.cut_bytes} bytes of records of the chunk cut there"
            if self.cut_bytes
            else ""
        )
        self.out.warnings.append(
            f"log file '{name}' is truncated at byte {n} (the recording stopped mid-write); "
            f"read the complete records before byte {pos}{kept} and dropped the rest"
        )


#: Records whose bodies the scan never looks at (read only to CRC the data section).
_SKIPPED = frozenset({0x09, 0x0A, 0x0C, 0x0D, 0x0E, 0x08, 0x10})


#: A summary section (and footer) up to this long is read in one go.
_TAIL_MAX = 1 << 20
#: Chunk records at least this long are mapped (``mmap``) rather than read into a copy.
_MAP_MIN = 1 << 16


def _fileno(fh: BinaryIO) -> int | None:
    try:
        return fh.fileno()
    except (OSError, AttributeError, io.UnsupportedOperation):
        return None  # an in-memory file


def _mapped(fileno: int, start: int, length: int) -> memoryview:
    """File bytes ``[start, start + length)`` mapped read-only, without copying them.

    The mapping lives as long as something refers to it (the chunk's segments), so a chunk's
    pages leave memory with the chunk. Mapped page-cache pages cost no page-zeroing and no
    copy, unlike a fresh buffer read per chunk.
    """
    base = start - start % mmap.ALLOCATIONGRANULARITY
    mapping = mmap.mmap(fileno, start - base + length, offset=base, access=mmap.ACCESS_READ)
    return memoryview(mapping)[start - base : start - base + length]


def _read_exact(fh: BinaryIO, n: int) -> bytes:
    data = fh.read(n)
    if len(data) != n:
        raise LogFormatError("the file became shorter while it was read")
    return data


def _crc_range(fh: BinaryIO, start: int, size: int) -> int | None:
    """CRC-32 of ``size`` bytes of the file from ``start``, read in blocks; None when the file
    ends before them (no CRC matches it)."""
    fh.seek(start)
    crc = 0
    while size > 0:
        block = fh.read(min(size, _BLOCK))
        if not block:
            return None
        crc = zlib.crc32(block, crc)
        size -= len(block)
    return crc


def _pick(seg: Segment, mask: np.ndarray) -> Segment:
    return Segment(
        buf=seg.buf,
        channel_id=seg.channel_id[mask],
        log_time_ns=seg.log_time_ns[mask],
        payload_off=seg.payload_off[mask],
        payload_len=seg.payload_len[mask],
    )


@dataclass
class _Pending:
    """A decompressed chunk waiting for the MessageIndex records that follow it."""

    pos: int
    buf: Buf
    lo: int
    hi: int
    offsets: list[np.ndarray] = field(default_factory=list)
    usable: bool = True
    has_crc: bool = False
    in_place: bool = False


def _add_index(pending: list[_Pending], body: Buf) -> None:
    """Attach a MessageIndex record (its body) to the chunk before it (a malformed one
    disables the index)."""
    if not pending:
        return
    offsets = _index_body_offsets(body, 0, len(body))
    if offsets is None:
        pending[-1].usable = False
    else:
        pending[-1].offsets.append(offsets)


@dataclass(frozen=True)
class _Origin:
    """Where a segment's records are in the file, to name a message's byte offset.

    In a compressed chunk at ``chunk_pos`` (``lo``: where its records start in the buffer);
    in an uncompressed chunk whose buffer starts at file byte ``file_base``; or outside
    chunks (``chunk_pos`` -1), batched: record ``i`` starts at buffer offset ``starts[i]``
    and file offset ``files[i]``.
    """

    chunk_pos: int
    lo: int
    file_base: int
    starts: np.ndarray | None = None
    files: np.ndarray | None = None

    def where(self, payload_off: int) -> str:
        record = payload_off - 9 - _MESSAGE_FIXED
        if self.starts is not None and self.files is not None:
            i = int(np.searchsorted(self.starts, record))
            return f"the message record at byte {int(self.files[i])}"
        if self.file_base >= 0:
            return f"the message record at byte {self.file_base + record}"
        return (
            f"the message record at byte {record - self.lo} of the decompressed chunk "
            f"at byte {self.chunk_pos}"
        )
