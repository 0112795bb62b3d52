"""`sysid calibrate` reads its validation logs as `sysid fit` and `agree` do (issue 12).

``--time-source {auto,header,log}``, ``--odom-velocity {auto,twist,pose}`` and the topics. The
logs: a TurtleBot3 driven by the reduced model with known parameters, recorded (a) by a driver
whose odometry header stamps run 15 s behind the recorder's clock, (b) by a driver whose
Odometry twist is zero while its pose moves. Read the wrong way, the validation velocities no
longer match the commands and the calibrated odometry noise balloons; read the right way
(the default 'auto' detects both) it stays at the log's noise.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from robots.reduced import simulate
from robots.spec import load_spec
from sim2real.agreement.calibration import calibrate
from sim2real.cli import main
from sim2real.logs import ReadOptions, integrate_pose, write_velocity_log
from tests.randomization_block import write_params_file

ROBOT = "turtlebot3_burger"
T0_NS = 1_700_000_000 * 10**9
NOISE_V, NOISE_W = 0.003, 0.02
DURATION_S = 16.0


def _truth(seed: int) -> dict[str, np.ndarray]:
    """Commands (steps at 10 Hz) and the noisy odometry (30 Hz) of the spec's robot."""
    spec = load_spec(ROBOT)
    rng = np.random.default_rng(seed)
    cmd_t = np.arange(0.0, DURATION_S, 0.1)
    cmd_v = np.repeat(rng.uniform(-0.2, 0.2, 9), 20)[: cmd_t.size]
    cmd_w = np.repeat(rng.uniform(-1.5, 1.5, 9), 20)[: cmd_t.size]
    cmd_v[cmd_t < 1.0] = 0.0
    cmd_w[cmd_t < 1.0] = 0.0
    meas_t = np.arange(0.0, DURATION_S, 1.0 / 30.0)
    sim = simulate(
        spec.drive, spec.geometry, cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=meas_t
    )
    return {
        "cmd_t_ns": T0_NS + np.rint(cmd_t * 1e9).astype(np.int64),
        "cmd_v": cmd_v,
        "cmd_w": cmd_w,
        "meas_t_ns": T0_NS + np.rint(meas_t * 1e9).astype(np.int64),
        "meas_v": sim.v + rng.normal(0.0, NOISE_V, meas_t.size),
        "meas_w": sim.w + rng.normal(0.0, NOISE_W, meas_t.size),
    }


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("calread")
    spec = load_spec(ROBOT)
    params = write_params_file(root / "p.yaml", spec.drive, ROBOT, rel=0.05)
    a = _truth(1)
    offset = write_velocity_log(
        root / "offset.mcap",
        **{**a, "meas_t_ns": a["meas_t_ns"] - 15 * 10**9},  # header stamps 15 s behind
        meas_log_t_ns=a["meas_t_ns"],
    )
    b = _truth(2)
    x, y, yaw = integrate_pose(b["meas_t_ns"], b["meas_v"], b["meas_w"])
    zero_twist = write_velocity_log(
        root / "zero_twist.mcap",
        **{**b, "meas_v": np.zeros_like(b["meas_v"]), "meas_w": np.zeros_like(b["meas_w"])},
        pose_x=x,
        pose_y=y,
        pose_yaw=yaw,
    )
    return {"params": params, "offset": offset, "zero_twist": zero_twist}


def test_help_documents_the_flags_with_examples(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["sysid", "calibrate", "--help"])
    assert stop.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--odom-velocity {auto,twist,pose}" in text and "--time-source {auto,header,log}" in text
    assert "--odom-velocity pose" in text and "--time-source log" in text  # in the examples
    assert "--cmd-topic" in text and "--odom-topic" in text


def test_time_source_auto_reads_past_a_clock_offset(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "cal.yaml"
    argv = ["sysid", "calibrate", str(files["params"]), str(files["offset"]), "--robot", ROBOT]
    assert main([*argv, "-o", str(out), "--ensemble", "4"]) == 0  # default: auto
    text = capsys.readouterr().out
    assert "note: " in text and "log times, because the header stamps of '/odom'" in text
    auto = yaml.safe_load(out.read_text())["calibration"]
    log_out = tmp_path / "log.yaml"
    assert main([*argv, "-o", str(log_out), "--ensemble", "4", "--time-source", "log"]) == 0
    assert yaml.safe_load(log_out.read_text())["calibration"] == auto
    header = calibrate(  # the wrong clock: kept whole (screened, it is mostly unattended)
        files["params"],
        [files["offset"]],
        robot=ROBOT,
        n=4,
        read=ReadOptions(time_source="header", keep_all=True),
    )
    # right clock: the noise the log was made with; 15 s off: the steps land on the wrong
    # commands and the "noise" is the whole motion
    assert auto["noise_std_v_mps"] < 3 * NOISE_V and auto["noise_std_w_radps"] < 3 * NOISE_W
    assert header.noise_std_v_mps > 10 * NOISE_V and header.noise_std_w_radps > 10 * NOISE_W
    assert auto["log_likelihood_per_sample"] > header.log_likelihood + 2.0


def test_odom_velocity_pose_reads_a_zero_twist(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["sysid", "calibrate", str(files["params"]), str(files["zero_twist"]), "--robot", ROBOT]
    argv += ["--ensemble", "4"]
    pose_out, auto_out = tmp_path / "pose.yaml", tmp_path / "auto.yaml"
    assert main([*argv, "-o", str(pose_out), "--odom-velocity", "pose"]) == 0
    assert main([*argv, "-o", str(auto_out)]) == 0
    assert "--odom-velocity twist" in capsys.readouterr().out  # auto says what it did
    pose = yaml.safe_load(pose_out.read_text())["calibration"]
    assert yaml.safe_load(auto_out.read_text())["calibration"] == pose
    twist = calibrate(  # the zero twist: kept whole (screened, it is mostly unattended)
        files["params"],
        [files["zero_twist"]],
        robot=ROBOT,
        n=4,
        read=ReadOptions(odom_velocity="twist", keep_all=True),
    )
    # from the pose: v, w back within a few times the log's noise (the differentiation
    # smooths); from the zeros: the "noise" is the whole motion
    assert pose["noise_std_v_mps"] < 0.02 and pose["noise_std_w_radps"] < 0.1
    assert twist.noise_std_v_mps > 0.05 and twist.noise_std_w_radps > 0.3
    assert pose["log_likelihood_per_sample"] > twist.log_likelihood + 2.0


def test_a_wrong_topic_or_choice_is_one_sentence_exit_2(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "c.yaml"
    argv = ["sysid", "calibrate", str(files["params"]), str(files["offset"]), "--robot", ROBOT]
    assert main([*argv, "-o", str(out), "--odom-topic", "/odometry"]) == 2
    err = capsys.readouterr().err
    assert "/odometry" in err and "Traceback" not in err and not out.exists()
    with pytest.raises(SystemExit) as stop:
        main([*argv, "-o", str(out), "--time-source", "gps"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "--time-source" in err and "invalid choice" in err and not out.exists()
