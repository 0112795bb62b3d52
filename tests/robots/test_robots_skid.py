"""Skid-steer drive (issue 12): track_factor and driver_track_factor in the one kernel.

Differential-drive robots keep both at 1 (the golden traces of test_robots_golden hold them
there bit for bit); a skid steer's wheel speeds follow the body through the effective track,
its driver's wheel targets through its own multiplier, and both engines agree.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots import PybulletRobot
from robots.check import check_spec
from robots.params import SCHEMA, BaseGeometry, DriveParams
from robots.reduced import ReducedDrive, simulate
from robots.spec import RobotSpec, load_spec
from robots.template import spec_text
from sysid.errors import SysidValueError
from sysid.fit import fit_drive
from tests.husky import husky_spec

GEO = BaseGeometry(
    mass_kg=50.0, yaw_inertia_kgm2=2.5, wheel_radius_m=0.165, wheel_separation_m=0.555
)


@pytest.fixture(scope="module")
def husky(tmp_path_factory: pytest.TempPathFactory) -> RobotSpec:
    """`robots new husky --drive skid` from the A200's published numbers."""
    return husky_spec(tmp_path_factory.mktemp("skid"))


def _steady(params: DriveParams, v: float, w: float, geometry: BaseGeometry = GEO) -> tuple:
    t = np.array([0.0])
    out = simulate(
        params,
        geometry,
        cmd_t_s=t,
        cmd_v=np.array([v]),
        cmd_w=np.array([w]),
        t_out_s=np.array([0.0, 20.0]),
    )
    return float(out.v[-1]), float(out.w[-1])


@settings(max_examples=25, deadline=None)
@given(chi=st.floats(1.0, 3.0), driver=st.floats(1.0, 3.0), w=st.floats(0.1, 1.5))
def test_a_yaw_command_turns_the_base_at_driver_over_track_factor(
    chi: float, driver: float, w: float
) -> None:
    """No friction, no caps: wheel targets through the driver's track, wheel speeds through
    the effective one, so the steady yaw rate is w x driver / chi (Mandow's ICR kinematics)."""
    p = DriveParams(motor_gain_nms_per_rad=5.0, track_factor=chi, driver_track_factor=driver)
    v_ss, w_ss = _steady(p, 0.3, w)
    assert v_ss == pytest.approx(0.3, rel=1e-6)
    assert w_ss == pytest.approx(w * driver / chi, rel=1e-6)


def test_scrub_droop_follows_the_skid_loop_gain() -> None:
    """Yaw Coulomb torque T_c: the loops hold w_ref - T_c / k_w with k_w = K L chi L / (2 r^2)
    (wheel speeds through the effective track, forces at the geometric half-track)."""
    k, chi, tc = 5.0, 1.7, 6.0
    p = DriveParams(
        motor_gain_nms_per_rad=k, track_factor=chi, driver_track_factor=chi, coulomb_w_nm=tc
    )
    r, sep = GEO.wheel_radius_m, GEO.wheel_separation_m
    kw = k * sep * chi * sep / (2 * r * r)
    _, w_ss = _steady(p, 0.0, 0.8)
    assert w_ss == pytest.approx(0.8 - tc / kw, rel=1e-6)
    _, w_diff = _steady(p.replace(track_factor=1.0, driver_track_factor=1.0), 0.0, 0.8)
    assert w_diff == pytest.approx(0.8 - tc / (kw / chi), rel=1e-6)


def test_the_driver_track_couples_turning_and_the_wheel_cap() -> None:
    """Both wheels are scaled together at the cap: a skid steer's turn takes wheel speed from
    the forward motion (v drops in a fast arc), more than a differential drive's does."""
    cap = 1.0 / GEO.wheel_radius_m
    base = DriveParams(motor_gain_nms_per_rad=5.0, wheel_speed_max_radps=cap)
    half = 0.5 * GEO.wheel_separation_m
    for driver in (1.0, 1.875):
        p = base.replace(track_factor=driver, driver_track_factor=driver)
        v_ss, w_ss = _steady(p, 0.8, 1.0)
        scale = cap / ((0.8 + 1.0 * driver * half) / GEO.wheel_radius_m)
        assert v_ss == pytest.approx(0.8 * scale, rel=1e-6)
        assert w_ss == pytest.approx(1.0 * scale, rel=1e-6)
    assert scale < 0.76  # the differential drive: 0.93


def test_schema_and_fit_treat_the_two_factors_right() -> None:
    chi, driver = SCHEMA["track_factor"], SCHEMA["driver_track_factor"]
    assert chi.fittable and chi.coord == "log" and chi.lower == 1.0
    assert not driver.fittable
    assert DriveParams().track_factor == 1.0 == DriveParams().driver_track_factor
    for name in ("turtlebot2", "turtlebot3_burger", "turtlebot3_waffle_pi"):
        spec = load_spec(name)
        assert spec.drive.track_factor == 1.0 and not spec.priors["track_factor"].informative
    t = np.arange(0.0, 10.0, 0.1)
    log = type(
        "Log",
        (),
        {
            "cmd_t_s": t,
            "cmd_v": np.where(t > 1, 0.2, 0.0),
            "cmd_w": np.where(t > 5, 0.5, 0.0),
            "meas_t_s": t,
            "meas_v": np.where(t > 1.2, 0.2, 0.0),
            "meas_w": np.where(t > 5.2, 0.5, 0.0),
        },
    )()
    with pytest.raises(SysidValueError, match="driver setting"):
        fit_drive([log], geometry=GEO, base_params=DriveParams(), free=["driver_track_factor"])


def test_robots_new_skid_writes_the_skid_prior(husky: RobotSpec, tmp_path: Path) -> None:
    prior = husky.priors["track_factor"]
    assert prior.nominal == pytest.approx(1.6) and prior.sd == pytest.approx(0.3)
    assert husky.drive.driver_track_factor == pytest.approx(1.6)
    assert not husky.priors["driver_track_factor"].informative
    # tread scrub: 10 % of the weight at half the track
    assert husky.drive.coulomb_w_nm == pytest.approx(0.1 * 50 * 9.81 * 0.2775, rel=1e-4)
    diff = tmp_path / "diffbot.yaml"
    diff.write_text(spec_text("diffbot", wheel_separation_m=0.555, wheel_radius_m=0.165))
    plain = load_spec(diff)
    assert plain.drive.track_factor == 1.0 and not plain.priors["track_factor"].informative


@pytest.mark.slow
def test_skid_spec_passes_robots_check(husky: RobotSpec) -> None:
    report = check_spec(husky)
    assert report.passed, report.reason()


@pytest.mark.slow
@pytest.mark.parametrize(("chi", "driver"), [(1.6, 1.6), (1.53, 1.875), (2.2, 1.5)])
def test_reduced_and_pybullet_agree_on_a_skid_steer(
    husky: RobotSpec, chi: float, driver: float
) -> None:
    """Same params, both engines: pybullet's tyres grip and the kernel's wheel-speed map
    carries the slip, so they agree as closely as on a differential drive."""
    params = husky.drive.replace(
        track_factor=chi, driver_track_factor=driver, delay_s=0.0, accel_lim_w_radps2=6.0
    )
    red = ReducedDrive(params, husky.geometry)
    commands = [(0.6, 0.0)] * 8 + [(0.6, 0.8)] * 10 + [(0.0, -1.2)] * 10 + [(1.0, 1.0)] * 10
    err_v, err_w, peak_w = [], [], 0.0
    with PybulletRobot(husky, params=params) as robot:
        for cmd in commands + [(0.0, 0.0)] * 6:
            a = robot.step(*cmd, 0.05)
            b = red.step(*cmd, 0.05)
            err_v.append(a[0] - b[0])
            err_w.append(a[1] - b[1])
            peak_w = max(peak_w, abs(b[1]))
    assert peak_w > 0.5
    assert math.sqrt(np.mean(np.square(err_v))) < 2e-3
    assert math.sqrt(np.mean(np.square(err_w))) < 5e-3
    # within the agreement tolerances (0.02 m/s, 0.1 rad/s) everywhere: agreement 1.0 >= 0.99
    assert max(map(abs, err_v)) < 0.02 and max(map(abs, err_w)) < 0.1


@pytest.mark.slow
def test_cli_robots_new_drive_skid(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from sim2real.cli import main

    out = tmp_path / "husky.yaml"
    argv = ["robots", "new", "husky", "--wheel-separation", "0.555", "--wheel-radius", "0.165"]
    assert (
        main([*argv, "--mass", "50", "--max-speed", "1.0", "--drive", "skid", "-o", str(out)]) == 0
    )
    printed = capsys.readouterr().out
    assert "track_factor" in printed and "wheel_separation_multiplier" in printed
    text = out.read_text()
    assert "  track_factor: 1.6  # prior: skid steer" in text
    assert "  track_factor: {sd: 0.3, session_sd: 0.1}" in text
    assert load_spec(out).priors["track_factor"].informative
