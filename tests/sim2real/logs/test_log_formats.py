"""Every input format gives the same trace: MCAP, ROS 1 bag, rosbag2 (sqlite3, mcap), CSV.

All files are real: MCAP from :func:`write_trace`, bags written by the ``rosbags`` writers, the
bag's MCAP conversion made by ``rosbags``' own converter (what ``rosbags-convert`` does), CSV
from :func:`write_csv_trace`. Bad input goes through the CLI (one line, exit 2).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from sim2real.cli import main
from sim2real.errors import LogFormatError, LogValueError, MissingTopicError
from sim2real.logs import Trace, TraceMeta, inspect_log, read_trace, write_trace
from sim2real.logs._bagwrite import write_rosbag
from sim2real.logs._csv import write_csv_trace
from tests.ros1_bags import write_joint_state_bag

T0_NS = 1_700_000_000_123_456_789
FIELDS = ("cmd_t_ns", "cmd_v", "cmd_w", "meas_t_ns", "meas_v", "meas_w", "pose_x", "pose_y")
BUMP_MSG = "bool leftFront\nbool rightFront\nbool leftSide\nbool rightSide\n"
TF_MSG = "geometry_msgs/TransformStamped[] transforms\n"


def recording(n: int = 240, seed: int = 3) -> Trace:
    """A 12 s recording: commands and odometry at 20 Hz on common stamps, with a pose."""
    rng = np.random.default_rng(seed)
    t = T0_NS + np.arange(n, dtype=np.int64) * 50_000_000 + rng.integers(0, 999, n)
    s = np.arange(n) * 0.05
    v, w = 0.2 + 0.1 * np.sin(0.5 * s), 0.8 * np.sin(0.3 * s)
    mv, mw = 0.9 * v + rng.normal(0, 0.002, n), 0.9 * w + rng.normal(0, 0.005, n)
    yaw = np.cumsum(mw) * 0.05
    return Trace(
        cmd_t_ns=t,
        cmd_v=v,
        cmd_w=w,
        meas_t_ns=t,
        meas_v=mv,
        meas_w=mw,
        pose_x=np.cumsum(mv * np.cos(yaw)) * 0.05,
        pose_y=np.cumsum(mv * np.sin(yaw)) * 0.05,
        pose_yaw=np.arctan2(np.sin(yaw), np.cos(yaw)),
        meta=TraceMeta(),
    )


@pytest.fixture(scope="module")
def formats(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("formats")
    rec = recording()
    files = {"mcap": write_trace(d / "run.mcap", rec)}
    for fmt, name in (("ros1", "run.bag"), ("sqlite3", "run_sqlite3"), ("mcap", "run_bag2")):
        files[fmt if fmt != "mcap" else "rosbag2_mcap"] = write_rosbag(d / name, rec, format=fmt)
    # CSV holds yaw itself; write the yaw a quaternion reader recovers, as a converter would
    files["csv"] = write_csv_trace(d / "run.csv", read_trace(files["mcap"]))
    return files


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "rosbag2_mcap", "csv"])
def test_every_format_gives_the_identical_trace(formats: dict[str, Path], kind: str) -> None:
    ref = read_trace(formats["mcap"])
    got = read_trace(formats[kind])
    for name in (*FIELDS, "pose_yaw"):
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name
    assert got.meta.warnings == ()
    assert (got.meta.cmd_count, got.meta.meas_count) == (240, 240)


def test_bag_numbers_equal_its_mcap_conversion(formats: dict[str, Path], tmp_path: Path) -> None:
    """rosbags' converter turns the .bag into rosbag2/MCAP; our MCAP reader reads that file."""
    from rosbags.convert.converter import convert

    dst = tmp_path / "converted"
    convert([formats["ros1"]], dst, "mcap", 9, None, "file", None, None, [], [], [], [])
    mcap_file = next(dst.glob("*.mcap"))
    from_bag, from_mcap = read_trace(formats["ros1"]), read_trace(mcap_file)
    for name in (*FIELDS, "pose_yaw"):
        assert np.array_equal(getattr(from_bag, name), getattr(from_mcap, name)), name
    assert from_mcap.meta.encoding == "cdr" and from_bag.meta.encoding == "ros1"


def test_ros1_bulk_decode_equals_rosbags_deserialiser(tmp_path: Path) -> None:
    """TwistStamped with frame ids of every length mod 8 (layout offsets) and Odometry."""
    from rosbags.rosbag1 import Reader, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    rng = np.random.default_rng(7)
    path = tmp_path / "stamped.bag"
    with Writer(path) as wr:
        conn = wr.add_connection("/cmd", "geometry_msgs/msg/TwistStamped", typestore=store)
        for i in range(40):
            t = T0_NS + i * 10**8
            head = T["std_msgs/msg/Header"](
                seq=i,
                stamp=T["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9),
                frame_id="f" * (i % 9),
            )
            vec = T["geometry_msgs/msg/Vector3"]
            tw = T["geometry_msgs/msg/Twist"](
                linear=vec(x=rng.normal(), y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=rng.normal())
            )
            msg = T["geometry_msgs/msg/TwistStamped"](header=head, twist=tw)
            wr.write(conn, t + 5, store.serialize_ros1(msg, "geometry_msgs/msg/TwistStamped"))
        odom = wr.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)
        src = write_rosbag(tmp_path / "o.bag", recording(30))
        with Reader(src) as rd:
            for c, t, raw in rd.messages():
                if c.topic == "/odom":
                    wr.write(odom, t, raw)
    tr = read_trace(path, odom_velocity="twist")
    with Reader(path) as rd:
        msgs = [(c.topic, store.deserialize_ros1(raw, c.msgtype)) for c, _, raw in rd.messages()]
    cmd = [m for topic, m in msgs if topic == "/cmd"]
    od = [m for topic, m in msgs if topic == "/odom"]
    assert tr.meta.cmd_time_source == "header"
    assert np.array_equal(tr.cmd_v, [m.twist.linear.x for m in cmd])
    assert np.array_equal(tr.cmd_w, [m.twist.angular.z for m in cmd])
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in cmd]
    assert np.array_equal(tr.cmd_t_ns, stamps)
    assert np.array_equal(tr.meas_v, [m.twist.twist.linear.x for m in od])
    assert np.array_equal(tr.pose_y, [m.pose.pose.position.y for m in od])


def _bag_with_extras(path: Path, *, topics: tuple[str, str] = ("/cmd_vel", "/odom")) -> Path:
    """A ROS 1 bag with a custom camelCase bumper message and a LaserScan besides the drive."""
    from rosbags.rosbag1 import Reader, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg(BUMP_MSG, "neato_node/msg/Bump"))
    store.register(get_types_from_msg(TF_MSG, "tf2_msgs/msg/TFMessage"))
    src = write_rosbag(path.with_suffix(".src.bag"), recording(60))
    with Writer(path) as wr:
        conns = {
            "/cmd_vel": wr.add_connection(topics[0], "geometry_msgs/msg/Twist", typestore=store),
            "/odom": wr.add_connection(topics[1], "nav_msgs/msg/Odometry", typestore=store),
        }
        bump = wr.add_connection("/bump", "neato_node/msg/Bump", typestore=store)
        scan = wr.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=store)
        tf = wr.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store)
        rosout = wr.add_connection("/rosout", "rosgraph_msgs/msg/Log", typestore=store)
        with Reader(src) as rd:
            for c, t, raw in rd.messages():
                wr.write(conns[c.topic], t, raw)
        Bump = store.types["neato_node/msg/Bump"]
        for i in range(10):
            msg = Bump(leftFront=i % 2, rightFront=0, leftSide=0, rightSide=1)
            wr.write(bump, T0_NS + i * 10**8, store.serialize_ros1(msg, "neato_node/msg/Bump"))
            wr.write(scan, T0_NS + i * 10**8, b"\x00" * 8)  # never decoded: only counted
        for i in range(60):  # 10 Hz, no transform (an empty array)
            wr.write(tf, T0_NS + i * 10**8, b"\x00" * 4)
        for i in range(11):  # a node's start-up lines: 11 messages within 0.2 s
            wr.write(rosout, T0_NS + i * 2 * 10**7, b"\x00" * 8)
    return path


def test_custom_and_unrelated_channels_are_skipped_with_one_note(tmp_path: Path) -> None:
    path = _bag_with_extras(tmp_path / "neato_like.bag")
    tr = read_trace(path)
    assert tr.meta.meas_count == 60
    notes = [w for w in tr.meta.warnings if "skipped" in w]
    assert len(notes) == 1 and "/bump (neato_node/msg/Bump)" in notes[0]
    for standard in ("/scan", "/tf", "/rosout"):  # standard types are not "unknown"
        assert standard not in notes[0]
    info = inspect_log(path)
    assert info.topic("/bump").count == 10 and info.topic("/scan").count == 10
    assert (info.cmd_topic, info.meas_topic) == ("/cmd_vel", "/odom")
    assert info.topic("/tf").rate_hz == pytest.approx(10.0)
    assert info.topic("/rosout").count == 11 and info.topic("/rosout").rate_hz is None


def test_logs_info_gives_no_rate_to_a_burst(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _bag_with_extras(tmp_path / "neato_like.bag")
    assert main(["logs", "info", str(path)]) == 0
    rows = {line.split()[0]: line.split() for line in capsys.readouterr().out.splitlines() if line}
    assert rows["/rosout"][-2:] == ["11", "-"]  # 11 messages in 0.2 s: no rate
    assert rows["/tf"][-1] == "10.00" and rows["/bump"][-1] == "-"  # /bump: 10 in 0.9 s
    assert main(["logs", "info", str(path), "--json"]) == 0
    topics = {t["topic"]: t for t in json.loads(capsys.readouterr().out)["topics"]}
    assert topics["/rosout"]["rate_hz"] is None and topics["/tf"]["rate_hz"] == pytest.approx(10)


def test_joint_state_in_a_bag(tmp_path: Path) -> None:
    t_ns = T0_NS + np.arange(5) * 10**8
    path = write_joint_state_bag(
        tmp_path / "wheels.bag",
        cmd_t_ns=t_ns.tolist(),
        cmd_v=[0.1] * 5,
        cmd_w=[0.0] * 5,
        js_t_ns=(t_ns + 1).tolist(),
        names=["wheel_left_joint", "wheel_right_joint"],
        velocity=np.tile([2.0, 4.0], (5, 1)),
    )
    tr = read_trace(path, wheel_radius_m=0.05, wheel_separation_m=0.2)
    assert np.allclose(tr.meas_v, 0.05 * 3.0) and np.allclose(tr.meas_w, 0.05 * 2.0 / 0.2)


def test_joint_state_without_velocities_says_so(tmp_path: Path) -> None:
    # a driver that publishes positions only: the wheels are found, their speeds are absent
    # (it said that no joint's name holds 'left' and another's 'right')
    t_ns = T0_NS + np.arange(5) * 10**8
    path = write_joint_state_bag(
        tmp_path / "positions.bag",
        cmd_t_ns=t_ns.tolist(),
        cmd_v=[0.1] * 5,
        cmd_w=[0.0] * 5,
        js_t_ns=t_ns.tolist(),
        names=["wheel_left_joint", "wheel_right_joint"],
        velocity=np.zeros((5, 0)),
    )
    with pytest.raises(LogValueError) as err:
        read_trace(path, wheel_radius_m=0.05, wheel_separation_m=0.2)
    text = str(err.value)
    assert "has joints ['wheel_left_joint', 'wheel_right_joint'] but 0 velocities" in text
    assert "one per joint is needed" in text and "holds 'left'" not in text


# ------------------------------------------------------------------------------- bad input


def test_bag_of_another_robots_topics_lists_them(tmp_path: Path) -> None:
    path = _bag_with_extras(tmp_path / "other.bag", topics=("/robot2/cmd", "/robot2/odometry"))
    # both are still unique candidates, so auto-detection works; asking for /odom must fail
    with pytest.raises(MissingTopicError, match=r"no topic '/odom'.*/robot2/odometry"):
        read_trace(path, odom_topic="/odom")


def test_bag_without_drive_topics(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    path = tmp_path / "lidar_only.bag"
    with Writer(path) as wr:
        scan = wr.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=store)
        wr.write(scan, T0_NS, b"\x00" * 8)
    assert (
        main(
            [
                "sysid",
                "fit",
                str(path),
                "--robot",
                "turtlebot3_burger",
                "-o",
                str(tmp_path / "p.yaml"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no command topic" in err[0] and "/scan" in err[0]


def test_rosbag2_folder_without_metadata(
    formats: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "nometa"
    folder.mkdir()
    (folder / "run_0.db3").write_bytes(next(formats["sqlite3"].glob("*.db3")).read_bytes())
    assert main(["logs", "info", str(folder)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "without a metadata.yaml" in err[0] and "run_0.db3" in err[0]


@pytest.mark.parametrize(
    ("text", "error", "match"),
    [
        ("t,cmd_v,meas_v,meas_w\n0,0,0,0\n1,0,0,0\n", LogFormatError, "lacks the column.s. cmd_w"),
        (
            "t,cmd_v,cmd_w,meas_v,meas_w\n0,0,0,0,0\n0.1,0,nan,0,0\n",
            LogValueError,
            "line 3 column 'cmd_w'",
        ),
        (
            "t,cmd_v,cmd_w,meas_v,meas_w\n0,0,0,0,0\n0.1,0,0,,0\n",
            LogValueError,
            "line 3 column 'meas_v'",
        ),
        ("t,cmd_v,cmd_w,meas_v,meas_w\n0,0,0,0,0\n0,0,0,0,0\n", LogValueError, "do not increase"),
        (  # times in nanoseconds, not seconds: beyond int64 nanoseconds (was an OverflowError)
            "t,cmd_v,cmd_w,meas_v,meas_w\n1700000000000000000,0,0,0,0\n1700000000050000000,0,0,0,0\n",
            LogValueError,
            "line 2 column 't' holds '1700000000000000000', which as seconds lies more than 292",
        ),
        (
            "t,cmd_v,cmd_w,meas_v,meas_w\n0,0,0,0,0\n1.7e12,0,0,0,0\n",
            LogValueError,
            "t must be in seconds",
        ),
    ],
)
def test_bad_csv(
    tmp_path: Path, text: str, error: type, match: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(error, match=match):
        read_trace(path)
    assert main(["agree", str(path), "--robot", "turtlebot3_burger"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sim2real: error: CSV log")


def test_csv_times_are_exact_nanoseconds(tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    path.write_text(
        "meas_w,t,cmd_v,cmd_w,meas_v,extra\n0,1700000000.000000001,0.1,0,0,x\n0,1700000000.5,0.1,0,0.1,y\n"
    )
    tr = read_trace(path)
    assert tr.meas_t_ns.tolist() == [1_700_000_000_000_000_001, 1_700_000_000_500_000_000]
    assert tr.pose_x is None and tr.meas_v.tolist() == [0.0, 0.1]


def test_mistyped_topic_did_you_mean(formats: dict[str, Path]) -> None:
    with pytest.raises(MissingTopicError, match=r"no topic '/odm'.*did you mean '/odom'\?"):
        read_trace(formats["ros1"], odom_topic="/odm")
    with pytest.raises(MissingTopicError, match=r"did you mean '/cmd_vel'\?"):
        read_trace(formats["mcap"], cmd_topic="cmd_vel")


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "rosbag2_mcap", "csv"])
def test_agree_report_on_every_format(
    formats: dict[str, Path], kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The HTML report hashes its log: a rosbag2 folder as its reader does (it tried to open it)."""
    report, summary = tmp_path / "r.html", tmp_path / "r.json"
    argv = ["agree", str(formats[kind]), "--robot", "turtlebot3_burger", "--engine", "reduced"]
    assert main([*argv, "--report", str(report), "--json", str(summary)]) == 0, (
        capsys.readouterr().err
    )
    sha = json.loads(summary.read_text())["log_sha256"]
    assert len(sha) == 64 and f"(sha256 {sha})" in report.read_text(encoding="utf-8")


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_rosbag2_with_zstd_compressed_files(
    formats: dict[str, Path], storage: str, tmp_path: Path
) -> None:
    """`ros2 bag record --compression-mode file`: storage files `*.db3.zstd` / `*.mcap.zstd`.

    They read as the plain bag, and count in the log's size and SHA-256 (which covered only
    ``metadata.yaml`` of such a folder, so two different recordings could share it).
    """
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, Reader, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    out = tmp_path / f"zstd_{storage}"
    plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
    writer = Writer(out, version=8, storage_plugin=plugin)
    writer.set_compression(CompressionMode.FILE, CompressionFormat.ZSTD)
    writer.open()
    with Reader(formats["sqlite3"]) as reader:
        conns = {
            c.id: writer.add_connection(c.topic, c.msgtype, typestore=store)
            for c in reader.connections
        }
        for conn, t, raw in reader.messages():
            writer.write(conns[conn.id], t, raw)
    writer.close()
    assert [p.name for p in out.iterdir() if p.name.endswith(".zstd")]
    ref, got = read_trace(formats["mcap"]), read_trace(out)
    for name in (*FIELDS, "pose_yaw"):
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name
    info = inspect_log(out)
    assert info.size_bytes == sum(p.stat().st_size for p in out.iterdir())
    meta_only = hashlib.sha256((out / "metadata.yaml").read_bytes()).hexdigest()
    assert got.meta.sha256 != meta_only and info.sha256 == got.meta.sha256
