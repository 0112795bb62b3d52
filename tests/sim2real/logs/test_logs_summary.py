"""``logs info`` from the MCAP summary section, the file digest computed only when read, and
each format's own words about checksums (issue 16.3)."""

from __future__ import annotations

import hashlib
import pickle
import struct
from pathlib import Path

import numpy as np
import pytest
from logs_helpers import make_arrays
from mcap.writer import CompressionType, Writer

from sim2real.cli import main
from sim2real.errors import LogFormatError
from sim2real.logs import (
    ODOMETRY,
    SCHEMA_TEXT,
    TWIST,
    _cdr,
    _info,
    _mcap,
    _summary,
    inspect_log,
    read_trace,
    write_trace,
)
from sim2real.logs._bagwrite import write_rosbag
from sim2real.logs._info import (
    NO_CHECKSUMS,
    ROS1_NO_CHECKSUMS,
    ROSBAG2_MCAP_NO_CHECKSUMS,
    ROSBAG2_NO_CHECKSUMS,
)

_ARR = make_arrays(n_cmd=50, n_meas=120, seed=5)


def _write(
    path: Path,
    *,
    compression: CompressionType = CompressionType.ZSTD,
    crcs: bool = True,
    data_crc: bool | None = None,
    use_chunking: bool = True,
) -> Path:
    """Commands, odometry and a busy /scan channel, small chunks, a summary section."""
    with path.open("wb") as fh:
        w = Writer(
            fh,
            compression=compression,
            enable_crcs=crcs,
            enable_data_crcs=crcs if data_crc is None else data_crc,
            chunk_size=3000,
            use_chunking=use_chunking,
        )
        w.start(profile="ros2", library="summary-test")
        blob = w.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        scan = w.register_channel("/scan", "cdr", blob)
        twist = w.register_schema(TWIST, "ros2msg", SCHEMA_TEXT[TWIST].encode())
        odom = w.register_schema(ODOMETRY, "ros2msg", SCHEMA_TEXT[ODOMETRY].encode())
        cmd_id = w.register_channel("/cmd_vel", "cdr", twist)
        odom_id = w.register_channel("/odom", "cdr", odom)
        rows = [
            (int(t), cmd_id, p)
            for t, p in zip(_ARR.cmd_t_ns, _cdr.encode_twist(_ARR.cmd_v, _ARR.cmd_w), strict=True)
        ]
        meas = _cdr.encode_odometry(
            _ARR.meas_t_ns,
            _ARR.meas_v,
            _ARR.meas_w,
            x=_ARR.pose_x,
            y=_ARR.pose_y,
            yaw=_ARR.pose_yaw,
            frame_id="odom",
            child_frame_id="base_link",
        )
        rows += [(int(t), odom_id, p) for t, p in zip(_ARR.meas_t_ns, meas, strict=True)]
        rows += [(int(t) + 5, scan, b"\0\1\0\0" + bytes(60)) for t in _ARR.meas_t_ns[::2]]
        for seq, (t, cid, payload) in enumerate(sorted(rows, key=lambda r: r[0])):
            w.add_message(cid, log_time=t, data=payload, publish_time=t, sequence=seq)
        w.finish()
    return path


def _scanned(path: Path, monkeypatch: pytest.MonkeyPatch):  # type: ignore[no-untyped-def]
    with monkeypatch.context() as m:
        m.setattr(_info, "read_summary", lambda p: None)
        return inspect_log(path)


def _same_info(a, b) -> None:  # type: ignore[no-untyped-def]
    keep = ("topics", "message_count", "start_ns", "end_ns", "cmd_topic", "meas_topic")
    for key in (*keep, "profile", "library", "warnings", "size_bytes"):
        assert getattr(a, key) == getattr(b, key), key


@pytest.mark.parametrize("compression", [CompressionType.ZSTD, CompressionType.NONE])
@pytest.mark.parametrize("crcs", [True, False])
def test_info_from_the_summary_equals_the_full_scan(tmp_path, monkeypatch, compression, crcs):
    path = _write(tmp_path / "s.mcap", compression=compression, crcs=crcs)
    fast = inspect_log(path)
    slow = _scanned(path, monkeypatch)
    assert (fast.source, slow.source) == ("summary", "scan")
    _same_info(fast, slow)
    counts = {t.topic: t.count for t in fast.topics}
    assert counts == {"/cmd_vel": 50, "/odom": 120, "/scan": 60}
    assert fast.topic("/odom").first_ns == int(_ARR.meas_t_ns[0])
    assert (NO_CHECKSUMS in fast.warnings) is (not crcs)


def test_summary_path_decompresses_no_chunk_and_decodes_no_payload(tmp_path, monkeypatch):
    path = _write(tmp_path / "z.mcap")

    def refuse(*args: object) -> bytes:
        raise AssertionError("a chunk was decompressed")

    monkeypatch.setattr(_mcap, "_decompress", refuse)
    monkeypatch.setattr(_cdr, "gather", refuse)
    info = inspect_log(path)
    assert info.source == "summary" and info.message_count == 230


@pytest.mark.parametrize("fixture", ["drexel_log", "neato_log"])
def test_real_logs_info_from_the_summary_equals_the_scan(request, monkeypatch, fixture):
    path = request.getfixturevalue(fixture)
    fast = inspect_log(path)
    assert fast.source == "summary"
    _same_info(fast, _scanned(path, monkeypatch))


def _damage(data: bytes, how: str) -> bytes:
    buf = bytearray(data)
    start = struct.unpack_from("<Q", data, len(data) - 8 - 20)[0]
    if how == "summary_crc":  # one byte of the summary section flipped
        buf[start + 20] ^= 0x40
    elif how == "statistics_count":  # Statistics says one message more than the indexes hold
        pos = start
        while data[pos] != 0x0B:
            pos += 9 + struct.unpack_from("<Q", data, pos + 1)[0]
        count = struct.unpack_from("<Q", data, pos + 9)[0]
        struct.pack_into("<Q", buf, pos + 9, count + 1)
    elif how == "no_footer":
        return bytes(buf[: len(data) - 20])
    return bytes(buf)


@pytest.mark.parametrize(
    ("how", "crcs"), [("summary_crc", True), ("statistics_count", False), ("no_footer", True)]
)
def test_a_summary_that_does_not_check_out_falls_back_to_the_scan(tmp_path, how, crcs):
    good = _write(tmp_path / "good.mcap", crcs=crcs).read_bytes()
    path = tmp_path / "bad.mcap"
    path.write_bytes(_damage(good, how))
    assert _summary.read_summary(path) is None
    if how == "statistics_count":  # the scan checks the count against the data: an error
        with pytest.raises(LogFormatError, match="summary counts 231 messages"):
            inspect_log(path)
        return
    info = inspect_log(path)
    assert info.source == "scan" and info.message_count == 230


def test_chunk_crcs_are_checked_where_no_decompression_is_needed(tmp_path):
    """Without a data CRC: uncompressed chunks' CRCs are checked, compressed ones noted."""
    path = _write(tmp_path / "z.mcap", data_crc=False)
    info = inspect_log(path)
    assert info.source == "summary"
    (note,) = info.warnings
    assert "compressed chunk(s) were not checked" in note
    plain = _write(tmp_path / "p.mcap", compression=CompressionType.NONE, data_crc=False)
    assert inspect_log(plain).warnings == ()
    data = bytearray(plain.read_bytes())
    mid = len(data) // 3  # inside a chunk's records: its CRC no longer matches
    data[mid] ^= 0xFF
    plain.write_bytes(bytes(data))
    assert _summary.read_summary(plain) is None
    with pytest.raises(LogFormatError, match="is corrupt"):
        inspect_log(plain)


def test_a_file_without_chunks_is_scanned(tmp_path):
    path = _write(tmp_path / "flat.mcap", use_chunking=False)
    assert _summary.read_summary(path) is None
    info = inspect_log(path)
    assert info.source == "scan" and info.message_count == 230


# ----------------------------------------------------------------------------- digest


class _CountingSha:
    """Counts the SHA-256 objects made through _digest (i.e. the files hashed)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.calls = 0
        real = hashlib.sha256

        def counting(*args: bytes):  # type: ignore[no-untyped-def]
            self.calls += 1
            return real(*args)

        # _digest imports hashlib where it hashes (not on the read path): patch the module
        monkeypatch.setattr(hashlib, "sha256", counting)


def test_reading_a_log_does_not_hash_it_reading_the_digest_does(tmp_path, monkeypatch):
    path = _write(tmp_path / "d.mcap")
    want = hashlib.sha256(path.read_bytes()).hexdigest()
    spy = _CountingSha(monkeypatch)
    tr = read_trace(path)
    info = inspect_log(path)
    part = tr.window(0.0, 2.0)  # a copy of the trace with its meta
    assert spy.calls == 0
    assert part.meta.sha256 == want and spy.calls == 1
    assert tr.meta.sha256 == want and info.sha256 == want
    assert tr.meta.sha256 == want and spy.calls == 3  # computed once per object, then kept
    again = pickle.loads(pickle.dumps(read_trace(path)))  # sent to a worker process
    assert again.meta.sha256 == want


def test_a_log_changed_after_reading_has_no_digest(tmp_path):
    path = _write(tmp_path / "c.mcap")
    tr = read_trace(path)
    path.write_bytes(path.read_bytes() + b"\0")
    with pytest.raises(LogFormatError, match="changed since it was read"):
        _ = tr.meta.sha256


def test_logs_info_hashes_only_with_the_flag(tmp_path, monkeypatch, capsys):
    path = _write(tmp_path / "f.mcap")
    want = hashlib.sha256(path.read_bytes()).hexdigest()
    spy = _CountingSha(monkeypatch)
    assert main(["logs", "info", str(path)]) == 0
    assert main(["logs", "info", str(path), "--json"]) == 0
    out = capsys.readouterr().out
    assert spy.calls == 0 and want not in out and '"sha256": null' in out
    assert "read from: summary section" in out
    assert main(["logs", "info", str(path), "--sha256"]) == 0
    assert main(["logs", "info", str(path), "--json", "--sha256"]) == 0
    out = capsys.readouterr().out
    assert out.count(want) == 2 and spy.calls == 2


# ----------------------------------------------------------------------------- formats


def _recording():  # type: ignore[no-untyped-def]
    from sim2real.logs import Trace

    t = _ARR.meas_t_ns
    return Trace(
        cmd_t_ns=t,
        cmd_v=_ARR.meas_v,
        cmd_w=_ARR.meas_w,
        meas_t_ns=t,
        meas_v=_ARR.meas_v,
        meas_w=_ARR.meas_w,
        pose_x=_ARR.pose_x,
        pose_y=_ARR.pose_y,
        pose_yaw=_ARR.pose_yaw,
    )


@pytest.mark.parametrize(
    ("fmt", "note"),
    [
        ("ros1", ROS1_NO_CHECKSUMS),
        ("sqlite3", ROSBAG2_NO_CHECKSUMS),
        ("mcap", ROSBAG2_MCAP_NO_CHECKSUMS),
    ],
)
def test_bags_say_what_is_true_of_their_format(tmp_path, fmt, note):
    path = write_rosbag(tmp_path / f"run_{fmt}", _recording(), format=fmt)
    info = inspect_log(path)
    assert info.source == "scan"
    assert note in info.warnings and NO_CHECKSUMS not in info.warnings
    assert "checksum" in note and info.message_count == 240


def test_our_own_mcap_files_are_answered_from_their_summary(tmp_path):
    path = write_trace(tmp_path / "own.mcap", _recording())
    info = inspect_log(path)
    assert info.source == "summary" and info.message_count == 240
    np.testing.assert_equal(info.topic("/odom").first_ns, int(_ARR.meas_t_ns[0]))
