"""Fuzz the reader: byte flips and truncations give a correct Trace or one of our errors."""

from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from logs_helpers import T0_NS, make_arrays
from mcap.writer import CompressionType, Writer

from sim2real.errors import Sim2RealError
from sim2real.logs import ODOMETRY, SCHEMA_TEXT, TWIST, Trace, _cdr, read_trace, write_velocity_log

_ARR = make_arrays(n_cmd=12, n_meas=30, seed=3)
_TMP = Path(tempfile.mkdtemp(prefix="logs-fuzz-"))
atexit.register(shutil.rmtree, _TMP, ignore_errors=True)
_VALID = write_velocity_log(_TMP / "valid.mcap", **_ARR.kwargs()).read_bytes()


def _no_crc_file() -> bytes:
    """The same data as ``rosbags`` writes it: uncompressed chunks and no CRCs at all."""
    path = _TMP / "nocrc.mcap"
    with path.open("wb") as fh:
        w = Writer(fh, compression=CompressionType.NONE, enable_crcs=False, chunk_size=600)
        w.start(profile="ros2", library="fuzz")
        cmd = w.register_channel(
            "/cmd_vel", "cdr", w.register_schema(TWIST, "ros2msg", SCHEMA_TEXT[TWIST].encode())
        )
        odo = w.register_channel(
            "/odom", "cdr", w.register_schema(ODOMETRY, "ros2msg", SCHEMA_TEXT[ODOMETRY].encode())
        )
        for t, p in zip(
            _ARR.cmd_t_ns.tolist(), _cdr.encode_twist(_ARR.cmd_v, _ARR.cmd_w), strict=True
        ):
            w.add_message(cmd, log_time=t, data=p, publish_time=t)
        odoms = _cdr.encode_odometry(
            _ARR.meas_t_ns,
            _ARR.meas_v,
            _ARR.meas_w,
            x=_ARR.pose_x,
            y=_ARR.pose_y,
            yaw=_ARR.pose_yaw,
            frame_id="odom",
            child_frame_id="base_link",
        )
        for t, p in zip(_ARR.meas_t_ns.tolist(), odoms, strict=True):
            w.add_message(odo, log_time=t, data=p, publish_time=t)
        w.finish()
    return path.read_bytes()


_NO_CRC = _no_crc_file()


def _mutate(data: bytes, flips: list[tuple[int, int]], keep: float | None) -> bytes:
    buf = bytearray(data)
    for pos, mask in flips:
        buf[pos % len(buf)] ^= mask
    if keep is not None:
        buf = buf[: int(len(buf) * keep)]
    return bytes(buf)


def _read(data: bytes) -> Trace | Sim2RealError:
    with tempfile.NamedTemporaryFile(suffix=".mcap", dir=_TMP, delete=False) as fh:
        fh.write(data)
    try:
        return read_trace(fh.name)
    except Sim2RealError as exc:  # the only exception type allowed
        assert str(exc) and "\n" not in str(exc)
        return exc
    finally:
        Path(fh.name).unlink()


def _assert_subset_of_original(tr: Trace) -> None:
    """Every sample of the trace is a sample of the written arrays (a prefix after a cut)."""
    ci = np.searchsorted(_ARR.cmd_t_ns, tr.cmd_t_ns)
    assert np.all(ci < _ARR.cmd_t_ns.size)
    np.testing.assert_array_equal(_ARR.cmd_t_ns[ci], tr.cmd_t_ns)
    np.testing.assert_array_equal(_ARR.cmd_v[ci], tr.cmd_v)
    np.testing.assert_array_equal(_ARR.cmd_w[ci], tr.cmd_w)
    mi = np.searchsorted(_ARR.meas_t_ns, tr.meas_t_ns)
    assert np.all(mi < _ARR.meas_t_ns.size)
    np.testing.assert_array_equal(_ARR.meas_t_ns[mi], tr.meas_t_ns)
    np.testing.assert_array_equal(_ARR.meas_v[mi], tr.meas_v)
    np.testing.assert_array_equal(_ARR.pose_x[mi], tr.pose_x)


flips = st.lists(st.tuples(st.integers(0, 10**6), st.integers(1, 255)), max_size=3)
keeps = st.none() | st.floats(0.0, 1.0)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(flips=flips, keep=keeps)
def test_fuzzed_crc_file_reads_correctly_or_raises_our_error(flips, keep):
    out = _read(_mutate(_VALID, flips, keep))
    if isinstance(out, Trace):
        _assert_subset_of_original(out)
        if not flips and keep is None:
            assert out.meta.cmd_count == 12 and out.meta.meas_count == 30


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(flips=flips, keep=keeps)
def test_fuzzed_file_without_crcs_never_raises_foreign_errors(flips, keep):
    out = _read(_mutate(_NO_CRC, flips, keep))
    if isinstance(out, Trace):  # values may be wrong (nothing to check them against) ...
        assert out.cmd_t_ns.size == out.cmd_v.size and out.meas_t_ns.size == out.meas_v.size
        assert np.all(np.diff(out.meas_t_ns) > 0) and np.all(np.isfinite(out.meas_v))


def test_unmutated_files_read_completely():
    for data in (_VALID, _NO_CRC):
        tr = _read(data)
        assert isinstance(tr, Trace)
        np.testing.assert_array_equal(tr.meas_t_ns, _ARR.meas_t_ns)
        assert tr.meta.warnings == () and tr.t0_ns >= T0_NS


@pytest.mark.parametrize("keep", [0.3, 0.6, 0.9, 0.99])
def test_truncations_of_the_crc_file(keep: float):
    out = _read(_VALID[: int(len(_VALID) * keep)])
    if isinstance(out, Trace):
        _assert_subset_of_original(out)
        assert any("truncated" in w or "summary" in w for w in out.meta.warnings)


@pytest.mark.parametrize("data", [_VALID, _NO_CRC], ids=["crc", "no-crc"])
@pytest.mark.parametrize("bit", range(16, 24))
def test_a_record_length_past_an_intact_footer_is_corruption_not_a_cut(data: bytes, bit: int):
    """A finished file (footer and closing magic intact) is never read as a recording cut
    short: a first record whose length runs past the end is an error naming its byte, and the
    records inside it (no longer covered by a CRC) are not read."""
    first = 8 + 9 + int.from_bytes(data[9:17], "little")  # after the magic and the Header
    buf = bytearray(data)
    buf[first + 1 + bit // 8] ^= 1 << (bit % 8)  # a high bit of the next record's length
    buf[first + 200] ^= 0x40  # and a byte inside it
    out = _read(bytes(buf))
    assert isinstance(out, Sim2RealError)
    assert "is corrupt" in str(out) and f"record at byte {first} " in str(out)
    assert "past the file's footer" in str(out)
