"""OdometryDelay and ActionDelay: exact delays in steps and seconds, fill modes, ranges."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from randomizers_testenv import NavDouble

from randomizers import ActionDelay, OdometryDelay, steps_from_seconds


def _actions(n: int) -> list[np.ndarray]:
    return [np.array([0.1 * (i + 1), -0.05 * (i + 1)], np.float32) for i in range(n)]


def _velocities(env: gym.Env, actions: list[np.ndarray], seed: int = 0) -> list[np.ndarray]:
    obs, _ = env.reset(seed=seed)
    seen = [obs["velocity"].copy()]
    for a in actions:
        seen.append(env.step(a)[0]["velocity"].copy())
    return seen


@pytest.mark.parametrize("k", [0, 1, 3, 7])
def test_odometry_delay_in_steps_is_exact(k: int) -> None:
    acts = _actions(12)
    clean = _velocities(NavDouble(), acts)
    delayed = _velocities(OdometryDelay(NavDouble(), delay_steps=k, key="velocity"), acts)
    for t in range(len(clean)):
        np.testing.assert_array_equal(delayed[t], clean[max(t - k, 0)])


@pytest.mark.parametrize(("delay_s", "k"), [(0.3, 3), (0.25, 3), (0.24, 2), (0.049, 0), (0.05, 1)])
def test_odometry_delay_in_seconds_rounds_to_nearest_step(delay_s: float, k: int) -> None:
    env = OdometryDelay(NavDouble(), delay_s=delay_s, key="velocity")  # control_dt = 0.1 s
    _, info = env.reset(seed=0)
    record = info["randomization"]["OdometryDelay[velocity]"]
    assert record["delay_steps"] == k
    assert record["delay_s"] == pytest.approx(0.1 * k)
    acts = _actions(6)
    clean = _velocities(NavDouble(), acts)
    delayed = _velocities(env, acts)
    for t in range(len(clean)):
        np.testing.assert_array_equal(delayed[t], clean[max(t - k, 0)])


def test_steps_from_seconds_table() -> None:
    assert [steps_from_seconds(s, 0.1) for s in (0.0, 0.04, 0.05, 0.15, 0.3, 1.0)] == [
        0,
        0,
        1,
        2,
        3,
        10,
    ]
    assert steps_from_seconds(0.06, 0.02) == 3  # 2.9999999999999996 steps in floats


def test_odometry_delay_fill_zeros_and_first() -> None:
    acts = _actions(4)
    env = OdometryDelay(NavDouble(), delay_steps=2, key="velocity", fill="zeros")
    env.unwrapped.velocity = np.array([9.0, 9.0], np.float32)  # overwritten by reset
    seen = _velocities(env, acts)
    np.testing.assert_array_equal(seen[0], [0, 0])
    np.testing.assert_array_equal(seen[1], [0, 0])
    np.testing.assert_array_equal(seen[3], acts[0])


def test_odometry_delay_holds_first_value_not_zeros() -> None:
    class Moving(NavDouble):
        def reset(self, *, seed=None, options=None):  # type: ignore[no-untyped-def]
            _obs, info = super().reset(seed=seed, options=options)
            self.velocity = np.array([0.7, -0.2], np.float32)
            return self._obs(), info

    seen = _velocities(OdometryDelay(Moving(), delay_steps=3, key="velocity"), _actions(4))
    for t in range(4):
        np.testing.assert_array_equal(seen[t], np.array([0.7, -0.2], np.float32))


def test_odometry_delay_only_delays_the_selected_entry() -> None:
    env = OdometryDelay(NavDouble(), delay_steps=2, key="velocity")
    env.reset(seed=0)
    obs = env.step(np.array([1.0, 0.0], np.float32))[0]
    np.testing.assert_array_equal(obs["goal"], env.unwrapped._obs()["goal"])


def test_odometry_delay_by_index_on_cartpole() -> None:
    env = OdometryDelay(gym.make("CartPole-v1"), delay_steps=2, index=[1, 2])
    bare = gym.make("CartPole-v1")
    obs, _ = env.reset(seed=1)
    ref = [bare.reset(seed=1)[0]]
    got = [obs]
    for a in [0, 1, 1, 0, 1]:
        got.append(env.step(a)[0])
        ref.append(bare.step(a)[0])
    for t in range(len(got)):
        assert got[t][1] == ref[max(t - 2, 0)][1]
        np.testing.assert_array_equal(got[t][[0, 2, 3]], ref[t][[0, 2, 3]])


def test_random_delay_range_covers_all_steps_uniformly() -> None:
    env = OdometryDelay(NavDouble(), delay_steps=[1, 4], key="velocity")
    counts = np.zeros(6, int)
    for seed in range(800):
        _, info = env.reset(seed=seed)
        counts[info["randomization"]["OdometryDelay[velocity]"]["delay_steps"]] += 1
    assert counts[0] == 0 and counts[5] == 0
    assert np.all(np.abs(counts[1:5] - 200) < 4 * np.sqrt(800 * 0.25 * 0.75))


def test_random_delay_in_seconds_and_scale() -> None:
    env = OdometryDelay(NavDouble(), delay_s=[0.0, 0.4], key="velocity", scale=0.5)
    delays = {
        env.reset(seed=s)[1]["randomization"]["OdometryDelay[velocity]"]["delay_steps"]
        for s in range(200)
    }
    assert delays == {0, 1, 2}  # 0.5 * U(0, 0.4) s = U(0, 0.2) s -> 0, 1 or 2 steps of 0.1 s


def test_delay_s_needs_control_dt_or_dt_s() -> None:
    env = OdometryDelay(gym.make("CartPole-v1"), delay_s=0.04, dt_s=0.02, index=1)
    _, info = env.reset(seed=0)
    assert info["randomization"]["OdometryDelay[1:2]"]["delay_steps"] == 2


@pytest.mark.parametrize("k", [1, 2, 5])
def test_action_delay_applies_actions_k_steps_late(k: int) -> None:
    acts = _actions(10)
    env = ActionDelay(NavDouble(), delay_steps=k)
    seen = _velocities(env, acts)[1:]  # velocity echoes the applied action
    for t, v in enumerate(seen):
        np.testing.assert_array_equal(v, acts[max(t - k, 0)])


def test_action_delay_fill_zeros_on_pendulum() -> None:
    env = ActionDelay(gym.make("Pendulum-v1"), delay_steps=2, fill="zeros")
    bare = gym.make("Pendulum-v1")
    env.reset(seed=0)
    bare.reset(seed=0)
    acts = [np.array([1.5], np.float32), np.array([-2.0], np.float32), np.array([0.5], np.float32)]
    applied = [np.zeros(1, np.float32), np.zeros(1, np.float32), acts[0]]
    for a, b in zip(acts, applied, strict=True):
        np.testing.assert_array_equal(env.step(a)[0], bare.step(b)[0])


def test_action_delay_in_seconds_and_discrete_actions() -> None:
    env = ActionDelay(gym.make("CartPole-v1"), delay_s=0.04, dt_s=0.02, fill="zeros")
    _, info = env.reset(seed=0)
    assert info["randomization"]["ActionDelay"]["delay_steps"] == 2
    assert [env.action(a) for a in (1, 1, 0)] == [0, 0, 1]


def test_action_delay_copies_the_agents_array() -> None:
    env = ActionDelay(NavDouble(), delay_steps=1)
    env.reset(seed=0)
    a = np.array([0.5, 0.5], np.float32)
    env.step(a)
    a[:] = -1.0  # the agent reuses its buffer
    v = env.step(np.zeros(2, np.float32))[0]["velocity"]
    np.testing.assert_array_equal(v, [0.5, 0.5])


def test_action_delay_resets_its_queue() -> None:
    env = ActionDelay(NavDouble(), delay_steps=2)
    env.reset(seed=0)
    env.step(np.array([1.0, 1.0], np.float32))
    env.reset(seed=0)
    first = np.array([0.2, 0.3], np.float32)
    np.testing.assert_array_equal(env.step(first)[0]["velocity"], first)
