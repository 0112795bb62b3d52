"""CrowdNav-v0: contract, scenarios and complexity, occlusion %, density, camera protocol."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs import CrowdNavEnv
from sim2real.errors import Sim2RealValueError


@pytest.fixture(scope="module")
def env() -> CrowdNavEnv:
    e = CrowdNavEnv()
    yield e
    e.close()


def test_check_env_passes_and_spaces(env: CrowdNavEnv) -> None:
    check_env(env, skip_render_check=True)
    space = env.observation_space
    assert space["depth"].shape == (48, 64)
    assert space["lidar"].shape == (640,)  # the TurtleBot 2 spec's lidar
    assert space["goal"].shape == (2,) and space["velocity"].shape == (2,)
    np.testing.assert_allclose(env.action_space.high, [0.7, 3.14], rtol=1e-6)
    assert env.control_dt == 0.1


@pytest.mark.parametrize(
    ("scenario", "c", "n_peds"),
    [("static", 1.0, 0), ("dynamic", 0.0, 5), ("dynamic", 1.0, 20), ("occluded", 0.5, 6)],
)
def test_complexity_sets_the_counts(env: CrowdNavEnv, scenario: str, c: float, n_peds: int) -> None:
    _, info = env.reset(seed=1, options={"scenario": scenario, "complexity": c})
    assert info["num_pedestrians"] == n_peds
    assert info["scenario"] == scenario and info["complexity"] == c
    n_static = len(env._scene.circles_r) + (len(env._scene.seg_a) // 4 - 4)
    if scenario == "static":
        assert n_static == 20
    if scenario == "dynamic" and c == 1.0:
        assert n_static == 10
        assert env.crowd is not None
        assert np.allclose(env.crowd.alpha, 1.4 * 1.5)  # faster walkers at c = 1


@pytest.mark.parametrize("c", [0.0, 0.3, 0.6, 1.0])
def test_occlusion_percent_follows_complexity(env: CrowdNavEnv, c: float) -> None:
    _, info = env.reset(seed=2, options={"scenario": "occluded", "complexity": c})
    assert info["occlusion_pct"] == pytest.approx(90.0 * c, abs=1.0)


def test_occluded_pedestrians_start_hidden_and_cross_later(env: CrowdNavEnv) -> None:
    env.reset(seed=3, options={"scenario": "occluded", "complexity": 1.0})
    assert env.crowd is not None
    start = env.crowd.position_m.copy()
    assert np.all(env.crowd.start_time_s >= 0.0) and env.crowd.start_time_s.max() > 1.0
    for _ in range(80):
        env.step(np.array([0.0, 0.0]))
    moved = np.linalg.norm(env.crowd.position_m - start, axis=1)
    assert moved.max() > 1.0


@pytest.mark.parametrize("density", [1.0, 3.0])
def test_dense_crowds_run(env: CrowdNavEnv, density: float) -> None:
    obs, info = env.reset(seed=0, options={"pedestrian_density": density})
    assert info["num_pedestrians"] == round(density * 7.4**2)
    for _ in range(3):
        obs, *_ = env.step(np.array([0.0, 0.0]))
    assert env.observation_space.contains(obs)


def test_seeded_reset_reproduces(env: CrowdNavEnv) -> None:
    o1, _ = env.reset(seed=5, options={"scenario": "dynamic", "complexity": 0.7})
    s1 = [env.step(np.array([0.3, 0.2]))[0] for _ in range(5)]
    o2, _ = env.reset(seed=5, options={"scenario": "dynamic", "complexity": 0.7})
    s2 = [env.step(np.array([0.3, 0.2]))[0] for _ in range(5)]
    for a, b in zip([o1, *s1], [o2, *s2], strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])


def test_camera_pose_protocol(env: CrowdNavEnv) -> None:
    env.reset(seed=0, options={"scenario": "static", "complexity": 0.0})
    xyz, rpy = env.get_camera_pose()
    np.testing.assert_allclose(xyz, [-0.087, 0.0125, 0.287])
    np.testing.assert_allclose(rpy, [0.0, 0.0, 0.0])
    obs_a, *_ = env.step(np.array([0.0, 0.0]))
    view_a = env.get_camera_view_matrix()
    assert view_a.shape == (16,)
    env.set_camera_pose(xyz + np.array([0.0, 0.0, 0.2]), [0.0, 0.3, 0.0])  # higher, pitched down
    obs_b, *_ = env.step(np.array([0.0, 0.0]))
    view_b = env.get_camera_view_matrix()
    assert not np.allclose(view_a, view_b)
    # pitched down, the rows that looked over the floor at the walls now see the floor
    assert obs_b["depth"][20].mean() < 0.5 * obs_a["depth"][20].mean()
    with pytest.raises(Sim2RealValueError, match="set_camera_pose"):
        env.set_camera_pose([0.0, 0.0], [0.0, 0.0, 0.0])
    env.set_camera_pose(xyz, rpy)


def test_goal_observation_is_relative(env: CrowdNavEnv) -> None:
    obs, _ = env.reset(seed=0, options={"scenario": "occluded", "complexity": 0.0})
    np.testing.assert_allclose(obs["goal"], [6.0, 0.0], atol=1e-6)  # straight ahead, 6 m


def test_bad_options_are_refused(env: CrowdNavEnv) -> None:
    with pytest.raises(
        Sim2RealValueError, match=r"complexity \(--complexity\) .*got 1.5; e.g. --complexity 0.5"
    ):
        env.reset(options={"complexity": 1.5})
    with pytest.raises(
        Sim2RealValueError, match=r"scenario \(--scenario\) .*got 'party'; e.g. --scenario dyn"
    ):
        env.reset(options={"scenario": "party"})
    with pytest.raises(Sim2RealValueError, match="unknown reset option"):
        env.reset(options={"preset": "TRAIN"})
    with pytest.raises(Sim2RealValueError, match="depth"):
        CrowdNavEnv(depth_width=0)
    with pytest.raises(Sim2RealValueError, match="depth camera"):
        CrowdNavEnv(robot="turtlebot3_burger")


def test_collision_with_a_pedestrian_ends_the_episode(env: CrowdNavEnv) -> None:
    env.reset(seed=0, options={"scenario": "dynamic", "complexity": 0.0, "num_pedestrians": 1})
    assert env.crowd is not None
    x, y, yaw = env._backend.pose
    env.crowd.position_m[0] = [x + 0.45 * np.cos(yaw), y + 0.45 * np.sin(yaw)]
    env.crowd.pref_speed_mps[:] = 0.0
    for _ in range(30):
        _, r, term, trunc, info = env.step(np.array([0.5, 0.0]))
        if term or trunc:
            break
    assert term and info["outcome"] == "collision" and r < -9.0


def test_async_vector_env_runs() -> None:
    envs = gym.make_vec("sim2real/CrowdNav-v0", num_envs=2, vectorization_mode="async")
    try:
        obs, _ = envs.reset(seed=[0, 1])
        assert obs["depth"].shape == (2, 48, 64)
        for _ in range(2):
            obs, r, *_ = envs.step(np.tile([0.2, 0.0], (2, 1)).astype(np.float32))
        assert r.shape == (2,)
    finally:
        envs.close()


def test_reward_terms_match_the_docstring(env: CrowdNavEnv) -> None:
    cfg = env.reward_config
    env.reset(seed=0, options={"scenario": "static", "complexity": 0.0})
    d0 = env._goal_polar()[0]
    _, r, *_ = env.step(np.array([0.5, 0.0]))
    v, w = env._backend.velocity
    d1 = env._goal_polar()[0]
    prox = cfg.proximity * max(0.0, 1.0 - env._clearance() / cfg.safe_clearance_m)
    expected = (
        cfg.progress_per_m * (d0 - d1)
        - cfg.step_penalty
        - prox
        - cfg.dv_per_mps * abs(v)
        - cfg.dw_per_radps * abs(w)
    )
    assert r == pytest.approx(expected, abs=1e-9)


def test_bad_constructor_pedestrian_count() -> None:
    with pytest.raises(Sim2RealValueError, match="num_pedestrians"):
        CrowdNavEnv(num_pedestrians=-1)


def _passable(env: CrowdNavEnv, start: tuple[float, float], goal: tuple[float, float]) -> bool:
    """Breadth-first search on a 5 cm grid of footprint-free cells."""
    from collections import deque

    from sim2real.envs.geometry import point_segment_distance

    res = 0.05
    xs = np.arange(-3.95, 3.95, res)
    gx, gy = np.meshgrid(xs, xs, indexing="ij")
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    sc = env._scene
    d = point_segment_distance(pts, sc.seg_a, sc.seg_b).min(axis=1)
    if sc.circles_r.size:
        dc = np.linalg.norm(pts[:, None] - sc.circles_xy[None], axis=2) - sc.circles_r
        d = np.minimum(d, dc.min(axis=1))
    free = (d > env.robot_radius_m + 0.02).reshape(gx.shape)

    def cell(p: tuple[float, float]) -> tuple[int, int]:
        return round((p[0] - xs[0]) / res), round((p[1] - xs[0]) / res)

    s, g = cell(start), cell(goal)
    seen, queue = {s}, deque([s])
    while queue:
        c = queue.popleft()
        if c == g:
            return True
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            n = (c[0] + dx, c[1] + dy)
            if min(n) >= 0 and max(n) < len(xs) and n not in seen and free[n]:
                seen.add(n)
                queue.append(n)
    return False


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_occluded_scenario_stays_passable_at_full_complexity(env: CrowdNavEnv, seed: int) -> None:
    _, info = env.reset(seed=seed, options={"scenario": "occluded", "complexity": 1.0})
    assert info["occlusion_pct"] == pytest.approx(90.0, abs=1.0)
    assert _passable(env, (-3.0, 0.0), (3.0, 0.0))


def test_fewer_lidar_beams_read_the_full_scan_at_their_angles() -> None:
    full, few = CrowdNavEnv(), CrowdNavEnv(lidar_beams=72)  # 640 beams, 639 = 9 x 71 gaps
    obs_full, _ = full.reset(seed=3)
    obs_few, _ = few.reset(seed=3)
    assert few.observation_space["lidar"].shape == (72,)
    np.testing.assert_array_equal(obs_few["lidar"], obs_full["lidar"][::9])
    np.testing.assert_array_equal(obs_few["depth"], obs_full["depth"])  # the world is the same
    assert few.observation_space.contains(obs_few)


@pytest.mark.parametrize("beams", [0, -3, 2.5, True])
def test_bad_lidar_beams_are_refused(beams: object) -> None:
    with pytest.raises(Sim2RealValueError, match="lidar_beams must be an integer >= 1"):
        CrowdNavEnv(lidar_beams=beams)  # type: ignore[arg-type]
