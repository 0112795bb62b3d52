"""Every fit result loads into pybullet: a fitted total mass or yaw inertia never takes the
base link's own below zero (issue 12: a negative ``added_yaw_inertia_kgm2`` fitted on the
Neato's raw twist once left pybullet's base link with a negative yaw inertia)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots import PybulletRobot
from robots.params import SCHEMA
from robots.spec import RobotSpec, load_spec, lumped_base_inertia, lumped_base_mass_kg
from robots.template import spec_text
from sim2real.logs import read_trace
from sysid._coords import COORDS, Mapper, soft_floor, soft_floor_inverse
from sysid.fit import fit_drive
from sysid.synthetic import step_commands, synthetic_log

SHIPPED = ("turtlebot2", "turtlebot3_burger", "turtlebot3_waffle_pi")


@pytest.fixture(scope="module")
def neato(tmp_path_factory: pytest.TempPathFactory) -> RobotSpec:
    path = tmp_path_factory.mktemp("guard") / "neato.yaml"
    path.write_text(spec_text("neato", wheel_separation_m=0.248, max_speed_mps=0.3))
    return load_spec(path)


def _base_link(spec: RobotSpec, added_mass_kg: float, added_izz: float) -> tuple[float, float]:
    """Mass and yaw inertia pybullet's base link gets (PybulletRobot.set_drive_params)."""
    return lumped_base_mass_kg(spec) + added_mass_kg, lumped_base_inertia(spec)[2] + added_izz


def test_geometry_knows_the_wheels_part() -> None:
    for name in SHIPPED:
        spec = load_spec(name)
        g = spec.geometry
        mass, izz = _base_link(spec, 0.0, 0.0)
        assert g.mass_kg - g.wheels_mass_kg == pytest.approx(mass, rel=1e-12)
        assert g.yaw_inertia_kgm2 - g.wheels_yaw_inertia_kgm2 == pytest.approx(izz, rel=1e-12)
        # the schema's plausible floor leaves the base link 10 % of its own
        lo = math.exp(SCHEMA["added_yaw_inertia_kgm2"].coord_bounds(g)[0])
        assert lo - g.wheels_yaw_inertia_kgm2 == pytest.approx(0.1 * izz, rel=1e-9)


@given(
    y=st.floats(1e-9, 10.0),
    hard=st.floats(1e-4, 1.0),
    gap=st.floats(1e-4, 1.0),
)
def test_soft_floor_is_smooth_monotone_and_invertible(y: float, hard: float, gap: float) -> None:
    knee = hard + gap
    total = soft_floor(y, hard, knee)
    assert total >= hard
    assert soft_floor(y * 1.01, hard, knee) >= total
    if y >= knee:
        assert total == y
    if total > hard * (1 + 1e-9) + 1e-12:
        assert soft_floor(soft_floor_inverse(total, hard, knee), hard, knee) == pytest.approx(
            total, rel=1e-9
        )
    eps = 1e-7 * knee  # continuous value and slope at the knee
    below = soft_floor(knee - eps, hard, knee)
    assert below == pytest.approx(knee - eps, rel=1e-5)


@settings(max_examples=60, deadline=None)
@given(
    which=st.sampled_from(SHIPPED),
    u_mass=st.floats(0.0, 1.0),
    u_izz=st.floats(0.0, 1.0),
    u_gain=st.floats(0.0, 1.0),
)
def test_every_internal_point_leaves_the_base_link_positive(
    which: str, u_mass: float, u_izz: float, u_gain: float
) -> None:
    """Anywhere inside the optimiser's box (motor gain included), the base link stays > 0."""
    spec = load_spec(which)
    mapper = Mapper(spec.geometry, spec.drive, spec.priors)
    values = {
        f: COORDS[f].lower + u * (COORDS[f].upper - COORDS[f].lower)
        for f, u in (
            ("added_mass_kg", u_mass),
            ("added_yaw_inertia_kgm2", u_izz),
            ("motor_gain_nms_per_rad", u_gain),
        )
    }
    params = mapper.from_coords(values, {})
    mass, izz = _base_link(spec, params.added_mass_kg, params.added_yaw_inertia_kgm2)
    assert mass >= 0.5 * 0.1 * lumped_base_mass_kg(spec) * (1 - 1e-9)
    assert izz >= 0.5 * 0.1 * lumped_base_inertia(spec)[2] * (1 - 1e-9)


@pytest.mark.slow
def test_fit_of_a_too_light_truth_loads_into_pybullet() -> None:
    """A log whose yaw inertia is below what the wheels alone hold: the fit stops at the
    floor, says so, and pybullet takes the result."""
    spec = load_spec("turtlebot3_burger")
    g = spec.geometry
    truth = spec.drive.replace(delay_s=0.05, added_yaw_inertia_kgm2=-0.97 * g.yaw_inertia_kgm2)
    t, v, w = step_commands(25.0, seed=4, v_max_mps=0.2, w_max_radps=2.0)
    log = synthetic_log(truth, g, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=4, spike_mps=None)
    free = ["delay_s", "added_yaw_inertia_kgm2"]  # the gain held: only the inertia can move
    result = fit_drive([log], geometry=g, base_params=spec.drive, robot=spec.name, free=free)
    _, izz = _base_link(spec, 0.0, result.params.added_yaw_inertia_kgm2)
    assert 0 < izz < 0.1 * lumped_base_inertia(spec)[2]
    assert any("added_yaw_inertia_kgm2" in w and "base link" in w for w in result.warnings)
    with PybulletRobot(spec, params=result.params) as robot:
        v1, _ = robot.step(0.1, 0.0, 0.3)
    assert v1 > 0.03


@pytest.mark.realdata
@pytest.mark.slow
def test_neato_raw_twist_fit_loads_into_pybullet(neato_log: Path, neato: RobotSpec) -> None:
    """The case seen in session 2: the raw twist, fitted on the part from 35 s on."""
    trace = read_trace(neato_log, odom_velocity="twist")
    part = trace.window(35.0, trace.duration_s + 1)
    result = fit_drive([part], geometry=neato.geometry, base_params=neato.drive, robot="neato")
    mass, izz = _base_link(neato, result.params.added_mass_kg, result.params.added_yaw_inertia_kgm2)
    assert mass > 0 and izz > 0
    with PybulletRobot(neato, params=result.params) as robot:
        v1, _ = robot.step(0.2, 0.0, 0.5)
    assert np.isfinite(v1) and v1 > 0.05
