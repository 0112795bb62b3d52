"""`sim2real sysid fit|show` on real MCAP files written with the ROS 2 message definitions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from robots.params import read_params_file
from robots.spec import load_spec
from sim2real.cli import main
from sim2real.logs import write_velocity_log
from sysid.synthetic import step_commands, synthetic_log

EPOCH_NS = 1_700_000_000_000_000_000


def _write(path: Path, *, seed: int, duration: float = 30.0, spike: float | None = 1.35) -> Path:
    spec = load_spec("turtlebot3_burger")
    truth = spec.drive.replace(delay_s=0.1, added_mass_kg=0.2)
    t, v, w = step_commands(duration, seed=seed, v_max_mps=0.2, w_max_radps=1.5)
    log = synthetic_log(
        truth, spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed, spike_mps=spike
    )
    write_velocity_log(
        path,
        cmd_t_ns=EPOCH_NS + np.round(log.cmd_t_s * 1e9).astype(np.int64),
        cmd_v=log.cmd_v,
        cmd_w=log.cmd_w,
        meas_t_ns=EPOCH_NS + np.round(log.meas_t_s * 1e9).astype(np.int64),
        meas_v=log.meas_v,
        meas_w=log.meas_w,
    )
    return path


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("sysid_cli")
    return _write(folder / "train.mcap", seed=1), _write(folder / "val.mcap", seed=2, spike=None)


@pytest.mark.slow
def test_fit_writes_params_and_prints_table(
    logs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "params.yaml"
    train, val = logs
    code = main(
        [
            *("sysid", "fit", str(train), "--robot", "turtlebot3_burger", "-o", str(out)),
            *("--validate", str(val)),
        ]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert "delay_s" in text and "95 % interval" in text and "validation" in text
    pf = read_params_file(out)
    assert pf.robot == "turtlebot3_burger"
    assert pf.values["delay_s"] == pytest.approx(0.1, abs=0.02)
    doc = yaml.safe_load(out.read_text())
    assert doc["data"][0]["sha256"] and len(doc["data"][0]["sha256"]) == 64
    assert doc["scores"]["validation"][0]["fit_percent_v"] > 80
    assert main(["sysid", "show", str(out)]) == 0
    assert "drive parameters of turtlebot3_burger" in capsys.readouterr().out


def test_window_and_free(logs: tuple[Path, Path], tmp_path: Path) -> None:
    out = tmp_path / "p.yaml"
    train, _ = logs
    code = main(
        [
            *("sysid", "fit", str(train), "--robot", "turtlebot3_burger", "-o", str(out)),
            *("--window", "0:20", "--free", "delay_s,added_mass_kg", "--odom-v-window", "auto"),
            *("--bootstrap", "4", "--seed", "3"),
        ]
    )
    assert code == 0
    doc = yaml.safe_load(out.read_text())
    fitted = {k for k, v in doc["parameters"].items() if v["status"] in ("fitted", "derived")}
    assert fitted == {"delay_s", "added_mass_kg"}
    assert doc["data"][0]["file"].endswith("train.mcap[0:20]")
    assert doc["settings"]["odom_v_window_s"] == pytest.approx(1 / 30)  # Burger odometry 30 Hz
    assert set(doc["bootstrap_std"]) == {"delay_s", "added_mass_kg"}
    assert all(0 < s < 0.5 for s in doc["bootstrap_std"].values())


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--robot", "no_such_robot"], "unknown robot 'no_such_robot'"),
        (["--window", "5:2"], "--window must be START:END"),
        (["--free", "mass"], "unknown free parameter 'mass'"),
        (["--odom-v-window", "soon"], "--odom-v-window must be 'auto' or seconds"),
    ],
)
def test_bad_arguments_exit_2_without_output(
    logs: tuple[Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    message: str,
) -> None:
    out = tmp_path / "params.yaml"
    args = ["sysid", "fit", str(logs[0]), "-o", str(out)]
    if "--robot" not in extra:
        args += ["--robot", "turtlebot3_burger"]
    assert main(args + extra) == 2
    err = capsys.readouterr().err
    assert err.startswith("sim2real: error: ") and message in err
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_output_in_missing_folder_exits_2(
    logs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "missing" / "params.yaml"
    code = main(["sysid", "fit", str(logs[0]), "--robot", "turtlebot3_burger", "-o", str(out)])
    assert code == 2
    assert "does not exist" in capsys.readouterr().err
    assert not out.parent.exists()


def test_short_and_flat_logs_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    short = _write(tmp_path / "short.mcap", seed=3, duration=2.0)
    n = 200
    flat = tmp_path / "flat.mcap"
    write_velocity_log(
        flat,
        cmd_t_ns=EPOCH_NS + np.arange(n, dtype=np.int64) * 100_000_000,
        cmd_v=np.full(n, 0.1),
        cmd_w=np.zeros(n),
        meas_t_ns=EPOCH_NS + np.arange(n, dtype=np.int64) * 100_000_000,
        meas_v=np.full(n, 0.1),
        meas_w=np.zeros(n),
    )
    out = tmp_path / "out" / "p.yaml"
    out.parent.mkdir()
    for path, message in ((short, "too short"), (flat, "never change")):
        code = main(["sysid", "fit", str(path), "--robot", "turtlebot3_burger", "-o", str(out)])
        assert code == 2
        assert message in capsys.readouterr().err
    assert list(out.parent.iterdir()) == []


def test_reader_warnings_reach_the_result(tmp_path: Path) -> None:
    path = _write(tmp_path / "nan.mcap", seed=4, spike=None)
    from sim2real.logs import read_trace

    trace = read_trace(path)
    meas_v = trace.meas_v.copy()
    meas_v[100] = np.nan
    bad = tmp_path / "with_nan.mcap"
    write_velocity_log(
        bad,
        cmd_t_ns=trace.cmd_t_ns,
        cmd_v=trace.cmd_v,
        cmd_w=trace.cmd_w,
        meas_t_ns=trace.meas_t_ns,
        meas_v=meas_v,
        meas_w=trace.meas_w,
    )
    out = tmp_path / "p.yaml"
    assert main(["sysid", "fit", str(bad), "--robot", "turtlebot3_burger", "-o", str(out)]) == 0
    warnings = yaml.safe_load(out.read_text())["warnings"]
    assert any("with_nan.mcap" in w and "NaN" in w for w in warnings)


def test_show_of_a_foreign_file_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    other = tmp_path / "x.yaml"
    other.write_text("format: other\n")
    assert main(["sysid", "show", str(other)]) == 2
    assert "is not a sysid result" in capsys.readouterr().err


def test_help_ends_with_examples(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["sysid", "fit", "--help"])
    out = capsys.readouterr().out
    assert out.rstrip().splitlines()[-1].strip().startswith("sim2real sysid fit")
    assert "examples:" in out
