"""`sim2real envs list` and `sim2real envs eval`, including bad input (exit 2)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sim2real.cli import main


def test_list_prints_ids_and_presets(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["envs", "list"]) == 0
    out = capsys.readouterr().out
    for word in (
        "CrowdNav",
        "RandomMap",
        "TRAIN",
        "TEST4",
        "occluded",
        "6-10 %",
        "Race-v0",
        "CarCrossing-v0",
        "circuit",
    ):
        assert word in out


@pytest.mark.slow
def test_eval_prints_rates_and_writes_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out_file = tmp_path / "eval.json"
    rc = main(
        [
            "envs",
            "eval",
            "RandomMap-v0",
            "--episodes",
            "1",
            "--preset",
            "test1",
            "--seed",
            "1",
            "--json",
            str(out_file),
        ]
    )
    assert rc == 0
    out = capsys.readouterr().out
    for word in ("success rate", "collision rate", "timeout rate", "path length", "jerk"):
        assert word in out
    doc = json.loads(out_file.read_text())
    assert doc["env"] == "sim2real/RandomMap-v0" and doc["seed"] == 1
    assert doc["success_rate"] + doc["collision_rate"] + doc["timeout_rate"] == pytest.approx(1)
    assert len(doc["episodes"]) == 1


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["envs", "eval", "Nope-v0"], "known envs are sim2real/CrowdNav-v0"),
        (["envs", "eval", "RandomMap-v0", "--preset", "TEST9"], "known presets are TRAIN"),
        (["envs", "eval", "CrowdNav-v0", "--preset", "TRAIN"], "RandomMap-v0 only"),
        (["envs", "eval", "RandomMap-v0", "--scenario", "static"], "CrowdNav-v0 only"),
        (["envs", "eval", "RandomMap-v0", "--episodes", "0"], "--episodes"),
        (["envs", "eval", "RandomMap-v0", "--dynamics", "ode"], "(--dynamics) must be one of"),
        (["envs", "eval", "CarCrossing-v0", "--complexity", "0.5"], "do not apply to CarCrossing"),
        (["envs", "eval", "Race-v0", "--track", "oval"], "track (--track) must be one of open"),
        (["envs", "eval", "Race-v0", "--opponents", "-1"], "must be an integer in [0, 5]"),
        (["envs", "eval", "Race-v0", "--planner", "rrt"], "--planner must be one of astar"),
        (["envs", "eval", "CrowdNav-v0", "--complexity", "1.5"], "must be a number in [0, 1]"),
        (["envs", "eval", "RandomMap-v0", "--track", "open"], "--track applies to Race-v0 only"),
        (
            ["envs", "eval", "RandomMap-v0", "--track", "open", "--opponents", "2"],
            "--track, --opponents apply to Race-v0 only, not RandomMap-v0; drop them",
        ),
    ],
)
def test_bad_input_exits_2(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("sim2real: error: ") and message in err
    assert "Traceback" not in err


def test_help_ends_with_examples(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["envs", "eval", "--help"])
    out = capsys.readouterr().out
    assert "examples:" in out and "sim2real envs eval RandomMap-v0" in out


def test_eval_car_crossing_baseline(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["envs", "eval", "sim2real/CarCrossing-v0", "--episodes", "10"]) == 0
    out = capsys.readouterr().out
    assert "Rule-based baseline" in out and "off-road rate" in out
    rate = float(out.split("success rate")[1].split()[1])
    assert rate >= 0.9


def test_eval_race_baseline(capsys: pytest.CaptureFixture[str]) -> None:
    # one race: the baseline's finishing rate is test_envs_race's (10 races a track); this is
    # the command's table and its rate
    argv = ["envs", "eval", "Race-v0", "--track", "open", "--opponents", "3", "--episodes", "1"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "astar + DWA baseline" in out and "wall collision rate" in out
    assert float(out.split("success rate")[1].split()[1]) == 1.0
