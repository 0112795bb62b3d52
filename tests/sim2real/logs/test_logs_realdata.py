"""The real third-party logs in ../shared/realdata (skipped when absent)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from sim2real.errors import Sim2RealError
from sim2real.logs import ODOMETRY, TWIST, inspect_log, read_trace

pytestmark = pytest.mark.realdata


def _generic_odom(path: Path) -> np.ndarray:
    """(stamp_ns, log_ns, v, w, x, y) of /odom decoded message by message by mcap_ros2."""
    rows = []
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _, _, message, msg in reader.iter_decoded_messages(topics=["/odom"]):
            st = msg.header.stamp
            rows.append(
                (
                    st.sec * 10**9 + st.nanosec,
                    message.log_time,
                    msg.twist.twist.linear.x,
                    msg.twist.twist.angular.z,
                    msg.pose.pose.position.x,
                    msg.pose.pose.position.y,
                )
            )
    return np.array(rows, dtype=object)


def test_drexel_counts_rates_and_topics(drexel_log: Path):
    tr = read_trace(drexel_log)
    m = tr.meta
    assert (m.cmd_topic, m.cmd_type, m.meas_topic, m.meas_type) == (
        "/cmd_vel",
        TWIST,
        "/odom",
        ODOMETRY,
    )
    assert (m.cmd_count, m.meas_count) == (299, 893)
    assert m.cmd_rate_hz == pytest.approx(9.7, abs=0.1)
    assert m.meas_rate_hz == pytest.approx(23.0, abs=0.2)
    assert tr.duration_s == pytest.approx(38.7, abs=0.2)
    assert (m.cmd_time_source, m.meas_time_source, m.warnings) == ("log", "header", ())
    assert tr.has_pose and tr.pose_x is not None


def test_drexel_motion_matches_the_readme(drexel_log: Path):
    tr = read_trace(drexel_log)
    # 165 odom samples at rest before the first command.
    assert int(np.sum(tr.meas_t_ns < tr.cmd_t_ns[0])) == 165
    # In-place turn with w decaying from 1.08 rad/s; straight segments at v = 0.20 m/s.
    assert tr.cmd_w.max() == pytest.approx(1.08, abs=0.01)
    assert np.isclose(tr.cmd_v, 0.2, atol=1e-6).sum() > 50
    # One impossible odom spike of ~1.35 m/s.
    assert tr.meas_v.max() == pytest.approx(1.35, abs=0.05)
    assert int(np.sum(tr.meas_v > 0.5)) == 1
    v_held, _ = tr.cmd_at_meas()
    moving = v_held > 0.15
    assert np.median(tr.meas_v[moving]) == pytest.approx(0.2, abs=0.03)


def test_neato_counts(neato_log: Path):
    tr = read_trace(neato_log)
    assert (tr.meta.cmd_count, tr.meta.meas_count) == (190, 537)
    assert tr.meta.meas_rate_hz == pytest.approx(7.1, abs=0.1)
    assert set(np.round(tr.cmd_w, 6)) <= {-1.0, 0.0, 1.0}
    assert set(np.round(tr.cmd_v, 6)) <= {0.0, 0.5}


@pytest.mark.parametrize("which", ["drexel", "neato"])
def test_bulk_decoder_equals_mcap_ros2(which: str, drexel_log: Path, neato_log: Path):
    path = drexel_log if which == "drexel" else neato_log
    ref = _generic_odom(path)
    order = np.argsort(ref[:, 0].astype(np.int64), kind="stable")
    ref = ref[order]
    tr = read_trace(path, odom_velocity="twist")  # the decoded twist, not the pose's (neato)
    np.testing.assert_array_equal(tr.meas_t_ns, ref[:, 0].astype(np.int64))
    np.testing.assert_array_equal(tr.meas_v, ref[:, 2].astype(float))
    np.testing.assert_array_equal(tr.meas_w, ref[:, 3].astype(float))
    np.testing.assert_array_equal(tr.pose_x, ref[:, 4].astype(float))
    np.testing.assert_array_equal(tr.pose_y, ref[:, 5].astype(float))
    by_log = read_trace(path, time_source="log")
    np.testing.assert_array_equal(by_log.meas_t_ns, np.sort(ref[:, 1].astype(np.int64)))


def test_drexel_log_time_is_bursty_compared_to_stamps(drexel_log: Path):
    """Why header stamps are the default: rosserial delivers odometry in bursts."""
    stamp = read_trace(drexel_log).meas_t_ns
    log = read_trace(drexel_log, time_source="log").meas_t_ns
    lag_s = (log - stamp) / 1e9
    assert lag_s.max() > 1.0  # a message logged > 1 s after it was stamped
    assert np.median(np.abs(lag_s)) < 0.05
    # Stamps step evenly (~35 ms); log times arrive in bursts (many steps < 5 ms).
    step_stamp_ms, step_log_ms = np.diff(stamp) / 1e6, np.diff(log) / 1e6
    assert int(np.sum(step_stamp_ms < 5)) <= 2 and int(np.sum(step_log_ms < 5)) > 100
    assert np.std(step_log_ms) > 4 * np.std(step_stamp_ms)


def test_inspect_real_logs(drexel_log: Path, neato_log: Path):
    info = inspect_log(drexel_log)
    assert [t.topic for t in info.topics] == ["/cmd_vel", "/imu", "/odom"]
    assert (info.topic("/cmd_vel").count, info.topic("/odom").count) == (299, 893)
    assert info.topic("/odom").rate_hz == pytest.approx(23.0, abs=0.1)
    assert info.topic("/cmd_vel").rate_hz == pytest.approx(9.7, abs=0.1)
    assert info.duration_s == pytest.approx(38.8, abs=0.1)
    assert (info.cmd_topic, info.meas_topic, info.profile) == ("/cmd_vel", "/odom", "ros2")
    neato = inspect_log(neato_log)
    assert (neato.topic("/cmd_vel").count, neato.topic("/odom").count) == (190, 537)
    assert neato.topic("/scan").type == "sensor_msgs/msg/LaserScan"
    assert neato.duration_s == pytest.approx(75.9, abs=0.1)


@settings(
    max_examples=20,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    flips=st.lists(st.tuples(st.integers(0, 2_095_601), st.integers(1, 255)), max_size=3),
    keep=st.none() | st.floats(0.0, 1.0),
)
def test_damaged_real_log_gives_trace_or_our_error(drexel_log: Path, tmp_path: Path, flips, keep):
    """The real log has no CRCs: damage may go unnoticed, but never as a foreign exception."""
    buf = bytearray(drexel_log.read_bytes())
    for pos, mask in flips:
        buf[pos % len(buf)] ^= mask
    if keep is not None:
        buf = buf[: int(len(buf) * keep)]
    path = tmp_path / "damaged.mcap"
    path.write_bytes(bytes(buf))
    for fn in (read_trace, inspect_log):
        try:
            fn(path)
        except Sim2RealError as exc:
            assert "\n" not in str(exc)


def test_neato_2017_held_pose_gives_a_steady_top_speed(realdata_dir: Path) -> None:
    """The 2017 Neato driver sends its pose at 20 Hz but updates it about every third message:
    on the straights of the square (commanded 1 m/s, capped near 0.3 m/s) the pose velocity
    holds the cap steadily instead of jumping between stale and fresh poses."""
    path = realdata_dir / "neato_paulruvolo-pr2_drive_square_bag_2017-01-29-18-30-40.mcap"
    if not path.exists():
        pytest.skip(f"{path.name} is absent")
    tr = read_trace(path, time_source="auto")
    assert "from the pose" in tr.meta.warnings[-1]
    cmd_v, _ = tr.cmd_at_meas()
    t = tr.meas_t_s
    straight = np.flatnonzero(cmd_v > 0.5)
    start = t[straight[np.r_[True, np.diff(straight) > 1]]]
    held = np.array([i for i in straight if np.min(t[i] - start[start <= t[i]]) > 1.5])
    assert held.size > 40
    assert 0.28 < np.median(tr.meas_v[held]) < 0.33
    assert np.std(tr.meas_v[held]) < 0.02  # stale-pose spikes gave 0.18-0.42 m/s
