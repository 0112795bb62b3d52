"""`sim2real logs info`, run in-process through sim2real.cli.main."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sim2real.cli import main


def test_info_table(small_log: Path, capsys: pytest.CaptureFixture[str]):
    assert main(["logs", "info", str(small_log)]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    cmd_row = next(line for line in lines if line.startswith("/cmd_vel "))
    odom_row = next(line for line in lines if line.startswith("/odom "))
    assert cmd_row.split() == ["/cmd_vel", "geometry_msgs/msg/Twist", "cdr", "40", "10.00"]
    assert odom_row.split()[:4] == ["/odom", "nav_msgs/msg/Odometry", "cdr", "100"]
    assert float(odom_row.split()[4]) == pytest.approx(25.0, abs=0.01)
    assert "command topic:     /cmd_vel (geometry_msgs/msg/Twist)" in out
    assert "measurement topic: /odom (nav_msgs/msg/Odometry)" in out
    assert "profile:   ros2" in out and "140 messages" in out


def test_info_json(small_log: Path, capsys: pytest.CaptureFixture[str]):
    assert main(["logs", "info", str(small_log), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert (data["cmd_topic"], data["meas_topic"], data["message_count"]) == (
        "/cmd_vel",
        "/odom",
        140,
    )
    topics = {t["topic"]: t for t in data["topics"]}
    assert topics["/odom"]["count"] == 100 and topics["/cmd_vel"]["message_encoding"] == "cdr"
    assert data["duration_s"] == pytest.approx(3.96, abs=0.01)


def test_info_without_command_topic_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    import numpy as np

    from sim2real.logs import write_joint_state_log

    t = 1_700_000_000 * 10**9 + np.arange(5, dtype=np.int64) * 10**8
    path = write_joint_state_log(
        tmp_path / "js.mcap",
        cmd_t_ns=t,
        cmd_v=np.zeros(5),
        cmd_w=np.zeros(5),
        js_t_ns=t,
        left_radps=np.zeros(5),
        right_radps=np.zeros(5),
        cmd_topic="/teleop/cmd",
    )
    assert main(["logs", "info", str(path), "--cmd-topic", "/teleop/cmd"]) == 0
    out = capsys.readouterr().out
    assert (
        "command topic:     /teleop/cmd" in out
        and "/joint_states (sensor_msgs/msg/JointState)" in out
    )


def test_info_bad_file_exits_2_with_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    bad = tmp_path / "notes.txt"
    bad.write_text("hello\n")
    assert main(["logs", "info", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("sim2real: error: log file ")
    assert "is not an MCAP file" in err and "Traceback" not in err


def test_info_missing_file_and_unknown_topic_exit_2(tmp_path: Path, small_log: Path, capsys):
    assert main(["logs", "info", str(tmp_path / "none.mcap")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["logs", "info", str(small_log), "--odom-topic", "/odometry/filtered"]) == 2
    err = capsys.readouterr().err
    assert "no topic '/odometry/filtered'" in err and "--odom-topic" in err


def test_help_shows_examples(capsys: pytest.CaptureFixture[str]):
    for argv in (["logs", "--help"], ["logs", "info", "--help"]):
        with pytest.raises(SystemExit) as info:
            main(argv)
        assert info.value.code == 0
        out = capsys.readouterr().out
        assert "examples:" in out and "sim2real logs info run.mcap" in out


@pytest.mark.realdata
def test_info_on_the_drexel_log(drexel_log: Path, capsys: pytest.CaptureFixture[str]):
    assert main(["logs", "info", str(drexel_log)]) == 0
    out = capsys.readouterr().out
    rows = {line.split()[0]: line.split() for line in out.splitlines() if line.startswith("/")}
    assert rows["/cmd_vel"][1:4] == ["geometry_msgs/msg/Twist", "cdr", "299"]
    assert rows["/odom"][1:4] == ["nav_msgs/msg/Odometry", "cdr", "893"]
    assert float(rows["/cmd_vel"][4]) == pytest.approx(9.7, abs=0.05)
    assert float(rows["/odom"][4]) == pytest.approx(23.0, abs=0.05)
    assert "duration:  38.8 s" in out


def test_info_on_a_csv_log(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    """A CSV log is accepted by `logs info` as by `sysid fit`/`agree`: rows, span, rate, columns."""
    path = tmp_path / "run.csv"
    rows = [f"{1700000000 + 0.05 * i:.2f},0.2,0.1,{0.01 * i:.2f},0.05,note{i}" for i in range(201)]
    path.write_text("t,cmd_v,cmd_w,meas_v,meas_w,comment\n" + "\n".join(rows) + "\n")
    assert main(["logs", "info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "duration:  10.0 s from 2023-11-14 22:13:20 UTC, 201 rows (20.00 Hz)" in out
    assert "no pose (x, y, yaw)" in out and "ignored:   columns comment" in out
    assert main(["logs", "info", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert (doc["format"], doc["rows"], doc["pose"]) == ("csv", 201, False)
    assert doc["duration_s"] == pytest.approx(10.0) and doc["rate_hz"] == pytest.approx(20.0)
    # topics do not apply; a bad row is named (one line, exit 2)
    assert main(["logs", "info", str(path), "--odom-topic", "/odom"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "columns, not topics" in err[0]
    path.write_text("t,cmd_v,cmd_w,meas_v,meas_w\n0,0,0,0,0\n0.1,0,0,nan,0\n")
    assert main(["logs", "info", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "line 3 column 'meas_v'" in err[0]


def test_info_on_a_csv_log_with_quoted_names(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    """A spreadsheet's export quotes the column names: they are the same columns (it listed
    all six as ignored, the five used ones with their quotes)."""
    path = tmp_path / "sheet.csv"
    rows = [f'{0.1 * i:.1f},0.2,0.0,{0.02 * i:.2f},0.0,"a, b"' for i in range(11)]
    head = ",".join(f'"{c}"' for c in ("t", "cmd_v", "cmd_w", "meas_v", "meas_w", "x y"))
    path.write_text(head + "\n" + "\n".join(rows) + "\n")
    assert main(["logs", "info", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["ignored_columns"] == ["x y"] and doc["rows"] == 11
    assert doc["rate_hz"] == pytest.approx(10.0)
