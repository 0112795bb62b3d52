"""`sim2real agree` end to end on small real MCAP logs (reduced engine for speed)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from _agreement_fixtures import HIDDEN, ROBOT, T0_NS, hidden_params, write_log, write_params

from robots.spec import load_spec
from sim2real.agreement.figures import AGREEMENT_KEYS, BAND_KEYS, measure_agreement
from sim2real.agreement.latency import REFERENCE_KEYS
from sim2real.agreement.replay import replay
from sim2real.cli import main
from sim2real.logs import read_trace


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_log(tmp_path_factory.mktemp("agree") / "val.mcap")


@pytest.fixture(scope="module")
def params(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_params(tmp_path_factory.mktemp("params") / "params.yaml", HIDDEN)


def _agree(*args: str | Path) -> int:
    return main(["agree", *map(str, args), "--robot", ROBOT, "--engine", "reduced"])


def test_json_has_exactly_the_keys_and_the_library_numbers(
    log: Path, params: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "agree.json"
    assert _agree(log, "--params", params, "--json", out) == 0
    figures = json.loads(out.read_text())
    assert tuple(figures) == (*AGREEMENT_KEYS, *REFERENCE_KEYS, "notes")
    trace = read_trace(log)
    expected = measure_agreement(
        trace,
        replay(trace, robot=ROBOT, params=hidden_params(), engine="reduced"),
        params_file=str(params),
    )
    assert figures["agreement"] == pytest.approx(expected.agreement)
    assert figures["agreement"] > 0.97  # the right parameters: noise well inside tolerance
    # the ceiling assumes the log's own noise (write_log adds 0.003 m/s and 0.02 rad/s)
    assert figures["noise_std_v_mps"] == pytest.approx(0.003, rel=0.15)
    assert figures["noise_std_w_radps"] == pytest.approx(0.02, rel=0.15)
    assert "this log's own odometry noise" in figures["notes"][-1]
    assert figures["n_active"] == expected.n_active and figures["n_samples"] == 900
    assert figures["log_sha256"] == trace.meta.sha256 and len(figures["log_sha256"]) == 64
    assert figures["params_file"] == str(params) and figures["robot"] == ROBOT
    table = capsys.readouterr().out
    assert "spec defaults" in table and "sysid params" in table and "agreement" in table


def test_defaults_give_lower_agreement_and_no_params_file(log: Path, tmp_path: Path) -> None:
    out = tmp_path / "agree.json"
    assert _agree(log, "--json", out) == 0
    figures = json.loads(out.read_text())
    assert figures["params_file"] is None
    assert figures["agreement"] < 0.8


def test_min_agreement_gate_exit_codes(
    log: Path, params: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _agree(log, "--params", params, "--min-agreement", "0.9") == 0
    out = capsys.readouterr().out.splitlines()
    assert re.fullmatch(
        r"agreement (9\d|100)\.\d % is at or above --min-agreement 90\.0 %: passed", out[-1]
    )
    assert _agree(log, "--min-agreement", "0.9") == 1  # spec defaults are far off
    captured = capsys.readouterr()
    assert "passed" not in captured.out
    assert re.fullmatch(r"agreement \d+\.\d % is below --min-agreement 90\.0 %\n", captured.err)
    assert _agree(log, "--min-agreement", "0") == 0
    assert capsys.readouterr().out.splitlines()[-1].endswith("--min-agreement 0.0 %: passed")
    assert _agree(log) == 0  # no gate, no gate line
    assert "min-agreement" not in capsys.readouterr().out


def test_sim_out_is_readable_with_real_stamps(log: Path, params: Path, tmp_path: Path) -> None:
    sim_path = tmp_path / "sim.mcap"
    assert _agree(log, "--params", params, "--sim-out", sim_path) == 0
    real = read_trace(log)
    sim = read_trace(sim_path)
    np.testing.assert_array_equal(sim.meas_t_ns, real.meas_t_ns)
    np.testing.assert_array_equal(sim.cmd_t_ns, real.cmd_t_ns)
    np.testing.assert_allclose(sim.cmd_v, real.cmd_v)
    # agree's default odometry window is the spec's (one 1/30 s encoder period)
    window = load_spec(ROBOT).odometry.v_window_s
    expected = replay(
        real, robot=ROBOT, params=hidden_params(), engine="reduced", odom_v_window_s=window
    )
    np.testing.assert_allclose(sim.meas_v, expected.v, atol=1e-12)
    np.testing.assert_allclose(sim.meas_w, expected.w, atol=1e-12)
    assert sim.meta.cmd_type == "geometry_msgs/msg/Twist"
    assert sim.meta.meas_type == "nav_msgs/msg/Odometry"


def _err(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.count("\n") == 1 and err.startswith("sim2real: error: ")
    return err


@pytest.mark.parametrize("flag", ["--tol-v", "--tol-w"])
@pytest.mark.parametrize("value", ["0", "-0.01"])
def test_bad_tolerance_exits_2(
    log: Path, flag: str, value: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _agree(log, flag, value) == 2
    assert flag in _err(capsys)


def test_params_for_another_robot_exits_2(
    log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    other = write_params(tmp_path / "p.yaml", {"delay_s": 0.1}, robot="turtlebot2")
    assert _agree(log, "--params", other) == 2
    err = _err(capsys)
    assert "turtlebot2" in err and ROBOT in err


def test_log_without_commands_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A real ROS 2 MCAP holding odometry only (written with mcap-ros2-support)."""
    from mcap_ros2.writer import Writer

    from sim2real.logs import ODOMETRY, SCHEMA_TEXT

    path = tmp_path / "odom_only.mcap"
    with open(path, "wb") as fh:
        writer = Writer(fh)
        schema = writer.register_msgdef(ODOMETRY, SCHEMA_TEXT[ODOMETRY])
        for k in range(50):
            t = T0_NS + k * 33_000_000
            msg = {
                "header": {"stamp": {"sec": t // 10**9, "nanosec": t % 10**9}, "frame_id": "odom"},
                "child_frame_id": "base_link",
                "pose": {"pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                                  "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
                         "covariance": [0.0] * 36},
                "twist": {"twist": {"linear": {"x": 0.1, "y": 0.0, "z": 0.0},
                                    "angular": {"x": 0.0, "y": 0.0, "z": 0.0}},
                          "covariance": [0.0] * 36},
            }  # fmt: skip
            writer.write_message("/odom", schema, msg, log_time=t, publish_time=t)
        writer.finish()
    assert _agree(path) == 2
    err = _err(capsys)
    assert "command" in err and "/odom" in err


def test_unwritable_outputs_exit_2_and_leave_nothing(
    log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    missing = tmp_path / "no_such_folder"
    for flag, name in (("--json", "a.json"), ("--report", "r.html"), ("--sim-out", "s.mcap")):
        assert _agree(log, flag, missing / name) == 2
        assert "no_such_folder" in _err(capsys)
    assert not missing.exists()
    assert _agree(log, "--json", tmp_path) == 2  # a folder, not a file
    _err(capsys)


def test_other_bad_arguments_exit_2(
    log: Path, params: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _agree(log, "--min-agreement", "90") == 2
    assert "--min-agreement" in _err(capsys)
    assert _agree(log, "--ensemble", "5") == 2
    assert "--params" in _err(capsys)
    assert _agree(log, "--params", params, "--ensemble", "1") == 2
    assert "--ensemble" in _err(capsys)
    assert _agree(log, "--params", params, "--ensemble", "3", "--spread", "-1") == 2
    assert "--spread" in _err(capsys)
    assert main(["agree", str(log), "--robot", "no_such_robot"]) == 2
    assert "no_such_robot" in _err(capsys)


def test_ensemble_adds_coverage_to_json(log: Path, params: Path, tmp_path: Path) -> None:
    out = tmp_path / "e.json"
    assert _agree(log, "--params", params, "--ensemble", "6", "--seed", "3", "--json", out) == 0
    figures = json.loads(out.read_text())
    assert tuple(figures) == (*AGREEMENT_KEYS, *BAND_KEYS, *REFERENCE_KEYS, "notes")
    assert None not in figures.values()
    assert 0.0 <= figures["coverage"] <= min(figures["coverage_v"], figures["coverage_w"]) <= 1
    assert figures["band_level"] == 0.9 and figures["ensemble_n"] == 6
    assert 0.0 < figures["band_width_v_mps"] < 0.2 and 0.0 < figures["band_width_w_radps"] < 1
    levels = [row["level"] for row in figures["coverage_by_level"]]
    assert levels == [0.5, 0.6, 0.7, 0.8, 0.9, 0.95]
    cov_v = [row["coverage_v"] for row in figures["coverage_by_level"]]
    assert cov_v == sorted(cov_v) and cov_v[4] == figures["coverage_v"]
    out2 = tmp_path / "e2.json"
    assert _agree(log, "--params", params, "--ensemble", "6", "--seed", "3", "--json", out2) == 0
    assert json.loads(out2.read_text()) == figures  # seeded: same numbers


def test_help_ends_with_examples(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["agree", "--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert "examples:" in text and "--min-agreement 0.9" in text
    # the last example (its continuation lines joined) is a command
    last = text.rstrip().split("examples:")[1].replace("\\\n", " ").splitlines()[-1]
    assert last.strip().startswith("sim2real agree"), last


def test_report_without_params_shows_the_defaults_only(log: Path, tmp_path: Path) -> None:
    out = tmp_path / "r.html"
    assert _agree(log, "--report", out) == 0
    page = out.read_text(encoding="utf-8")
    assert page.count('<div class="card">') == 1 and "agreement — spec defaults" in page
    assert "sysid params" not in page
    assert len(list(tmp_path.glob("r_*.png"))) == 4
