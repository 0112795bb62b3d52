"""``sim2real.fitting.fit_logs``: the one fit behind ``sim2real sysid fit`` and the Python API."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from robots.params import SPECS_DIR, ParamsFile
from robots.spec import load_spec
from sim2real.cli import main
from sim2real.fitting import beyond_spec_notes, fit_logs, read_fit_logs
from sysid import LogArrays

REPO = Path(__file__).resolve().parents[2]
DEMO_TRAIN = REPO / "data" / "demo_train.mcap"
DEMO_VALIDATE = REPO / "data" / "demo_validate.mcap"


@pytest.mark.slow
def test_cli_and_library_give_the_same_fit(demo_run: Path) -> None:
    # the CLI's fit: the demo's step 1, `sysid fit` of the tour's command line (parsed by the
    # CLI's parser, run by its handler), shared with the tests of the demo's other outputs
    out = demo_run / "out" / "params.yaml"
    fit = fit_logs([DEMO_TRAIN], robot="turtlebot3_burger", validate=[DEMO_VALIDATE])
    from_cli = yaml.safe_load(out.read_text(encoding="utf-8"))
    from_library = yaml.safe_load(fit.result.to_yaml())
    for doc in (from_cli, from_library):
        doc["settings"].pop("seconds")  # the fit's wall time
    assert from_cli == from_library  # every number: values, intervals, scores, randomisation
    # the spec's defaults reach the fit: its priors and the encoder's odometry window
    spec = load_spec("turtlebot3_burger")
    assert fit.result.settings["odom_v_window_s"] == pytest.approx(spec.odometry.v_window_s)
    assert fit.result.priors["delay_s"]["sd"] == pytest.approx(spec.priors["delay_s"].sd)
    delay = from_cli["parameters"]["delay_s"]["value"]
    assert 0.04 < delay < 0.12
    assert any("time source auto" in note for note in fit.notes)


def test_window_crops_and_pauses_split(tmp_path: Path) -> None:
    spec = load_spec("turtlebot3_burger")
    whole = read_fit_logs([DEMO_TRAIN], spec=spec)
    part = read_fit_logs([DEMO_TRAIN], spec=spec, window=(0.0, 20.0))
    span = sum(float(p.meas_t_s[-1] - p.meas_t_s[0]) for p in part)
    assert 15.0 < span <= 20.0
    assert sum(p.meas_t_s.size for p in part) < sum(p.meas_t_s.size for p in whole)


@pytest.mark.slow
def test_params_of_a_spec_file_name_the_file_in_the_advice(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec_file = tmp_path / "mybot.yaml"  # a robot known only by its spec file
    text = (SPECS_DIR / "turtlebot3_burger.yaml").read_text(encoding="utf-8")
    spec_file.write_text(text.replace("name: turtlebot3_burger", "name: mybot"), encoding="utf-8")
    params = tmp_path / "params.yaml"
    fit = ["sysid", "fit", str(DEMO_TRAIN), "--robot", str(spec_file), "-o", str(params)]
    assert main([*fit, "--free", "delay_s"]) == 0
    assert yaml.safe_load(params.read_text())["settings"]["spec_file"] == str(spec_file)
    capsys.readouterr()
    agree = ["agree", str(DEMO_VALIDATE), "--params", str(params), "--engine", "reduced"]
    assert main([*agree, "--robot", "turtlebot3_burger"]) == 2
    err = capsys.readouterr().err
    assert f"pass --robot {spec_file} or fit a params file for turtlebot3_burger" in err
    assert main([*agree, "--robot", str(spec_file)]) == 0  # the advice works as printed


def test_robot_option_of_a_params_file(tmp_path: Path) -> None:
    def option(robot: str, settings: dict[str, str] | None = None) -> str:
        doc = {} if settings is None else {"settings": settings}
        pf = ParamsFile(path=tmp_path / "p.yaml", robot=robot, values={}, stds={}, document=doc)
        return pf.robot_option()

    spec_file = tmp_path / "my bot.yaml"
    spec_file.write_text("name: mybot\n", encoding="utf-8")
    assert option("turtlebot2") == "--robot turtlebot2"  # shipped: the name loads it
    assert option("mybot", {"spec_file": str(spec_file)}) == f"--robot '{spec_file}'"
    gone = option("mybot", {"spec_file": str(tmp_path / "gone.yaml")})
    assert gone.startswith("--robot with the spec file of robot 'mybot'")


def _pieces(v: np.ndarray, w: np.ndarray) -> list[LogArrays]:
    t = np.arange(v.size) * 0.05
    return [LogArrays(cmd_t_s=t, cmd_v=v, cmd_w=w, meas_t_s=t, meas_v=v, meas_w=w, name="x")]


def test_a_robot_faster_than_its_spec_is_noted() -> None:
    spec = load_spec("turtlebot3_burger")  # top speed 0.22 m/s, top yaw rate 2.84 rad/s
    n = 400
    within = _pieces(np.full(n, 1.2 * 0.22), np.full(n, 1.2 * 2.84))
    assert beyond_spec_notes(within, spec) == []  # under 1.25x: the spec's spread covers it
    fast_v = np.full(n, 0.6)
    spiky = fast_v.copy()
    spiky[:] = 0.2
    spiky[::200] = 5.0  # two single-sample spikes: not the robot's speed
    assert beyond_spec_notes(_pieces(spiky, np.zeros(n)), spec) == []
    [note] = beyond_spec_notes(_pieces(fast_v, np.zeros(n)), spec)
    assert note.startswith("the logs measure v up to 0.6 m/s, 2.73x the spec's top speed 0.22")
    assert "--max-speed" in note
    [note_w] = beyond_spec_notes(_pieces(np.zeros(n), np.full(n, -4.0)), spec)
    assert "w up to 4 rad/s" in note_w and "top yaw rate 2.84 rad/s" in note_w
    assert "--max-turn-rate" in note_w


def test_the_demo_log_is_within_its_spec() -> None:
    spec = load_spec("turtlebot3_burger")
    pieces = read_fit_logs([DEMO_TRAIN], spec=spec, window=None, notes=[])
    assert beyond_spec_notes(pieces, spec) == []


@pytest.mark.realdata
@pytest.mark.slow
def test_sysid_fit_says_when_the_spec_top_speed_is_far_too_low(
    realdata_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A large skid steer given a spec with the template's 0.5 m/s top speed (real Warthog)."""
    spec = tmp_path / "warthog.yaml"
    new = ["robots", "new", "warthog", "--wheel-separation", "1.08", "--wheel-radius", "0.3",
           "--drive", "skid", "-o", str(spec)]  # fmt: skip
    assert main(new) == 0
    log = realdata_dir / "warthog_close" / "trace.csv"
    fit = ["sysid", "fit", str(log), "--robot", str(spec), "-o", str(tmp_path / "p.yaml")]
    assert main(fit) == 0
    printed = capsys.readouterr()
    said = " ".join((printed.out + printed.err).split())
    assert "the logs measure v up to 3." in said and "the spec's top speed 0.5 m/s" in said
    assert "--max-speed" in said


@pytest.mark.slow
@pytest.mark.realdata
def test_cli_and_library_give_the_same_fit_on_a_real_robot_of_a_spec_file(
    realdata_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A new user's path: a `robots new` spec file, a real Neato log whose odometry twist is
    spiky (velocities from the pose, read through the measurement operator). The README's
    call and `sysid fit` write the same file, number for number."""
    monkeypatch.chdir(tmp_path)
    argv = ["robots", "new", "neato", "--wheel-separation", "0.248", "--max-speed", "0.3"]
    assert main(argv) == 0
    log = realdata_dir / "neato_yycho0108_drive_square_demo.mcap"
    assert main(["sysid", "fit", str(log), "--robot", "neato.yaml", "-o", "cli.yaml"]) == 0
    fit = fit_logs([log], robot="neato.yaml")
    from_cli = yaml.safe_load(Path("cli.yaml").read_text(encoding="utf-8"))
    from_library = yaml.safe_load(fit.result.to_yaml())
    for doc in (from_cli, from_library):
        doc["settings"].pop("seconds")
    assert from_cli == from_library
    assert from_cli["settings"]["measurement"]  # the pose-derived velocities' operator
