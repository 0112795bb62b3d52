"""CrowdNav-v0's ``reward`` argument: constants from a config mapping."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs.crowd_nav import CrowdNavEnv, CrowdNavReward
from sim2real.errors import Sim2RealValueError

_SMALL = {"depth_width": 8, "depth_height": 6, "num_pedestrians": 0, "complexity": 0.0}


def _standing_rewards(**kwargs: object) -> list[float]:
    env = CrowdNavEnv(max_episode_steps=5, **_SMALL, **kwargs)  # type: ignore[arg-type]
    env.reset(seed=0)
    return [float(env.step(np.zeros(2, dtype=np.float32))[1]) for _ in range(5)]


def test_the_step_penalty_is_what_standing_still_costs() -> None:
    np.testing.assert_allclose(_standing_rewards(), -0.01, atol=1e-9)
    np.testing.assert_allclose(_standing_rewards(reward={"step_penalty": 0.05}), -0.05, atol=1e-9)


def test_a_mapping_sets_the_named_constants_and_keeps_the_others() -> None:
    env = gym.make("sim2real/CrowdNav-v0", reward={"step_penalty": 0, "reach": 20.0}, **_SMALL)
    cfg = env.unwrapped.reward_config
    assert (cfg.step_penalty, cfg.reach, cfg.collision) == (0.0, 20.0, CrowdNavReward().collision)


def test_bad_reward_is_one_sentence() -> None:
    with pytest.raises(Sim2RealValueError, match="mapping of its fields") as err:
        gym.make("sim2real/CrowdNav-v0", reward={"steps": 1.0}, **_SMALL)
    assert "\n" not in str(err.value)
