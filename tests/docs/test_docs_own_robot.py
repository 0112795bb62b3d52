"""README "Your own robot": the four commands, run as written, on generated ROS 1 bags.

The bags come from a foreign plant of the README's robot: the reduced drive model with hidden
parameters unlike the spec's priors (latency, payload, a velocity smoother), driven by two
different random command sequences, with realistic odometry defects (sysid.synthetic), written
by rosbags' ROS 1 writer (sim2real.logs.write_rosbag) with a custom bumper channel beside.
"""

from __future__ import annotations

import json
import os
import shlex
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
T0_NS = 1_700_000_000 * 10**9


def _section_commands() -> list[list[str]]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    body = text.split("## Your own robot", 1)[1].split("\n## ", 1)[0]
    block = body.split("```sh\n", 1)[1].split("```", 1)[0].replace("\\\n", " ")
    lines = [ln.split("#", 1)[0].strip() for ln in block.splitlines()]
    return [shlex.split(ln)[1:] for ln in lines if ln.startswith("sim2real ")]


def _bag(path: Path, spec_path: Path, seed: int) -> None:
    from robots.spec import load_spec
    from sim2real.logs import Trace, TraceMeta, write_rosbag
    from sysid.synthetic import step_commands, synthetic_log

    spec = load_spec(spec_path)
    truth = spec.drive.replace(
        delay_s=0.18, added_mass_kg=0.8, accel_lim_v_mps2=1.2, accel_lim_w_radps2=6.0
    )
    t, v, w = step_commands(60.0, seed=seed, v_max_mps=0.45, w_max_radps=2.0)
    log = synthetic_log(
        truth, spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed, odom_rate_hz=30.0
    )
    ns = lambda s: T0_NS + np.round(np.asarray(s) * 1e9).astype(np.int64)  # noqa: E731
    trace = Trace(
        cmd_t_ns=ns(log.cmd_t_s),
        cmd_v=log.cmd_v,
        cmd_w=log.cmd_w,
        meas_t_ns=ns(log.meas_t_s),
        meas_v=log.meas_v,
        meas_w=log.meas_w,
        meta=TraceMeta(),
    )
    write_rosbag(path, trace)


@pytest.mark.slow
def test_own_robot_commands_run_as_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from sim2real.cli import main

    commands = _section_commands()
    assert 1 <= len(commands) <= 5
    assert [c[:2] for c in commands] == [
        ["robots", "new"],
        ["logs", "info"],
        ["sysid", "fit"],
        ["agree", "val.bag"],
    ]
    cwd = os.getcwd()
    try:
        os.chdir(tmp_path)
        assert main(commands[0]) == 0  # the spec first: the bags are made for it
        _bag(tmp_path / "train.bag", tmp_path / "myrobot.yaml", seed=11)
        _bag(tmp_path / "val.bag", tmp_path / "myrobot.yaml", seed=12)
        for argv in commands[1:]:
            assert main(argv) == 0, argv
    finally:
        os.chdir(cwd)
    out = capsys.readouterr().out
    assert "/cmd_vel" in out and "/odom" in out
    assert (tmp_path / "report.html").is_file()
    figures = json.loads((tmp_path / "agreement.json").read_text())
    print(f"own-robot agreement on val.bag: {figures['agreement']:.3f}")
    assert figures["agreement"] >= 0.8, figures["agreement"]
