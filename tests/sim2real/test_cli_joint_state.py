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
from typing import Any

import numpy as np
import pytest
import yaml

from robots.spec import load_spec
from sim2real.cli import main
from sim2real.cli._demo import find_data_dir
from sim2real.logs import Trace, read_trace
from tests.ros1_bags import write_joint_state_bag

ROBOT = "turtlebot3_burger"


def _joint_state_bag(path: Path, trace: Trace, radius_m: float, separation_m: float) -> Path:
    """``trace`` as a ROS 1 bag: Twist commands and a JointState of the two wheels (rad/s)."""
    left = (trace.meas_v - 0.5 * separation_m * trace.meas_w) / radius_m
    right = (trace.meas_v + 0.5 * separation_m * trace.meas_w) / radius_m
    return write_joint_state_bag(
        path,
        cmd_t_ns=trace.cmd_t_ns.tolist(),
        cmd_v=trace.cmd_v,
        cmd_w=trace.cmd_w,
        js_t_ns=trace.meas_t_ns.tolist(),
        names=["wheel_left_joint", "wheel_right_joint"],
        velocity=np.column_stack((left, right)),
    )


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
    figures: dict[str, Any] = {}
    for kind in ("", "_js"):
        params = tmp_path / f"p{kind}.yaml"
        fit = ["sysid", "fit", logs[f"train{kind}"], "--robot", ROBOT, "--window", "0:60"]
        assert main([str(a) for a in [*fit, "-o", params]]) == 0, capsys.readouterr().err
        out = tmp_path / f"a{kind}.json"
        argv = ["agree", logs[f"validate{kind}"], "--robot", ROBOT, "--params", params]
        assert main([str(a) for a in [*argv, "--engine", "reduced", "--json", out]]) == 0
        delay = yaml.safe_load(params.read_text())["parameters"]["delay_s"]["value"]
        figures[kind] = (delay, json.loads(out.read_text()))
        # 4 robots a likelihood evaluation (the default 32 is most of the test's cost): the
        # reading of the bag is what is compared, the same draws on both.
        cal = ["sysid", "calibrate", params, logs[f"validate{kind}"], "--robot", ROBOT]
        out = tmp_path / f"c{kind}.yaml"
        assert main([str(a) for a in [*cal, "--ensemble", 4, "-o", out]]) == 0
        figures[f"cal{kind}"] = yaml.safe_load(out.read_text())["calibration"]
    capsys.readouterr()
    (delay, report), (delay_js, report_js) = figures[""], figures["_js"]
    assert delay_js == pytest.approx(delay, abs=1e-4)
    for key in ("agreement", "agreement_v", "agreement_w"):
        assert report_js[key] == pytest.approx(report[key], abs=2e-3), key
    assert report_js["agreement"] > 0.9 and report_js["n_samples"] == report["n_samples"]
    cal, cal_js = figures["cal"], figures["cal_js"]
    assert cal_js["n_active"] == cal["n_active"]
    for key in ("dynamics_factor", "noise_std_v_mps", "noise_std_w_radps"):
        assert cal_js[key] == pytest.approx(cal[key], rel=1e-2), key


def test_bag_of_an_arm_is_one_sentence(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Another robot's bag: a 6-joint arm's JointState and a Twist, nothing of a base."""
    t_ns = 1_700_000_000 * 10**9 + np.arange(20) * 10**8
    path = write_joint_state_bag(
        tmp_path / "arm.bag",
        cmd_t_ns=t_ns.tolist(),
        cmd_v=[0.1] * 20,
        cmd_w=[0.0] * 20,
        js_t_ns=t_ns.tolist(),
        names=[f"joint{k}" for k in range(6)],
        velocity=np.ones((20, 6)),
        cmd_topic="/arm/cmd_vel",
    )
    for argv in (["agree", path], ["sysid", "fit", path, "-o", tmp_path / "p.yaml"]):
        assert main([str(a) for a in [*argv, "--robot", ROBOT]]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "['joint0', 'joint1'" in err[0], err
        assert "choose the base's Odometry topic with --odom-topic" in err[0]
