"""`envs eval` / `envs robustness` against plant sessions, with 95 % intervals."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.cli import main
from sim2real.envs import EvalSummary
from sim2real.training.evaluation import outcome_intervals, wilson_interval


def _eval_json(tmp_path: Path, name: str, *extra: str) -> dict[str, object]:
    out = tmp_path / name
    argv = ["envs", "eval", "RandomMap-v0", "--preset", "TEST1", "--dynamics", "plant"]
    assert main([*argv, "--episodes", "4", "--seed", "7", *extra, "--json", str(out)]) == 0
    doc: dict[str, object] = json.loads(out.read_text())
    return doc


@pytest.fixture(scope="module")
def plant_eval(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """`envs eval` of the TEST1 preset on 4 plant sessions (seed 7), its JSON."""
    return _eval_json(tmp_path_factory.mktemp("plant_eval"), "a.json")


def test_eval_on_plant_sessions_prints_and_writes_the_intervals(
    plant_eval: dict[str, object], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = plant_eval
    episodes = doc["episodes"]
    assert isinstance(episodes, list) and len(episodes) == 4
    wins = sum(e["outcome"] == "success" for e in episodes)
    crashes = sum(e["outcome"] == "crash" for e in episodes)
    assert doc["dynamics"] == "plant"
    assert doc["success_ci95"] == pytest.approx(list(wilson_interval(wins, 4)))
    assert doc["collision_ci95"] == pytest.approx(list(wilson_interval(crashes, 4)))
    times = [e["time_to_goal_s"] for e in episodes if e["outcome"] == "success"]
    lo, hi = doc["time_to_goal_ci95"]  # type: ignore[misc]
    if len(times) > 1:
        assert lo <= sum(times) / len(times) <= hi
    # same seeds, same plant sessions, same numbers; and it says so on the terminal
    capsys.readouterr()
    assert _eval_json(tmp_path, "b.json") == {**doc, "episodes": doc["episodes"]}
    out = capsys.readouterr().out
    assert "dynamics plant" in out and "95 % CI" in out


def test_plant_sessions_differ_from_the_drive_model(
    plant_eval: dict[str, object], tmp_path: Path
) -> None:
    model = tmp_path / "m.json"
    argv = ["envs", "eval", "RandomMap-v0", "--preset", "TEST1", "--episodes", "4"]
    assert main([*argv, "--seed", "7", "--json", str(model)]) == 0
    reduced = json.loads(model.read_text())
    assert [e["path_length_m"] for e in plant_eval["episodes"]] != [  # type: ignore[union-attr]
        e["path_length_m"] for e in reduced["episodes"]
    ]


def test_robustness_on_the_plant_with_an_observation_randomizer(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = tmp_path / "dr.yaml"
    cfg.write_text(
        "format: sim2real.randomizers/1\nrandomizers:\n  - type: ActionDelay\n    delay_steps: 2\n"
    )
    out = tmp_path / "r.json"
    argv = ["envs", "robustness", "RandomMap-v0", "--preset", "TEST1", "--dynamics", "plant"]
    assert main([*argv, "--episodes", "2", "--randomize", str(cfg), "--json", str(out)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert [r["condition"] for r in rows] == ["none", "ActionDelay", "all"]
    for r in rows:
        assert r["collision_ci95"] == pytest.approx(
            list(wilson_interval(round(r["collision_rate"] * 2), 2))
        )
    assert "time to goal s" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["envs", "eval", "RandomMap-v0", "--dynamics", "plant", "--params", "p.yaml"],
            "--params sets the drive model's parameters, which --dynamics plant does not use",
        ),
        (
            ["envs", "eval", "CarCrossing-v0", "--dynamics", "plant"],
            "must be one of reduced, pybullet, got 'plant'",
        ),
        (["envs", "eval", "RandomMap-v0", "--dynamics", "plants"], "or 'plant' (a foreign base"),
    ],
)
def test_bad_plant_input_exits_2(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([*argv, "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sim2real: error: ") and message in err and "Traceback" not in err


@settings(max_examples=40, deadline=None)
@given(
    outcomes=st.lists(
        st.sampled_from(["success", "collision", "timeout"]), min_size=1, max_size=60
    ),
    times=st.lists(st.floats(1.0, 100.0), min_size=60, max_size=60),
)
def test_outcome_intervals_contain_their_figures(outcomes: list[str], times: list[float]) -> None:
    rows = tuple(
        {"outcome": o, "time_to_goal_s": t if o == "success" else math.nan}
        for o, t in zip(outcomes, times, strict=False)
    )
    n = len(rows)
    wins, crashes = outcomes.count("success"), outcomes.count("collision")
    s = EvalSummary(
        episodes=n,
        success_rate=wins / n,
        collision_rate=crashes / n,
        timeout_rate=outcomes.count("timeout") / n,
        means={},
        per_episode=rows,
    )
    ci = outcome_intervals(s)
    assert ci.success_ci95 == wilson_interval(wins, n)
    assert ci.collision_ci95[0] <= ci.collision_rate <= ci.collision_ci95[1]
    if wins >= 2:
        assert ci.time_to_goal_ci95[0] <= ci.time_to_goal_s <= ci.time_to_goal_ci95[1]
    else:
        assert math.isnan(ci.time_to_goal_ci95[0])
