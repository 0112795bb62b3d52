"""The MessageIndex path of the MCAP scan: same result as the full walk, never trusted blindly.

The files have several channels (commands, odometry and two busy channels the reader does not
need, as in real robot logs with /scan and /tf), several chunks per file, and Schema/Channel
records inside the chunks, so the index path has gaps to walk.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from logs_helpers import make_arrays
from mcap.writer import CompressionType, IndexType, Writer

from sim2real.errors import Sim2RealError
from sim2real.logs import ODOMETRY, SCHEMA_TEXT, TWIST, Trace, _cdr, _mcap, inspect_log, read_trace
from sim2real.logs._reader import load_log

_ARR = make_arrays(n_cmd=30, n_meas=80, seed=11)
_STRING = "std_msgs/msg/String"
_N_NOISE = 150  # messages on each of the two unused channels


def _string_cdr(text: str) -> bytes:
    """A std_msgs/msg/String in little-endian CDR: encapsulation, u32 length, bytes, NUL."""
    raw = text.encode() + b"\0"
    return b"\x00\x01\x00\x00" + struct.pack("<I", len(raw)) + raw


def _write(
    path: Path,
    *,
    compression: CompressionType = CompressionType.NONE,
    crcs: bool = False,
    index: IndexType = IndexType.ALL,
) -> Path:
    """Commands, odometry and two busy String channels, interleaved by time, small chunks."""
    with path.open("wb") as fh:
        w = Writer(
            fh,
            compression=compression,
            enable_crcs=crcs,
            enable_data_crcs=crcs,
            chunk_size=4000,
            index_types=index,
        )
        w.start(profile="ros2", library="index-test")
        string_schema = w.register_schema(_STRING, "ros2msg", b"string data")
        rows: list[tuple[int, int, bytes]] = []
        for topic in ("/scan", "/tf"):
            cid = w.register_channel(topic, "cdr", string_schema)
            t = _ARR.meas_t_ns[0] + np.arange(_N_NOISE, dtype=np.int64) * 21_000_000 + 7
            rows += [(int(ti), cid, _string_cdr(f"{topic} {i}")) for i, ti in enumerate(t)]
        twist = w.register_schema(TWIST, "ros2msg", SCHEMA_TEXT[TWIST].encode())
        cmd = w.register_channel("/cmd_vel", "cdr", twist)
        payloads = _cdr.encode_twist(_ARR.cmd_v, _ARR.cmd_w)
        rows += [(int(t), cmd, p) for t, p in zip(_ARR.cmd_t_ns, payloads, strict=True)]
        odom = w.register_schema(ODOMETRY, "ros2msg", SCHEMA_TEXT[ODOMETRY].encode())
        odo = w.register_channel("/odom", "cdr", odom)
        payloads = _cdr.encode_odometry(
            _ARR.meas_t_ns,
            _ARR.meas_v,
            _ARR.meas_w,
            x=_ARR.pose_x,
            y=_ARR.pose_y,
            yaw=_ARR.pose_yaw,
            frame_id="odom",
            child_frame_id="base_link",
        )
        rows += [(int(t), odo, p) for t, p in zip(_ARR.meas_t_ns, payloads, strict=True)]
        for t, cid, data in sorted(rows, key=lambda r: r[0]):
            w.add_message(cid, log_time=t, data=data, publish_time=t)
        w.finish()
    return path


def _records(data: bytes, opcode: int) -> list[tuple[int, int]]:
    """(start, end) of the top-level records of ``data`` with ``opcode``, up to the footer."""
    pos, out = 8, []
    while pos + 9 <= len(data):
        op, length = struct.unpack_from("<BQ", data, pos)
        if op == opcode:
            out.append((pos, pos + 9 + length))
        if op == 0x02:
            break
        pos += 9 + length
    return out


class _Spy:
    """Counts how chunks were scanned: through the index or by the full walk."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.full = 0
        full = _mcap._scan_chunk

        def counting(*args: object) -> None:
            self.full += 1
            full(*args)  # type: ignore[arg-type]

        monkeypatch.setattr(_mcap, "_scan_chunk", counting)


def _scan(data: bytes) -> _mcap.Container:
    return _mcap.scan_mcap(data, name="x.mcap")


def _full_walk(data: bytes, monkeypatch: pytest.MonkeyPatch) -> _mcap.Container:
    with monkeypatch.context() as m:
        m.setattr(_mcap, "_scan_chunk_indexed", lambda *a: False)
        return _scan(data)


def _assert_same(a: _mcap.Container, b: _mcap.Container) -> None:
    assert a.schemas == b.schemas and a.channels == b.channels and a.warnings == b.warnings
    assert len(a.segments) == len(b.segments) >= 1
    for x, y in zip(a.segments, b.segments, strict=True):
        for key in ("channel_id", "log_time_ns", "payload_len"):
            np.testing.assert_array_equal(getattr(x, key), getattr(y, key))
        assert _payloads(x) == _payloads(y)


def _payloads(seg: _mcap.Segment) -> list[bytes]:
    """The payload bytes of a segment (offsets differ between files, payloads must not)."""
    pairs = zip(seg.payload_off.tolist(), seg.payload_len.tolist(), strict=True)
    return [bytes(seg.buf[o : o + n]) for o, n in pairs]


def _assert_same_trace(a: Trace, b: Trace) -> None:
    for key in ("cmd_t_ns", "cmd_v", "cmd_w", "meas_t_ns", "meas_v", "meas_w", "pose_x"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key))
    assert a.meta.warnings == b.meta.warnings


@pytest.mark.parametrize("compression", [CompressionType.NONE, CompressionType.ZSTD])
@pytest.mark.parametrize("crcs", [False, True])
def test_index_path_gives_the_full_walk_result(tmp_path, monkeypatch, compression, crcs):
    data = _write(tmp_path / "multi.mcap", compression=compression, crcs=crcs).read_bytes()
    spy = _Spy(monkeypatch)
    indexed = _scan(data)
    assert spy.full == 0  # every chunk was read through its index
    chunks = len(_records(data, 0x06))
    # one segment per chunk (the scan streams: a chunk's bytes are dropped after it)
    assert chunks >= 5
    assert len(indexed.segments) == chunks
    _assert_same(indexed, _full_walk(data, monkeypatch))
    assert spy.full == chunks
    assert indexed.message_count() == 2 * _N_NOISE + _ARR.cmd_t_ns.size + _ARR.meas_t_ns.size


@pytest.mark.parametrize("compression", [CompressionType.NONE, CompressionType.ZSTD])
def test_index_path_trace_and_info_match_the_written_arrays(tmp_path, monkeypatch, compression):
    path = _write(tmp_path / "multi.mcap", compression=compression, crcs=True)
    spy = _Spy(monkeypatch)
    tr = read_trace(path)
    info = inspect_log(path)
    assert spy.full == 0
    np.testing.assert_array_equal(tr.cmd_t_ns, _ARR.cmd_t_ns)
    np.testing.assert_array_equal(tr.cmd_v, _ARR.cmd_v)
    np.testing.assert_array_equal(tr.meas_t_ns, _ARR.meas_t_ns)
    np.testing.assert_array_equal(tr.meas_w, _ARR.meas_w)
    np.testing.assert_allclose(tr.pose_yaw, _ARR.pose_yaw, atol=1e-12)
    counts = {t.topic: t.count for t in info.topics}
    assert counts == {"/cmd_vel": 30, "/odom": 80, "/scan": _N_NOISE, "/tf": _N_NOISE}
    assert info.message_count == 30 + 80 + 2 * _N_NOISE
    assert (info.cmd_topic, info.meas_topic) == ("/cmd_vel", "/odom")


def test_file_without_message_indexes_takes_the_full_walk(tmp_path, monkeypatch):
    plain = _write(tmp_path / "plain.mcap").read_bytes()
    bare = _write(tmp_path / "bare.mcap", index=IndexType.NONE).read_bytes()
    assert _records(bare, 0x07) == [] and _records(plain, 0x07) != []
    spy = _Spy(monkeypatch)
    from_bare = _scan(bare)
    assert spy.full == len(_records(bare, 0x06))
    _assert_same(from_bare, _full_walk(plain, monkeypatch))


def _damaged(data: bytes, how: str) -> bytes:
    """``data`` with its first chunk's message index damaged in one way."""
    buf = bytearray(data)
    pos, run = _records(data, 0x06)[0][1], []  # the index records right after chunk 1
    while data[pos] == 0x07:
        run.append(pos)
        pos += 9 + struct.unpack_from("<Q", data, pos + 1)[0]
    run.sort(key=lambda r: -struct.unpack_from("<I", data, r + 11)[0])  # longest first
    a, b = run[:2]
    size = struct.unpack_from("<I", buf, a + 11)[0]
    assert size >= 32  # at least two (log_time, offset) entries
    off0 = a + 15 + 8  # the first entry's offset
    if how == "shifted":
        struct.pack_into("<Q", buf, off0, struct.unpack_from("<Q", buf, off0)[0] + 1)
    elif how == "past_end":
        struct.pack_into("<Q", buf, off0, 10**9)
    elif how == "huge":
        struct.pack_into("<Q", buf, off0, 2**64 - 1)
    elif how == "duplicate":
        buf[off0 + 16 : off0 + 24] = buf[off0 : off0 + 8]
    elif how == "bad_size":
        struct.pack_into("<I", buf, a + 11, size - 16)
    elif how == "dropped":
        buf[b] = 0x80  # the second index record becomes an unknown (ignored) record
    elif how == "not_a_message":  # one more entry, pointing at the chunk's first record
        # chunk body: start/end time, size (24 bytes), crc (4), compression "" (4), length (8)
        assert data[_records(data, 0x06)[0][0] + 9 + 40] == 0x03  # a Schema record
        struct.pack_into("<Q", buf, a + 1, struct.unpack_from("<Q", buf, a + 1)[0] + 16)
        struct.pack_into("<I", buf, a + 11, size + 16)
        buf[a + 15 : a + 15] = struct.pack("<QQ", 0, 0)
    elif how == "swapped_channel":
        buf[a + 9 : a + 11] = buf[b + 9 : b + 11]  # channel ids do not matter, offsets do
    return bytes(buf)


@pytest.mark.parametrize(
    "how",
    [
        "shifted",
        "past_end",
        "huge",
        "duplicate",
        "bad_size",
        "dropped",
        "not_a_message",
        "swapped_channel",
    ],
)
def test_damaged_index_falls_back_to_the_full_walk(tmp_path, monkeypatch, how):
    good = _write(tmp_path / "good.mcap").read_bytes()
    bad = _damaged(good, how)
    assert bad != good
    spy = _Spy(monkeypatch)
    scanned = _scan(bad)
    assert spy.full == (0 if how == "swapped_channel" else 1)  # only the damaged chunk
    _assert_same(scanned, _full_walk(good, monkeypatch))
    (tmp_path / "bad.mcap").write_bytes(bad)
    _assert_same_trace(read_trace(tmp_path / "bad.mcap"), read_trace(tmp_path / "good.mcap"))


def test_damaged_index_with_a_data_crc_is_a_clean_error(tmp_path):
    good = _write(tmp_path / "good.mcap", crcs=True).read_bytes()
    path = tmp_path / "bad.mcap"
    path.write_bytes(_damaged(good, "shifted"))
    with pytest.raises(Sim2RealError, match="does not match its CRC"):
        read_trace(path)


def test_index_offsets_parse_and_reject_malformed_records():
    pairs = np.array([[5, 0], [6, 31]], dtype="<u8").tobytes()
    rec = struct.pack("<BQHI", 0x07, 6 + len(pairs), 3, len(pairs)) + pairs
    np.testing.assert_array_equal(_mcap._index_offsets(rec, 0, len(rec)), [0, 31])
    short = struct.pack("<BQHI", 0x07, 6 + 8, 3, 8) + pairs[:8]  # half an entry
    assert _mcap._index_offsets(short, 0, len(short)) is None
    assert _mcap._index_offsets(rec[:12], 0, 12) is None


_GOOD: dict[str, bytes] = {}


def _good_file(tmp: Path) -> bytes:
    if "data" not in _GOOD:
        _GOOD["data"] = _write(tmp / "fuzz.mcap").read_bytes()
    return _GOOD["data"]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    flips=st.lists(
        st.tuples(st.integers(0, 10**6), st.integers(0, 10**6), st.integers(1, 255)),
        min_size=1,
        max_size=4,
    )
)
def test_fuzzed_index_bodies_never_change_the_result(tmp_path_factory, flips):
    """Any damage inside MessageIndex bodies (no CRC to catch it) gives the clean result."""
    good = _good_file(tmp_path_factory.mktemp("idx"))
    index = _records(good, 0x07)
    buf = bytearray(good)
    for which, where, mask in flips:
        start, end = index[which % len(index)]
        buf[start + 9 + where % (end - start - 9)] ^= mask
    try:
        got = _scan(bytes(buf))
    except Sim2RealError as exc:  # pragma: no cover - would be a regression
        pytest.fail(f"damaged index made the read fail: {exc}")
    want = _scan(good)
    assert got.channels == want.channels
    for x, y in zip(got.segments, want.segments, strict=True):
        np.testing.assert_array_equal(x.payload_off, y.payload_off)
        np.testing.assert_array_equal(x.channel_id, y.channel_id)


def _raw_mcap(records: bytes) -> bytes:
    """A minimal MCAP file with channel 1 and one uncompressed, CRC-less chunk of ``records``."""

    def rec(op: int, body: bytes) -> bytes:
        return struct.pack("<BQ", op, len(body)) + body

    def string(text: str) -> bytes:
        return struct.pack("<I", len(text)) + text.encode()

    chunk = struct.pack("<QQQI", 0, 0, len(records), 0) + string("")
    chunk += struct.pack("<Q", len(records)) + records
    channel = struct.pack("<HH", 1, 0) + string("/raw") + string("cdr") + struct.pack("<I", 0)
    body = rec(0x01, string("ros2") + string("raw")) + rec(0x04, channel) + rec(0x06, chunk)
    body += rec(0x0F, struct.pack("<I", 0)) + rec(0x02, struct.pack("<QQI", 0, 0, 0))
    return _mcap.MAGIC + body + _mcap.MAGIC


def test_record_header_cut_short_at_an_uncompressed_chunk_end_is_an_error():
    """The chunk is read in place: bytes after it must not complete a cut record header."""
    message = struct.pack("<BQHIQQ", 0x05, 22 + 3, 1, 0, 5, 5) + b"abc"
    for tail, reason in ((b"\x05\x01\x00", "cut short"), (b"\x04\xff" + bytes(7), "runs past")):
        with pytest.raises(Sim2RealError, match=reason):
            _scan(_raw_mcap(message + tail))
    whole = _scan(_raw_mcap(message))
    assert _payloads(whole.segments[0]) == [b"abc"]


@pytest.mark.parametrize("fixture", ["drexel_log", "neato_log"])
def test_real_logs_are_read_through_their_index(request, monkeypatch, fixture):
    """The real logs (several busy channels the reader skips) use the index, same result."""
    path = request.getfixturevalue(fixture)
    data = Path(path).read_bytes()
    spy = _Spy(monkeypatch)
    indexed = _scan(data)
    assert spy.full == 0
    _assert_same(indexed, _full_walk(data, monkeypatch))
    tr = read_trace(path)
    with monkeypatch.context() as m:
        m.setattr(_mcap, "_scan_chunk_indexed", lambda *a: False)
        _assert_same_trace(tr, read_trace(path))
        counts = {t.topic: t.count for t in inspect_log(path).topics}
    assert counts == {t.topic: t.count for t in inspect_log(path).topics}
    assert sum(counts.values()) == indexed.message_count()


def test_chunk_whose_records_do_not_tile_it_is_refused_as_by_the_full_walk(tmp_path, monkeypatch):
    """A Schema record inside the first chunk made one byte longer: the records between the
    indexed messages no longer end where the next message starts, so the index is not
    trusted and the read fails exactly as the record-by-record walk does."""
    data = _write(tmp_path / "good.mcap").read_bytes()
    chunk = _records(data, 0x06)[0][0]
    schema = chunk + 9 + 40  # the chunk's first record (see _damaged: "not_a_message")
    assert data[schema] == 0x03
    buf = bytearray(data)
    struct.pack_into("<Q", buf, schema + 1, struct.unpack_from("<Q", buf, schema + 1)[0] + 1)
    bad = bytes(buf)
    spy = _Spy(monkeypatch)
    with pytest.raises(Sim2RealError) as indexed:
        _scan(bad)
    assert spy.full == 1  # the index was refused: the chunk was walked
    with pytest.raises(Sim2RealError) as walked:
        _full_walk(bad, monkeypatch)
    assert str(indexed.value) == str(walked.value)
    assert f"the record at byte {chunk} is broken" in str(indexed.value)


def _summary_cuts(data: bytes) -> list[int]:
    """File lengths that cut the file inside its summary section (after DataEnd)."""
    (data_end,) = _records(data, 0x0F)
    starts = [a for op in range(0x01, 0x12) for a, _ in _records(data, op) if a > data_end[0]]
    cuts = {data_end[1], data_end[1] + 5, len(data) - 1, len(data) - 8}
    cuts |= {a + d for a in starts for d in (0, 4, 12)}
    return sorted(c for c in cuts if data_end[1] <= c < len(data))


def test_summary_read_in_one_go_equals_the_record_by_record_walk(tmp_path, monkeypatch):
    """After DataEnd the summary section is read at once; for every cut inside it the
    result (warning naming the cut record, messages, counts) equals the old walk's, which
    reads record by record (``_TAIL_MAX = -1``)."""
    data = _write(tmp_path / "good.mcap", crcs=True).read_bytes()
    cuts = _summary_cuts(data)
    assert len(cuts) >= 20
    n_msgs = 2 * _N_NOISE + _ARR.cmd_t_ns.size + _ARR.meas_t_ns.size
    for cut in cuts:
        part = data[:cut]
        one_go = _scan(part)
        with monkeypatch.context() as m:
            m.setattr(_mcap, "_TAIL_MAX", -1)
            walked = _scan(part)
        _assert_same(one_go, walked)
        assert one_go.message_count() == walked.message_count() == n_msgs
        if cut < len(data) - len(_mcap.MAGIC):  # cut before the footer's end
            (warning,) = one_go.warnings
            assert "ends inside its summary section" in warning
        else:  # only (part of) the closing magic is missing: read as a whole file
            assert one_go.warnings == []
    whole = _scan(data)
    assert whole.warnings == [] and whole.message_count() == n_msgs


def test_broken_statistics_record_is_the_same_error_in_the_summary_read(tmp_path, monkeypatch):
    """A Statistics record too short for its message count: one sentence naming its byte,
    whether the summary is read at once or record by record."""
    data = _write(tmp_path / "good.mcap").read_bytes()
    ((stats, _),) = _records(data, 0x0B)
    buf = bytearray(data)
    struct.pack_into("<Q", buf, stats + 1, 4)  # 4 bytes: the u64 count does not fit
    errors = []
    for tail_max in (_mcap._TAIL_MAX, -1):
        with monkeypatch.context() as m:
            m.setattr(_mcap, "_TAIL_MAX", tail_max)
            with pytest.raises(Sim2RealError) as err:
                _scan(bytes(buf))
        errors.append(str(err.value))
    assert errors[0] == errors[1]
    assert f"the record at byte {stats} is broken (a field of 8 bytes runs past" in errors[0]


def _cursor_schema(buf: bytes, pos: int, end: int) -> _mcap.SchemaRecord:
    c = _mcap._Cursor(buf, pos, end)
    sid, name, enc = c.u16(), c.string(), c.string()
    return _mcap.SchemaRecord(id=sid, name=name, encoding=enc, data=c.take(c.u32()))


def _cursor_channel(buf: bytes, pos: int, end: int) -> _mcap.ChannelRecord:
    c = _mcap._Cursor(buf, pos, end)
    cid, sid, topic, enc = c.u16(), c.u16(), c.string(), c.string()
    return _mcap.ChannelRecord(id=cid, schema_id=sid, topic=topic, message_encoding=enc)


def _outcome(fn: object, *args: object) -> object:
    try:
        return fn(*args)  # type: ignore[operator]
    except _mcap._Corrupt as exc:
        return f"corrupt: {exc}"


def test_schema_and_channel_fields_read_straight_equal_the_checked_walk():
    """Schema/Channel bodies read field by field with bounds checks (the old way) and read
    straight (the fast path): the same record or the same error, for intact bodies, every
    shortened end, bad UTF-8 and length fields that run past the record or the buffer."""
    rng = np.random.default_rng(3)

    def s(text: bytes) -> bytes:
        return struct.pack("<I", len(text)) + text

    schema = struct.pack("<H", 7) + s(b"nav_msgs/msg/Odometry") + s(b"ros2msg") + s(b"a" * 40)
    channel = struct.pack("<HH", 3, 7) + s(b"/odom") + s(b"cdr") + struct.pack("<I", 0)
    bodies = [(schema, _mcap._schema, _cursor_schema), (channel, _mcap._channel, _cursor_channel)]
    seen = set()
    for body, fast, slow in bodies:
        variants = [body[:k] for k in range(len(body) + 1)]
        for _ in range(300):
            b = bytearray(body)
            b[int(rng.integers(len(b)))] = int(rng.integers(256))
            variants.append(bytes(b))
        variants.append(body.replace(b"ros2msg", b"ros\xff2ms").replace(b"cdr", b"c\xffr"))
        for v in variants:
            pad = b"\x00" * int(rng.integers(0, 3))  # bytes past the record end
            for end in (len(v), max(len(v) - 1, 0)):
                got, want = _outcome(fast, v + pad, 0, end), _outcome(slow, v + pad, 0, end)
                assert got == want, (v, end)
                seen.add("record" if not isinstance(want, str) else want)
    assert "record" in seen and "corrupt: a string field is not valid UTF-8" in seen
    assert sum("runs past its record end" in k for k in seen) > 10


@pytest.mark.parametrize("decode", [True, False])
def test_channel_log_times_of_mixed_chunks_are_the_written_ones(tmp_path, decode):
    """Chunks mixing decoded (/cmd_vel, /odom) and skipped (/scan, /tf) channels: each
    channel's sorted log times are exactly those written, whether decoded or only timed."""
    path = _write(tmp_path / "multi.mcap", compression=CompressionType.ZSTD)
    noise = _ARR.meas_t_ns[0] + np.arange(_N_NOISE, dtype=np.int64) * 21_000_000 + 7
    want = {"/scan": noise, "/tf": noise, "/cmd_vel": _ARR.cmd_t_ns, "/odom": _ARR.meas_t_ns}
    log = load_log(path, decode=decode)
    assert len(_records(path.read_bytes(), 0x06)) >= 5  # several chunks, each mixed
    assert {c.topic for c in log.chans} == set(want)
    for chan in log.chans:
        np.testing.assert_array_equal(chan.log_time_ns, want[chan.topic])
    unsorted = load_log(path, decode=decode, sort_times=False)
    for chan in unsorted.chans:
        np.testing.assert_array_equal(np.sort(chan.log_time_ns), want[chan.topic])
