"""The numba depth renderer: analytic depths and pixel agreement with pybullet's renderer."""

from __future__ import annotations

import math

import numpy as np
import pytest

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
