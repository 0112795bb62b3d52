"""RandomMap-v0: gymnasium contract, observation, outcomes, reward terms, protocols, vector envs."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from hypothesis import given, settings
from hypothesis import strategies as st

import sim2real.envs  # noqa: F401  (registers the ids)
from robots.spec import load_spec
from sim2real.envs import RandomMapEnv, RandomMapReward
from sim2real.envs.maps import MapConfig
from sim2real.errors import Sim2RealValueError

EMPTY = MapConfig(n_min=0, n_max=0, r_wall=0.0)
EMPTY_1M = MapConfig(n_min=0, n_max=0, r_wall=0.0, d_target_m=1.0)


def test_check_env_passes_and_spaces_match_the_paper() -> None:
    env = gym.make("sim2real/RandomMap-v0")
    check_env(env.unwrapped, skip_render_check=True)
    assert env.observation_space.shape == (40,)
    np.testing.assert_allclose(env.action_space.low, [0.0, -1.0])
    np.testing.assert_allclose(env.action_space.high, [0.21, 1.0])
    assert env.unwrapped.control_dt == 0.1
    env.close()


def test_robot_action_limits_follow_the_spec_and_reach_its_top_speed() -> None:
    env = RandomMapEnv(
        map_config=MapConfig(n_min=0, n_max=0, r_wall=0.0, d_target_m=6.0),
        robot="turtlebot2",
        action_limits="robot",
    )
    check_env(env, skip_render_check=True)
    np.testing.assert_allclose(env.action_space.low, [0.0, -3.14], rtol=1e-6)
    np.testing.assert_allclose(env.action_space.high, [0.7, 3.14], rtol=1e-6)
    env.reset(seed=0)
    for _ in range(20):
        env.step(np.array([0.7, 0.0]))
    v, _ = env._backend.velocity
    assert v > 0.6  # the paper's limits would hold the TurtleBot 2 at 0.21 m/s
    with pytest.raises(Sim2RealValueError, match="action_limits must be one of paper, robot"):
        RandomMapEnv(action_limits="fast")


def test_a_goal_speed_makes_success_a_stop_inside_the_tolerance() -> None:
    def drive(goal_speed_mps: float) -> tuple[str, int]:
        env = RandomMapEnv(
            map_config=MapConfig(n_min=0, n_max=0, r_wall=0.0, d_target_m=1.0),
            goal_speed_mps=goal_speed_mps,
            max_episode_steps=200,
        )
        obs, _ = env.reset(seed=0)
        for step in range(200):
            d, bearing = float(obs[36]), float(obs[37])
            v = 0.21 if abs(bearing) < 0.3 and d > 0.1 else 0.0
            obs, _, term, trunc, info = env.step(np.array([v, np.clip(2 * bearing, -1, 1)]))
            if term or trunc:
                return info["outcome"], step
        raise AssertionError("the episode did not end")

    (passing, n_pass), (stopping, n_stop) = drive(math.inf), drive(0.02)
    assert passing == stopping == "success"
    assert n_stop > n_pass  # inside the 0.3 m tolerance at speed is not yet a stop


def test_leaving_the_tolerance_without_a_stop_ends_the_episode_as_an_overshoot() -> None:
    def through(goal_speed_mps: float) -> tuple[str, bool, dict, list[float]]:
        env = RandomMapEnv(map_config=EMPTY_1M, goal_speed_mps=goal_speed_mps)
        obs, _ = env.reset(seed=0)
        dists, facing = [], False
        for _ in range(200):  # face the goal, then top speed straight on, never braking
            bearing = float(obs[37])
            facing = facing or abs(bearing) < 0.3
            w = 0.0 if facing else np.clip(2 * bearing, -1, 1)
            obs, _, term, trunc, info = env.step(np.array([0.21 if facing else 0.0, w]))
            dists.append(env._goal_polar()[0])
            if term or trunc:
                return info["outcome"], term, info["metrics"], dists
        raise AssertionError("the episode did not end")

    outcome, terminated, metrics, dists = through(0.02)
    assert outcome == "overshoot" and terminated
    assert metrics["overshoot"] and not (metrics["success"] or metrics["timeout"])
    assert math.isnan(metrics["time_to_goal_s"])
    # it ends on the first step outside the 0.3 m disc after steps inside it
    assert dists[-1] >= 0.3 and min(dists) < 0.3 and all(d < 0.3 for d in dists[-3:-1])
    assert through(math.inf)[0] == "success"  # without a goal speed, passing through counts


def test_the_goal_speed_term_charges_speed_near_the_goal_more_the_closer() -> None:
    radius_m, k = 0.8, 5.0

    def rewards(reward: object) -> list[tuple[float, float, float]]:
        env = RandomMapEnv(
            map_config=MapConfig(n_min=0, n_max=0, r_wall=0.0, d_target_m=1.5),
            goal_speed_mps=0.01,
            reward=reward,  # type: ignore[arg-type]
        )
        obs, _ = env.reset(seed=0)
        out = []
        for _ in range(100):  # at 0.21 m/s towards the goal and through it
            bearing = float(obs[37])
            obs, r, term, trunc, info = env.step(np.array([0.21, np.clip(2 * bearing, -1, 1)]))
            d, _ = env._goal_polar()
            out.append((d, float(obs[38]), r))
            if term or trunc:  # never slow enough to count as a stop
                assert info["outcome"] == "overshoot"
                return out
        raise AssertionError("the episode did not end")

    base = rewards(None)
    shaped = rewards({"goal_speed_per_mps": k, "goal_speed_radius_m": radius_m})
    far = [(b[2], s[2]) for b, s in zip(base, shaped, strict=True) if b[0] >= radius_m]
    near = [(b, s) for b, s in zip(base, shaped, strict=True) if b[0] < radius_m / 2]
    assert far and near
    np.testing.assert_allclose(*zip(*far, strict=True), atol=1e-12)
    for b, s in near:  # the measured speed in the observation is the one charged
        assert b[2] - s[2] == pytest.approx(k * abs(b[1]) * (1 - b[0] / radius_m), rel=1e-5)
        assert b[2] - s[2] > k * 0.1 * 0.5
    with pytest.raises(Sim2RealValueError, match="RandomMapReward or a mapping of its fields"):
        RandomMapEnv(reward={"goal_speed": 1.0})  # type: ignore[arg-type]


def test_observation_layout() -> None:
    env = RandomMapEnv(preset="TEST1")
    obs, info = env.reset(seed=4)
    assert obs.dtype == np.float32
    assert np.all((obs[:36] >= 0.12) & (obs[:36] <= 3.5))
    layout = env.layout
    assert layout is not None
    yaw = layout.start_yaw_rad
    assert obs[36] == pytest.approx(8.0)
    assert obs[37] == pytest.approx(math.atan2(math.sin(-yaw), math.cos(-yaw)), abs=1e-6)
    assert obs[38] == 0.0 and obs[39] == 0.0
    assert info["rho_obs"] == layout.rho_obs and info["preset"] == "TEST1"


def test_seeded_resets_reproduce_the_scene_and_the_rollout() -> None:
    a, b = RandomMapEnv(), RandomMapEnv()
    oa, _ = a.reset(seed=11)
    ob, _ = b.reset(seed=11)
    np.testing.assert_array_equal(oa, ob)
    assert a.layout is not None and b.layout is not None
    np.testing.assert_array_equal(a.layout.cylinders, b.layout.cylinders)
    for _ in range(20):
        sa = a.step(np.array([0.2, 0.3]))
        sb = b.step(np.array([0.2, 0.3]))
        np.testing.assert_array_equal(sa[0], sb[0])
        assert sa[1] == sb[1]
    oc, _ = a.reset(seed=12)
    assert not np.array_equal(oa, oc)


def test_straight_drive_on_an_empty_map_succeeds() -> None:
    env = RandomMapEnv(map_config=MapConfig(n_min=0, n_max=0, r_wall=0.0, d_target_m=1.0))
    obs, _ = env.reset(seed=0)
    total = 0.0
    for _ in range(400):
        bearing = float(obs[37])
        obs, r, term, trunc, info = env.step(
            np.array([0.21 if abs(bearing) < 0.3 else 0.0, np.clip(2 * bearing, -1, 1)])
        )
        total += r
        if term or trunc:
            break
    assert info["outcome"] == "success" and term and not trunc
    m = info["metrics"]
    assert m["success"] and not m["collision"]
    assert m["time_to_goal_s"] == pytest.approx(m["steps"] * 0.1)
    assert 0.7 - 1e-6 <= m["path_length_m"] < 1.3
    assert r > 90.0  # r_reach = 100 dominates the final step
    with pytest.raises(Sim2RealValueError, match="reset"):
        env.step(np.array([0.1, 0.0]))


def test_driving_into_a_cylinder_is_a_crash_with_the_band_penalty() -> None:
    cfg = MapConfig(n_min=0, n_max=0, r_wall=0.0)
    env = RandomMapEnv(map_config=cfg)
    env.reset(seed=0)
    # put one cylinder right ahead of the robot
    x, y, yaw = env._backend.pose
    from sim2real.envs.geometry import Scene2D

    env._scene = Scene2D.build(circles=[(x + 0.6 * math.cos(yaw), y + 0.6 * math.sin(yaw), 0.15)])
    rewards = []
    for _ in range(100):
        _, r, term, trunc, info = env.step(np.array([0.21, 0.0]))
        rewards.append(r)
        if term or trunc:
            break
    assert info["outcome"] == "crash" and term
    assert info["metrics"]["collision"]
    assert rewards[-1] < -99.0  # -r_crash,1


def test_trap_is_a_truncation_after_max_steps() -> None:
    env = RandomMapEnv(map_config=EMPTY, max_episode_steps=5)
    env.reset(seed=0)
    for _ in range(5):
        _, _, term, trunc, info = env.step(np.array([0.0, 0.0]))
    assert trunc and not term and info["outcome"] == "trap"
    assert info["metrics"]["timeout"] and math.isnan(info["metrics"]["time_to_goal_s"])


def test_reward_terms_match_the_paper_formulas() -> None:
    cfg = RandomMapReward(free_weight=1.0, step_penalty=0.05)
    env = RandomMapEnv(map_config=EMPTY, reward=cfg)
    obs, _ = env.reset(seed=0)
    obs, r, *_ = env.step(np.array([0.0, 0.0]))
    # at rest in free space: r_goal = 0, r_crash = 0, r_free = -sum(1 - 3.5/3.5)^4 = 0
    assert r == pytest.approx(-0.05)
    from sim2real.envs.geometry import Scene2D

    x, y, _ = env._backend.pose
    env._scene = Scene2D.build(circles=[(x + 0.5, y, 0.3)])  # clearance ~0.2 - r_robot
    obs, r, *_ = env.step(np.array([0.0, 0.0]))
    d = obs[:36].astype(float)
    r_free = -np.sum((1.0 - d / 3.5) ** 4)
    clearance = env._clearance()
    bands = cfg.crash_bands_m
    r_crash = next(
        (-p for e, p in zip(bands, cfg.crash_penalties, strict=True) if clearance <= e), 0.0
    )
    assert r == pytest.approx(r_free + r_crash - 0.05, abs=1e-5)


def test_drive_params_protocol_changes_the_motion() -> None:
    env = RandomMapEnv(map_config=EMPTY)
    spec_drive = load_spec("turtlebot3_burger").drive
    assert env.get_drive_params() == spec_drive
    env.reset(seed=0)
    for _ in range(10):
        v_default = env.step(np.array([0.2, 0.0]))[0][38]
    env.set_drive_params(spec_drive.replace(coulomb_v_fwd_n=1.0))
    env.reset(seed=0)
    for _ in range(10):
        v_friction = env.step(np.array([0.2, 0.0]))[0][38]
    assert env.get_drive_params().coulomb_v_fwd_n == 1.0
    assert v_friction < v_default - 0.01
    with pytest.raises(Sim2RealValueError, match="DriveParams"):
        env.set_drive_params({"delay_s": 0.1})  # type: ignore[arg-type]


def test_bad_arguments_are_refused() -> None:
    with pytest.raises(Sim2RealValueError, match="dynamics"):
        RandomMapEnv(dynamics="mujoco")
    with pytest.raises(Sim2RealValueError, match="control_dt"):
        RandomMapEnv(control_dt=0.0)
    with pytest.raises(Sim2RealValueError, match="preset"):
        RandomMapEnv(preset="HARD")
    env = RandomMapEnv()
    with pytest.raises(Sim2RealValueError, match="unknown reset option"):
        env.reset(options={"complexity": 1.0})
    env.reset(seed=0, options={"preset": "TEST4"})
    assert env.preset == "TEST4"
    with pytest.raises(Sim2RealValueError, match=r"^action must be 2 finite numbers \(v"):
        env.step(np.array([np.nan, 0.0]))


def test_async_vector_env_runs() -> None:
    envs = gym.make_vec(
        "sim2real/RandomMap-v0", num_envs=2, vectorization_mode="async", preset="TEST1"
    )
    try:
        obs, _ = envs.reset(seed=[0, 1])
        assert obs.shape == (2, 40)
        assert not np.array_equal(obs[0], obs[1])
        for _ in range(3):
            obs, r, _, _, _ = envs.step(np.tile([0.1, 0.0], (2, 1)).astype(np.float32))
        assert obs.shape == (2, 40) and r.shape == (2,)
    finally:
        envs.close()


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), preset=st.sampled_from(["TRAIN", "TEST1", "TEST4"]))
def test_any_seed_reproduces_its_scene(seed: int, preset: str) -> None:
    a, b = RandomMapEnv(preset=preset), RandomMapEnv(preset=preset)
    oa, ia = a.reset(seed=seed)
    ob, ib = b.reset(seed=seed)
    np.testing.assert_array_equal(oa, ob)
    assert ia["rho_obs"] == ib["rho_obs"]
    act = np.array([0.15, -0.4])
    np.testing.assert_array_equal(a.step(act)[0], b.step(act)[0])


def test_goal_criteria_can_change_between_steps() -> None:
    env = RandomMapEnv(map_config=EMPTY_1M, goal_speed_mps=0.05)
    env.set_goal_criteria(speed_mps=1.0, tolerance_m=0.5)
    assert (env.goal_speed_mps, env.goal_tolerance_m) == (1.0, 0.5)
    env.set_goal_criteria(tolerance_m=0.4)  # None keeps the speed
    assert (env.goal_speed_mps, env.goal_tolerance_m) == (1.0, 0.4)
    obs, _ = env.reset(seed=0)
    for _ in range(200):  # at the loose criteria driving through the goal is a success
        bearing = float(obs[37])
        v = 0.21 if abs(bearing) < 0.3 else 0.0
        obs, _, term, trunc, info = env.step(np.array([v, np.clip(2 * bearing, -1, 1)]))
        if term or trunc:
            break
    assert info["outcome"] == "success" and env._goal_polar()[0] < 0.4
    with pytest.raises(Sim2RealValueError, match="speed_mps must be a number > 0 or None"):
        env.set_goal_criteria(speed_mps=0.0)


def test_the_goal_range_clips_the_observed_distance_and_bounds_its_space() -> None:
    near, far = (RandomMapEnv(map_config=EMPTY, goal_range_m=r) for r in (2.0, 30.0))
    assert near.observation_space.high[36] == 2.0 and far.observation_space.high[36] == 30.0
    obs_near, obs_far = near.reset(seed=0)[0], far.reset(seed=0)[0]
    assert obs_far[36] > 2.0 and obs_near[36] == 2.0  # the same start, clipped
    np.testing.assert_array_equal(np.delete(obs_near, 36), np.delete(obs_far, 36))
    for bad in (0.0, math.inf, True):
        with pytest.raises(Sim2RealValueError, match="goal_range_m must be a finite number"):
            RandomMapEnv(goal_range_m=bad)  # type: ignore[arg-type]
