"""Reproducibility and independence of the randomizers' random streams; info records; names."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from randomizers_testenv import DEPTH_FAR_M, DEPTH_NEAR_M, FULL_STACK, NavDouble

import randomizers
from randomizers import DepthNoise, GoalNoise, LidarNoise, ObservationNoise, OdometryDelay
from randomizers.errors import RandomizerValueError


def _rollout(env: Any, seed: int, steps: int = 6) -> list[Any]:
    obs, info = env.reset(seed=seed)
    out = [(obs, info)]
    for i in range(steps):
        a = np.array([0.3 + 0.05 * i, 0.1], np.float32)
        out.append(env.step(a))
    return out


def _flatten(rollout: list[Any]) -> list[np.ndarray]:
    arrays = []
    for item in rollout:
        obs = item[0]
        arrays.extend(np.asarray(obs[k]) for k in sorted(obs))
    return arrays


def _assert_same(a: list[np.ndarray], b: list[np.ndarray]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def test_reset_with_seed_repeats_the_episode_exactly() -> None:
    env = randomizers.from_config(NavDouble(), FULL_STACK)
    first = _rollout(env, seed=42)
    _rollout(env, seed=7)
    again = _rollout(env, seed=42)
    _assert_same(_flatten(first), _flatten(again))
    assert first[0][1]["randomization"] == again[0][1]["randomization"]


def test_two_envs_same_seed_same_numbers_and_other_seed_differs() -> None:
    a = _rollout(randomizers.from_config(NavDouble(), FULL_STACK), seed=3)
    b = _rollout(randomizers.from_config(NavDouble(), FULL_STACK), seed=3)
    c = _rollout(randomizers.from_config(NavDouble(), FULL_STACK), seed=4)
    _assert_same(_flatten(a), _flatten(b))
    assert not np.array_equal(a[0][0]["depth"], c[0][0]["depth"], equal_nan=True)


def test_reset_without_seed_continues_the_stream() -> None:
    env = DepthNoise(NavDouble(), near_m=DEPTH_NEAR_M, far_m=DEPTH_FAR_M, key="depth")
    a = env.reset(seed=1)[0]["depth"]
    b = env.reset()[0]["depth"]
    assert not np.array_equal(a, b, equal_nan=True)
    c = env.reset(seed=1)[0]["depth"]
    np.testing.assert_array_equal(a, c)


def _depth(env: Any) -> DepthNoise:
    return DepthNoise(env, near_m=DEPTH_NEAR_M, far_m=DEPTH_FAR_M, key="depth")


def test_adding_or_removing_other_wrappers_never_changes_a_wrappers_draws() -> None:
    alone = _depth(NavDouble())
    below = _depth(LidarNoise(GoalNoise(NavDouble(), key="goal"), key="lidar", dropout=0.1))
    above = ObservationNoise(
        OdometryDelay(_depth(NavDouble()), key="velocity", delay_steps=2), key="lidar", std=0.1
    )
    runs = [_rollout(e, seed=5) for e in (alone, below, above)]
    depth = [[item[0]["depth"] for item in run] for run in runs]
    _assert_same(depth[0], depth[1])
    _assert_same(depth[0], depth[2])


def test_streams_of_different_wrappers_are_independent() -> None:
    """Same class on two keys and the env itself, one seed: uncorrelated streams."""
    inner = ObservationNoise(NavDouble(), key="depth", std=1.0)
    outer = ObservationNoise(inner, key="lidar", std=1.0)
    outer.reset(seed=0)
    n = 100_000
    streams = [
        inner.rng.standard_normal(n),
        outer.rng.standard_normal(n),
        outer.unwrapped.np_random.standard_normal(n),
        np.random.default_rng(0).standard_normal(n),
    ]
    corr = np.corrcoef(streams)
    off_diagonal = corr[~np.eye(4, dtype=bool)]
    assert np.all(np.abs(off_diagonal) < 4 / np.sqrt(n))


def test_info_records_every_randomizer_at_reset() -> None:
    env = randomizers.from_config(NavDouble(), FULL_STACK)
    _, info = env.reset(seed=0)
    assert set(info["randomization"]) == {
        "DynamicsRandomizer",
        "CameraPoseJitter",
        "ActionDelay",
        "OdometryDelay[velocity]",
        "DepthNoise[depth]",
        "LidarNoise[lidar]",
        "GoalNoise[goal]",
        "ObservationNoise[velocity]",
    }
    for record in info["randomization"].values():
        assert record["scale"] == 1.0


def test_duplicate_names_are_refused_and_custom_names_allowed() -> None:
    env = ObservationNoise(NavDouble(), key="lidar", std=0.1)
    with pytest.raises(RandomizerValueError, match="already in this stack"):
        ObservationNoise(env, key="lidar", std=0.2)
    twice = ObservationNoise(env, key="lidar", std=0.2, name="lidar-bias")
    _, info = twice.reset(seed=0)
    assert set(info["randomization"]) == {"ObservationNoise[lidar]", "lidar-bias"}


def test_set_scale_takes_effect_at_next_reset() -> None:
    env = GoalNoise(NavDouble(), key="goal", std_m=0.2, resample="step")
    env.reset(seed=0)
    env.set_scale(0.0)
    assert env.scale == 1.0  # still this episode's scale
    info = env.step(np.zeros(2, np.float32))[4]
    assert info["randomization"]["GoalNoise[goal]"]["std_m"] == 0.2
    _, info = env.reset()
    assert env.scale == 0.0 and info["randomization"]["GoalNoise[goal]"]["offset_m"] == [0.0, 0.0]


def _entry_name(env: Any) -> str:
    return next(iter(randomizers.iter_randomizers(env))).name


@pytest.mark.parametrize("position", range(len(FULL_STACK["randomizers"])))
def test_each_wrapper_draws_the_same_alone_and_in_the_full_stack(position: int) -> None:
    entry = FULL_STACK["randomizers"][position]
    alone = randomizers.from_config(NavDouble(), {"randomizers": [entry]})
    name = _entry_name(alone)
    full = randomizers.from_config(NavDouble(), FULL_STACK)
    records = []
    for env in (alone, full):
        _, info = env.reset(seed=21)
        seen = [info["randomization"][name]]
        for _ in range(3):
            info = env.step(np.array([0.2, 0.1], np.float32))[4]
            seen.append(info.get("randomization", {}).get(name))
        records.append(seen)
    assert records[0] == records[1]


def test_scale_zero_everywhere_gives_the_bare_envs_observations() -> None:
    env = randomizers.from_config(NavDouble(), FULL_STACK)
    randomizers.set_scale(env, 0.0)
    bare = NavDouble()
    acts = [np.array([0.1 * i, -0.1], np.float32) for i in range(6)]
    got = _rollout_actions(env, acts)
    want = _rollout_actions(bare, acts)
    for a, b in zip(got, want, strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    record = env.reset(seed=0)[1]["randomization"]
    assert record["DynamicsRandomizer"]["coulomb_v_fwd_n"] == 1.0  # centre of [0.5, 1.5]
    assert record["ActionDelay"]["delay_steps"] == 0
    assert record["CameraPoseJitter"]["position_offset_m"] == [0.0, 0.0, 0.0]


def _rollout_actions(env: Any, actions: list[np.ndarray]) -> list[dict[str, np.ndarray]]:
    obs, _ = env.reset(seed=8)
    out = [obs]
    out.extend(env.step(a)[0] for a in actions)
    return out
