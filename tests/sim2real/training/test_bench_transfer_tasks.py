"""benchmarks/bench_transfer.py --gap tasks: the stop-at-goal task is wired and feasible in time."""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from sim2real.plants.closed_loop import PlantSessions
from sim2real.training.environment import build_env

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench_transfer  # noqa: E402


def _brake_at(env: object, brake_m: float, seed: int, burger: bool = False) -> str:
    """Face the goal, drive at top speed, command a stop ``brake_m`` before it (TurtleBot 2's
    limits and gains, or the Burger's)."""
    v_max, gain, w_max, facing = (0.22, 3.0, 2.84, 0.3) if burger else (0.7, 1.5, 3.14, 0.5)
    obs, _ = env.reset(seed=seed)  # type: ignore[attr-defined]
    while True:
        d, bearing = float(obs[36]), float(obs[37])
        v = 0.0 if d < brake_m or abs(bearing) > facing else v_max
        action = np.array([v, np.clip(gain * bearing, -w_max, w_max)])
        obs, _, term, trunc, info = env.step(action)  # type: ignore[attr-defined]
        if term or trunc:
            return str(info["outcome"])


def test_kobuki_stop_needs_a_stop_and_a_braking_controller_makes_it_in_time() -> None:
    kwargs = bench_transfer.GAP_TASKS["kobuki_stop"]
    env = build_env(bench_transfer.ENV_ID, kwargs).unwrapped
    assert env.goal_speed_mps == 0.05 and env.goal_tolerance_m == 0.15
    assert env.reward_config.goal_speed_per_mps == 5.0
    assert env.max_episode_steps == 80 and float(env.action_space.high[0]) == pytest.approx(0.7)
    plant = build_env(bench_transfer.ENV_ID, {**kwargs, "dynamics": "plant"}).unwrapped
    sim_wins = sum(_brake_at(env, 0.4, s) == "success" for s in range(20))
    plant_wins = sum(_brake_at(plant, 0.4, s) == "success" for s in range(20))
    # the spec's model answers its yaw commands 0.2 s late: the starts facing away need most
    # of the 8 s to turn, so a few time out even with a braking rule that stops in the goal
    assert 12 <= sim_wins < 20 and plant_wins >= sim_wins
    assert _brake_at(env, 0.05, 0) == "overshoot"  # no brake: the goal is passed, not reached


def test_burger_stop_a_brake_the_spec_allows_overshoots_with_the_latency_of_real_bases() -> None:
    kwargs = bench_transfer.GAP_TASKS["burger_stop"]
    env = build_env(bench_transfer.ENV_ID, kwargs).unwrapped
    assert env.goal_tolerance_m == 0.05 and env.max_episode_steps == 105
    assert env.observation_space.high[36] == 2.5
    real = PlantSessions.of("turtlebot3_burger", variation=bench_transfer.REAL_LATENCY)
    worlds = {
        "sim": env,
        "plant": build_env(bench_transfer.ENV_ID, {**kwargs, "dynamics": "plant"}).unwrapped,
        "real": build_env(
            bench_transfer.ENV_ID, {**kwargs, "dynamics": "plant", "plant_sessions": real}
        ).unwrapped,
    }
    late = {
        w: Counter(_brake_at(e, 0.01, s, burger=True) for s in range(20)) for w, e in worlds.items()
    }
    # the spec's 0.05 s latency stops the Burger within 1 cm: a stop command 1 cm before the
    # goal is in time in its sim and on the default sessions (0.06-0.16 s), not at 0.10-0.23 s
    assert late["sim"]["success"] == 20 and late["plant"]["success"] >= 19
    assert late["real"]["success"] <= 15 and late["real"]["overshoot"] >= 4
    # braking 4 cm before the goal is in time on every world: the task stays feasible
    assert all(_brake_at(worlds["real"], 0.04, s, burger=True) == "success" for s in range(20))


def test_burger_stop_4cm_a_late_brake_overshoots_at_real_latency_an_early_one_does_not() -> None:
    kwargs = bench_transfer.GAP_TASKS["burger_stop_4cm"]
    env = build_env(bench_transfer.ENV_ID, kwargs).unwrapped
    assert env.goal_tolerance_m == 0.04 and env.max_episode_steps == 105
    assert bench_transfer.TASKS["burger_stop_4cm"][1] == bench_transfer.REAL_LATENCY
    real = PlantSessions.of("turtlebot3_burger", variation=bench_transfer.REAL_LATENCY)
    plant = build_env(
        bench_transfer.ENV_ID, {**kwargs, "dynamics": "plant", "plant_sessions": real}
    ).unwrapped
    outcomes = {
        brake_m: (
            Counter(_brake_at(env, brake_m, s, burger=True) for s in range(20)),
            Counter(_brake_at(plant, brake_m, s, burger=True) for s in range(20)),
        )
        for brake_m in (0.01, 0.04)
    }
    # a stop commanded 1 cm before the goal is in time with the spec's 0.05 s latency, and
    # overshoots the 4 cm disc on most sessions at 0.10-0.23 s
    sim, real_latency = outcomes[0.01]
    assert sim["success"] == 20 and real_latency["overshoot"] >= 12
    # commanded 4 cm before, it stops inside on every world: the task stays feasible
    assert outcomes[0.04][0]["success"] == 20 and outcomes[0.04][1]["success"] == 20
