"""Vector envs (sync and async), gymnasium's env checker, and the success-rate curriculum."""

from __future__ import annotations

import functools
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from randomizers_testenv import DEPTH_FAR_M, DEPTH_NEAR_M, ENV_ID, FULL_STACK, NavDouble

import randomizers
from randomizers import (
    ActionDelay,
    DepthNoise,
    GoalNoise,
    ObservationNoise,
    OdometryDelay,
    SuccessRateCurriculum,
)

WRAPPERS = [
    functools.partial(DepthNoise, key="depth", near_m=DEPTH_NEAR_M, far_m=DEPTH_FAR_M),
    functools.partial(GoalNoise, key="goal"),
    functools.partial(OdometryDelay, key="velocity", delay_steps=[0, 2]),
    functools.partial(ActionDelay, delay_s=0.1),
]


def _vec(mode: str) -> Any:
    return gym.make_vec(ENV_ID, num_envs=2, vectorization_mode=mode, wrappers=WRAPPERS)


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_make_vec_runs_and_is_reproducible(mode: str) -> None:
    envs = _vec(mode)
    try:
        obs, info = envs.reset(seed=10)
        assert obs["depth"].shape == (2, 64, 64) and obs["depth"].dtype == np.float32
        rec = info["randomization"]
        offsets = rec["GoalNoise[goal]"]["offset_m"]
        assert len(offsets) == 2 and not np.array_equal(offsets[0], offsets[1])  # seeds 10, 11
        first = obs["depth"].copy()
        actions = np.tile(np.array([[0.5, 0.0]], np.float32), (2, 1))
        for _ in range(3):
            obs, *_ = envs.step(actions)
        obs, _ = envs.reset(seed=10)
        np.testing.assert_array_equal(obs["depth"], first)
        assert randomizers.set_scale(envs, 0.0) == 4
        obs, info = envs.reset(seed=10)
        np.testing.assert_array_equal(obs["depth"][0], NavDouble(invalid_pixels=False)._depth)
    finally:
        envs.close()


def test_sync_and_async_give_the_same_numbers() -> None:
    results = []
    for mode in ("sync", "async"):
        envs = _vec(mode)
        try:
            obs, _ = envs.reset(seed=1)
            obs, *_ = envs.step(np.full((2, 2), 0.3, np.float32))
            results.append(obs)
        finally:
            envs.close()
    for key in results[0]:
        np.testing.assert_array_equal(results[0][key], results[1][key])


def test_check_env_passes_for_the_full_stack() -> None:
    env = randomizers.from_config(NavDouble(invalid_pixels=False), FULL_STACK)
    check_env(env, skip_render_check=True)


@pytest.mark.parametrize("env_id", ["CartPole-v1", "Pendulum-v1"])
def test_check_env_passes_on_classic_control(env_id: str) -> None:
    env = ActionDelay(ObservationNoise(gym.make(env_id).unwrapped, std=0.01), delay_steps=1)
    env = OdometryDelay(env, delay_steps=1, index=1)
    check_env(env, skip_render_check=True)


def test_curriculum_raises_scale_on_success_rate() -> None:
    env = randomizers.from_config(NavDouble(), FULL_STACK)
    cur = SuccessRateCurriculum(env, threshold=0.6, window=5, increment=0.3)
    assert all(r.scale == 1.0 for r in randomizers.iter_randomizers(env))  # pending until reset
    env.reset(seed=0)
    assert all(r.scale == 0.0 for r in randomizers.iter_randomizers(env))
    outcomes = [True, False, True, False, False]  # 0.4 < 0.6: no raise
    updates = [cur.record(o) for o in outcomes]
    assert [u.raised for u in updates] == [False] * 5 and updates[-1].success_rate == 0.4
    updates = [cur.record(o) for o in [True, True, True]]  # sliding window: 0.4, then 0.6
    assert updates[0].success_rate == 0.4 and not updates[0].raised
    assert updates[1].success_rate == 0.6 and updates[1].raised and updates[1].scale == 0.3
    assert updates[2].success_rate is None  # the window restarts after a raise
    env.reset()
    assert {r.scale for r in randomizers.iter_randomizers(env)} == {0.3}
    for _ in range(20):
        cur.record(True)
    assert cur.scale == 1.0


def test_curriculum_drives_vector_envs() -> None:
    envs = _vec("sync")
    try:
        cur = SuccessRateCurriculum(envs, threshold=0.5, window=2, increment=0.5)
        cur.record(True)
        cur.record(True)
        envs.reset(seed=0)
        scales = [r.scale for e in envs.envs for r in randomizers.iter_randomizers(e)]
        assert scales == [0.5] * 8
    finally:
        envs.close()


def test_curriculum_needs_randomizers() -> None:
    with pytest.raises(ValueError, match="no randomizer"):
        SuccessRateCurriculum(gym.make("CartPole-v1"))


def test_from_sysid_factory_pickles_into_async_workers(tmp_path) -> None:  # type: ignore[no-untyped-def]

    from robots.spec import load_spec
    from tests.randomization_block import write_params_file

    centre = load_spec("turtlebot2").drive.replace(coulomb_v_fwd_n=2.0)
    path = write_params_file(tmp_path / "params.yaml", centre, "turtlebot2", rel=0.8)
    factory = randomizers.DynamicsRandomizer.from_sysid(path, scale=0.5)
    envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="async", wrappers=[factory])
    try:
        _, info = envs.reset(seed=0)
        drawn = info["randomization"]["DynamicsRandomizer"]["coulomb_v_fwd_n"]
        assert len(drawn) == 2 and drawn[0] != drawn[1]
        assert all(abs(v - 2.0) < 5 * 0.5 * 0.8 * 0.5 for v in drawn)  # sd 0.8 x 0.5 N
        assert list(info["randomization"]["DynamicsRandomizer"]["scale"]) == [0.5, 0.5]
    finally:
        envs.close()
