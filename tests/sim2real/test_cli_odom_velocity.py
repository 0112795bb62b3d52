"""`--odom-velocity {auto,twist,pose}` on every command that reads velocity logs (issue 12).

The log: a TurtleBot3 driven by the reduced model, recorded by a driver whose Odometry twist is
zero while its pose moves (the pose is the true path). ``pose`` and ``auto`` take the velocities
from the pose; ``twist`` keeps the zeros.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from robots.spec import load_spec
from sim2real.cli import main
from sim2real.logs import Trace, TraceMeta, integrate_pose, write_trace
from sysid.synthetic import step_commands, synthetic_log

T0_NS = 1_700_000_000 * 10**9


@pytest.fixture(scope="module")
def zero_twist_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    spec = load_spec("turtlebot3_burger")
    t, v, w = step_commands(20.0, seed=3, v_max_mps=0.2, w_max_radps=1.5)
    # the spec's nominal robot: what '--free delay_s' holds the other fields at (their prior
    # nominals, e.g. the wheel loops' integral gain)
    nominal = {"speed_loop_ki_per_s": spec.priors["speed_loop_ki_per_s"].nominal}
    log = synthetic_log(
        spec.drive.replace(delay_s=0.1, **nominal),
        spec.geometry,
        cmd_t_s=t,
        cmd_v=v,
        cmd_w=w,
        seed=3,
        spike_mps=None,
        drop_fraction=0.0,
        noise_v_mps=0.0,
        noise_w_radps=0.0,
    )
    meas_ns = T0_NS + np.round(log.meas_t_s * 1e9).astype(np.int64)
    x, y, yaw = integrate_pose(meas_ns, log.meas_v, log.meas_w)
    trace = Trace(
        cmd_t_ns=T0_NS + np.round(log.cmd_t_s * 1e9).astype(np.int64),
        cmd_v=log.cmd_v,
        cmd_w=log.cmd_w,
        meas_t_ns=meas_ns,
        meas_v=np.zeros_like(log.meas_v),
        meas_w=np.zeros_like(log.meas_w),
        pose_x=x,
        pose_y=y,
        pose_yaw=yaw,
        meta=TraceMeta(),
    )
    return write_trace(tmp_path_factory.mktemp("odomvel") / "zero_twist.mcap", trace)


@pytest.mark.parametrize("command", [("sysid", "fit"), ("agree",)])
def test_help_documents_the_flag(command: tuple[str, ...], capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as stop:
        main([*command, "--help"])
    assert stop.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--odom-velocity {auto,twist,pose}" in text
    assert "smoothed differentiation" in text and "--odom-velocity pose" in text


def _agreement(log: Path, tmp_path: Path, mode: str) -> dict:
    out = tmp_path / f"agree_{mode}.json"
    argv = ["agree", str(log), "--robot", "turtlebot3_burger", "--engine", "reduced"]
    code = main([*argv, "--json", str(out), "--odom-velocity", mode])
    assert code == 0
    return json.loads(out.read_text())


def test_agree_takes_the_velocity_source(
    zero_twist_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    pose = _agreement(zero_twist_log, tmp_path, "pose")
    auto = _agreement(zero_twist_log, tmp_path, "auto")
    # the spec's model against the true (pose) velocities; auto detects the zero twist
    assert pose["agreement"] > 0.8
    assert auto["agreement"] == pose["agreement"]
    assert "--odom-velocity twist" in capsys.readouterr().err
    # the twist of zeros has nothing to compare with: one sentence, exit 2
    argv = ["agree", str(zero_twist_log), "--robot", "turtlebot3_burger", "--engine", "reduced"]
    assert main([*argv, "--odom-velocity", "twist"]) == 2
    err = capsys.readouterr().err
    assert "is mostly unattended" in err and "--odom-velocity pose" in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_bad_choice_is_one_line_exit_2(zero_twist_log: Path, capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["agree", str(zero_twist_log), "--robot", "turtlebot3_burger", "--odom-velocity", "x"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--odom-velocity" in err and "invalid choice" in err


@pytest.mark.slow
def test_sysid_fit_takes_the_velocity_source(zero_twist_log: Path, tmp_path: Path) -> None:
    out = tmp_path / "p.yaml"
    argv = ["sysid", "fit", str(zero_twist_log), "--robot", "turtlebot3_burger", "-o", str(out)]
    assert main([*argv, "--odom-velocity", "pose", "--free", "delay_s"]) == 0
    doc = yaml.safe_load(out.read_text())
    assert abs(doc["parameters"]["delay_s"]["value"] - 0.1) < 0.03
    assert doc["scores"]["fit"][0]["agreement"] > 0.9
    # the zero twist: nothing moves, so there is nothing to fit (one sentence, exit 2)
    assert main([*argv, "--odom-velocity", "twist", "--free", "delay_s"]) == 2
