"""CarCrossing-v0 (Trararak et al.): spaces, scenario, rewards, hazards, baseline, randomizers."""

from __future__ import annotations

import math
from collections import Counter

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import randomizers as dr
import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs._car import CAR, DEFAULT_CAR_PARAMS, ReducedCar
from sim2real.envs.car_baseline import CarCrossingBaseline
from sim2real.envs.car_crossing import CarCrossingEnv
from sim2real.errors import Sim2RealValueError


def _run(env: gym.Env, policy, seed: int) -> tuple[dict, float, int]:  # type: ignore[no-untyped-def]
    obs, _ = env.reset(seed=seed)
    total, steps = 0.0, 0
    while True:
        obs, r, term, trunc, info = env.step(policy(obs))
        total += float(r)
        steps += 1
        if term or trunc:
            return info, total, steps


def test_check_env_and_spaces() -> None:
    env = CarCrossingEnv()
    check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=0)
    assert obs.shape == (14,) and env.action_space == gym.spaces.Discrete(4)
    assert info["is_success"] is False and info["collision"] is None
    # start: in its own lane, facing +x, obstacle seen, pedestrian hidden behind it
    assert obs[10] == 1.0 and obs[11] == 1.0 and obs[12] == 0.0 and obs[9] == 1.0
    assert obs[8] == pytest.approx(math.hypot(*env.obstacle_xy - [0.0, env.car.pose[1]]) / 3.0)


def test_same_seed_same_episode() -> None:
    env = gym.make("sim2real/CarCrossing-v0")
    rollouts = []
    for _ in range(2):
        obs, _ = env.reset(seed=7)
        seq = [obs]
        for a in [0, 2, 2, 3, 1, 0, 3, 3, 2, 1] * 3:
            obs, r, term, trunc, _ = env.step(a)
            seq.append(np.append(obs, r))
            if term or trunc:
                break
        rollouts.append(np.concatenate(seq))
    assert np.array_equal(rollouts[0], rollouts[1])
    env.reset(seed=8)
    assert not np.array_equal(env.unwrapped.obstacle_xy, [1.4, 0.3])


def test_full_throttle_without_steering_hits_the_obstacle() -> None:
    env = gym.make("sim2real/CarCrossing-v0")
    outcomes = Counter(_run(env, lambda o: 0, s)[0]["collision"] for s in range(20))
    assert outcomes["obstacle"] >= 16


def test_lane_change_without_waiting_hits_the_pedestrian() -> None:
    """Passing at 0.6 m/s in the adjacent lane meets the occluded pedestrian."""
    env = gym.make("sim2real/CarCrossing-v0")
    hits = 0
    for s in range(10):
        ctrl = CarCrossingBaseline(stop_x_m=10.0, cruise_mps=0.6)
        ctrl.go = True
        hits += _run(env, ctrl.act, s)[0]["collision"] == "pedestrian"
    assert hits >= 8


def test_baseline_succeeds_in_90_percent() -> None:
    env = gym.make("sim2real/CarCrossing-v0")
    n_ok = 0
    for s in range(30):
        ctrl = CarCrossingBaseline()
        info, ret, _ = _run(env, ctrl.act, s)
        n_ok += bool(info["is_success"])
        if info["is_success"]:
            assert ret > 15.0 and info["metrics"]["outcome"] == "success"  # +20 minus waiting
    assert n_ok >= 27


def test_rewards_follow_the_fixed_equations() -> None:
    env = CarCrossingEnv()
    env.reset(seed=0)
    d0 = env._goal_distance()
    _, r, *_ = env.step(1)  # slow down a little: still moving towards the goal
    assert r == pytest.approx(1.5 * (d0 - env._goal_distance()), rel=1e-9)
    # a car at rest with its speed command at 0 is immobile: -0.05
    env.reset(seed=0)
    for _ in range(12):
        env.step(1)
    _, r, *_ = env.step(1)
    assert r == pytest.approx(-0.05)
    # full throttle into the obstacle: the last reward holds -7 (plus a step of progress)
    env.reset(seed=0)
    term = False
    while not term:
        _, r, term, _, info = env.step(0)
    assert info["collision"] == "obstacle" and -7.0 < r < -6.8
    # off the road to the left: -min(|2.733 - 10 d|, 2) = -2 far from the goal
    env.reset(seed=0)
    for _ in range(40):
        _, r, term, _, info = env.step(2)
        if term:
            break
    assert info["outcome"] == "off_road" and info["collision"] is None
    assert r < -1.9


def test_bad_actions_and_options_raise() -> None:
    env = CarCrossingEnv()
    with pytest.raises(Sim2RealValueError, match="no reset options"):
        env.reset(seed=0, options={"complexity": 0.5})
    env.reset(seed=0)
    with pytest.raises(Sim2RealValueError, match="action must be 0"):
        env.step(4)
    with pytest.raises(Sim2RealValueError, match="dynamics"):
        CarCrossingEnv(dynamics="mujoco")


def test_drive_params_shape_the_car() -> None:
    """Delay and speed limit of the drive-parameter protocol act on the car."""
    fast = ReducedCar(CAR, DEFAULT_CAR_PARAMS)
    slow = ReducedCar(CAR, DEFAULT_CAR_PARAMS.replace(speed_lim_v_mps=0.3, delay_s=0.3))
    for car in (fast, slow):
        car.reset(0.0, 0.0, 0.0, 0.0)
        for _ in range(20):
            car.step(1.0, math.radians(10.0), 0.1)
    assert fast.speed_mps == pytest.approx(1.0, abs=0.02)
    assert slow.speed_mps == pytest.approx(0.3, abs=0.02)
    # kinematic bicycle: yaw rate v tan(delta) / L
    car = ReducedCar(CAR, DEFAULT_CAR_PARAMS.replace(delay_s=0.0, accel_lim_v_mps2=math.inf))
    car.reset(0.0, 0.0, 0.0, 0.5)
    car.step(0.5, math.radians(10.0), 0.5)  # steering reaches 10 deg in 0.06 s
    yaw0 = car.pose[2]
    car.step(0.5, math.radians(10.0), 0.5)
    rate = (car.pose[2] - yaw0) / 0.5
    assert rate == pytest.approx(
        car.speed_mps * math.tan(math.radians(10.0)) / CAR.wheelbase_m, rel=0.03
    )


def test_randomizer_stack_applies() -> None:
    cfg = {
        "format": "sim2real.randomizers/1",
        "randomizers": [
            {"type": "DynamicsRandomizer", "uniform": {"delay_s": [0.1, 0.2]}},
            {
                "type": "LidarNoise",
                "index": [2, 7],
                "std_m": 0.02,
                "range_min_m": 0.0,
                "range_max_m": 1.0,
            },
            {"type": "GoalNoise", "index": [0, 2], "std_m": 0.01},
            {"type": "OdometryDelay", "index": [7, 8], "delay_steps": 1},
            {"type": "ActionDelay", "delay_steps": [0, 2]},
        ],
    }
    env = dr.from_config(gym.make("sim2real/CarCrossing-v0"), cfg)
    obs, info = env.reset(seed=0)
    assert len(info["randomization"]) == 5
    assert 0.1 <= env.unwrapped.get_drive_params().delay_s <= 0.2
    for _ in range(5):
        obs, *_ = env.step(2)
    assert env.observation_space.contains(obs)
    env.close()


@pytest.mark.slow
def test_pybullet_car_runs_the_baseline() -> None:
    env = gym.make("sim2real/CarCrossing-v0", dynamics="pybullet")
    for s in range(2):
        ctrl = CarCrossingBaseline()
        info, _, _ = _run(env, ctrl.act, s)
        assert info["is_success"]
    env.close()


@pytest.mark.slow
def test_backends_agree_on_a_lane_change() -> None:
    poses = {}
    for dyn in ("reduced", "pybullet"):
        env = CarCrossingEnv(dynamics=dyn)
        env.reset(seed=0)
        for a in [3, 3, 3, 1, 1, 2, 2, 2, 2, 2, 2, 3, 3, 3, 1, 1]:
            env.step(a)
        poses[dyn] = np.array(env.car.pose)
        env.close()
    assert np.allclose(poses["reduced"][:2], poses["pybullet"][:2], atol=0.03)
    assert abs(poses["reduced"][2] - poses["pybullet"][2]) < 0.05
