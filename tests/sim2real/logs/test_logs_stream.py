"""Streaming decode (issue 16.3): memory follows the output arrays and the largest chunk, not
the file; the result equals the one of a scan that keeps every chunk."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from sim2real.logs import ODOMETRY, SCHEMA_TEXT, TWIST, Trace, _cdr, _mcap, read_trace
from sim2real.logs._channels import channel_table
from sim2real.logs._decode import decode_channel

T0_NS = 1_700_000_000_000_000_000
_SCAN_BYTES = 16_000  # a laser scan / image-sized message on a channel the trace never reads


def _write_big(path: Path, seconds: int, compression: CompressionType) -> dict[str, np.ndarray]:
    """Twist at 20 Hz, Odometry at 50 Hz and incompressible 16 kB messages at 10 Hz."""
    rng = np.random.default_rng(7)
    n_cmd, n_odom, n_scan = 20 * seconds, 50 * seconds, 10 * seconds
    cmd_t = T0_NS + np.arange(n_cmd, dtype=np.int64) * 50_000_000 + 11
    odom_t = T0_NS + np.arange(n_odom, dtype=np.int64) * 20_000_000
    want = {
        "cmd_t": cmd_t,
        "cmd_v": rng.uniform(-0.3, 0.3, n_cmd),
        "cmd_w": rng.uniform(-1.0, 1.0, n_cmd),
        "odom_t": odom_t,
        "odom_v": rng.normal(0.1, 0.05, n_odom),
        "odom_w": rng.normal(0.0, 0.3, n_odom),
    }
    xy = np.cumsum(rng.normal(0, 0.001, (2, n_odom)), axis=1)
    odom = _cdr.encode_odometry(
        odom_t,
        want["odom_v"],
        want["odom_w"],
        x=xy[0],
        y=xy[1],
        yaw=np.zeros(n_odom),
        frame_id="odom",
        child_frame_id="base_footprint",
    )
    cmd = _cdr.encode_twist(want["cmd_v"], want["cmd_w"])
    rows = [(int(t), 1, p) for t, p in zip(cmd_t, cmd, strict=True)]
    rows += [(int(t), 2, p) for t, p in zip(odom_t, odom, strict=True)]
    rows += [
        (T0_NS + i * 100_000_000 + 5, 3, b"\0\1\0\0" + rng.bytes(_SCAN_BYTES))
        for i in range(n_scan)
    ]
    rows.sort(key=lambda r: r[0])
    with path.open("wb") as fh:
        w = Writer(fh, compression=compression, chunk_size=1 << 20)
        w.start(profile="ros2", library="stream-test")
        tw = w.register_schema(TWIST, "ros2msg", SCHEMA_TEXT[TWIST].encode())
        od = w.register_schema(ODOMETRY, "ros2msg", SCHEMA_TEXT[ODOMETRY].encode())
        sc = w.register_schema("sensor_msgs/msg/CompressedImage", "ros2msg", b"uint8[] data")
        assert w.register_channel("/cmd_vel", "cdr", tw) == 1
        assert w.register_channel("/odom", "cdr", od) == 2
        assert w.register_channel("/camera", "cdr", sc) == 3
        for t, cid, data in rows:
            w.add_message(cid, log_time=t, data=data, publish_time=t)
        w.finish()
    return want


def _largest_chunk_bytes(path: Path) -> int:
    """The largest chunk held at once: its compressed record plus its decompressed records."""
    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    return max(c.compressed_size + c.uncompressed_size for c in summary.chunk_indexes)


def _output_bytes(tr: Trace) -> int:
    arrays = (tr.cmd_t_ns, tr.cmd_v, tr.cmd_w, tr.meas_t_ns, tr.meas_v, tr.meas_w)
    poses = (tr.pose_x, tr.pose_y, tr.pose_yaw)
    return sum(a.nbytes for a in arrays) + sum(a.nbytes for a in poses if a is not None)


@pytest.fixture(scope="module")
def big_log(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, np.ndarray]]:
    path = tmp_path_factory.mktemp("stream") / "big.mcap"
    want = _write_big(path, seconds=300, compression=CompressionType.ZSTD)
    return path, want


@pytest.mark.slow
def test_peak_memory_follows_output_and_largest_chunk_not_the_file(big_log):
    path, want = big_log
    size = path.stat().st_size
    assert size > 40 * 2**20  # the file is far larger than what the read needs
    read_trace(path)  # imports and caches outside the measurement
    tracemalloc.start()
    try:
        tr = read_trace(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(tr.meas_t_ns, want["odom_t"])
    np.testing.assert_array_equal(tr.cmd_v, want["cmd_v"])
    bound = 2 * (_output_bytes(tr) + _largest_chunk_bytes(path))
    assert peak <= bound, f"peak {peak / 2**20:.1f} MiB > bound {bound / 2**20:.1f} MiB"
    assert peak < size / 5


@pytest.mark.parametrize("compression", [CompressionType.ZSTD, CompressionType.NONE])
def test_streamed_decode_equals_the_decode_of_every_kept_chunk(tmp_path, compression):
    """The sink decodes chunk by chunk what a scan keeping all chunks decodes in one go."""
    path = tmp_path / "s.mcap"
    want = _write_big(path, seconds=40, compression=compression)
    tr = read_trace(path, time_source="log")
    kept = _mcap.scan_mcap(path.read_bytes(), name=str(path))
    assert len(kept.segments) >= 2  # several chunks
    odom_id = next(c for c, r in kept.channels.items() if r.topic == "/odom")
    v = np.concatenate(
        [
            _cdr.decode_odometry(s.u8, s.payload_off[m], s.payload_len[m])["v"]
            for s in kept.segments
            if np.any(m := s.channel_id == odom_id)
        ]
    )
    np.testing.assert_array_equal(tr.meas_v, v)
    np.testing.assert_array_equal(tr.meas_v, want["odom_v"])
    np.testing.assert_array_equal(tr.cmd_w, want["cmd_w"])
    assert kept.message_count() == 20 * 40 + 50 * 40 + 10 * 40


def test_a_channel_never_read_is_not_decoded_and_its_errors_do_not_matter(tmp_path):
    """A broken second Odometry topic fails only when it is the one asked for."""
    from sim2real.errors import LogFormatError
    from sim2real.logs._reader import load_log

    t = T0_NS + np.arange(60, dtype=np.int64) * 20_000_000
    good = _cdr.encode_odometry(
        t,
        np.ones(60),
        np.zeros(60),
        x=t * 0.0,
        y=t * 0.0,
        yaw=t * 0.0,
        frame_id="o",
        child_frame_id="b",
    )
    path = tmp_path / "two.mcap"
    with path.open("wb") as fh:
        w = Writer(fh, chunk_size=4000)
        w.start(profile="ros2", library="stream-test")
        tw = w.register_schema(TWIST, "ros2msg", SCHEMA_TEXT[TWIST].encode())
        od = w.register_schema(ODOMETRY, "ros2msg", SCHEMA_TEXT[ODOMETRY].encode())
        cmd, odom = (
            w.register_channel("/cmd_vel", "cdr", tw),
            w.register_channel("/odom", "cdr", od),
        )
        bad = w.register_channel("/odom_broken", "cdr", od)
        for i, ti in enumerate(t.tolist()):
            w.add_message(
                cmd,
                log_time=ti,
                data=_cdr.encode_twist(np.ones(1), np.zeros(1))[0],
                publish_time=ti,
            )
            w.add_message(odom, log_time=ti, data=good[i], publish_time=ti)
            w.add_message(bad, log_time=ti, data=good[i][:50], publish_time=ti)
        w.finish()
    assert read_trace(path).meta.meas_count == 60
    with pytest.raises(LogFormatError, match=r"message 0 of topic '/odom_broken'.*Odometry"):
        read_trace(path, odom_topic="/odom_broken")
    log = load_log(path, decode=False)
    assert log.container.parts == {} and [c.count for c in channel_table(log.container)] == [
        60,
        60,
        60,
    ]
    empty = decode_channel(log.container, log.chans[1], name="x", type_name=ODOMETRY)
    assert list(empty) == ["log_ns"] and empty["log_ns"].size == 0  # nothing was kept


@pytest.mark.slow
def test_decode_peak_of_an_odometry_heavy_log_follows_its_output(tmp_path):
    """The reader's own stage (stream, decode the two channels, join): when the output is
    most of the data (only odometry and commands), its peak stays within the bound too."""
    from sim2real.logs import write_velocity_log
    from sim2real.logs._reader import load_log

    n = 60_000
    rng = np.random.default_rng(3)
    t = T0_NS + np.arange(n, dtype=np.int64) * 20_000_000
    path = write_velocity_log(
        tmp_path / "odom.mcap",
        cmd_t_ns=t[::2] + 7,
        cmd_v=rng.uniform(-0.2, 0.2, n // 2),
        cmd_w=rng.uniform(-1, 1, n // 2),
        meas_t_ns=t,
        meas_v=rng.normal(0.1, 0.05, n),
        meas_w=rng.normal(0, 0.3, n),
    )
    load_log(path)
    tracemalloc.start()
    try:
        log = load_log(path)
        raw = [
            decode_channel(log.container, c, name="x", type_name=c.type, release=True)
            for c in log.chans
        ]
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    output = sum(a.nbytes for d in raw for a in d.values())
    assert raw[1]["v"].size == n and set(raw[1]) == {
        "log_ns",
        "stamp_ns",
        "v",
        "w",
        "x",
        "y",
        "yaw",
    }
    bound = 2 * (output + _largest_chunk_bytes(path))
    assert peak <= bound, f"peak {peak / 2**20:.1f} MiB > bound {bound / 2**20:.1f} MiB"
