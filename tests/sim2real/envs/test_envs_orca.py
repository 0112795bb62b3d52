"""ORCA (van den Berg et al. 2011): reciprocal avoidance, antipodal circle, LP properties."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.envs.orca import OrcaAgents, OrcaConfig, orca_velocities
from sim2real.errors import Sim2RealValueError


def _min_pair_gap(xy: np.ndarray, r: np.ndarray) -> float:
    d = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=2) - (r[:, None] + r[None, :])
    np.fill_diagonal(d, np.inf)
    return float(d.min())


def test_two_agents_swapping_never_touch() -> None:
    agents = OrcaAgents(
        position_m=np.array([[-3.0, 0.0], [3.0, 0.0]]),
        radius_m=np.array([0.3, 0.3]),
        max_speed_mps=np.array([1.0, 1.0]),
    )
    goals = np.array([[3.0, 0.0], [-3.0, 0.0]])
    worst = np.inf
    for _ in range(200):
        agents.step(0.05, goals=goals)
        worst = min(worst, _min_pair_gap(agents.position_m, agents.radius_m))
    assert worst >= -1e-9  # never closer than the sum of the radii
    assert worst < 0.5  # and they did have to pass each other
    assert np.allclose(agents.position_m, goals, atol=0.05)


@settings(max_examples=15)
@given(
    offset=st.floats(-0.5, 0.5),
    speed=st.floats(0.3, 1.5),
    r=st.floats(0.1, 0.4),
)
def test_swap_property(offset: float, speed: float, r: float) -> None:
    agents = OrcaAgents(
        position_m=np.array([[-2.5, offset], [2.5, -offset]]),
        radius_m=np.array([r, r]),
        max_speed_mps=np.array([speed, speed]),
    )
    goals = np.array([[2.5, offset], [-2.5, -offset]])
    for _ in range(int((5.0 / speed + 6.0) / 0.05)):  # straight-line time + 6 s
        agents.step(0.05, goals=goals)
        assert _min_pair_gap(agents.position_m, agents.radius_m) >= -1e-6
    assert np.allclose(agents.position_m, goals, atol=0.05)


@pytest.mark.parametrize("n", [4, 8, 12])
def test_circle_of_agents_reach_antipodes_without_collision(n: int) -> None:
    angles = 2.0 * math.pi * np.arange(n) / n
    start = 4.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    agents = OrcaAgents(position_m=start, radius_m=np.full(n, 0.3), max_speed_mps=np.full(n, 1.0))
    goals = -start
    worst = np.inf
    for _ in range(600):  # 30 s
        agents.step(0.05, goals=goals)
        worst = min(worst, _min_pair_gap(agents.position_m, agents.radius_m))
    assert worst >= -1e-6
    assert np.max(np.linalg.norm(agents.position_m - goals, axis=1)) < 0.05


def test_velocity_is_preferred_when_free_and_within_speed_limit() -> None:
    v = orca_velocities(
        np.array([[0.0, 0.0], [10.0, 10.0]]),
        np.zeros((2, 2)),
        np.array([0.3, 0.3]),
        np.array([[0.5, 0.2], [3.0, 4.0]]),
        np.array([1.0, 1.0]),
        0.1,
        config=OrcaConfig(neighbor_dist_m=5.0),
    )
    assert np.allclose(v[0], [0.5, 0.2])
    assert np.allclose(v[1], [0.6, 0.8])  # clipped to the speed disc


def test_non_reciprocating_robot_is_avoided_fully() -> None:
    """A robot that drives straight through: the agent alone keeps clear of it."""
    agents = OrcaAgents(
        position_m=np.array([[2.0, 0.0]]), radius_m=np.array([0.3]), max_speed_mps=np.array([1.0])
    )
    robot = np.array([-2.0, 0.0])
    worst = np.inf
    for _ in range(120):
        agents.step(
            0.05,
            goals=np.array([[-2.0, 0.0]]),
            others_xy=robot,
            others_velocity_mps=np.array([0.5, 0.0]),
            others_radius_m=np.array([0.3]),
        )
        robot = robot + np.array([0.5, 0.0]) * 0.05
        gap = float(np.linalg.norm(agents.position_m[0] - robot)) - 0.6
        worst = min(worst, gap)
    assert worst >= -1e-6


def test_walls_keep_agents_out() -> None:
    wall = (np.array([[1.0, -5.0]]), np.array([[1.0, 5.0]]))
    agents = OrcaAgents(
        position_m=np.array([[0.0, 0.0]]), radius_m=np.array([0.3]), max_speed_mps=np.array([1.0])
    )
    for _ in range(100):
        agents.step(0.05, goals=np.array([[3.0, 0.0]]), walls=wall)
        assert agents.position_m[0, 0] <= 1.0 - 0.3 + 1e-9
    assert agents.position_m[0, 0] > 0.6  # it did walk up to the wall


def test_bad_input_names_the_argument() -> None:
    with pytest.raises(Sim2RealValueError, match="radii"):
        orca_velocities(
            np.zeros((1, 2)), np.zeros((1, 2)), np.array([-1.0]), np.zeros((1, 2)), 1.0, 0.1
        )
    with pytest.raises(Sim2RealValueError, match="time_horizon_s"):
        OrcaConfig(time_horizon_s=0.0)
