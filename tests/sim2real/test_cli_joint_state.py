"""A recording whose only measurement is a wheel ``JointState`` works through the CLI.

``read_trace`` needs the wheel radius and separation to turn wheel speeds into (v, w); the
commands that take ``--robot`` (``sysid fit``, ``sysid calibrate``, ``agree``) pass the spec's
wheels. They did not, so such a bag was refused ("wheel_radius_m must be a positive number of
metres, got None; pass it") although no option could pass it. The same session written once
with Odometry and once with wheel speeds (the inverse of the differential-drive kinematics with
the TurtleBot3 Burger's published wheels) must give the same figures.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from robots.spec import load_spec
from sim2real.cli import main
from sim2real.cli._demo import find_data_dir
from sim2real.logs import Trace, read_trace

ROBOT = "turtlebot3_burger"


def _joint_state_bag(path: Path, trace: Trace, radius_m: float, separation_m: float) -> Path:
    """``trace`` as a ROS 1 bag: Twist commands and a JointState of the two wheels (rad/s)."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    vec, twist = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Twist"]
    with Writer(path) as wr:
        cmd = wr.add_connection("/cmd_vel", "geometry_msgs/msg/Twist", typestore=store)
        js = wr.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        for t, v, w in zip(trace.cmd_t_ns.tolist(), trace.cmd_v, trace.cmd_w, strict=True):
            msg = twist(linear=vec(x=float(v), y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=float(w)))
            wr.write(cmd, t, store.serialize_ros1(msg, "geometry_msgs/msg/Twist"))
        left = (trace.meas_v - 0.5 * separation_m * trace.meas_w) / radius_m
        right = (trace.meas_v + 0.5 * separation_m * trace.meas_w) / radius_m
        for i, t in enumerate(trace.meas_t_ns.tolist()):
            head = T["std_msgs/msg/Header"](
                seq=i,
                stamp=T["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9),
                frame_id="",
            )
            msg = T["sensor_msgs/msg/JointState"](
                header=head,
                name=["wheel_left_joint", "wheel_right_joint"],
                position=np.zeros(2),
                velocity=np.array([left[i], right[i]]),
                effort=np.zeros(0),
            )
            wr.write(js, t, store.serialize_ros1(msg, "sensor_msgs/msg/JointState"))
    return path


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("js")
    wheels = load_spec(ROBOT).wheels
    data = find_data_dir()
    out = {}
    for part in ("train", "validate"):
        src = data / f"demo_{part}.mcap"
        out[part] = src
        out[f"{part}_js"] = _joint_state_bag(
            d / f"{part}_js.bag", read_trace(src), wheels.radius_m, wheels.separation_m
        )
    return out


def test_sysid_fit_and_agree_on_a_joint_state_bag(
    logs: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    figures = {}
    for kind in ("", "_js"):
        params = tmp_path / f"p{kind}.yaml"
        fit = ["sysid", "fit", logs[f"train{kind}"], "--robot", ROBOT, "--window", "0:60"]
        assert main([str(a) for a in [*fit, "-o", params]]) == 0, capsys.readouterr().err
        out = tmp_path / f"a{kind}.json"
        argv = ["agree", logs[f"validate{kind}"], "--robot", ROBOT, "--params", params]
        assert main([str(a) for a in [*argv, "--engine", "reduced", "--json", out]]) == 0
        delay = yaml.safe_load(params.read_text())["parameters"]["delay_s"]["value"]
        figures[kind] = (delay, json.loads(out.read_text()))
    cal = ["sysid", "calibrate", tmp_path / "p_js.yaml", logs["validate_js"], "--robot", ROBOT]
    assert main([str(a) for a in [*cal, "-o", tmp_path / "c.yaml"]]) == 0
    capsys.readouterr()
    (delay, report), (delay_js, report_js) = figures[""], figures["_js"]
    assert delay_js == pytest.approx(delay, abs=1e-4)
    for key in ("agreement", "agreement_v", "agreement_w"):
        assert report_js[key] == pytest.approx(report[key], abs=2e-3), key
    assert report_js["agreement"] > 0.9 and report_js["n_samples"] == report["n_samples"]


def test_bag_of_an_arm_is_one_sentence(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Another robot's bag: a 6-joint arm's JointState and a Twist, nothing of a base."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    path = tmp_path / "arm.bag"
    with Writer(path) as wr:
        js = wr.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        cmd = wr.add_connection("/arm/cmd_vel", "geometry_msgs/msg/Twist", typestore=store)
        vec = T["geometry_msgs/msg/Vector3"]
        twist = T["geometry_msgs/msg/Twist"](
            linear=vec(x=0.1, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0)
        )
        for i in range(20):
            t = 1_700_000_000 * 10**9 + i * 10**8
            head = T["std_msgs/msg/Header"](
                seq=i,
                stamp=T["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=0),
                frame_id="",
            )
            msg = T["sensor_msgs/msg/JointState"](
                header=head,
                name=[f"joint{k}" for k in range(6)],
                position=np.zeros(6),
                velocity=np.ones(6),
                effort=np.zeros(0),
            )
            wr.write(js, t, store.serialize_ros1(msg, "sensor_msgs/msg/JointState"))
            wr.write(cmd, t, store.serialize_ros1(twist, "geometry_msgs/msg/Twist"))
    for argv in (["agree", path], ["sysid", "fit", path, "-o", tmp_path / "p.yaml"]):
        assert main([str(a) for a in [*argv, "--robot", ROBOT]]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "['joint0', 'joint1'" in err[0], err
        assert "choose the base's Odometry topic with --odom-topic" in err[0]
