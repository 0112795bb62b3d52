"""Write -> read round trips for every message type and both encodings; Foxglove-style reads."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from logs_helpers import T0_NS, Arrays
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from sim2real.logs import (
    JOINT_STATE,
    ODOMETRY,
    TWIST,
    TWIST_STAMPED,
    Trace,
    integrate_pose,
    read_trace,
    write_joint_state_log,
    write_trace,
    write_velocity_log,
)


def _assert_same(tr: Trace, a: Arrays) -> None:
    np.testing.assert_array_equal(tr.cmd_t_ns, a.cmd_t_ns)
    np.testing.assert_array_equal(tr.cmd_v, a.cmd_v)
    np.testing.assert_array_equal(tr.cmd_w, a.cmd_w)
    np.testing.assert_array_equal(tr.meas_t_ns, a.meas_t_ns)
    np.testing.assert_array_equal(tr.meas_v, a.meas_v)
    np.testing.assert_array_equal(tr.meas_w, a.meas_w)
    np.testing.assert_array_equal(tr.pose_x, a.pose_x)
    np.testing.assert_array_equal(tr.pose_y, a.pose_y)
    np.testing.assert_allclose(tr.pose_yaw, a.pose_yaw, rtol=0, atol=1e-14)


@pytest.mark.parametrize("encoding", ["cdr", "json"])
@pytest.mark.parametrize("cmd_type", [TWIST, TWIST_STAMPED])
def test_velocity_log_round_trip(tmp_path: Path, arrays: Arrays, encoding: str, cmd_type: str):
    path = write_velocity_log(
        tmp_path / "rt.mcap", cmd_type=cmd_type, encoding=encoding, **arrays.kwargs()
    )
    tr = read_trace(path)
    _assert_same(tr, arrays)
    m = tr.meta
    assert (m.cmd_topic, m.cmd_type, m.meas_topic, m.meas_type) == (
        "/cmd_vel",
        cmd_type,
        "/odom",
        ODOMETRY,
    )
    assert (m.cmd_count, m.meas_count, m.encoding, m.warnings) == (40, 100, encoding, ())
    assert m.cmd_time_source == ("header" if cmd_type == TWIST_STAMPED else "log")
    assert m.meas_time_source == "header"
    assert m.cmd_rate_hz == pytest.approx(10.0, rel=1e-9)
    assert m.meas_rate_hz == pytest.approx(25.0, rel=1e-4)


def test_write_trace_round_trip_is_bit_exact(tmp_path: Path, small_log: Path, arrays: Arrays):
    first = read_trace(small_log)
    again = read_trace(write_trace(tmp_path / "copy.mcap", first))
    _assert_same(again, arrays)
    # yaw -> quaternion -> yaw is exact up to one rounding step
    np.testing.assert_allclose(again.pose_yaw, first.pose_yaw, rtol=0, atol=4.5e-16)
    assert again.meta.sha256 != first.meta.sha256 and len(again.meta.sha256) == 64


def test_trace_without_pose_is_written_with_dead_reckoned_pose(tmp_path: Path):
    t = np.arange(11, dtype=np.int64) * 100_000_000 + T0_NS
    tr = Trace(
        cmd_t_ns=t,
        cmd_v=np.ones(11),
        cmd_w=np.zeros(11),
        meas_t_ns=t,
        meas_v=np.full(11, 0.5),
        meas_w=np.zeros(11),
    )
    back = read_trace(write_trace(tmp_path / "np.mcap", tr))
    assert back.pose_x is not None and back.pose_x[-1] == pytest.approx(0.5)
    np.testing.assert_array_equal(back.meas_v, tr.meas_v)


def test_log_time_differs_from_header_stamp(tmp_path: Path, arrays: Arrays):
    delay = np.linspace(5e6, 300e6, arrays.meas_t_ns.size).astype(np.int64)
    cmd_delay = np.full(arrays.cmd_t_ns.size, 20_000_000, dtype=np.int64)
    path = write_velocity_log(
        tmp_path / "lt.mcap",
        cmd_type=TWIST_STAMPED,
        meas_log_t_ns=arrays.meas_t_ns + delay,
        cmd_log_t_ns=arrays.cmd_t_ns + cmd_delay,
        **arrays.kwargs(),
    )
    by_header = read_trace(path)
    by_log = read_trace(path, time_source="log")
    np.testing.assert_array_equal(by_header.meas_t_ns, arrays.meas_t_ns)
    np.testing.assert_array_equal(by_header.cmd_t_ns, arrays.cmd_t_ns)
    np.testing.assert_array_equal(by_log.meas_t_ns, arrays.meas_t_ns + delay)
    np.testing.assert_array_equal(by_log.cmd_t_ns, arrays.cmd_t_ns + cmd_delay)
    assert (by_log.meta.cmd_time_source, by_log.meta.meas_time_source) == ("log", "log")
    np.testing.assert_array_equal(by_log.meas_v, by_header.meas_v)


@pytest.mark.parametrize("encoding", ["cdr", "json"])
def test_joint_state_wheels_give_v_and_w(tmp_path: Path, encoding: str):
    t = T0_NS + np.arange(50, dtype=np.int64) * 20_000_000
    left = np.linspace(-2.0, 5.0, 50)
    right = np.linspace(3.0, 4.0, 50)
    path = write_joint_state_log(
        tmp_path / "js.mcap",
        cmd_t_ns=t[::5],
        cmd_v=np.full(10, 0.1),
        cmd_w=np.zeros(10),
        js_t_ns=t,
        left_radps=left,
        right_radps=right,
        encoding=encoding,
    )
    tr = read_trace(path, wheel_radius_m=0.033, wheel_separation_m=0.16)
    assert (tr.meta.meas_topic, tr.meta.meas_type) == ("/joint_states", JOINT_STATE)
    np.testing.assert_allclose(tr.meas_v, 0.033 * (right + left) / 2, rtol=1e-15)
    np.testing.assert_allclose(tr.meas_w, 0.033 * (right - left) / 0.16, rtol=1e-15)
    np.testing.assert_array_equal(tr.meas_t_ns, t)
    assert tr.pose_x is None and tr.pose_yaw is None and not tr.has_pose


def test_joint_state_with_explicit_joint_names(tmp_path: Path):
    t = T0_NS + np.arange(4, dtype=np.int64) * 10**8
    path = write_joint_state_log(
        tmp_path / "js2.mcap",
        cmd_t_ns=t,
        cmd_v=np.zeros(4),
        cmd_w=np.zeros(4),
        js_t_ns=t,
        left_radps=np.ones(4),
        right_radps=np.full(4, 3.0),
        joint_names=("a", "b"),
    )
    tr = read_trace(path, wheel_radius_m=0.1, wheel_separation_m=0.5, wheel_joints=("a", "b"))
    np.testing.assert_allclose(tr.meas_v, 0.2)
    np.testing.assert_allclose(tr.meas_w, 0.4)


@pytest.mark.parametrize("cmd_type", [TWIST, TWIST_STAMPED])
def test_mcap_ros2_decodes_our_files(tmp_path: Path, arrays: Arrays, cmd_type: str):
    """What Foxglove and ros2 tooling see: the generic ROS 2 decoder reads the same values."""
    path = write_velocity_log(tmp_path / "fx.mcap", cmd_type=cmd_type, **arrays.kwargs())
    odom, cmd = [], []
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, message, msg in reader.iter_decoded_messages():
            assert schema is not None and schema.encoding == "ros2msg"
            assert channel.message_encoding == "cdr"
            if channel.topic == "/odom":
                st = msg.header.stamp
                odom.append(
                    (
                        st.sec * 10**9 + st.nanosec,
                        msg.twist.twist.linear.x,
                        msg.twist.twist.angular.z,
                        msg.pose.pose.position.x,
                        msg.header.frame_id,
                        msg.child_frame_id,
                        message.log_time,
                    )
                )
            else:
                twist = msg.twist if cmd_type == TWIST_STAMPED else msg
                cmd.append((message.log_time, twist.linear.x, twist.angular.z))
    o = np.array([r[:4] for r in odom], dtype=object)
    np.testing.assert_array_equal(o[:, 0].astype(np.int64), arrays.meas_t_ns)
    np.testing.assert_array_equal(o[:, 1].astype(float), arrays.meas_v)
    np.testing.assert_array_equal(o[:, 2].astype(float), arrays.meas_w)
    np.testing.assert_array_equal(o[:, 3].astype(float), arrays.pose_x)
    assert {(r[4], r[5]) for r in odom} == {("odom", "base_link")}
    assert [r[6] for r in odom] == arrays.meas_t_ns.tolist()
    np.testing.assert_array_equal(np.array([c[1] for c in cmd]), arrays.cmd_v)
    np.testing.assert_array_equal(np.array([c[2] for c in cmd]), arrays.cmd_w)


def test_write_is_atomic_and_rejects_float_times(tmp_path: Path, arrays: Arrays):
    from sim2real.errors import Sim2RealValueError

    kw = arrays.kwargs()
    kw["cmd_t_ns"] = kw["cmd_t_ns"] / 1e9
    with pytest.raises(Sim2RealValueError, match=r"cmd_t_ns must be a 1-D array of integer"):
        write_velocity_log(tmp_path / "bad.mcap", **kw)
    assert list(tmp_path.iterdir()) == []


def test_integrate_pose_drives_a_quarter_circle():
    # v = 1 m/s, w = pi/2 rad/s for 1 s in 10 000 steps: quarter circle of radius 2/pi.
    n = 10_001
    t = np.arange(n, dtype=np.int64) * 100_000
    x, y, yaw = integrate_pose(t, np.ones(n), np.full(n, np.pi / 2))
    r = 2 / np.pi
    assert yaw[-1] == pytest.approx(np.pi / 2, abs=1e-9)
    assert x[-1] == pytest.approx(r, abs=1e-3) and y[-1] == pytest.approx(r, abs=1e-3)


def test_writing_into_a_missing_folder_is_a_clear_error(tmp_path: Path, arrays: Arrays):
    from sim2real.errors import Sim2RealFileNotFoundError

    with pytest.raises(Sim2RealFileNotFoundError, match="which does not exist"):
        write_velocity_log(tmp_path / "no" / "x.mcap", **arrays.kwargs())
