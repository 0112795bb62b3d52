"""Bad recordings and params of another robot: one sentence, exit 2, advice that works."""

from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np
import pytest
from _agreement_fixtures import T0_NS, write_log

from sim2real.cli import main
from sim2real.logs import write_velocity_log


def _log(path: Path, *, cmd_v: float, meas_v: float) -> Path:
    t = T0_NS + np.arange(300) * 50_000_000
    n = t.size
    return write_velocity_log(
        path,
        cmd_t_ns=t,
        cmd_v=np.full(n, cmd_v),
        cmd_w=np.zeros(n),
        meas_t_ns=t,
        meas_v=np.full(n, meas_v),
        meas_w=np.zeros(n),
    )


def _one_sentence(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("sim2real: error: ")
    assert "Traceback" not in err
    return err


@pytest.fixture(scope="module")
def params(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("bad")
    log = write_log(root / "fit.mcap", duration_s=20.0)
    out = root / "p.yaml"
    assert main(["sysid", "fit", str(log), "--robot", "turtlebot3_burger", "-o", str(out)]) == 0
    return out


@pytest.mark.parametrize(
    ("cmd_v", "meas_v", "words"),
    [(0.0, 0.0, "active"), (0.0, 0.3, "mostly unattended")],  # idle; driven by hand
)
def test_idle_or_hand_driven_logs_are_refused_by_every_command(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    params: Path,
    cmd_v: float,
    meas_v: float,
    words: str,
) -> None:
    log = _log(tmp_path / "bad.mcap", cmd_v=cmd_v, meas_v=meas_v)
    robot = ["--robot", "turtlebot3_burger"]
    for argv in (
        ["agree", str(log), *robot, "--engine", "reduced"],
        ["sysid", "fit", str(log), *robot, "-o", str(tmp_path / "x.yaml")],
        ["sysid", "calibrate", str(params), str(log), *robot, "-o", str(tmp_path / "c.yaml")],
    ):
        assert main(argv) == 2
        err = _one_sentence(capsys)
        assert str(log) in err
        if words == "mostly unattended":
            assert words in err and "--keep-all" in err
        else:
            assert "active" in err or "never change" in err


def test_params_of_another_robot_given_as_a_spec_file_advise_a_working_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    for name, sep in (("neato", "0.248"), ("other", "0.4")):
        assert main(["robots", "new", name, "--wheel-separation", sep, "--max-speed", "0.3"]) == 0
    (tmp_path / "specs").mkdir()
    Path("other.yaml").rename("specs/other.yaml")
    log = write_log(tmp_path / "run.mcap", duration_s=15.0)
    argv = ["sysid", "fit", str(log), "--robot", "specs/other.yaml", "-o", "other_params.yaml"]
    assert main(argv) == 0
    capsys.readouterr()
    agree = ["agree", str(log), "--params", "other_params.yaml", "--engine", "reduced"]
    assert main([*agree, "--robot", "neato.yaml"]) == 2
    err = _one_sentence(capsys)
    assert "identified for robot 'other', not 'neato'" in err
    advice = err.split("pass ", 1)[1].split(" or fit")[0]  # "--robot /abs/specs/other.yaml"
    assert advice.endswith("specs/other.yaml")
    assert main([*agree, *shlex.split(advice)]) == 0  # the advice works as printed
    assert main(["sysid", "calibrate", "other_params.yaml", str(log), "--robot", "neato.yaml",
                 "-o", "c.yaml"]) == 2  # fmt: skip
    assert advice in _one_sentence(capsys)
