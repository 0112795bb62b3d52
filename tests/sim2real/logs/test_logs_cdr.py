"""The numpy bulk CDR decoders agree with mcap-ros2-support's generic decoder."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory

from sim2real.logs import JOINT_STATE, ODOMETRY, SCHEMA_TEXT, TWIST, TWIST_STAMPED, _cdr

_FACTORY = DecoderFactory()


def _generic(type_name: str, payload: bytes):
    sid = sorted(SCHEMA_TEXT).index(type_name) + 1
    schema = Schema(
        id=sid, name=type_name, encoding="ros2msg", data=SCHEMA_TEXT[type_name].encode()
    )
    decoder = _FACTORY.decoder_for("cdr", schema)
    assert decoder is not None
    return decoder(payload)


def _batch(payloads: list[bytes]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Concatenate payloads with a 3-byte gap so offsets are not aligned in the buffer."""
    buf = b"".join(b"\xaa\xbb\xcc" + p for p in payloads)
    lens = np.array([len(p) for p in payloads], dtype=np.int64)
    offs = np.cumsum(np.concatenate([[3], lens[:-1] + 3]))
    return np.frombuffer(buf, dtype=np.uint8), offs.astype(np.int64), lens


frames = st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=13)
finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
stamps = st.integers(min_value=-(2**31) * 10**9, max_value=2**31 * 10**9 - 10)


@settings(max_examples=40, deadline=None)
@given(frame=frames, child=frames, v=finite, w=finite, x=finite, t=stamps, n=st.integers(1, 4))
def test_odometry_bulk_matches_generic(frame, child, v, w, x, t, n):
    ts = np.full(n, t, dtype=np.int64) + np.arange(n)
    payloads = _cdr.encode_odometry(
        ts,
        np.full(n, v),
        np.full(n, w),
        x=np.full(n, x),
        y=np.full(n, -x),
        yaw=np.linspace(-3, 3, n),
        frame_id=frame,
        child_frame_id=child,
    )
    out = _cdr.decode_odometry(*_batch(payloads))
    for i, p in enumerate(payloads):
        msg = _generic(ODOMETRY, p)
        assert msg.header.frame_id == frame and msg.child_frame_id == child
        assert (
            out["stamp_ns"][i] == msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == ts[i]
        )
        assert out["v"][i] == msg.twist.twist.linear.x == v
        assert out["w"][i] == msg.twist.twist.angular.z == w
        assert out["x"][i] == msg.pose.pose.position.x and out["y"][i] == msg.pose.pose.position.y
        assert out["qz"][i] == msg.pose.pose.orientation.z
        assert out["qw"][i] == msg.pose.pose.orientation.w


@settings(max_examples=30, deadline=None)
@given(frame=frames, v=finite, w=finite, t=stamps)
def test_twist_stamped_bulk_matches_generic(frame, v, w, t):
    payloads = _cdr.encode_twist_stamped(
        np.array([t, t + 7]), np.array([v, -v]), np.array([w, 0.0]), frame_id=frame
    )
    out = _cdr.decode_twist_stamped(*_batch(payloads))
    msg = _generic(TWIST_STAMPED, payloads[1])
    assert msg.header.frame_id == frame
    assert out["stamp_ns"].tolist() == [t, t + 7]
    assert out["v"].tolist() == [v, -v] and out["w"].tolist() == [w, 0.0]
    assert msg.twist.linear.x == -v


def test_twist_bulk_matches_generic():
    v, w = np.array([0.25, -1.5, 0.0]), np.array([1.0, 0.5, -2.25])
    payloads = _cdr.encode_twist(v, w)
    assert all(len(p) == 52 for p in payloads)
    out = _cdr.decode_twist(*_batch(payloads))
    np.testing.assert_array_equal(out["v"], v)
    np.testing.assert_array_equal(out["w"], w)
    msg = _generic(TWIST, payloads[1])
    assert (msg.linear.x, msg.angular.z, msg.linear.y) == (-1.5, 0.5, 0.0)


def test_joint_state_encoding_matches_generic_decoder():
    payload = _cdr.encode_joint_state(
        5 * 10**9 + 7,
        frame_id="base",
        names=["wheel_left_joint", "wheel_right_joint", "x"],
        position=[1.0, 2.0, 3.0],
        velocity=[4.0, -5.0, 6.0],
        effort=[],
    )
    msg = _generic(JOINT_STATE, payload)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (5, 7, "base")
    assert msg.name == ["wheel_left_joint", "wheel_right_joint", "x"]
    assert msg.velocity == [4.0, -5.0, 6.0] and list(msg.effort) == []


def test_short_payload_raises_layout_error_with_index():
    good = _cdr.encode_odometry(
        np.array([1, 2]),
        np.zeros(2),
        np.zeros(2),
        x=np.zeros(2),
        y=np.zeros(2),
        yaw=np.zeros(2),
        frame_id="odom",
        child_frame_id="base",
    )
    u8, off, ln = _batch([good[0], good[1][:-9]])
    try:
        _cdr.decode_odometry(u8, off, ln)
    except _cdr.CdrLayoutError as exc:
        assert exc.index == 1
    else:
        raise AssertionError("a cut Odometry payload was decoded")


def test_schema_text_has_ros2_dependency_sections():
    text = SCHEMA_TEXT[ODOMETRY]
    sections = text.split("=" * 80 + "\n")
    assert sections[0].splitlines()[0] == "std_msgs/Header header"
    names = [s.splitlines()[0] for s in sections[1:]]
    assert names[:2] == ["MSG: std_msgs/Header", "MSG: builtin_interfaces/Time"]
    assert "MSG: geometry_msgs/Quaternion" in names and "MSG: geometry_msgs/Vector3" in names
    assert SCHEMA_TEXT[TWIST].count("MSG: ") == 1
