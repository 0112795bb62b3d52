"""The numba depth renderer: analytic depths and pixel agreement with pybullet's renderer."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.envs import depth
from sim2real.envs._world import PybulletWorld, render_pybullet_depth
from sim2real.envs.depth import DepthCamera, DepthScene, camera_rays, render_depth, rpy_matrix


def _cam(xyz: tuple[float, float, float], rpy: tuple[float, float, float]) -> DepthCamera:
    return DepthCamera(
        width=64,
        height=48,
        hfov_deg=60.0,
        near_m=0.05,
        far_m=8.0,
        xyz_m=xyz,
        rpy_rad=rpy,
        base_height_m=0.0,
    )


def test_wall_depth_is_its_distance_along_the_optical_axis() -> None:
    scene = DepthScene.build(boxes=[(3.0, 0.0, 0.2, 20.0, 0.0, 2.0)])  # face at x = 2.9
    img = _cam((0.0, 0.0, 0.3), (0.0, 0.0, 0.0)).render(scene, 0.0, 0.0, 0.0)
    upper = img[:20]  # rows above the horizon see the wall everywhere
    np.testing.assert_allclose(upper, 2.9, atol=1e-9)


def test_floor_depth_follows_the_pinhole_model() -> None:
    img = _cam((0.0, 0.0, 0.5), (0.0, 0.0, 0.0)).render(DepthScene.build(), 0.0, 0.0, 0.0)
    rays = camera_rays(64, 48, 60.0).reshape(48, 64, 3)
    below = rays[..., 2] < 0
    expected = np.clip(-0.5 / rays[..., 2][below], 0.05, 8.0)
    np.testing.assert_allclose(img[below], expected, rtol=1e-12)
    assert np.all(img[~below] == 8.0)


def test_top_of_a_low_box_is_seen_from_above() -> None:
    scene = DepthScene.build(boxes=[(2.0, 0.0, 1.0, 1.0, 0.0, 0.4)])  # top at z = 0.4
    cam = _cam((0.0, 0.0, 1.0), (0.0, 0.5, 0.0))  # pitched down
    img = cam.render(scene, 0.0, 0.0, 0.0)
    eye, rot = cam.world_pose(0.0, 0.0, 0.0)
    d = camera_rays(64, 48, 60.0) @ rot.T
    t_top = (0.4 - eye[2]) / d[:, 2]
    hit = eye[:2] + t_top[:, None] * d[:, :2]
    on_top = (np.abs(hit[:, 0] - 2.0) < 0.45) & (np.abs(hit[:, 1]) < 0.45) & (d[:, 2] < 0)
    assert on_top.sum() > 20
    np.testing.assert_allclose(img.reshape(-1)[on_top], t_top[on_top], rtol=1e-9)


@pytest.mark.parametrize(
    ("xyz", "rpy"),
    [((0.0, 0.0, 0.3), (0.0, 0.0, 0.0)), ((0.1, 0.0, 1.0), (0.1, 0.25, -0.2))],
)
def test_agrees_with_pybullet_tiny_renderer(
    xyz: tuple[float, float, float], rpy: tuple[float, float, float]
) -> None:
    rng = np.random.default_rng(0)
    cyl = np.column_stack(
        [
            rng.uniform(0.8, 5, 15),
            rng.uniform(-2, 2, 15),
            rng.uniform(0.15, 0.3, 15),
            rng.uniform(0.5, 1.8, 15),
        ]
    )
    box = np.array([[3.0, 1.0, 1.0, 0.3, 0.4, 0.6], [6.0, 0.0, 0.1, 8.0, 0.0, 1.5]])
    world = PybulletWorld()
    try:
        world.set_static(
            cylinders=cyl[:, :3],
            cylinder_height_m=cyl[:, 3],
            boxes=box[:, :5],
            box_height_m=box[:, 5],
        )
        cam = _cam(xyz, rpy)
        ours = cam.render(DepthScene(cylinders=cyl, boxes=box), 0.2, -0.1, 0.15)
        ref = render_pybullet_depth(
            world, cam.view_matrix, width=64, height=48, hfov_deg=60.0, near_m=0.05, far_m=8.0
        )
    finally:
        world.close()
    err = np.abs(ours - ref)
    # pybullet tessellates cylinders; a few edge pixels differ, the rest agree to ~1 cm
    assert np.mean(err > 0.05) < 0.02
    assert np.median(err) < 1e-3


def test_rpy_matrix_is_a_rotation() -> None:
    r = rpy_matrix(0.3, -0.2, 1.1)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert math.isclose(np.linalg.det(r), 1.0)
    np.testing.assert_allclose(rpy_matrix(0, 0, math.pi / 2) @ [1, 0, 0], [0, 1, 0], atol=1e-12)


def test_render_depth_without_cached_rays_equals_cached() -> None:
    scene = DepthScene.build(cylinders=[(2.0, 0.5, 0.3, 1.0)])
    kw = dict(
        eye=np.array([0.0, 0.0, 0.3]),
        rotation=np.eye(3),
        width=16,
        height=12,
        hfov_deg=60.0,
        near_m=0.05,
        far_m=8.0,
    )
    a = render_depth(scene, **kw)  # type: ignore[arg-type]
    b = render_depth(scene, rays=camera_rays(16, 12, 60.0), **kw)  # type: ignore[arg-type]
    np.testing.assert_array_equal(a, b)


_coord = st.floats(-5.0, 5.0)


@st.composite
def _scenes(draw: st.DrawFn) -> DepthScene:
    cylinders = draw(
        st.lists(st.tuples(_coord, _coord, st.floats(0.05, 1.0), st.floats(0.1, 2.0)), max_size=12)
    )
    boxes = draw(
        st.lists(
            st.tuples(
                _coord,
                _coord,
                st.floats(0.05, 3.0),
                st.floats(0.05, 3.0),
                st.floats(-4.0, 4.0),
                st.floats(0.1, 2.0),
            ),
            max_size=6,
        )
    )
    return DepthScene.build(cylinders=cylinders, boxes=boxes)


@settings(max_examples=60, deadline=None)
@given(
    scene=_scenes(),
    eye=st.tuples(_coord, _coord, st.floats(0.05, 2.5)),
    yaw=st.floats(-4.0, 4.0),
    size=st.tuples(st.integers(1, 40), st.integers(1, 30)),
    hfov_deg=st.floats(10.0, 170.0),
)
def test_level_camera_column_renderer_equals_every_ray_against_every_body(
    scene: DepthScene,
    eye: tuple[float, float, float],
    yaw: float,
    size: tuple[int, int],
    hfov_deg: float,
) -> None:
    """A level camera's image columns are vertical planes: the renderer then intersects each
    body once per column; the image must be the per-ray renderer's to the bit."""
    width, height = size
    d = np.ascontiguousarray(camera_rays(width, height, hfov_deg) @ rpy_matrix(0.0, 0.0, yaw).T)
    assert depth._columns_are_vertical(d, width)
    cyl = np.ascontiguousarray(scene.cylinders)
    boxes = depth._packed_boxes(scene.boxes)
    e = np.asarray(eye, dtype=np.float64)
    by_column, by_ray = np.empty(d.shape[0]), np.empty(d.shape[0])
    depth._render_columns(e, d, cyl, boxes, width, by_column)
    depth._render_rays(e, d, cyl, boxes, by_ray)
    np.testing.assert_array_equal(by_column, by_ray)


def test_a_pitched_camera_falls_back_to_the_per_ray_renderer() -> None:
    d = depth.world_rays(camera_rays(16, 12, 60.0), rpy_matrix(0.0, 0.3, 0.7))
    np.testing.assert_allclose(d, camera_rays(16, 12, 60.0) @ rpy_matrix(0.0, 0.3, 0.7).T, 1e-15)
    assert not depth._columns_are_vertical(d, 16)
    scene = DepthScene.build(cylinders=[(2.0, 0.5, 0.4, 1.0)], boxes=[(3, -1, 1, 2, 0.3, 0.5)])
    kw = dict(eye=np.array([0.0, 0.0, 0.5]), width=16, height=12, hfov_deg=60.0)
    kw.update(near_m=0.05, far_m=8.0)
    pitched = render_depth(scene, rotation=rpy_matrix(0.0, 0.3, 0.7), **kw)  # type: ignore[arg-type]
    expected = np.empty(d.shape[0])
    e = np.array([0.0, 0.0, 0.5])
    depth._render_rays(e, d, scene.cylinders, depth._packed_boxes(scene.boxes), expected)
    np.testing.assert_array_equal(pitched, np.clip(expected, 0.05, 8.0).reshape(12, 16))


def test_crowd_nav_camera_renders_by_columns() -> None:
    """CrowdNav's depth camera is level, so its frames take the per-column renderer."""
    import gymnasium as gym

    import sim2real.envs  # noqa: F401  (registers the ids)

    env = gym.make("sim2real/CrowdNav-v0").unwrapped
    env.reset(seed=3)
    cam = env.camera  # type: ignore[attr-defined]
    for yaw in (0.0, 0.4, -2.9):
        _, rot = cam.world_pose(0.3, -0.2, yaw)
        d = np.ascontiguousarray(cam._rays @ rot.T)
        assert depth._columns_are_vertical(d, cam.width)
    env.close()
