"""End-to-end audit of the ``sim2real`` CLI on bad input, through ``sim2real.cli.main``.

The rule under test (README, docs/ARCHITECTURE.md): bad input prints ONE line on stderr,
``sim2real: error: ...``, naming the file/argument and the value received, exits with code 2,
shows no traceback and leaves no output file behind. ``--min-agreement`` exits with 1 when the
gate fails. Every log here is a real ROS 2 CDR MCAP file written by
:func:`sim2real.logs.write_velocity_log` (20 s, commands at 10 Hz, odometry at 30 Hz).
"""

from __future__ import annotations

import json
import re
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import yaml

from robots.params import DriveParams
from robots.reduced import simulate
from robots.spec import list_robots, load_spec
from sim2real.cli import main
from sim2real.logs import write_velocity_log
from tests.randomization_block import distribution_around

ROBOT = "turtlebot3_burger"
T0_NS = 1_700_000_000_000_000_000
#: A robot unlike the spec defaults (slower, heavier, delayed): the defaults agree poorly.
HIDDEN = {"delay_s": 0.15, "added_mass_kg": 0.4, "accel_lim_v_mps2": 0.6, "coulomb_v_fwd_n": 0.4}
NOWHERE = Path("/nonexistent/sim2real-audit")


# ----------------------------------------------------------------------------- helpers


@dataclass(frozen=True, kw_only=True)
class Run:
    """Exit code and captured streams of one in-process CLI call."""

    code: int
    out: str
    err: str


def cli(capsys: pytest.CaptureFixture[str], *argv: object) -> Run:
    """Run ``sim2real ARGV`` in-process; an escaping exception fails the test (= traceback)."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return Run(code=code, out=out, err=err)


def assert_bad_input(run: Run, *needles: object) -> str:
    """Exit 2, exactly one ``sim2real: error:`` line naming every needle, no traceback."""
    assert "Traceback" not in run.err + run.out
    assert run.code == 2, run.err
    lines = run.err.splitlines()
    assert len(lines) == 1, run.err
    assert lines[0].startswith("sim2real: error: "), run.err
    for needle in needles:
        assert str(needle) in lines[0], f"{needle!r} not in {lines[0]!r}"
    return lines[0]


def _ns(t_s: np.ndarray) -> np.ndarray:
    return T0_NS + np.rint(t_s * 1e9).astype(np.int64)


def write_log(
    path: Path,
    *,
    params: DriveParams | None = None,
    commands: bool = True,
    hold: tuple[float, float] | None = None,
    nan_odom: slice | None = None,
    duration_s: float = 20.0,
) -> Path:
    """Steps in v and w every 2 s (10 Hz), odometry from the reduced model (30 Hz).

    ``hold`` replaces the steps by one constant command; ``commands=False`` writes an empty
    command stream (an odometry-only log); ``nan_odom`` puts NaN in those odometry v samples.
    """
    spec = load_spec(ROBOT)
    rng = np.random.default_rng(0)
    cmd_t = np.arange(0.0, duration_s, 0.1)
    n_steps = int(duration_s / 2.0) + 1
    cmd_v = np.repeat(rng.uniform(-0.2, 0.2, n_steps), 20)[: cmd_t.size]
    cmd_w = np.repeat(rng.uniform(-1.5, 1.5, n_steps), 20)[: cmd_t.size]
    if hold is not None:
        cmd_v[:], cmd_w[:] = hold
    meas_t = np.arange(0.0, duration_s, 1.0 / 30.0)
    sim = simulate(
        params or spec.drive, spec.geometry,
        cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=meas_t,
    )  # fmt: skip
    meas_v = sim.v.copy()
    if nan_odom is not None:
        meas_v[nan_odom] = np.nan
    keep = slice(None) if commands else slice(0, 0)
    return write_velocity_log(
        path,
        cmd_t_ns=_ns(cmd_t)[keep],
        cmd_v=cmd_v[keep],
        cmd_w=cmd_w[keep],
        meas_t_ns=_ns(meas_t),
        meas_v=meas_v,
        meas_w=sim.w,
    )


def write_params(path: Path, values: dict[str, float], *, robot: str = ROBOT) -> Path:
    """A params file in the sysid result format (``format: sim2real.sysid/1``).

    Its ``randomization`` block is centred on the spec values with ``values`` applied when
    they are valid drive parameters (else on the spec values).
    """
    drive = load_spec(robot).drive
    try:
        centre = drive.replace(**values)
    except (TypeError, ValueError):
        centre = drive
    doc = {
        "format": "sim2real.sysid/1",
        "robot": robot,
        "tool_version": "test",
        "parameters": {
            k: {"value": v, "std": 0.05 * abs(v), "ci95": None, "status": "fitted"}
            for k, v in values.items()
        },
        "randomization": distribution_around(centre, robot).to_dict(),
    }
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


@dataclass(frozen=True, kw_only=True)
class Files:
    """The audit's input files (built once per module)."""

    root: Path
    good: Path
    hidden: Path
    no_cmd: Path
    some_nan: Path
    all_nan: Path
    still: Path
    constant: Path
    text: Path
    empty: Path
    truncated: Path
    corrupt: Path
    missing: Path
    params_ok: Path
    params_tb2: Path
    params_unknown_key: Path
    params_negative: Path
    bad_yaml: Path

    def bad_log(self, kind: str) -> Path:
        return {
            "missing": self.missing,
            "text": self.text,
            "empty": self.empty,
            "truncated": self.truncated,
            "corrupt": self.corrupt,
            "no_commands": self.no_cmd,
            "all_nan": self.all_nan,
        }[kind]


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Files:
    root = tmp_path_factory.mktemp("cli_bad_input")
    good = write_log(root / "good.mcap")
    truncated = root / "truncated.mcap"
    data = good.read_bytes()
    truncated.write_bytes(data[:64])  # cut in the first chunk's header: no message remains
    flipped, mid = bytearray(data), len(data) // 2  # invert 4 bytes of the CRC'd data section
    flipped[mid : mid + 4] = bytes(b ^ 0xFF for b in data[mid : mid + 4])
    corrupt = root / "corrupt.mcap"
    corrupt.write_bytes(bytes(flipped))
    text = root / "notes.mcap"
    text.write_text("this is a text file, not a log\n", encoding="utf-8")
    empty = root / "empty.mcap"
    empty.write_bytes(b"")
    bad_yaml = root / "bad.yaml"
    bad_yaml.write_text("format: [unclosed\nrobot: x\n", encoding="utf-8")
    hidden = load_spec(ROBOT).drive.replace(**HIDDEN)
    return Files(
        root=root,
        good=good,
        hidden=write_log(root / "hidden.mcap", params=hidden),
        no_cmd=write_log(root / "odom_only.mcap", commands=False),
        some_nan=write_log(root / "some_nan.mcap", nan_odom=slice(30, 40)),
        all_nan=write_log(root / "all_nan.mcap", nan_odom=slice(None)),
        still=write_log(root / "still.mcap", hold=(0.0, 0.0)),
        constant=write_log(root / "constant.mcap", hold=(0.1, 0.3)),
        text=text,
        empty=empty,
        truncated=truncated,
        corrupt=corrupt,
        missing=root / "missing.mcap",
        params_ok=write_params(root / "ok.yaml", HIDDEN),
        params_tb2=write_params(root / "tb2.yaml", {"delay_s": 0.1}, robot="turtlebot2"),
        params_unknown_key=write_params(root / "typo.yaml", {"delay_sec": 0.1}),
        params_negative=write_params(root / "negative.yaml", {"delay_s": -0.15}),
        bad_yaml=bad_yaml,
    )


def agree(log: Path, *extra: object) -> list[object]:
    return ["agree", log, "--robot", ROBOT, "--engine", "reduced", *extra]


def fit(log: Path, out: Path, *extra: object) -> list[object]:
    return ["sysid", "fit", log, "--robot", ROBOT, "-o", out, *extra]


def leftovers(folder: Path) -> list[str]:
    """Temp files of atomic_write (``.NAME.*.tmp``) left in a folder."""
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


# ----------------------------------------------------------------------------- bad log files

#: What the message must say about each bad log (besides its path).
BAD_LOG_WORDS = {
    "missing": "does not exist",
    "text": "is not an MCAP file",
    "empty": "is empty (0 bytes)",
    "truncated": "is truncated",
    "corrupt": "is corrupt",
    "no_commands": "'/cmd_vel'",
    "all_nan": "NaN",
}


@pytest.mark.parametrize("kind", list(BAD_LOG_WORDS))
@pytest.mark.parametrize(
    "command",
    ["sysid fit", "sysid fit --validate", "agree", "demo train log", "demo validate log"],
)
def test_bad_log_exits_2_naming_the_file(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str, command: str
) -> None:
    bad = files.bad_log(kind)
    out, words = tmp_path / "out", BAD_LOG_WORDS[kind]
    if command == "sysid fit":
        argv = fit(bad, tmp_path / "p.yaml")
    elif command == "sysid fit --validate":
        argv = fit(files.good, tmp_path / "p.yaml", "--validate", bad)
    elif command == "agree":
        argv = agree(bad, "--json", tmp_path / "a.json", "--sim-out", tmp_path / "sim.mcap")
    else:
        data = tmp_path / "data"
        data.mkdir()
        good_role, bad_role = ("demo_validate", "demo_train")
        if command == "demo validate log":
            good_role, bad_role = bad_role, good_role
        shutil.copy(files.good, data / f"{good_role}.mcap")
        shutil.copy(files.good, data / "demo_calibrate.mcap")
        if bad.exists():
            bad = Path(shutil.copy(bad, data / f"{bad_role}.mcap"))
        else:  # a missing log: the data folder is incomplete
            bad, words = data, "were not found"
        argv = ["demo", "--data", data, "--engine", "reduced", "--ensemble", 0, "--out", out]
    line = assert_bad_input(cli(capsys, *argv), bad, words)
    if kind == "no_commands":
        assert "no messages" in line
    # nothing written: no params file, no JSON, no sim log, no demo folder, no temp file
    assert sorted(p.name for p in tmp_path.iterdir()) in ([], ["data"])


@pytest.mark.parametrize("kind", ["missing", "text", "empty", "truncated", "corrupt"])
def test_logs_info_on_an_unreadable_log_exits_2(
    files: Files, capsys: pytest.CaptureFixture[str], kind: str
) -> None:
    bad = files.bad_log(kind)
    assert_bad_input(cli(capsys, "logs", "info", bad), bad, BAD_LOG_WORDS[kind])


def test_debug_shows_the_library_error_instead(files: Files) -> None:
    from sim2real.errors import LogFormatError

    with pytest.raises(LogFormatError, match="is not an MCAP file"):
        main(["--debug", "logs", "info", str(files.text)])


def test_truncated_log_message_says_where_it_was_cut(
    files: Files, capsys: pytest.CaptureFixture[str]
) -> None:
    size = files.truncated.stat().st_size
    line = assert_bad_input(cli(capsys, "logs", "info", files.truncated), files.truncated)
    assert f"truncated at byte {size}" in line


def test_a_log_cut_inside_its_chunk_keeps_the_complete_messages(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Cut at half its bytes, inside its one compressed chunk: the messages before the cut are
    read (a warning says where it was cut), the figures come from them."""
    data = files.good.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    run = cli(capsys, *agree(cut, "--json", tmp_path / "a.json"))
    assert run.code == 0 and "Traceback" not in run.err
    assert f"is truncated at byte {len(data) // 2}" in run.err
    assert "bytes of records of the chunk cut there" in run.err
    whole = cli(capsys, *agree(files.good, "--json", tmp_path / "b.json"))
    assert whole.code == 0
    n_cut = json.loads((tmp_path / "a.json").read_text())["n_samples"]
    n_whole = json.loads((tmp_path / "b.json").read_text())["n_samples"]
    assert 0.2 * n_whole < n_cut < n_whole


def test_logs_info_on_an_odometry_only_log_warns_that_reading_it_will_fail(
    files: Files, capsys: pytest.CaptureFixture[str]
) -> None:
    run = cli(capsys, "logs", "info", files.no_cmd)
    assert run.code == 0 and run.err == ""
    assert "warning: the command topic '/cmd_vel' has no messages" in run.out
    info = json.loads(cli(capsys, "logs", "info", files.no_cmd, "--json").out)
    assert [t["count"] for t in info["topics"]] == [0, 600]
    assert any("'/cmd_vel' has no messages" in w for w in info["warnings"])


def test_a_folder_given_as_log_exits_2(files: Files, capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["logs", "info", files.root], agree(files.root)):
        assert_bad_input(cli(capsys, *argv), files.root, "is a folder")


# ----------------------------------------------------------------------------- topics


@pytest.mark.parametrize("flag", ["--odom-topic", "--cmd-topic"])
@pytest.mark.parametrize("command", ["logs info", "sysid fit", "agree"])
def test_wrong_topic_lists_the_topics_present(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str], flag: str, command: str
) -> None:
    argv: list[object] = {
        "logs info": ["logs", "info", files.good],
        "sysid fit": fit(files.good, tmp_path / "p.yaml"),
        "agree": agree(files.good),
    }[command]
    line = assert_bad_input(cli(capsys, *argv, flag, "/wheel_odom"), files.good, "'/wheel_odom'")
    assert "/cmd_vel (geometry_msgs/msg/Twist, 200 msgs)" in line
    assert "/odom (nav_msgs/msg/Odometry, 600 msgs)" in line
    assert flag in line
    assert not (tmp_path / "p.yaml").exists()


def test_topic_of_the_wrong_type_exits_2(files: Files, capsys: pytest.CaptureFixture[str]) -> None:
    line = assert_bad_input(cli(capsys, *agree(files.good, "--odom-topic", "/cmd_vel")))
    assert "'/cmd_vel'" in line and "geometry_msgs/msg/Twist" in line and "Odometry" in line


# ----------------------------------------------------------------------------- NaN values


def test_all_nan_odometry_exits_2_naming_topic_and_file(
    files: Files, capsys: pytest.CaptureFixture[str]
) -> None:
    line = assert_bad_input(cli(capsys, *agree(files.all_nan)), files.all_nan, "'/odom'")
    assert "every one of the 600 samples" in line


def test_some_nan_samples_are_dropped_and_reported(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dropped = "dropped 10 of 600 samples of topic '/odom' with NaN/inf values"
    run = cli(capsys, *agree(files.some_nan, "--json", tmp_path / "a.json"))
    assert run.code == 0
    assert run.err.splitlines() == [f"sim2real: warning: {files.some_nan}: {dropped}"]
    figures = json.loads((tmp_path / "a.json").read_text())
    assert figures["n_samples"] == 590  # the 10 NaN samples are not compared
    run = cli(capsys, *fit(files.some_nan, tmp_path / "p.yaml", "--free", "delay_s"))
    assert run.code == 0, run.err
    assert dropped in run.out
    warnings = yaml.safe_load((tmp_path / "p.yaml").read_text())["warnings"]
    assert f"{files.some_nan}: {dropped}" in warnings


# ----------------------------------------------------------------------------- robots, params


@pytest.mark.parametrize(
    "argv",
    [
        ["robots", "show", "turtlebot4"],
        ["sysid", "fit", "LOG", "--robot", "turtlebot4", "-o", "OUT"],
        ["agree", "LOG", "--robot", "turtlebot4", "--engine", "reduced"],
    ],
)
def test_unknown_robot_lists_the_known_ones(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str]
) -> None:
    subst = {"LOG": files.good, "OUT": tmp_path / "p.yaml"}
    line = assert_bad_input(cli(capsys, *(subst.get(a, a) for a in argv)), "'turtlebot4'")
    for name in list_robots():
        assert name in line
    assert list(tmp_path.iterdir()) == []


def test_robots_list_shows_every_robot(capsys: pytest.CaptureFixture[str]) -> None:
    run = cli(capsys, "robots", "list")
    assert run.code == 0 and run.err == ""
    assert [line.split()[0] for line in run.out.splitlines()[1:]] == list_robots()


@pytest.mark.parametrize(
    ("content", "words"),
    [
        ("just a sentence\n", "must be a mapping"),
        ("name: x\n", "required key 'description' is missing"),
        ("name: [x\n", "is not valid YAML"),
    ],
)
def test_bad_spec_file_exits_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str, words: str
) -> None:
    spec = tmp_path / "my_robot.yaml"
    spec.write_text(content, encoding="utf-8")
    assert_bad_input(cli(capsys, "robots", "show", spec), spec, words)
    missing = tmp_path / "absent.yaml"
    assert_bad_input(cli(capsys, "robots", "show", missing), missing, "does not exist")


def test_params_for_another_robot_exits_2_and_names_both_robots(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = cli(capsys, *agree(files.good, "--params", files.params_tb2, "--json", tmp_path / "a"))
    line = assert_bad_input(run, files.params_tb2, "'turtlebot2'", f"'{ROBOT}'")
    assert "--robot turtlebot2" in line  # the fix
    assert list(tmp_path.iterdir()) == []


def _block_file(folder: Path, name: str, change: str) -> Path:
    """A good params file whose ``randomization`` block is broken as ``change`` says."""
    path = write_params(folder / name, HIDDEN)
    doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    block = doc["randomization"]
    i = block["names"].index("delay_s")
    if change == "nan_std":
        block["covariance"][i][i] = float("nan")
    elif change == "absurd_spread":
        block["covariance"][i][i] = 1.0e6  # a delay sd of 1000 s
    elif change == "other_robot":
        block["robot"] = "turtlebot2"
    elif change == "negative_noise":
        block["noise"]["v"]["std_mps"] = -0.1
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ("nan_std", ["randomization", "covariance", "'delay_s'", "nan"]),
        ("absurd_spread", ["randomization", "covariance", "'delay_s'", "absurd"]),
        ("other_robot", ["randomization", "robot", "turtlebot2"]),
        ("negative_noise", ["randomization", "std_v_mps", "-0.1"]),
    ],
)
def test_bad_randomization_block_exits_2_in_agree_and_calibrate(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str], change: str, words: list[str]
) -> None:
    params = _block_file(files.root, f"block_{change}.yaml", change)
    out = tmp_path / "a.json"
    run = cli(capsys, *agree(files.good, "--params", params, "--ensemble", 3, "--json", out))
    assert_bad_input(run, params, *words)
    cal = ["sysid", "calibrate", params, files.hidden, "--robot", ROBOT, "-o", tmp_path / "c.yaml"]
    assert_bad_input(cli(capsys, *cal), params, *words)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--ensemble", "3"], ["--ensemble", ">= 4", "3"]),
        (["--ensemble", "-1"], ["--ensemble", "-1"]),
        (["--odom-v-window", "5"], ["--odom-v-window", "'5'"]),
        (["--robot", "turtlebot2"], ["turtlebot2", ROBOT]),
    ],
)
def test_bad_calibrate_argument_exits_2_without_output(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str],
    words: list[str],
) -> None:  # fmt: skip
    argv = ["sysid", "calibrate", files.params_ok, files.hidden, "-o", tmp_path / "c.yaml"]
    robot = [] if "--robot" in extra else ["--robot", ROBOT]
    assert_bad_input(cli(capsys, *argv, *robot, *extra), *words)
    assert list(tmp_path.iterdir()) == []


def test_calibrate_output_over_an_input_exits_2(
    files: Files, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["sysid", "calibrate", files.params_ok, files.hidden, "--robot", ROBOT]
    assert_bad_input(cli(capsys, *argv, "-o", files.params_ok), "input", files.params_ok)


@pytest.mark.parametrize(
    ("which", "agree_words", "show_words"),
    [
        ("missing", "does not exist", "does not exist"),
        ("folder", "is a folder", "is a folder"),
        ("text", "has no 'parameters' mapping", "'format' is absent"),
        ("empty", "has no 'parameters' mapping", "the file is empty"),
        ("binary", "is not valid YAML", "is not valid YAML"),
        ("bad_yaml", "is not valid YAML", "is not valid YAML"),
        ("unknown_key", "'delay_sec'", "'delay_sec'"),
        ("negative", "-0.15", "-0.15"),
    ],
)
def test_bad_params_file_exits_2_for_agree_and_sysid_show(
    files: Files, capsys: pytest.CaptureFixture[str], which: str, agree_words: str, show_words: str
) -> None:
    path = {
        "missing": files.root / "absent.yaml",
        "folder": files.root,
        "text": files.text,
        "empty": files.empty,
        "binary": files.good,
        "bad_yaml": files.bad_yaml,
        "unknown_key": files.params_unknown_key,
        "negative": files.params_negative,
    }[which]
    assert_bad_input(cli(capsys, *agree(files.good, "--params", path)), path, agree_words)
    assert_bad_input(cli(capsys, "sysid", "show", path), path, show_words)


def test_sysid_show_of_a_good_params_file_exits_0(
    files: Files, capsys: pytest.CaptureFixture[str]
) -> None:
    run = cli(capsys, "sysid", "show", files.params_ok)
    assert run.code == 0 and run.err == ""
    assert "delay_s" in run.out and "0.15" in run.out


# ----------------------------------------------------------------------------- arguments


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--tol-v", "0"], ["--tol-v", "0.0"]),
        (["--tol-v", "-0.01"], ["--tol-v", "-0.01"]),
        (["--tol-w", "0"], ["--tol-w", "0.0"]),
        (["--tol-w", "nan"], ["--tol-w", "nan"]),
        (["--tol-v", "inf"], ["--tol-v", "inf"]),
        (["--min-agreement", "1.5"], ["--min-agreement", "1.5"]),
        (["--min-agreement", "nan"], ["--min-agreement", "nan"]),
        (["--ensemble", "3"], ["--ensemble", "--params"]),
        (["--params", "OK", "--ensemble", "1"], ["--ensemble", "1"]),
        (["--params", "OK", "--ensemble", "3", "--spread", "-1"], ["--spread", "-1.0"]),
        (["--params", "OK", "--ensemble", "3", "--band-level", "1"], ["--band-level", "1.0"]),
        (["--params", "OK", "--ensemble", "3", "--band-level", "0"], ["--band-level", "0.0"]),
        (["--params", "OK", "--ensemble", "3", "--band-level", "nan"], ["--band-level", "nan"]),
        (["--params", "OK", "--ensemble", "0"], ["--ensemble", "0"]),
        (["--params", "OK", "--ensemble", "10001"], ["--ensemble", "from 2 to 10000", "10001"]),
        (["--params", "OK", "--spread", "3"], ["--spread only shape", "needs --ensemble N"]),
        (["--seed", "7", "--band-level", "0.8"], ["--seed, --band-level", "needs --ensemble N"]),
    ],
)
def test_bad_agree_argument_exits_2_before_writing(
    files: Files,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    words: list[str],
) -> None:
    extra = [files.params_ok if a == "OK" else a for a in extra]  # type: ignore[misc]
    outputs = ["--json", tmp_path / "a.json", "--report", tmp_path / "r.html"]
    outputs += ["--sim-out", tmp_path / "sim.mcap"]
    assert_bad_input(cli(capsys, *agree(files.good, *extra, *outputs)), *words)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--window", "5:2"], ["--window", "'5:2'"]),
        (["--window", "a:b"], ["--window", "'a:b'"]),
        (["--window", "100:200"], ["100:200", "0.00..19.97 s"]),
        (["--validate", "GOOD", "--validate-window=-1:3"], ["--validate-window", "'-1:3'"]),
        (["--free", "delay_sec"], ["'delay_sec'", "delay_s"]),
        (["--free", ","], ["--free", "','"]),
        (["--odom-v-window", "2"], ["--odom-v-window", "'2'"]),
        (["--dt", "0"], ["--dt", "0.0", "e.g. --dt 0.005"]),
        (["--dt", "0.2"], ["--dt", "(0, 0.05] s", "0.2", "e.g. --dt 0.005"]),
        (["--dt", "nan"], ["--dt", "nan", "e.g. --dt 0.005"]),
        (["--bootstrap", "-1"], ["--bootstrap", ">= 0", "-1", "e.g. --bootstrap 20"]),
    ],
)
def test_bad_sysid_fit_argument_exits_2_without_output(
    files: Files,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    words: list[str],
) -> None:
    extra = [files.good if a == "GOOD" else a for a in extra]  # type: ignore[misc]
    line = assert_bad_input(cli(capsys, *fit(files.good, tmp_path / "p.yaml", *extra)), *words)
    assert "segment_s" not in line  # a library keyword the CLI cannot set
    assert list(tmp_path.iterdir()) == []


def test_argparse_usage_errors_exit_2_without_traceback(
    files: Files, capsys: pytest.CaptureFixture[str]
) -> None:
    for argv in (
        agree(files.good, "--tol-v", "abc"),  # not a float
        ["sysid", "fit", files.good, "-o", "p.yaml"],  # --robot missing
        ["agree", files.good, "--robot", ROBOT, "--engine", "gazebo"],  # not a choice
    ):
        with pytest.raises(SystemExit) as exc:
            main([str(a) for a in argv])
        err = capsys.readouterr().err
        assert exc.value.code == 2
        assert "Traceback" not in err
        assert len(err.splitlines()) == 1, err
        assert err.startswith("sim2real: error: sim2real ")
        assert "--help'" in err


# ----------------------------------------------------------------------------- output paths


@pytest.mark.parametrize(
    ("argv", "what"),
    [
        (["sysid", "fit", "GOOD", "--robot", ROBOT, "-o", "OUT"], "params file"),
        (["agree", "GOOD", "--robot", ROBOT, "--engine", "reduced", "--json", "OUT"], "--json"),
        (["agree", "GOOD", "--robot", ROBOT, "--engine", "reduced", "--report", "OUT"], "report"),
        (["agree", "GOOD", "--robot", ROBOT, "--engine", "reduced", "--sim-out", "OUT"], "--sim"),
        (["envs", "eval", "RandomMap-v0", "--episodes", "1", "--json", "OUT"], "--json"),
    ],
)
@pytest.mark.parametrize("where", ["missing folder", "existing folder as file"])
def test_unwritable_output_exits_2_and_writes_nothing(
    files: Files,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    argv: list[str],
    what: str,
    where: str,
) -> None:
    target = NOWHERE / "dir" / "out.file" if where == "missing folder" else tmp_path
    words = ["which does not exist"] if where == "missing folder" else ["is a folder"]
    subst = {"GOOD": files.good, "OUT": target}
    assert_bad_input(cli(capsys, *(subst.get(a, a) for a in argv)), target, what, *words)
    assert not NOWHERE.exists()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("flag", "clash"),
    [
        ("-o", "log"),
        ("-o", "validation log"),
        ("--json", "log"),
        ("--report", "log"),
        ("--sim-out", "log"),
        ("--json", "params"),
        ("--sim-out", "params"),
    ],
)
def test_output_that_is_an_input_exits_2_and_keeps_the_input(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str], flag: str, clash: str
) -> None:
    log = Path(shutil.copy(files.good, tmp_path / "run.mcap"))
    params = Path(shutil.copy(files.params_ok, tmp_path / "params.yaml"))
    before = {p: p.read_bytes() for p in (log, params)}
    if flag == "-o":
        other = Path(shutil.copy(files.hidden, tmp_path / "val.mcap"))
        before[other] = other.read_bytes()
        target = log if clash == "log" else other
        argv = fit(log, target, "--validate", other)
    else:
        target = log if clash == "log" else params
        argv = agree(log, "--params", params, flag, target)
    assert_bad_input(cli(capsys, *argv), target, "would be overwritten")
    assert {p: p.read_bytes() for p in before} == before
    assert leftovers(tmp_path) == []


def test_a_failing_agree_leaves_no_output_of_the_others(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--json and --sim-out are writable but --report is not: nothing at all is written."""
    run = cli(
        capsys,
        *agree(files.good, "--json", tmp_path / "a.json", "--sim-out", tmp_path / "sim.mcap"),
        "--report",
        NOWHERE / "r.html",
    )
    assert_bad_input(run, NOWHERE / "r.html")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("log", "words"),
    [("still", ["cmd_v = 0 m/s", "cmd_w = 0 rad/s"]), ("constant", ["cmd_v = 0.1 m/s"])],
)
def test_log_with_nothing_to_identify_exits_2_and_keeps_the_old_params_file(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str], log: str, words: list[str]
) -> None:
    path = files.still if log == "still" else files.constant
    out = tmp_path / "p.yaml"
    out.write_text("previous result\n", encoding="utf-8")
    line = assert_bad_input(cli(capsys, *fit(path, out)), path, "never change", *words)
    assert "record a log with steps" in line
    assert out.read_text(encoding="utf-8") == "previous result\n"  # untouched
    assert leftovers(tmp_path) == []


# ----------------------------------------------------------------------------- gate


def test_min_agreement_gate_exits_1_below_and_0_at_or_above(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = cli(capsys, *agree(files.hidden, "--json", tmp_path / "a.json"))
    assert run.code == 0 and run.err == ""
    agreement = json.loads((tmp_path / "a.json").read_text())["agreement"]
    assert 0.5 < agreement < 0.95  # the defaults are not the robot that made the log
    below = cli(capsys, *agree(files.hidden, "--min-agreement", round(agreement + 0.02, 3)))
    assert below.code == 1
    assert len(below.err.splitlines()) == 1
    assert f"agreement {100 * agreement:.1f} % is below --min-agreement" in below.err
    assert "Traceback" not in below.err
    above = cli(capsys, *agree(files.hidden, "--min-agreement", round(agreement - 0.02, 3)))
    assert above.code == 0 and above.err == ""
    # the log was made by the spec defaults and reports their instantaneous v (no encoder
    # window): compared the same way, with the reduced engine, they agree 100 %
    exact = cli(capsys, *agree(files.good, "--min-agreement", 1.0, "--odom-v-window", 0))
    assert exact.code == 0 and exact.err == ""


# ----------------------------------------------------------------------------- envs, demo


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["envs", "eval", "Maze-v9"], ["'Maze-v9'", "sim2real/RandomMap-v0", "CrowdNav-v0"]),
        (["envs", "eval", "RandomMap-v0", "--preset", "TEST9"], ["'TEST9'", "TEST4"]),
        (
            ["envs", "eval", "CrowdNav-v0", "--scenario", "crowded"],
            ["--scenario", "'crowded'", "occluded", "e.g. --scenario dynamic"],
        ),
        (
            ["envs", "eval", "CrowdNav-v0", "--complexity", "5"],
            ["--complexity", "[0, 1]", "5.0", "e.g. --complexity 0.5"],
        ),
        (
            ["envs", "eval", "RandomMap-v0", "--dynamics", "gazebo"],
            ["--dynamics", "'gazebo'", "use 'reduced'"],
        ),
        (
            ["envs", "eval", "RandomMap-v0", "--episodes", "0"],
            ["--episodes", "0", "e.g. --episodes 10"],
        ),
        (["envs", "eval", "CrowdNav-v0", "--preset", "TRAIN"], ["--preset", "RandomMap-v0"]),
        (["envs", "eval", "RandomMap-v0", "--scenario", "static"], ["--scenario", "CrowdNav"]),
    ],
)
def test_bad_envs_eval_exits_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], words: list[str]
) -> None:
    extra = ["--json", tmp_path / "e.json"] if "--episodes" in argv else ["--episodes", 1]
    run = cli(capsys, *argv, *extra)
    assert_bad_input(run, *words)
    assert run.out == ""  # not even the empty line of a progress bar
    assert list(tmp_path.iterdir()) == []


def test_envs_list_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    run = cli(capsys, "envs", "list")
    assert run.code == 0
    assert "sim2real/RandomMap-v0" in run.out and "TEST4" in run.out


def test_an_absurd_demo_ensemble_exits_2_before_anything(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "demo"
    run = cli(capsys, "demo", "--out", out, "--engine", "reduced", "--ensemble", 20000)
    assert_bad_input(run, "--ensemble", "from 2 to 10000", "20000")
    assert not out.exists()


@pytest.mark.parametrize("case", ["no data folder", "out is a file", "out under a file"])
def test_bad_demo_paths_exit_2_and_create_nothing(
    files: Files, tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str
) -> None:
    data, out = tmp_path / "data", tmp_path / "out"
    data.mkdir()
    for name in ("demo_train.mcap", "demo_calibrate.mcap", "demo_validate.mcap"):
        shutil.copy(files.good, data / name)
    words: list[object]
    if case == "no data folder":
        data, words = tmp_path / "nodata", [tmp_path / "nodata", "--data"]
    elif case == "out is a file":
        out = data / "demo_train.mcap"
        words = [out, "is not a folder"]
    else:
        out = data / "demo_train.mcap" / "sub" / "deeper"
        parent = data / "demo_train.mcap"
        words = ["--out", out, f"parent '{parent}' is a file", "e.g. --out sim2real-demo"]
    before = sorted(p.name for p in tmp_path.rglob("*"))
    argv = ["demo", "--data", data, "--engine", "reduced", "--ensemble", 0, "--out", out]
    run = cli(capsys, *argv)
    assert_bad_input(run, *words)
    assert run.out == ""  # refused up front, before the fit starts
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


# ----------------------------------------------------------------------------- help

COMMANDS = [
    [],
    ["logs"],
    ["logs", "info"],
    ["robots"],
    ["robots", "list"],
    ["robots", "show"],
    ["robots", "new"],
    ["robots", "check"],
    ["robots", "export"],
    ["sysid"],
    ["sysid", "fit"],
    ["sysid", "show"],
    ["sysid", "plan"],
    ["sysid", "sensors"],
    ["sysid", "calibrate"],
    ["agree"],
    ["envs"],
    ["envs", "list"],
    ["envs", "eval"],
    ["envs", "robustness"],
    ["train"],
    ["demo"],
]


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: " ".join(c) or "sim2real")
def test_every_help_exits_0_with_examples(
    capsys: pytest.CaptureFixture[str], command: list[str]
) -> None:
    with pytest.raises(SystemExit) as exc:
        main([*command, "--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0
    assert "examples:" in out
    examples = out.split("examples:", 1)[1]
    assert "sim2real " + " ".join(command) in examples  # the examples show this very command
    # a continued example line keeps its backslash (a lone "\\" in the source string joined
    # the two lines into one with a run of spaces, which cannot be pasted as shown)
    joined = [ln for ln in out.splitlines() if re.search(r"\S {4,}--", ln)]
    assert not joined, joined


def test_help_covers_every_registered_subcommand() -> None:
    """COMMANDS above lists every (sub)command the parser knows: none escapes the audit."""
    from sim2real.cli import build_parser

    def walk(parser: object, prefix: list[str]) -> list[list[str]]:
        found = [prefix]
        for action in getattr(parser, "_actions", []):
            choices = getattr(action, "choices", None)
            if isinstance(choices, dict):
                for name, sub in choices.items():
                    found += walk(sub, [*prefix, name])
        return found

    assert sorted(walk(build_parser(), [])) == sorted(COMMANDS)


@pytest.mark.parametrize(
    "argv", [["logs", "info", "data/demo_train.mcap"], ["robots", "show", "turtlebot2"]]
)
def test_closed_stdout_stops_quietly(argv: list[str]) -> None:
    """`sim2real logs info run.bag | head -1`: a closed pipe is no traceback (exit 141)."""
    import os
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader has gone before the command writes
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "sim2real", *argv],
            stdout=write_end,
            stderr=subprocess.PIPE,
            text=True,
            cwd=root,
            check=False,
        )
    finally:
        os.close(write_end)
    assert proc.returncode == 141 and proc.stderr == "", proc.stderr[-500:]


def test_a_broken_pipe_that_is_not_stdout_is_not_hidden(
    monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str]
) -> None:
    """A BrokenPipeError from another pipe (a training env's worker process that died) is
    raised, not turned into the quiet exit 141 of a closed stdout (stdout here is open)."""
    import sim2real.cli._robots as robots_cli

    def broken(args: object) -> int:
        raise BrokenPipeError(32, "Broken pipe")  # as Connection.send to a dead worker

    monkeypatch.setattr(robots_cli, "handle_list", broken)
    with pytest.raises(BrokenPipeError):
        main(["robots", "list"])
