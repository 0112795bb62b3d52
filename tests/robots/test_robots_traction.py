"""Tyre grip of the pybullet robot: its tyres carry whatever forces the drive chain asks (issue 11).

The reduced model has no wheel slip: its wheel forces are whatever the loops, the torque cap and
the axis friction give. The pybullet robot carries all of them through its tyres, whose normal
load falls under hard braking (the base pitches onto a caster: the load moves by
:math:`m a h / x_c`). A drive that asks more than the tyres' friction times that load made the
pybullet wheels spin (a fitted P3-DX: 94-97 % agreement, max |dv| 0.25 m/s in reversals).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from robots import PybulletRobot, load_spec, simulate
from robots.params import DriveParams
from robots.pybullet_robot import MIN_LOAD_FRACTION, WHEEL_FRICTION, tyre_friction
from robots.spec import RobotSpec

ROBOTS = ["turtlebot2", "turtlebot3_burger", "turtlebot3_waffle_pi"]
G = 9.81


def _strong(spec: RobotSpec, mu: float) -> DriveParams:
    """The spec's drive with a torque cap whose tyre force is ``mu`` times the static wheel load,
    a P gain that reaches it at half the top wheel speed, and a viscous drag of 3 /s of
    the mass (fitted drives reach 3.8 /s): a reversal at the top speed brakes at > mu g."""
    d, r = spec.drive, spec.wheels.radius_m
    tau = mu * 0.5 * spec.rigid_mass_kg * G * r
    return dataclasses.replace(
        d,
        wheel_torque_max_nm=tau,
        motor_gain_nms_per_rad=tau / (0.5 * d.wheel_speed_max_radps),
        viscous_v_ns_per_m=3.0 * spec.rigid_mass_kg,
        accel_lim_v_mps2=math.inf,
        accel_lim_w_radps2=math.inf,
    )


@pytest.mark.parametrize("name", ROBOTS)
def test_shipped_drives_keep_the_default_tyres(name: str) -> None:
    # their drives ask mu 0.60 / 0.82 / 0.63 of the load left in a top-speed reversal
    spec = load_spec(name)
    assert tyre_friction(spec, spec.drive) == WHEEL_FRICTION


def test_tyre_friction_golden_p3dx_like() -> None:
    """A 9 kg base, r = 0.0975 m, L = 0.33 m, centre of mass 0.0975 m up, casters at +-0.3 m.

    By hand (g = 9.81): torque cap 2 N m -> 20.513 N per wheel; friction 3 N + 30 N s/m x
    1.2 m/s = 39 N -> 19.5 N per wheel; yaw friction 0.5 N m + 0.5 N m s x 7.2727 rad/s = 4.1364
    N m -> 12.534 N per wheel: F = 52.547 N. Braking at a = (41.026 + 39) / 9 = 8.8917 m/s^2
    moves 9 x 8.8917 x 0.0975 / 0.6 = 13.004 N off each wheel, a_lat = 1.2^2 / 0.66 = 2.1818
    m/s^2 moves 9 x 2.1818 x 0.0975 / 0.33 = 5.8017 N off the outer one, both doubled (steps):
    N = 44.145 - 2 (13.004 + 5.8017) = 6.5334 N, mu = 52.547 / 6.5334 = 8.0429 (lateral 1.50).
    """
    spec = load_spec("turtlebot3_burger")
    wheels = dataclasses.replace(spec.wheels, radius_m=0.0975, separation_m=0.33, mass_kg=0.0)
    casters = tuple(
        dataclasses.replace(c, xyz_m=(x, 0.0, c.xyz_m[2]), mass_kg=0.0)
        for c, x in zip(spec.casters[:2], (0.3, -0.3), strict=True)
    )
    base = dataclasses.replace(
        spec, wheels=wheels, casters=casters, point_masses=(), base_link_height_m=0.0975
    )
    base = dataclasses.replace(base, base_mass_kg=9.0)
    assert base.rigid_mass_kg == pytest.approx(9.0, abs=1e-12)
    drive = dataclasses.replace(
        spec.drive,
        speed_lim_v_mps=math.inf,
        speed_lim_w_radps=math.inf,
        wheel_speed_max_radps=1.2 / 0.0975,
        wheel_torque_max_nm=2.0,
        wheel_stall_torque_nm=math.inf,
        wheel_no_load_speed_radps=math.inf,
        coulomb_v_fwd_n=3.0,
        coulomb_v_bwd_n=2.0,
        coulomb_w_nm=0.5,
        viscous_v_ns_per_m=30.0,
        viscous_w_nms_per_rad=0.5,
        added_mass_kg=0.0,
    )
    assert tyre_friction(base, drive) == pytest.approx(8.0429, rel=1e-4)
    # a base that tips onto a caster at the drive's peak: the load floor
    heavy = dataclasses.replace(drive, wheel_torque_max_nm=8.0)
    floor = MIN_LOAD_FRACTION * 0.5 * 9.0 * G
    force = 8.0 / 0.0975 + 19.5 + 4.1364 / 0.33
    assert tyre_friction(base, heavy) == pytest.approx(force / floor, rel=1e-4)


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("turn", [0.0, 1.0])
def test_hard_reversal_agrees_with_the_reduced_model(name: str, turn: float) -> None:
    spec = load_spec(name)
    params = _strong(spec, 1.6)
    v_top = min(params.speed_lim_v_mps, params.wheel_speed_max_radps * spec.wheels.radius_m)
    w_cmd = turn * min(params.speed_lim_w_radps, 0.5 * v_top / spec.wheels.separation_m)
    # top speed, a reversal at 1.5 s, another at 2.5 s, a stop at 3.5 s; sent at 10 Hz (timeouts)
    cmd_t = np.arange(0.0, 4.5, 0.1)
    sign = np.where(cmd_t < 1.5, 1.0, np.where(cmd_t < 2.5, -1.0, np.where(cmd_t < 3.5, 1.0, 0.0)))
    cmd_v, cmd_w = sign * v_top, sign * w_cmd
    t = np.arange(0.0, 4.5, 0.01)
    red = simulate(params, spec.geometry, cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=t)
    with PybulletRobot(spec, params=params) as bot:
        pb = bot.replay(cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=t)
    # the reversals brake at more than 1 g (their tyre forces exceed 1.5 x the load left)
    assert np.max(np.abs(np.diff(red.v))) / 0.01 > G
    assert np.max(np.abs(pb.v - red.v)) <= 0.02
    assert np.max(np.abs(pb.w - red.w)) <= 0.1
