"""Race-v0's ``local_goal_m``: SARL*'s dynamic local goal (Li et al. 2019) in the observation."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.errors import Sim2RealValueError

GOAL = slice(41, 43)  # goal distance (m), bearing (rad)


def test_local_goal_stays_within_its_radius_and_ends_at_the_goal_line() -> None:
    far = gym.make("sim2real/Race-v0", track="open", num_opponents=0, control_dt=0.25)
    near = gym.make(
        "sim2real/Race-v0", track="open", num_opponents=0, control_dt=0.25, local_goal_m=1.0
    )
    o_far, _ = far.reset(seed=0)
    o_near, _ = near.reset(seed=0)
    np.testing.assert_array_equal(o_far[:41], o_near[:41])  # only the goal entries differ
    assert o_far[41] > 5.0 and 0.5 < o_near[41] <= 1.0
    distances = []
    for _ in range(400):
        bearing = float(o_near[42])
        o_near, _, done, _, info = near.step(np.array([0.22, np.clip(2 * bearing, -2.8, 2.8)]))
        distances.append(float(o_near[41]))
        if done:
            break
    assert info["outcome"] == "success"  # steering at the local goal finishes the open track
    assert max(distances[:-20]) <= 1.0 + 0.25  # at most one waypoint spacing past the radius
    tail = o_near[GOAL]  # the goal line's centre is the target at the end
    assert tail[0] < 1.0 and abs(tail[1]) < math.pi


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), "1 m", True])
def test_bad_local_goal_radius_is_one_sentence(bad: object) -> None:
    with pytest.raises(Sim2RealValueError, match="local_goal_m must be a distance"):
        gym.make("sim2real/Race-v0", track="open", local_goal_m=bad)
