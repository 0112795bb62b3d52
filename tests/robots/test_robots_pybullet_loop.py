"""The pybullet robot's physics-step loop (issue 16): how many pybullet calls a physics step
costs, and replay's sampled and every-step recordings give the same numbers."""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np
import pytest

from robots import PybulletRobot, load_spec
from robots._pybullet import pybullet as p
from robots._pybullet_robot import _WHEELS, _sampled_steps
from tests.robots._golden_drive import commands

SPEC = load_spec("turtlebot3_burger")
_CALLS = (
    "getJointStates",
    "getBaseVelocity",
    "getBasePositionAndOrientation",
    "setJointMotorControlArray",
    "applyExternalForce",
    "applyExternalTorque",
    "stepSimulation",
)


def test_a_physics_step_costs_two_reads_one_torque_write_and_the_step(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    count: Counter[str] = Counter()
    for name in _CALLS:
        real = getattr(p, name)

        def spy(*args: Any, _real: Any = real, _name: str = name, **kw: Any) -> Any:
            count[_name] += 1
            return _real(*args, **kw)

        monkeypatch.setattr(p, name, spy)
    with PybulletRobot(SPEC) as robot:
        robot.step(0.1, 0.5, 0.1)  # compile, settle
        count.clear()
        control_steps, substeps = 10, 24
        for _ in range(control_steps):
            robot.step(0.15, -0.8, 0.1)
    steps = control_steps * substeps
    assert count["stepSimulation"] == steps
    assert count["setJointMotorControlArray"] == steps
    assert count["getJointStates"] == steps
    # per substep one base-velocity read; per control step one more, and one for the result
    assert count["getBaseVelocity"] == steps + 2 * control_steps
    # the pose (yaw) once per control step for the kernel and once for the result
    assert count["getBasePositionAndOrientation"] == 2 * control_steps
    assert count["applyExternalForce"] == count["applyExternalTorque"] == 0


def test_a_torque_control_torque_acts_in_one_physics_step_only() -> None:
    # why the loop writes the torques in every physics step, and why benchmarks/bench_perf.py
    # does not take a loop that sets them once per control step as the same motion: set once
    # per 24 steps, the wheels get 1/24 of the impulse (the robot coasts between the writes)
    speeds = []
    with PybulletRobot(SPEC) as robot:
        c, body, wheels = robot.client, robot.body_id, list(_WHEELS)
        for every in (1, 24):
            robot.reset()
            for k in range(240):
                if k % every == 0:
                    p.setJointMotorControlArray(
                        body, wheels, p.TORQUE_CONTROL, forces=[0.02, 0.02], physicsClientId=c
                    )
                p.stepSimulation(physicsClientId=c)
            speeds.append(robot.velocity[0])
    # 2 x 0.02 N m on the wheels' radius for 1 s, on the rolling mass (the wheels' spin
    # inertia counted): 1.1658 m/s
    rolling_mass_kg = SPEC.drive.total_mass_kg(SPEC.geometry)
    assert speeds[0] == pytest.approx(
        2 * 0.02 * 1.0 / (SPEC.wheels.radius_m * rolling_mass_kg), rel=1e-3
    )
    assert speeds[0] / speeds[1] == pytest.approx(24.0, rel=0.01)


def test_replay_every_step_equals_replay_at_sparse_times() -> None:
    cmd = commands(SPEC, seconds=4.0)
    cmd["t_out_s"] = np.arange(0.0, 4.0, 0.25)  # sparse: read the state only around these
    every_step = {**cmd, "t_out_s": np.arange(0.0, 4.0, 1.0 / 240.0)}
    with PybulletRobot(SPEC) as robot:
        dense = robot.replay(**every_step, v0=0.05, w0=-0.1)
    with PybulletRobot(SPEC) as robot:
        sparse = robot.replay(**cmd, v0=0.05, w0=-0.1)
    for name in ("v", "w", "odom_v", "odom_w", "x_m", "y_m", "yaw_rad"):
        at_sparse = np.interp(cmd["t_out_s"], every_step["t_out_s"], getattr(dense, name))
        np.testing.assert_array_equal(at_sparse, getattr(sparse, name), err_msg=name)
    assert np.ptp(sparse.v) > 0.1 and np.ptp(sparse.yaw_rad) > 0.5
    assert 4 * robots_sampled(every_step["t_out_s"]) > 961 > 4 * robots_sampled(cmd["t_out_s"])


def robots_sampled(t_out_s: np.ndarray) -> int:
    """How many physics steps replay reads the state at for these output times (4 s run)."""
    grid = np.arange(961) / 240.0
    return int(_sampled_steps(grid, t_out_s).size)
