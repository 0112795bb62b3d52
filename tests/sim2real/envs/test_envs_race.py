"""Race-v0 and the PettingZoo race (Pozo Ruiz 2024): tracks, ORCA opponents, outcomes, baseline."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs import RaceEnv, race_parallel_env
from sim2real.envs.geometry import disc_clearance
from sim2real.envs.race_baseline import RaceBaseline, plan_path
from sim2real.envs.tracks import TRACKS, get_track, occupancy_grid
from sim2real.errors import Sim2RealValueError


@pytest.mark.parametrize("track", TRACKS)
def test_check_env_and_track_geometry(track: str) -> None:
    env = RaceEnv(track=track, num_opponents=4)
    check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=1)
    assert obs.shape == (63,) and info["track"] == track
    t = env.track
    # the centre line stays clear of walls and islands, start and goal lines are 8+ m apart
    clear = min(disc_clearance(t.scene(), p, 0.0) for p in t.centreline)
    assert clear > 0.55  # (0.6 m to the wall closing the corridor beyond the goal)
    assert t.length_m >= 8.0 - 1e-9
    assert not t.crossed_goal(t.start_xy) and t.crossed_goal(t.goal_xy + 0.01 * t.goal_dir)
    env.close()


def test_circuit_has_sharp_turns_and_a_roundabout() -> None:
    t = get_track("circuit")
    assert t.islands.shape == (1, 3)  # the roundabout's island
    heading = np.unwrap(np.arctan2(*np.diff(t.centreline, axis=0).T[::-1]))
    assert heading.max() - heading.min() > math.radians(150)  # half-way round the island
    assert t.length_m > 15.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"track": "oval"}, "track (--track) must be one of open, curve, cross, circuit"),
        ({"num_opponents": -1}, "num_opponents (--opponents) must be an integer in [0, 5]"),
        ({"num_opponents": 6}, "in [0, 5], got 6"),
        ({"dynamics": "ode"}, "dynamics (--dynamics) must be one of"),
    ],
)
def test_bad_options_raise_one_clear_error(kwargs: dict, message: str) -> None:
    with pytest.raises(Sim2RealValueError) as err:
        RaceEnv(**kwargs)
    assert message in str(err.value)
    with pytest.raises(Sim2RealValueError, match="n_robots"):
        race_parallel_env(n_robots=0)


def test_same_seed_same_race() -> None:
    env = gym.make("sim2real/Race-v0", track="cross", num_opponents=4)
    runs = []
    for _ in range(2):
        obs, _ = env.reset(seed=3)
        seq = [obs]
        for k in range(40):
            obs, r, *_ = env.step(np.array([0.2, 0.3 * math.sin(0.2 * k)], np.float32))
            seq.append(np.append(obs, r))
        runs.append(np.concatenate(seq))
    assert np.array_equal(runs[0], runs[1])


def test_opponents_race_to_the_goal_without_touching() -> None:
    env = RaceEnv(track="curve", num_opponents=5)
    env.reset(seed=0)
    core = env.core
    worst = np.inf
    for _ in range(600):
        env.step(np.zeros(2, np.float32))
        live = ~core.opp_done
        xy, r = core.opp_xy[live], core.opp_r[live]
        if len(xy) > 1:
            d = np.linalg.norm(xy[:, None] - xy[None], axis=2) - (r[:, None] + r[None])
            np.fill_diagonal(d, np.inf)
            worst = min(worst, float(d.min()))
        for p in xy:  # and they stay off the walls
            assert disc_clearance(core.scene, p, core.radius_m) > -0.01
    assert worst > -0.01
    assert core.opp_done.sum() >= 4  # most finished the 9.4 m course in 60 s
    assert np.all(core.opp_vmax <= 0.22 + 1e-9) and np.all(core.opp_r == core.radius_m)


def test_driving_into_a_wall_is_a_wall_collision() -> None:
    env = RaceEnv(track="curve", num_opponents=0)
    env.reset(seed=0)
    for _ in range(400):
        _, r, term, trunc, info = env.step(np.array([0.22, 0.6], np.float32))
        if term or trunc:
            break
    assert info["outcome"] == "wall_collision" and r < -9.0
    m = info["metrics"]
    assert m["wall_collision"] and not m["collision"] and math.isnan(m["completion_time_s"])


def test_planner_paths_avoid_walls_and_astar_matches_dijkstra_length() -> None:
    t = get_track("circuit")
    grid = occupancy_grid("circuit")
    goal = t.goal_xy + 0.3 * t.goal_dir
    lengths = {}
    for method in ("astar", "dijkstra"):
        path = plan_path(t, t.start_xy, goal, robot_radius_m=0.1, method=method)
        assert min(disc_clearance(t.scene(), p, 0.1) for p in path) > 0.0
        lengths[method] = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    assert lengths["astar"] == pytest.approx(lengths["dijkstra"], rel=0.05)
    assert grid.clearance_m.shape[0] > 100


#: Races a track and how many the baseline must finish: 8 of 10 fails a racer that finishes half
#: its races with probability 1 - P(Bin(10, 0.5) >= 8) = 0.945 (0.83 at a rate of 0.6) and passes
#: one that finishes 95 % of them with probability 0.989 (seeds 0-9 finish 39 of the 40 races).
RACES, MUST_FINISH = 10, 8


@pytest.mark.slow
@pytest.mark.parametrize("track", TRACKS)
def test_baseline_finishes_80_percent(track: str) -> None:
    """Seeds 0-9 in order; the races stop as soon as the verdict on all ten is certain (8 won, or
    3 lost): the same verdict as racing all ten."""
    env = gym.make("sim2real/Race-v0", track=track, num_opponents=4)
    ctrl = RaceBaseline.for_env(env)
    wins = losses = 0
    for s in range(RACES):
        if wins >= MUST_FINISH or losses > RACES - MUST_FINISH:
            break
        obs, _ = env.reset(seed=s)
        ctrl.reset()
        while True:
            obs, _, term, trunc, info = env.step(ctrl.act(obs))
            if term or trunc:
                break
        if info["outcome"] == "success":
            wins += 1
            if track == "open":  # 8 m at <= 0.22 m/s, with room to accelerate and steer
                assert 36.0 < info["metrics"]["completion_time_s"] < 60.0
        else:
            losses += 1
    assert wins >= MUST_FINISH, f"{wins} of {wins + losses} races finished on {track}"


def test_pettingzoo_parallel_api() -> None:
    env = race_parallel_env(n_robots=3, track="curve", num_opponents=3)
    parallel_api_test(env, num_cycles=100)
    obs, _ = env.reset(seed=0)
    assert set(obs) == {"robot_0", "robot_1", "robot_2"}
    # other robots appear among each robot's neighbours
    assert np.count_nonzero(obs["robot_0"][43:63]) > 0
    env.close()


@pytest.mark.slow
def test_pybullet_race_runs() -> None:
    env = RaceEnv(track="curve", num_opponents=3, dynamics="pybullet")
    env.reset(seed=0)
    for _ in range(50):
        _, _, term, trunc, _ = env.step(np.array([0.2, 0.0], np.float32))
        if term or trunc:
            break
    assert env.core.backends[0].pose[0] > 0.5
    env.close()


def test_a_bad_action_is_one_sentence_and_a_large_one_is_clipped() -> None:
    env = RaceEnv(track="curve", num_opponents=0)
    env.reset(seed=0)
    for bad in ([np.nan, 0.0], [0.1, 0.0, 0.0]):
        with pytest.raises(Sim2RealValueError, match=r"^action must be 2 finite numbers \(v"):
            env.step(np.array(bad))
    env.step(np.array([100.0, -100.0]))  # beyond the limits: clipped, not refused
    env.close()
