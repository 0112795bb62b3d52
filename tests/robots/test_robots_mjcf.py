"""robots.mjcf: the one mapping of drive parameters onto the MJCF model, and its text."""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import xml.etree.ElementTree as ET

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.errors import ParamsFileError
from robots.mjcf import (
    MAX_TYRE_FRICTION,
    check_drive_kind,
    mjcf_mapping,
    mjcf_text,
    wheel_torque_cap_nm,
)
from robots.params import DriveParams
from robots.spec import RobotSpec, list_robots, load_spec


@pytest.mark.parametrize("name", list_robots())
def test_every_drive_field_has_one_place(name: str) -> None:
    spec = load_spec(name)
    entries = mjcf_mapping(spec, spec.drive)
    sources = {s.strip() for e in entries for s in e.source.split(",")}
    # every DriveParams field is carried by the MJCF or by MujocoDrive
    missing = set(DriveParams.names()) - sources - {"coulomb_*", "viscous_*"}
    assert missing == set()
    assert len({e.name for e in entries}) == len(entries)


def test_text_carries_the_identified_values() -> None:
    spec = load_spec("turtlebot2")
    params = spec.drive.replace(
        added_mass_kg=1.5,
        added_yaw_inertia_kgm2=0.02,
        motor_gain_nms_per_rad=0.123,
        wheel_torque_max_nm=0.75,
        wheel_speed_max_radps=9.5,
        viscous_v_ns_per_m=0.7,
        coulomb_v_fwd_n=0.4,
        coulomb_w_nm=0.05,
        viscous_w_nms_per_rad=0.03,
    )
    root = ET.fromstring(mjcf_text(spec, params))
    base = root.find(".//body[@name='base_link']/inertial")
    assert base is not None
    by_name = {e.name: e.value for e in mjcf_mapping(spec, params)}
    assert float(base.get("mass", "nan")) == pytest.approx(by_name["base_mass"], rel=1e-8)
    assert by_name["base_mass"] == pytest.approx(spec.base_mass_kg + 1.5 + 0.0, abs=0.5)
    izz = float(base.get("diaginertia", "").split()[2])
    assert izz == pytest.approx(by_name["base_yaw_inertia"], rel=1e-8)
    speed = root.findall(".//velocity")
    assert [float(a.get("kv", "nan")) for a in speed] == [0.123, 0.123]
    assert {a.get("ctrlrange") for a in speed} == {"-9.5 9.5"}
    joints = root.findall(".//joint[@type='hinge']")
    assert {j.get("actuatorfrcrange") for j in joints} == {"-0.75 0.75"}
    fwd = root.find(".//tendon/fixed[@name='forward']")
    yaw = root.find(".//tendon/fixed[@name='yaw']")
    assert fwd is not None and yaw is not None
    assert (fwd.get("damping"), fwd.get("frictionloss")) == ("0.7", "0.4")
    assert (yaw.get("damping"), yaw.get("frictionloss")) == ("0.03", "0.05")
    r, sep = spec.wheels.radius_m, spec.wheels.separation_m
    assert [float(j.get("coef", "nan")) for j in fwd] == pytest.approx([r / 2, r / 2])
    assert [float(j.get("coef", "nan")) for j in yaw] == pytest.approx([-r / sep, r / sep])


def test_every_value_is_commented_with_its_field() -> None:
    spec = load_spec("turtlebot3_burger")
    text = mjcf_text(spec, spec.drive)
    comments = " ".join(re.findall(r"<!--(.*?)-->", text, flags=re.S))
    for entry in mjcf_mapping(spec, spec.drive):
        for source in entry.source.split(","):
            if "*" not in source:
                assert source.strip() in comments, entry.name


def test_no_limit_is_an_unlimited_range_and_the_torque_is_the_grip() -> None:
    spec = load_spec("turtlebot3_burger")
    params = spec.drive.replace(wheel_torque_max_nm=math.inf, wheel_speed_max_radps=math.inf)
    root = ET.fromstring(mjcf_text(spec, params))
    assert {a.get("ctrlrange") for a in root.findall(".//velocity")} == {"0 0"}
    # no torque cap: what a tyre carries at MAX_TYRE_FRICTION under half the weight
    grip = MAX_TYRE_FRICTION * 0.5 * spec.geometry.mass_kg * 9.81 * spec.wheels.radius_m
    assert wheel_torque_cap_nm(spec, params) == pytest.approx(grip)
    ranges = {j.get("actuatorfrcrange") for j in root.findall(".//joint[@type='hinge']")}
    assert ranges == {f"{-grip:.9g} {grip:.9g}"}


def test_skid_params_on_a_diff_spec_refused() -> None:
    spec = load_spec("turtlebot2")
    with pytest.raises(ParamsFileError, match=r"track_factor 1\.7 \(a skid steer\).*turtlebot2"):
        check_drive_kind(spec, spec.drive.replace(track_factor=1.7))
    check_drive_kind(spec, spec.drive)  # its own drive is fine


def test_docs_table_is_the_mapping() -> None:
    """docs/mujoco.md prints mjcf_mapping's rows (field, place, note) for turtlebot3_burger."""
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[2] / "docs" / "mujoco.md").read_text()
    spec = load_spec("turtlebot3_burger")
    rows = [line for line in doc.splitlines() if line.startswith("| `")]
    entries = mjcf_mapping(spec, spec.drive)
    assert len(rows) == len(entries)
    for row, entry in zip(rows, entries, strict=True):
        source, place, field, note = (c.strip() for c in row.strip("|").split("|"))
        assert source.replace("`", "") == entry.source
        assert place == (entry.mjcf or "`MujocoDrive`")
        assert field == ("" if entry.model is None else f"`{entry.model[2]}`")
        assert note == entry.note


@functools.cache
def _spec(name: str) -> RobotSpec:
    """``load_spec(name)``, parsed once: reading the YAML is most of an example's time."""
    return load_spec(name)


@pytest.mark.parametrize("name", list_robots())
@settings(max_examples=200, deadline=None)
@given(added=st.floats(min_value=0.0, max_value=0.2))
def test_written_inertia_keeps_the_triangle_inequality(name: str, added: float) -> None:
    # MuJoCo refuses a body whose diaginertia breaks A + B >= C; roll and pitch are raised to
    # half the yaw inertia, and the 9-digit text must not round that below C
    spec = _spec(name)
    params = dataclasses.replace(spec.drive, added_yaw_inertia_kgm2=added)
    base = ET.fromstring(mjcf_text(spec, params)).find(".//body[@name='base_link']/inertial")
    assert base is not None
    a, b, c = (float(x) for x in base.get("diaginertia", "").split())
    assert a + b >= c
