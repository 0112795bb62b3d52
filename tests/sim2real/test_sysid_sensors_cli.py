"""`sim2real sysid sensors` and `read_scans` on real ROS files written with rosbags."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sim2real.cli import main
from sim2real.logs import read_scans
from sim2real.sensor_report import simulated_spread
from sysid.sensors import PoseArrays, ScanArrays, load_sensor, still_spread
from tests.sim2real.test_cli_bad_input import assert_bad_input, cli
from tests.sysid.sensor_truth import MOUNT_XY_M, draw_truth, synthetic_recording

T0_NS = 1_700_000_000_000_000_000


def _messages(
    store: Any,
    scans: ScanArrays,
    odom: PoseArrays,
    *,
    ros1: bool,
    beams_at: dict[int, int] | None = None,
) -> list[tuple[int, str, str, object]]:
    """The scans and odometry as (log time ns, topic, type, message), unsorted."""
    T = store.types
    stamp = T["builtin_interfaces/msg/Time"]
    header = T["std_msgs/msg/Header"]
    scan_t = T0_NS + np.rint(scans.t_s * 1e9).astype(np.int64)
    odom_t = T0_NS + np.rint(odom.t_s * 1e9).astype(np.int64)

    def hdr(t_ns: int, frame: str) -> object:
        s = stamp(sec=int(t_ns // 10**9), nanosec=int(t_ns % 10**9))
        return header(seq=0, stamp=s, frame_id=frame) if ros1 else header(stamp=s, frame_id=frame)

    def laser(k: int) -> object:
        r = scans.ranges_m[k].astype(np.float32)
        if beams_at and k in beams_at:
            r = r[: beams_at[k]]
        return T["sensor_msgs/msg/LaserScan"](
            header=hdr(int(scan_t[k]), "base_laser_link"),
            angle_min=scans.angle_min_rad,
            angle_max=scans.angle_min_rad + scans.angle_increment_rad * (r.size - 1),
            angle_increment=scans.angle_increment_rad,
            time_increment=0.0,
            scan_time=0.2,
            range_min=scans.range_min_m,
            range_max=scans.range_max_m,
            ranges=r,
            intensities=np.zeros(0, np.float32),
        )

    def odometry(i: int) -> object:
        g = T
        yaw = float(odom.yaw_rad[i])
        pose = g["geometry_msgs/msg/Pose"](
            position=g["geometry_msgs/msg/Point"](
                x=float(odom.x_m[i]), y=float(odom.y_m[i]), z=0.0
            ),
            orientation=g["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)
            ),
        )
        zero3 = g["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        return g["nav_msgs/msg/Odometry"](
            header=hdr(int(odom_t[i]), "odom"),
            child_frame_id="base_link",
            pose=g["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
            twist=g["geometry_msgs/msg/TwistWithCovariance"](
                twist=g["geometry_msgs/msg/Twist"](linear=zero3, angular=zero3),
                covariance=np.zeros(36),
            ),
        )

    msgs = [
        (int(scan_t[k]), "/scan", "sensor_msgs/msg/LaserScan", laser(k))
        for k in range(scans.t_s.size)
    ]
    msgs += [
        (int(odom_t[i]), "/odom", "nav_msgs/msg/Odometry", odometry(i))
        for i in range(odom.t_s.size)
    ]
    return msgs


def _write(
    path: Path,
    scans: ScanArrays,
    odom: PoseArrays,
    *,
    ros1: bool,
    beams_at: dict[int, int] | None = None,
) -> Path:
    """The recording as a ROS 1 bag or a ROS 2 MCAP (a rosbag2 folder's .mcap file)."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    msgs = _messages(store, scans, odom, ros1=ros1, beams_at=beams_at)
    msgs.sort(key=lambda m: m[0])
    if ros1:
        from rosbags.rosbag1 import Writer as Ros1Writer

        with Ros1Writer(path) as wr:
            conns: dict[str, object] = {}
            for t_ns, topic, ty, msg in msgs:
                if topic not in conns:
                    conns[topic] = wr.add_connection(topic, ty, typestore=store)
                wr.write(conns[topic], t_ns, store.serialize_ros1(msg, ty))
        return path
    return write_mcap(path, store, msgs)


def write_mcap(path: Path, store: Any, msgs: list[tuple[int, str, str, object]]) -> Path:
    """Messages (log time ns, topic, type, message) as a ROS 2 MCAP file (rosbag2 folder)."""
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Ros2Writer

    with Ros2Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as wr:
        conns: dict[str, object] = {}
        for t_ns, topic, ty, msg in sorted(msgs, key=lambda m: m[0]):
            if topic not in conns:
                conns[topic] = wr.add_connection(topic, ty, typestore=store)
            wr.write(conns[topic], t_ns, store.serialize_cdr(msg, ty))
    return next(path.glob("*.mcap"))


@pytest.fixture(scope="module")
def recording() -> tuple[ScanArrays, PoseArrays]:
    return synthetic_recording(draw_truth(np.random.default_rng(11)), 11)


@pytest.fixture(scope="module")
def mcap_log(
    tmp_path_factory: pytest.TempPathFactory, recording: tuple[ScanArrays, PoseArrays]
) -> Path:
    """The synthetic recording as a ROS 2 MCAP file."""
    return _write(tmp_path_factory.mktemp("mcap") / "r2", *recording, ros1=False)


@pytest.fixture(scope="module")
def spec_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A robot spec whose lidar sits where the synthetic recordings mount it."""
    return mounted_spec(tmp_path_factory.mktemp("spec") / "base.yaml")


def mounted_spec(path: Path) -> Path:
    """Write a robot spec whose lidar sits where the synthetic recordings mount it."""
    assert (
        main(
            [
                "robots",
                "new",
                "base",
                "--wheel-separation",
                "0.25",
                "--max-speed",
                "0.3",
                "-o",
                str(path),
            ]
        )
        == 0
    )
    body = path.read_text()
    path.write_text(body.replace("xyz_m: [0.0, 0.0,", f"xyz_m: [{MOUNT_XY_M[0]}, {MOUNT_XY_M[1]},"))
    return path


def test_mcap_and_ros1_bag_read_the_same_scans(
    tmp_path: Path, recording: tuple[ScanArrays, PoseArrays]
) -> None:
    scans, odom = recording
    a = read_scans(_write(tmp_path / "r2", scans, odom, ros1=False))
    b = read_scans(_write(tmp_path / "r1.bag", scans, odom, ros1=True))
    assert a.ranges_m.shape == (scans.t_s.size, 360)
    np.testing.assert_array_equal(a.ranges_m, scans.ranges_m.astype(np.float32))
    np.testing.assert_array_equal(a.ranges_m, b.ranges_m)
    np.testing.assert_array_equal(a.stamp_ns, b.stamp_ns)
    np.testing.assert_allclose(a.odom_yaw_rad, odom.yaw_rad, atol=1e-12)
    assert (a.range_max_m, a.topic, a.odom_topic) == (5.0, "/scan", "/odom")


def test_cli_identifies_the_synthetic_lidar(
    tmp_path: Path, mcap_log: Path, spec_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = mcap_log
    out = tmp_path / "sensors.yaml"
    run = cli(capsys, "sysid", "sensors", log, "--robot", spec_file, "-o", out)
    assert run.code == 0, run.err  # its speed (<= 5 s) is benchmarks/bench_sensors.py's
    est = load_sensor(out)
    truth = draw_truth(np.random.default_rng(11))
    assert est.time_offset_s == pytest.approx(truth.offset_s, abs=0.010)
    assert est.mounting_yaw_rad == pytest.approx(truth.yaw_rad, abs=math.radians(0.5))
    assert est.noise_std_at(3.0) == pytest.approx(truth.std_at(3.0), rel=0.15)
    assert "scan time offset" in run.out and "wrote" in run.out
    assert "range noise std (still stretches)" in run.out
    assert "moving scans" in run.out  # the moving scans' noise beside each range bin's


def test_log_without_scans_lists_its_topics(
    tmp_path: Path, mcap_log: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = mcap_log
    run = cli(
        capsys,
        "sysid",
        "sensors",
        log,
        "--robot",
        "turtlebot3_burger",
        "-o",
        tmp_path / "s.yaml",
        "--scan-topic",
        "/base_scan",
    )
    assert_bad_input(
        run, "no sensor_msgs/msg/LaserScan topic '/base_scan'", "/odom (nav_msgs/msg/Odometry"
    )


def test_changing_beam_count_is_one_sentence(
    tmp_path: Path, recording: tuple[ScanArrays, PoseArrays], capsys: pytest.CaptureFixture[str]
) -> None:
    scans, odom = recording
    log = _write(tmp_path / "r1.bag", scans, odom, ros1=True, beams_at={7: 359})
    run = cli(
        capsys, "sysid", "sensors", log, "--robot", "turtlebot3_burger", "-o", tmp_path / "s.yaml"
    )
    assert_bad_input(run, "changes its beam count", "scan 7 has 359")


def test_no_still_stretch_and_no_motion_is_one_sentence(
    tmp_path: Path, recording: tuple[ScanArrays, PoseArrays], capsys: pytest.CaptureFixture[str]
) -> None:
    scans, odom = recording
    late = PoseArrays(t_s=odom.t_s + 1000.0, x_m=odom.x_m, y_m=odom.y_m, yaw_rad=odom.yaw_rad)
    log = _write(tmp_path / "r2", scans, late, ros1=False)
    run = cli(
        capsys, "sysid", "sensors", log, "--robot", "turtlebot3_burger", "-o", tmp_path / "s.yaml"
    )
    assert_bad_input(run, "no still stretch", "no scan pair with motion")
    assert not (tmp_path / "s.yaml").exists()


def test_report_draws_the_simulated_lidar_over_the_real_spread(
    tmp_path: Path,
    recording: tuple[ScanArrays, PoseArrays],
    mcap_log: Path,
    spec_file: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    scans, odom = recording
    log = mcap_log
    report = tmp_path / "sensors.html"
    run = cli(
        capsys,
        "sysid",
        "sensors",
        log,
        "--robot",
        spec_file,
        "-o",
        tmp_path / "s.yaml",
        "--report",
        report,
    )
    assert run.code == 0, run.err
    page = report.read_text()
    assert page.count("data:image/png;base64,") == 2
    assert "noise std growth, mm per m" in page
    assert "ray caster" in page
    # on a recording with known noise, the simulated lidar (the ray caster in a map of each
    # still stretch, with the identified noise) spreads like the real one on the same groups
    est = load_sensor(tmp_path / "s.yaml")
    spread = still_spread(scans, odom)
    sim = simulated_spread(est, [scans], [odom])
    assert sim.median_m.size == pytest.approx(spread.median_m.size, rel=0.05)
    assert np.median(sim.std_m) / np.median(spread.std_m) == pytest.approx(1.0, abs=0.05)
    near = sim.median_m < np.median(sim.median_m)
    real_near = spread.median_m < np.median(spread.median_m)
    assert np.median(sim.std_m[near]) == pytest.approx(np.median(spread.std_m[real_near]), rel=0.1)


def test_report_of_a_recording_that_never_stands_still(
    tmp_path: Path, spec_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scans, odom = synthetic_recording(draw_truth(np.random.default_rng(12)), 12, stops=False)
    log = _write(tmp_path / "r2", scans, odom, ros1=False)
    report = tmp_path / "sensors.html"
    out = tmp_path / "s.yaml"
    run = cli(capsys, "sysid", "sensors", log, "--robot", spec_file, "-o", out, "--report", report)
    assert run.code == 0, run.err
    assert "range noise std (matched moving scans)" in run.out
    assert "not identified: dropout: no still stretch" in run.out
    page = report.read_text()
    assert page.count("data:image/png;base64,") == 1  # the noise; no invalid-return figure
    assert "the model comes from the moving scans" in page
    assert load_sensor(out).noise_source == "moving"
