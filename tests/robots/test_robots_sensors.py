"""Lidar and depth camera: known obstacles at known ranges, conventions for no-return, poses."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pybullet as p
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots import DepthCamera, Lidar, PybulletRobot, load_spec
from robots.errors import RobotsValueError
from robots.spec import CameraSpec
from robots.world import add_box, add_cylinder

ROBOTS = ["turtlebot2", "turtlebot3_burger", "turtlebot3_waffle_pi"]


@pytest.fixture(params=ROBOTS)
def robot(request: pytest.FixtureRequest) -> Iterator[PybulletRobot]:
    bot = PybulletRobot(load_spec(request.param), start_pose=(0.5, -0.3, 0.4))
    yield bot
    bot.close()


def _lidar_world_xy(robot: PybulletRobot) -> tuple[float, float, float]:
    x, y, yaw = robot.pose
    mx, my, _ = robot.spec.lidar.xyz_m
    return (
        x + mx * math.cos(yaw) - my * math.sin(yaw),
        y + mx * math.sin(yaw) + my * math.cos(yaw),
        yaw,
    )


def test_lidar_sees_a_box_at_the_right_range_in_the_right_beam(robot: PybulletRobot) -> None:
    lidar = Lidar(robot.spec.lidar, robot)
    lx, ly, yaw = _lidar_world_xy(robot)
    spec = robot.spec.lidar
    # a post in the direction of a beam 20 % into the field of view, 1.5 m away (face distance)
    i = int(0.2 * (spec.beams - 1))
    bearing = yaw + float(lidar.angles_rad[i])
    dist, half = 1.5, 0.05
    centre = (lx + (dist + half) * math.cos(bearing), ly + (dist + half) * math.sin(bearing), 0.5)
    add_box(robot.client, centre, (half, half, 0.5), yaw=bearing)
    ranges = lidar.scan()
    assert ranges.dtype == np.float32 and ranges.shape == (spec.beams,)
    assert ranges[i] == pytest.approx(dist, abs=0.01)
    hit = np.flatnonzero(ranges < spec.range_max_m)
    assert i in hit
    # the 10 cm post subtends ~3.8 deg: only beams around i see it
    spread = np.degrees(np.abs(lidar.angles_rad[hit] - lidar.angles_rad[i]))
    assert float(spread.max()) < 2.5
    assert np.all(ranges[np.setdiff1d(np.arange(spec.beams), hit)] == np.float32(spec.range_max_m))


def test_lidar_reads_range_max_for_no_return_and_for_too_near(robot: PybulletRobot) -> None:
    spec = robot.spec.lidar
    lidar = Lidar(spec, robot)
    assert np.all(lidar.scan() == np.float32(spec.range_max_m))  # open ground: no return
    lx, ly, yaw = _lidar_world_xy(robot)
    i = int(0.5 * (spec.beams - 1))
    bearing = yaw + float(lidar.angles_rad[i])
    near = 0.5 * spec.range_min_m
    centre = (lx + (near + 0.2) * math.cos(bearing), ly + (near + 0.2) * math.sin(bearing), 1.0)
    # a block from `near` to near+0.4 m: nearer than range_min, so its face is not seen
    add_box(robot.client, centre, (0.2, 0.5, 1.0), yaw=bearing)
    assert lidar.scan()[i] == np.float32(spec.range_max_m)


def test_lidar_sees_a_cylinder_beyond_the_robot_as_it_turns() -> None:
    with PybulletRobot("turtlebot3_burger") as bot:
        lidar = Lidar(bot.spec.lidar, bot)
        add_cylinder(bot.client, (0.0, 1.2, 0.3), 0.1, 0.6)
        ranges = lidar.scan()
        lx = bot.spec.lidar.xyz_m[0]
        expect = math.hypot(lx, 1.2) - 0.1
        k = int(np.argmin(ranges))
        assert ranges[k] == pytest.approx(expect, abs=0.01)
        assert math.degrees(float(lidar.angles_rad[k])) == pytest.approx(
            math.degrees(math.atan2(1.2, -lx)), abs=1.0
        )
        for _ in range(10):
            bot.step(0.0, 1.0, 0.1)
        k2 = int(np.argmin(lidar.scan()))
        turned = math.degrees(bot.pose[2])
        # the post moves clockwise in the scan by the angle the robot turned
        assert (k - k2) % 360 == pytest.approx(turned, abs=2.0)


def _camera_robot(name: str) -> PybulletRobot:
    robot = PybulletRobot(load_spec(name))
    cam = robot.spec.depth_camera
    assert cam is not None
    # a wall 1.8 m in front of the camera (its face), 4 m wide, 3 m high
    add_box(robot.client, (cam.xyz_m[0] + 1.8 + 0.05, 0.0, 1.5), (0.05, 2.0, 1.5))
    return robot


@pytest.mark.parametrize("name", ["turtlebot2", "turtlebot3_waffle_pi"])
def test_depth_camera_sees_a_wall_at_its_distance(name: str) -> None:
    robot = _camera_robot(name)
    cam_spec = robot.spec.depth_camera
    assert cam_spec is not None
    cam = DepthCamera(cam_spec, robot, width=80, height=60)
    depth = cam.render()
    assert depth.dtype == np.float32 and depth.shape == (60, 80)
    centre = depth[20:40, 25:55]
    assert float(np.nanmedian(centre)) == pytest.approx(1.8, abs=0.02)
    # along the optical axis: the whole wall reads the same depth (not the ray length)
    wall = depth[np.isfinite(depth) & (np.abs(depth - 1.8) < 0.05)]
    assert wall.size > 0.3 * depth.size
    assert float(np.std(wall)) < 0.01
    robot.close()


def test_depth_camera_nan_beyond_far_and_pose_changes_at_run_time() -> None:
    robot = _camera_robot("turtlebot2")
    cam_spec = robot.spec.depth_camera
    assert cam_spec is not None
    cam = DepthCamera(cam_spec, robot, width=64, height=48)
    xyz, rpy = cam.get_pose()
    assert xyz.tolist() == list(cam_spec.xyz_m) and rpy.tolist() == [0.0, 0.0, 0.0]
    view0 = cam.view_matrix()
    assert view0.shape == (16,)
    # look backwards (yaw pi): nothing but the ground, whose far part is beyond far_m
    cam.set_pose(xyz, (0.0, 0.0, math.pi))
    back = cam.render()
    assert np.isnan(back[: 48 // 3]).all()  # the sky above the horizon: no return -> NaN
    assert np.isfinite(back[-4:]).all()  # the floor in front of it
    assert not np.allclose(cam.view_matrix(), view0)
    # tilt down 30 deg: the floor is seen; pixel row of the optical axis reads h / sin(30)
    cam.set_pose(xyz, (0.0, math.radians(30.0), math.pi))
    down = cam.render()
    height = cam_spec.xyz_m[2] + robot.spec.base_link_height_m
    axis_depth = float(np.nanmedian(down[23:25, 30:34]))
    assert axis_depth == pytest.approx(height / math.sin(math.radians(30.0)), rel=0.02)
    cam.set_pose(xyz, rpy)
    assert np.allclose(cam.view_matrix(), view0)
    robot.close()


def test_view_matrix_matches_pybullet_for_the_camera_frame() -> None:
    with PybulletRobot("turtlebot3_waffle_pi", start_pose=(1.0, 2.0, 0.7)) as bot:
        cam_spec = bot.spec.depth_camera
        assert cam_spec is not None
        cam = DepthCamera(cam_spec, bot)
        eye, rot = cam.world_pose()
        x, y, yaw = bot.pose
        cx, cy = cam_spec.xyz_m[0], cam_spec.xyz_m[1]
        assert eye[0] == pytest.approx(x + cx * math.cos(yaw) - cy * math.sin(yaw), abs=1e-6)
        assert eye[1] == pytest.approx(y + cx * math.sin(yaw) + cy * math.cos(yaw), abs=1e-6)
        expect = p.computeViewMatrix(eye.tolist(), (eye + rot[:, 0]).tolist(), rot[:, 2].tolist())
        assert np.allclose(cam.view_matrix(), expect)
        assert cam.vfov_deg == pytest.approx(
            math.degrees(2 * math.atan(math.tan(math.radians(62.2) / 2) * 480 / 640))
        )


def test_bad_camera_arguments() -> None:
    with PybulletRobot("turtlebot2") as bot:
        spec = bot.spec.depth_camera
        assert isinstance(spec, CameraSpec)
        cam = DepthCamera(spec, bot, width=8, height=6)
        with pytest.raises(RobotsValueError, match="camera xyz"):
            cam.set_pose((0.0, 0.0), (0.0, 0.0, 0.0))
        with pytest.raises(RobotsValueError, match="camera rpy"):
            cam.set_pose((0.0, 0.0, 0.3), (0.0, float("nan"), 0.0))
        with pytest.raises(RobotsValueError, match="camera size"):
            DepthCamera(spec, bot, width=-1, height=6)


@settings(max_examples=20, deadline=None)
@given(
    bearing_deg=st.floats(-179.0, 179.0),
    dist=st.floats(0.2, 3.3),
    yaw=st.floats(-math.pi, math.pi),
)
def test_lidar_range_of_a_wall_anywhere(bearing_deg: float, dist: float, yaw: float) -> None:
    """A wall facing the lidar at any bearing/distance is read within 1 cm in its beam."""
    with PybulletRobot("turtlebot3_burger", start_pose=(0.0, 0.0, yaw)) as bot:
        lidar = Lidar(bot.spec.lidar, bot)
        lx, ly, _ = _lidar_world_xy(bot)
        i = round(bearing_deg) % 360  # the beam pointing there (1 deg beams from 0)
        world = yaw + float(lidar.angles_rad[i])
        centre = (lx + (dist + 0.05) * math.cos(world), ly + (dist + 0.05) * math.sin(world), 0.5)
        add_box(bot.client, centre, (0.05, 0.6, 0.5), yaw=world)
        assert lidar.scan()[i] == pytest.approx(dist, abs=0.01)
