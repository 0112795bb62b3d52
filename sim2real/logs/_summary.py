"""What an MCAP file's summary section says, without decompressing a chunk (private).

An MCAP file written to the end (``ros2 bag record``, the ``mcap`` writers) carries a
*summary section* after its data (MCAP spec, "Summary Section"): the Schema and Channel
records again, a ``Statistics`` record (message counts per channel), and a ``ChunkIndex``
record per chunk giving the file offsets of the chunk's ``MessageIndex`` records. Those
list the log time and offset of every message of one channel in one chunk, uncompressed, right
after the chunk. So the topics, types, counts and per-channel log times (hence rates and the
time range) of a log come from the summary and the message indexes alone: a few reads near
the chunks, no decompression and no message payload (``sim2real logs info``).

The summary is only used when it checks out: footer and summary parse, the summary CRC
matches when the writer filled it in, every chunk has its message indexes, the indexes list
exactly the counts of the ``Statistics`` record, every channel id they name has a Channel
record, and no channel is JSON without a schema (its type is guessed from a payload).
Otherwise :func:`read_summary` returns None and the caller scans the whole file, which gives
the precise error when something is wrong.

Integrity is checked as far as it goes without decompressing: the data-section CRC (one
pass of CRC-32 over the file's bytes) when the writer filled it in, else the CRC of every
uncompressed chunk (its records are file bytes). A mismatch makes :func:`read_summary` return
None, so the scan reports it. Only the CRCs of compressed chunks in a file without a data CRC
stay unchecked; :attr:`SummaryView.unchecked_chunks` counts them.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import numpy as np

from sim2real.logs._mcap import (
    MAGIC,
    LogRecords,
    _channel,
    _Corrupt,
    _crc_range,
    _Cursor,
    _schema,
)

__all__ = ["SummaryView", "read_summary", "stated_counts"]

_FOOTER_BYTES = 9 + 20  # opcode, length, summary_start u64, summary_offset_start u64, crc u32
_HEADER, _FOOTER, _SCHEMA, _CHANNEL = 0x01, 0x02, 0x03, 0x04
_MESSAGE_INDEX, _CHUNK_INDEX, _STATISTICS, _DATA_END = 0x07, 0x08, 0x0B, 0x0F
_OP_LEN = struct.Struct("<BQ")
#: Chunk record body before ``uncompressed_crc``: start/end time and uncompressed size.
_CHUNK_CRC_AT = 9 + 24


@dataclass
class SummaryView(LogRecords):
    """Channels, schemas and per-channel log times of an MCAP file, from its summary."""

    #: Sorted log times (ns) of each channel's messages.
    log_times: dict[int, np.ndarray] = field(default_factory=dict)
    #: True when the file carries a data-section CRC or a CRC on every chunk.
    checksums: bool = False
    #: Compressed chunks whose CRC was not checked (only possible without a data CRC).
    unchecked_chunks: int = 0


@dataclass(frozen=True)
class _ChunkIndex:
    start: int  # file offset of the Chunk record
    length: int  # its length in bytes
    index_offsets: dict[int, int]  # channel id -> file offset of its MessageIndex record
    index_length: int  # bytes of all MessageIndex records after the chunk


@dataclass
class _Stats:
    message_count: int
    chunk_count: int
    per_channel: dict[int, int]


def read_summary(path: Path) -> SummaryView | None:
    """The summary of the MCAP file at ``path``, or None when it has none that checks out."""
    try:
        with path.open("rb") as fh:
            return _read(fh, path.stat().st_size)
    except (_Corrupt, OSError, struct.error, ValueError):
        return None


def _read(fh: BinaryIO, size: int) -> SummaryView | None:
    tail_at = size - len(MAGIC) - _FOOTER_BYTES
    if tail_at < len(MAGIC) + 9:
        return None
    fh.seek(tail_at)
    tail = fh.read(_FOOTER_BYTES + len(MAGIC))
    op, length = _OP_LEN.unpack_from(tail, 0)
    if op != _FOOTER or length != 20 or tail[_FOOTER_BYTES:] != MAGIC:
        return None
    start, _, crc = struct.unpack_from("<QQI", tail, 9)
    if not len(MAGIC) + 13 <= start <= tail_at:
        return None
    fh.seek(start)
    summary = fh.read(tail_at - start)
    if crc != 0 and zlib.crc32(tail[:25], zlib.crc32(summary)) != crc:
        return None
    out = SummaryView()
    chunks: list[_ChunkIndex] = []
    stats = _summary_records(summary, out, chunks)
    if stats is None or stats.chunk_count != len(chunks):
        return None
    fh.seek(start - 13)  # the DataEnd record ends the data section
    op, length, data_crc = struct.unpack("<BQI", fh.read(13))
    if op != _DATA_END or length != 4:
        return None
    if not _index_times(fh, chunks, out, stats):
        return None
    if data_crc != 0:
        if _crc_range(fh, 0, start - 13) != data_crc:
            return None  # the scan says which check failed
        out.checksums = True
    else:
        checked = _check_chunks(fh, chunks, out)
        if checked is None:
            return None
        out.checksums = bool(chunks) and checked
    fh.seek(len(MAGIC))
    head = fh.read(9)
    op, length = _OP_LEN.unpack_from(head, 0)
    if op == _HEADER and length <= start:
        c = _Cursor(fh.read(length), 0, length)
        out.profile, out.library = c.string(), c.string()
    return out


#: Summary sections larger than this are not read just for their message counts.
_COUNTS_MAX_BYTES = 1 << 24


def stated_counts(fh: BinaryIO, size: int) -> dict[int, int]:
    """Per channel id, the message count the summary's ``Statistics`` record states.

    A hint for sizing the decoded arrays, never trusted for results: ``{}`` when the file has
    no footer, no summary or no Statistics record, or they do not parse; each count is capped
    at ``size // 16`` (a message costs at least its 16-byte MessageIndex entry in a file whose
    counts can be believed), so a false count cannot reserve more than a few times the file.
    """
    try:
        tail_at = size - len(MAGIC) - _FOOTER_BYTES
        if tail_at < len(MAGIC) + 9:
            return {}
        fh.seek(tail_at)
        tail = fh.read(_FOOTER_BYTES)
        op, length, start = struct.unpack_from("<BQQ", tail, 0)
        if op != _FOOTER or length != 20 or not len(MAGIC) <= start <= tail_at:
            return {}
        if start == 0 or tail_at - start > _COUNTS_MAX_BYTES:
            return {}
        fh.seek(start)
        data = fh.read(tail_at - start)
        pos = 0
        while pos + 9 <= len(data):
            op, length = _OP_LEN.unpack_from(data, pos)
            end = pos + 9 + length
            if end > len(data):
                return {}
            if op == _STATISTICS:
                counts = _statistics(data, pos + 9, end).per_channel
                return {k: min(v, size // 16) for k, v in counts.items()}
            pos = end
    except (_Corrupt, OSError, struct.error):
        return {}
    return {}


def _summary_records(data: bytes, out: SummaryView, chunks: list[_ChunkIndex]) -> _Stats | None:
    """Parse the summary section's records into ``out``/``chunks``; its Statistics or None."""
    pos, stats = 0, None
    while pos < len(data):
        if pos + 9 > len(data):
            return None
        op, length = _OP_LEN.unpack_from(data, pos)
        end = pos + 9 + length
        if end > len(data):
            return None
        if op == _SCHEMA:
            rec = _schema(data, pos + 9, end)
            out.schemas[rec.id] = rec
        elif op == _CHANNEL:
            ch = _channel(data, pos + 9, end)
            out.channels[ch.id] = ch
        elif op == _STATISTICS:
            stats = _statistics(data, pos + 9, end)
        elif op == _CHUNK_INDEX:
            chunks.append(_chunk_index(data, pos + 9, end))
        pos = end
    return stats


def _u16_u64_map(c: _Cursor) -> dict[int, int]:
    raw = c.take(c.u32())
    if len(raw) % 10:
        raise _Corrupt("a map<uint16, uint64> field has a partial entry")
    return {k: v for k, v in struct.iter_unpack("<HQ", raw)}


def _statistics(data: bytes, pos: int, end: int) -> _Stats:
    c = _Cursor(data, pos, end)
    count = c.u64()
    c.take(2 + 4 + 4 + 4)  # schema, channel, attachment and metadata counts
    chunk_count = c.u32()
    c.take(16)  # message start and end time
    return _Stats(message_count=count, chunk_count=chunk_count, per_channel=_u16_u64_map(c))


def _chunk_index(data: bytes, pos: int, end: int) -> _ChunkIndex:
    c = _Cursor(data, pos, end)
    c.take(16)  # message start and end time
    start, length = c.u64(), c.u64()
    offsets = _u16_u64_map(c)
    return _ChunkIndex(start=start, length=length, index_offsets=offsets, index_length=c.u64())


def _index_times(fh: BinaryIO, chunks: list[_ChunkIndex], out: SummaryView, stats: _Stats) -> bool:
    """Read every chunk's MessageIndex records into ``out.log_times``; False if they do not
    account for exactly the messages the Statistics record counts."""
    parts: dict[int, list[np.ndarray]] = {}
    for chunk in chunks:
        if not chunk.index_offsets:
            continue  # an empty chunk, or one without indexes (caught by the counts below)
        at = chunk.start + chunk.length
        fh.seek(at)
        block = fh.read(chunk.index_length)
        for cid, off in chunk.index_offsets.items():
            rel = off - at
            if rel < 0 or rel + 15 > len(block):
                return False
            op, _, rec_cid, size = struct.unpack_from("<BQHI", block, rel)
            if op != _MESSAGE_INDEX or rec_cid != cid or size % 16 or rel + 15 + size > len(block):
                return False
            pairs = np.frombuffer(block, dtype="<u8", count=size // 8, offset=rel + 15)
            parts.setdefault(cid, []).append(pairs[0::2].astype(np.int64))
    counts = {cid: sum(p.size for p in ps) for cid, ps in parts.items()}
    if sum(counts.values()) != stats.message_count:
        return False  # messages outside chunks, or chunks without indexes
    if stats.per_channel and {k: v for k, v in counts.items() if v} != {
        k: v for k, v in stats.per_channel.items() if v
    }:
        return False
    if any(cid not in out.channels for cid in counts):
        return False  # the full scan names the offending message
    for cid, rec in out.channels.items():
        schema = out.schemas.get(rec.schema_id)
        if rec.message_encoding == "json" and (schema is None or not schema.name):
            return False  # its type is guessed from a payload
        ps = parts.get(cid, [])
        out.log_times[cid] = (
            np.sort(np.concatenate(ps), kind="stable") if ps else np.zeros(0, np.int64)
        )
    return True


def _check_chunks(fh: BinaryIO, chunks: list[_ChunkIndex], out: SummaryView) -> bool | None:
    """Whether every chunk has a CRC; the CRCs of uncompressed chunks are checked (their
    records are file bytes), those of compressed ones counted in ``out.unchecked_chunks``.
    None when a CRC does not match (the caller scans, which names the broken chunk)."""
    all_crcs = True
    for chunk in chunks:
        fh.seek(chunk.start)
        head = fh.read(_CHUNK_CRC_AT + 8)
        if len(head) < _CHUNK_CRC_AT + 8 or head[0] != 0x06:
            raise _Corrupt("a chunk index does not point at a chunk")
        crc, name_len = struct.unpack_from("<II", head, _CHUNK_CRC_AT)
        if crc == 0:
            all_crcs = False
            continue
        if name_len:
            out.unchecked_chunks += 1
            continue
        size = struct.unpack("<Q", fh.read(8))[0]
        if _crc_range(fh, chunk.start + _CHUNK_CRC_AT + 16, size) != crc:
            return None
    return all_crcs
