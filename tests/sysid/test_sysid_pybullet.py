"""Sysid on logs from the pybullet robot (real rigid bodies) with known hidden parameters."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robots.pybullet_robot import PybulletRobot
from robots.spec import load_spec
from sysid import LogArrays, fit_drive
from sysid._coords import Mapper
from sysid.synthetic import degrade_odometry, step_commands

SPEC = load_spec("turtlebot3_burger")
TRUTH = SPEC.drive.replace(
    delay_s=0.12,
    added_mass_kg=0.4,
    added_yaw_inertia_kgm2=0.004,
    coulomb_v_fwd_n=0.3,
    coulomb_v_bwd_n=0.3,
    coulomb_w_nm=0.01,
    viscous_v_ns_per_m=0.5,
    accel_lim_v_mps2=1.0,
    accel_lim_w_radps2=5.0,
)
ODOM_STEPS = 5  # physics steps (240 Hz) per odometry sample: 48 Hz
CMD_EVERY = 5  # odometry samples per command: ~10 Hz, like a ROS planner


def _pybullet_log(duration_s: float, seed: int, spike: float | None) -> LogArrays:
    _, v, w = step_commands(duration_s, seed=seed, v_max_mps=0.2, w_max_radps=2.0)
    robot = PybulletRobot(SPEC, params=TRUTH)
    dt = ODOM_STEPS / robot.physics_hz
    cmd_t, meas_t, meas_v, meas_w = [], [], [], []
    try:
        for cv, cw in zip(v, w, strict=True):
            cmd_t.append(robot.time_s)
            robot.step(float(cv), float(cw), dt)
            for k in range(CMD_EVERY):
                if k:
                    robot.advance(dt)
                ov, ow = robot.odometry()
                meas_t.append(robot.time_s)
                meas_v.append(ov)
                meas_w.append(ow)
    finally:
        robot.close()
    # one Dynamixel tick (4096/rev) per odometry period
    quantum = 2 * math.pi / 4096 * SPEC.geometry.wheel_radius_m / dt
    t, mv, mw = degrade_odometry(
        np.asarray(meas_t),
        np.asarray(meas_v),
        np.asarray(meas_w),
        seed=seed,
        quantum_v_mps=quantum,
        spike_mps=spike,
    )
    return LogArrays(
        cmd_t_s=np.asarray(cmd_t),
        cmd_v=v,
        cmd_w=w,
        meas_t_s=t,
        meas_v=mv,
        meas_w=mw,
        name=f"pybullet-{seed}",
    )


@pytest.mark.slow
def test_fit_recovers_pybullet_truth() -> None:
    train = _pybullet_log(60.0, seed=1, spike=1.35)
    val = _pybullet_log(30.0, seed=2, spike=None)
    res = fit_drive([train], geometry=SPEC.geometry, base_params=SPEC.drive, validate=[val])
    assert abs(res.params.delay_s - TRUTH.delay_s) <= 0.010
    truth = Mapper(SPEC.geometry, SPEC.drive).identifiable(TRUTH)
    checked = 0
    for est in res.identifiable:
        if est.status == "fixed" or est.name == "delay_s":
            continue
        assert est.value == pytest.approx(truth[est.name][0], rel=0.10), est.name
        checked += 1
    assert checked >= 12
    (score,) = res.scores_validation
    assert score.fit_percent_v >= 90 and score.fit_percent_w >= 90
