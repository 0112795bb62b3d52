"""Race-v0's ``reward`` argument: RaceReward constants from a config mapping."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs.geometry import FloatArray
from sim2real.envs.race import RaceReward, race_reward
from sim2real.errors import Sim2RealValueError


def _standing_rewards(**kwargs: object) -> list[float]:
    env = gym.make("sim2real/Race-v0", track="open", num_opponents=0, control_dt=0.25, **kwargs)
    env.reset(seed=0)
    return [float(env.step(np.zeros(2))[1]) for _ in range(3)]


def test_a_mapping_sets_the_named_constants_and_keeps_the_others() -> None:
    reward = race_reward({"stop": 0.1, "keep_moving": 0.05})
    assert (reward.stop, reward.keep_moving) == (0.1, 0.05)
    assert reward.goal == RaceReward().goal and race_reward(None) == RaceReward()
    assert race_reward(reward) is reward


def test_the_stop_penalty_is_paid_every_step_standing_still() -> None:
    default, strict = _standing_rewards(), _standing_rewards(reward={"stop": 0.1})
    np.testing.assert_allclose(default, -0.02, atol=1e-9)  # open track: no wall or mover near
    np.testing.assert_allclose(strict, -0.1, atol=1e-9)


def _driving_rewards(**kwargs: object) -> list[float]:
    env = gym.make("sim2real/Race-v0", track="open", num_opponents=0, control_dt=0.25, **kwargs)
    env.reset(seed=0)
    return [float(env.step(np.array([0.22, 0.0]))[1]) for _ in range(8)]


def test_the_time_cost_is_paid_every_step_moving_or_not() -> None:
    # the same seed drives the same course: the time cost is the only difference, every step
    free, timed = _driving_rewards(), _driving_rewards(reward={"time": 0.05})
    np.testing.assert_allclose(np.subtract(free, timed), 0.05, atol=1e-9)
    assert np.mean(free[4:]) > 0.05  # at top speed the progress pays more than the time cost
    standing = _standing_rewards(reward={"time": 0.05})
    np.testing.assert_allclose(standing, -0.07, atol=1e-9)  # stop 0.02 + time 0.05


def _turning_run(command: tuple[float, float], **kwargs: object) -> tuple[FloatArray, FloatArray]:
    env = gym.make("sim2real/Race-v0", track="open", num_opponents=0, control_dt=0.25, **kwargs)
    env.reset(seed=0)
    steps = [env.step(np.array(command)) for _ in range(6)]
    return np.array([float(s[1]) for s in steps]), np.array([float(s[0][40]) for s in steps])


@pytest.mark.parametrize("w_radps", [-1.5, -0.6, 0.2, 1.5])
def test_the_turn_cost_is_paid_per_radian_of_measured_turn(w_radps: float) -> None:
    # the same seed drives the same arc: the cost is k |w| dt with the measured w, every step
    free, w_measured = _turning_run((0.22, w_radps))
    costly, _ = _turning_run((0.22, w_radps), reward={"turn_per_rad": 0.5})
    assert np.all(np.abs(w_measured) > 0.1)  # it turns (the drive model takes ~0.08 rad/s off)
    np.testing.assert_allclose(free - costly, 0.5 * np.abs(w_measured) * 0.25, atol=1e-9)
    straight, _ = _turning_run((0.22, 0.0))
    straight_costly, _ = _turning_run((0.22, 0.0), reward={"turn_per_rad": 0.5})
    np.testing.assert_allclose(straight, straight_costly, atol=1e-12)  # a straight line is free
    assert RaceReward().turn_per_rad == 0.0  # off unless a config asks for it


@pytest.mark.parametrize(
    ("bad", "words"),
    [
        ({"stopp": 0.1}, "mapping of its fields"),
        ([0.1], "mapping of its fields"),
        ({"stop": "high"}, "reward.stop must be a number"),
        ({"stop": True}, "reward.stop must be a number"),
    ],
)
def test_bad_reward_is_one_sentence(bad: object, words: str) -> None:
    with pytest.raises(Sim2RealValueError, match=words) as err:
        gym.make("sim2real/Race-v0", track="open", reward=bad)
    assert "\n" not in str(err.value)
