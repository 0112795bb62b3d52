"""Pedestrians: eq. (1) of Liang et al. (2020), its calibration, spawning at 3 / m^2, crowd stepping."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.envs.geometry import Scene2D
from sim2real.envs.pedestrians import (
    ALPHA,
    BETA,
    Crowd,
    spawn_positions,
    walking_speed,
    weidmann_speed,
)
from sim2real.errors import Sim2RealValueError


def test_equation_one_golden_values() -> None:
    # V = min(|v_pref|, (S alpha / (H (1 + beta)))^2) with H = height / 1.72
    k = ALPHA / (1.0 + BETA)
    assert walking_speed(1.34, 1.0, 1.72) == pytest.approx(min(1.34, k**2))
    assert walking_speed(2.0, 0.5, 1.72 * 1.1) == pytest.approx((0.5 * k / 1.1) ** 2)
    assert walking_speed(0.8, 5.0, 1.72) == pytest.approx(0.8)
    assert walking_speed(1.0, -1.0, 1.72) == 0.0


def test_calibration_follows_the_fundamental_diagram_at_1_to_3_per_m2() -> None:
    rho = np.array([1.0, 2.0, 3.0])
    ours = walking_speed(1.34, 1.0 / np.sqrt(rho), 1.72)
    np.testing.assert_allclose(ours, weidmann_speed(rho), atol=0.07)


@settings(max_examples=30, deadline=None)
@given(s=st.floats(0.0, 3.0), h=st.floats(1.4, 2.0), vp=st.floats(0.0, 2.0), a=st.floats(1.0, 3.0))
def test_speed_is_bounded_and_monotone_in_space(s: float, h: float, vp: float, a: float) -> None:
    v = float(walking_speed(vp, s, h, alpha=a))
    assert 0.0 <= v <= vp + 1e-12
    assert float(walking_speed(vp, s + 0.1, h, alpha=a)) >= v
    assert float(walking_speed(vp, s, h, alpha=a * 1.2)) >= v


def test_spawn_three_per_m2_without_overlap() -> None:
    rng = np.random.default_rng(0)
    pos = spawn_positions(
        rng,
        164,
        bounds=(-3.7, 3.7, -3.7, 3.7),
        radius_m=0.24,
        scene=Scene2D.build(),
        keep_out=np.array([[-3.0, 0.0]]),
        keep_out_radius_m=0.6,
    )
    d = np.linalg.norm(pos[:, None] - pos[None], axis=2) + np.eye(len(pos)) * 10
    assert d.min() >= 0.48
    assert np.min(np.linalg.norm(pos - [-3.0, 0.0], axis=1)) > 0.84
    with pytest.raises(Sim2RealValueError, match="lower the number"):
        spawn_positions(
            rng,
            500,
            bounds=(-3.7, 3.7, -3.7, 3.7),
            radius_m=0.24,
            scene=Scene2D.build(),
            keep_out=np.zeros((0, 2)),
            keep_out_radius_m=0.0,
        )


def _crowd(pos: np.ndarray, **kw: object) -> Crowd:
    n = len(pos)
    return Crowd(
        np.random.default_rng(0),
        position_m=pos,
        radius_m=np.full(n, 0.2),
        height_m=np.full(n, 1.72),
        pref_speed_mps=np.full(n, 1.3),
        bounds=(-10.0, 10.0, -10.0, 10.0),
        **kw,  # type: ignore[arg-type]
    )


def test_free_walker_walks_at_preferred_speed_to_its_goal() -> None:
    crowd = _crowd(np.array([[0.0, 0.0]]), goals=np.array([[5.0, 0.0]]))
    far = np.array([50.0, 50.0])
    for _ in range(10):
        crowd.step(0.1, Scene2D.build(), robot_xy=far, robot_radius_m=0.2)
    np.testing.assert_allclose(crowd.position_m[0], [1.3, 0.0], atol=1e-9)
    state = crowd.state().as_array()
    assert state.shape == (1, 7)
    np.testing.assert_allclose(state[0, 3:5], [1.3, 0.0], atol=1e-9)


def test_walker_slows_down_and_never_enters_a_wall() -> None:
    wall = Scene2D.build(segments=[(1.0, -5.0, 1.0, 5.0)])
    crowd = _crowd(np.array([[0.0, 0.0]]), goals=np.array([[5.0, 0.0]]))
    speeds = []
    for _ in range(30):
        crowd.step(0.1, wall, robot_xy=np.array([50.0, 50.0]), robot_radius_m=0.2)
        speeds.append(np.linalg.norm(crowd.velocity_mps[0]))
    assert crowd.position_m[0, 0] <= 1.0 - 0.2 + 1e-9
    assert speeds[-1] < 0.9 * speeds[0]


def test_dense_crowd_steps_without_overlap() -> None:
    rng = np.random.default_rng(3)
    pos = spawn_positions(
        rng,
        120,
        bounds=(-3.0, 3.0, -3.0, 3.0),
        radius_m=0.22,
        scene=Scene2D.build(),
        keep_out=np.zeros((0, 2)),
        keep_out_radius_m=0.0,
    )
    n = len(pos)
    crowd = Crowd(
        rng,
        position_m=pos,
        radius_m=np.full(n, 0.2),
        height_m=np.full(n, 1.72),
        pref_speed_mps=np.full(n, 1.3),
        bounds=(-3.0, 3.0, -3.0, 3.0),
    )
    for _ in range(20):
        crowd.step(0.1, Scene2D.build(), robot_xy=np.array([9.0, 9.0]), robot_radius_m=0.2)
    d = np.linalg.norm(crowd.position_m[:, None] - crowd.position_m[None], axis=2)
    d += np.eye(n) * 10
    assert d.min() > 0.4 - 0.02  # overlaps pushed apart
    speeds = np.linalg.norm(crowd.velocity_mps, axis=1)
    assert speeds.max() <= 1.3 + 1e-9
    assert speeds.mean() < 1.0  # density slows the crowd down
