"""Robot specs: shipped files, derived geometry (golden numbers), bad files, generated URDF, CLI."""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
import yaml

from robots import list_robots, load_spec
from robots._urdf import urdf_path, urdf_text
from robots.errors import SpecError, UnknownRobotError
from robots.params import DriveParams
from sim2real.cli import main

ROBOTS = ["turtlebot2", "turtlebot3_burger", "turtlebot3_waffle_pi"]


def test_list_robots_has_the_three_shipped_specs() -> None:
    assert list_robots() == ROBOTS


@pytest.mark.parametrize("name", ROBOTS)
def test_spec_loads_and_round_trips_through_yaml(name: str, tmp_path: Path) -> None:
    spec = load_spec(name)
    assert spec.name == name
    assert spec.sources and all(s.startswith("[") for s in spec.sources)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(spec.to_dict(), sort_keys=False))
    assert dataclasses.replace(load_spec(path), path=spec.path) == spec


def test_burger_published_numbers_and_effective_geometry() -> None:
    spec = load_spec("turtlebot3_burger")
    assert spec.base_mass_kg == 0.82573504
    assert spec.wheels.radius_m == 0.033 and spec.wheels.separation_m == 0.16
    assert (spec.max_v_mps, spec.max_w_radps) == (0.22, 2.84)
    assert spec.lidar.beams == 360 and spec.lidar.range_min_m == 0.12
    assert spec.lidar.angle_increment_rad == pytest.approx(math.radians(1.0))
    assert spec.depth_camera is None
    # rigid: base + LDS + caster + 2 wheels; effective adds 2 J/r^2 of the spinning wheels
    rigid = 0.82573504 + 0.114 + 0.005 + 2 * 0.028498940
    assert spec.rigid_mass_kg == pytest.approx(rigid, rel=1e-12)
    assert spec.geometry.mass_kg == pytest.approx(rigid + 2 * 2.0712558e-5 / 0.033**2, rel=1e-12)
    izz = 2.0064271e-3 + 0.114 * 0.032**2 + 0.005 * 0.081**2
    izz += 2 * (1.1175580e-5 + (0.028498940 + 2.0712558e-5 / 0.033**2) * 0.08**2)
    assert spec.geometry.yaw_inertia_kgm2 == pytest.approx(izz, rel=1e-12)
    # Dynamixel cap 77.17 rpm [FW-M]
    assert spec.drive.wheel_speed_max_radps == pytest.approx(337 * 0.229 * 2 * math.pi / 60, 1e-4)


def test_turtlebot2_kobuki_numbers_and_camera_mount() -> None:
    spec = load_spec("turtlebot2")
    assert spec.drive.delay_s == 0.2 and spec.drive.cmd_timeout_s == 0.6
    assert (spec.drive.accel_lim_v_mps2, spec.drive.accel_lim_w_radps2) == (1.0, 2.0)
    cam = spec.depth_camera
    assert cam is not None
    assert cam.xyz_m == (-0.087, 0.0125, 0.287) and cam.hfov_deg == 60.0
    assert (cam.near_m, cam.far_m, cam.width, cam.height) == (0.05, 8.0, 640, 480)
    assert spec.body.shape == "cylinder" and spec.body.size_m[0] == pytest.approx(0.356)
    left, right = spec.wheel_positions_m
    assert left == pytest.approx((0.0, 0.115, 0.035 - 0.0102))
    assert right[1] == -0.115


@pytest.mark.parametrize("name", ROBOTS)
def test_motor_gain_gives_the_documented_time_constant(name: str) -> None:
    spec = load_spec(name)
    g, k = spec.geometry, spec.drive.motor_gain_nms_per_rad
    tau = g.mass_kg * g.wheel_radius_m**2 / (2 * k)
    assert tau == pytest.approx(0.1 if name == "turtlebot2" else 0.05, rel=1e-3)


@pytest.mark.parametrize("name", ROBOTS)
def test_spec_speed_caps_are_within_the_wheel_cap(name: str) -> None:
    spec = load_spec(name)
    r, half = spec.wheels.radius_m, spec.wheels.separation_m / 2
    cap = spec.drive.wheel_speed_max_radps
    assert spec.max_v_mps / r <= cap
    assert spec.max_w_radps * half / r <= cap


def test_unknown_robot_lists_the_known_ones() -> None:
    with pytest.raises(UnknownRobotError) as err:
        load_spec("turtlebot9")
    assert "turtlebot9" in str(err.value)
    for name in ROBOTS:
        assert name in str(err.value)
    assert isinstance(err.value, KeyError)


def test_missing_spec_file_path_is_reported(tmp_path: Path) -> None:
    with pytest.raises(UnknownRobotError, match="does not exist"):
        load_spec(tmp_path / "absent.yaml")


def _doc() -> dict[str, Any]:
    return load_spec("turtlebot3_burger").to_dict()


def _write(tmp_path: Path, doc: Any) -> Path:
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _mutations() -> list[tuple[str, Any, str]]:
    def missing(doc: dict[str, Any]) -> None:
        del doc["wheels"]["radius_m"]

    def unknown(doc: dict[str, Any]) -> None:
        doc["base"]["colour"] = "red"

    def neg_mass(doc: dict[str, Any]) -> None:
        doc["base"]["mass_kg"] = -1.0

    def neg_delay(doc: dict[str, Any]) -> None:
        doc["drive"]["delay_s"] = -0.1

    def missing_drive(doc: dict[str, Any]) -> None:
        del doc["drive"]["coulomb_w_nm"]

    def bad_range(doc: dict[str, Any]) -> None:
        doc["lidar"]["range_max_m"] = 0.05

    def bad_type(doc: dict[str, Any]) -> None:
        doc["limits"]["max_v_mps"] = "fast"

    def bad_odom(doc: dict[str, Any]) -> None:
        doc["odometry"]["w_source"] = "compass"

    def top_unknown(doc: dict[str, Any]) -> None:
        doc["colour"] = "red"

    def zero_speed_cap(doc: dict[str, Any]) -> None:
        doc["drive"]["wheel_speed_max_radps"] = 0.0

    return [
        ("wheels.radius_m", missing, "missing"),
        ("base.colour", unknown, "unknown"),
        ("base.mass_kg", neg_mass, "> 0"),
        ("delay_s", neg_delay, ">= 0"),
        ("drive.coulomb_w_nm", missing_drive, "missing"),
        ("lidar.range_max_m", bad_range, "range_min_m"),
        ("limits.max_v_mps", bad_type, "number"),
        ("odometry.w_source", bad_odom, "one of"),
        ("colour", top_unknown, "unknown"),
        ("wheel_speed_max_radps", zero_speed_cap, "> 0"),
    ]


@pytest.mark.parametrize(("key", "mutate", "rule"), _mutations(), ids=[m[0] for m in _mutations()])
def test_bad_spec_files_name_the_key(tmp_path: Path, key: str, mutate: Any, rule: str) -> None:
    doc = _doc()
    mutate(doc)
    with pytest.raises(SpecError) as err:
        load_spec(_write(tmp_path, doc))
    msg = str(err.value)
    assert key in msg and rule in msg and "bad.yaml" in msg
    assert isinstance(err.value, ValueError)


def test_spec_that_is_not_a_mapping_or_not_yaml(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="mapping"):
        load_spec(_write(tmp_path, [1, 2]))
    path = tmp_path / "broken.yaml"
    path.write_text("name: [unclosed\n")
    with pytest.raises(SpecError, match="not valid YAML"):
        load_spec(path)


def test_with_params_replaces_the_drive_defaults() -> None:
    spec = load_spec("turtlebot3_burger")
    other = spec.with_params(DriveParams(delay_s=0.3))
    assert other.drive.delay_s == 0.3 and spec.drive.delay_s == 0.05


@pytest.mark.parametrize("name", ROBOTS)
def test_generated_urdf_has_the_spec_bodies(name: str) -> None:
    spec = load_spec(name)
    root = ET.fromstring(urdf_text(spec))
    links = {link.get("name"): link for link in root.iter("link")}
    assert {"base_link", "wheel_left_link", "wheel_right_link", "lidar_link"} <= set(links)
    assert ("camera_link" in links) == (spec.depth_camera is not None)
    joints = {j.get("name"): j for j in root.iter("joint")}
    for side, sign in (("left", 1), ("right", -1)):
        joint = joints[f"wheel_{side}_joint"]
        assert joint.get("type") == "continuous"
        origin = joint.find("origin")
        assert origin is not None
        xyz = [float(x) for x in origin.get("xyz", "").split()]
        assert xyz[1] == pytest.approx(sign * spec.wheels.separation_m / 2)
    masses = [float(m.get("value", "nan")) for m in root.iter("mass")]
    assert sum(masses) == pytest.approx(spec.rigid_mass_kg, abs=1e-5)
    spheres = links["base_link"].findall("collision/geometry/sphere")
    assert len(spheres) == len(spec.casters)
    assert urdf_path(spec).read_text() == urdf_text(spec)


def test_cli_robots_list(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "list"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:3] == ["name", "mass_kg", "wheel_r_m"]
    burger = next(line for line in out if line.startswith("turtlebot3_burger"))
    assert "1.002" in burger and "0.160" in burger and "2.84" in burger and "lidar 360x" in burger
    assert len(out) == 1 + len(ROBOTS)


def test_cli_robots_show_and_yaml(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["robots", "show", "turtlebot2"]) == 0
    out = capsys.readouterr().out
    assert "delay_s" in out and "0.2" in out and "[KI]" in out and "cmd_timeout_s" in out
    assert main(["robots", "show", "turtlebot2", "--yaml"]) == 0
    path = tmp_path / "tb2.yaml"
    path.write_text(capsys.readouterr().out)
    assert dataclasses.replace(load_spec(path), path=load_spec("turtlebot2").path) == load_spec(
        "turtlebot2"
    )


def test_cli_unknown_robot_exits_2_listing_names(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "show", "r2d2"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sim2real: error:") and "turtlebot3_burger" in err
    assert "Traceback" not in err


def test_cli_help_ends_with_examples(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["robots", "show", "--help"])
    assert "examples:" in capsys.readouterr().out
