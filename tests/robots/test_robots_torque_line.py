"""The motors' torque-speed line (``wheel_stall_torque_nm``, ``wheel_no_load_speed_radps``) in
the one drive kernel: its envelope, the top speed it gives, its stability, both engines."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots import PybulletRobot, load_spec, simulate
from robots._kernel import pack_params, torque_limits
from robots.params import BaseGeometry, DriveParams

GEO = BaseGeometry(
    mass_kg=2.0, yaw_inertia_kgm2=0.03, wheel_radius_m=0.035, wheel_separation_m=0.23
)


def test_envelope_is_the_dc_motor_line_capped_by_the_current_limit() -> None:
    # stall 0.5 N m, no-load 20 rad/s, cap 0.3 N m
    assert torque_limits(0.0, 0.3, 0.5, 20.0) == (-0.3, 0.3)  # at rest the cap binds
    lo, hi = torque_limits(10.0, 0.3, 0.5, 20.0)
    assert hi == pytest.approx(0.25) and lo == -0.3  # driving: the line; braking: the cap
    lo, hi = torque_limits(-16.0, 0.3, 0.5, 20.0)
    assert lo == pytest.approx(-0.1) and hi == 0.3  # backwards, mirrored
    lo, hi = torque_limits(20.0, 0.3, 0.5, 20.0)
    assert hi == pytest.approx(0.0)  # no torque left at the no-load speed
    assert torque_limits(30.0, 0.3, 0.5, math.inf) == (-0.3, 0.3)  # no line: the flat cap


def test_no_line_unless_both_ends_are_finite() -> None:
    p = pack_params(DriveParams(wheel_torque_max_nm=0.2, wheel_stall_torque_nm=0.5), GEO)
    assert math.isinf(p[20])
    p = pack_params(DriveParams(wheel_no_load_speed_radps=20.0), GEO)
    assert math.isinf(p[19]) and math.isinf(p[20])


def _straight(params: DriveParams, v_cmd: float, dt_s: float = 1.0 / 240.0) -> np.ndarray:
    t = np.arange(0.0, 6.0, 0.02)
    resp = simulate(
        params,
        GEO,
        cmd_t_s=np.array([0.0]),
        cmd_v=np.array([v_cmd]),
        cmd_w=np.array([0.0]),
        t_out_s=t,
        dt_s=dt_s,
    )
    return np.asarray(resp.v)


def test_top_speed_is_where_the_line_meets_the_load() -> None:
    """A stiff loop commanded past the no-load speed: the base settles where the line's torque
    equals the viscous load, 2 tau_s (1 - v/(r w0)) / r = b v."""
    tau_s, w0, b, r = 0.4, 20.0, 3.0, GEO.wheel_radius_m
    params = DriveParams(
        motor_gain_nms_per_rad=1.0,
        wheel_stall_torque_nm=tau_s,
        wheel_no_load_speed_radps=w0,
        viscous_v_ns_per_m=b,
    )
    v = _straight(params, 1.5)  # 1.5 m/s: far above w0 r = 0.7 m/s
    expect = (2.0 * tau_s / r) / (b + 2.0 * tau_s / (r * r * w0))
    assert v[-1] == pytest.approx(expect, rel=1e-3)
    assert expect < w0 * r
    flat = _straight(params.replace(wheel_no_load_speed_radps=math.inf), 1.5)
    assert flat[-1] > 1.4  # without the line the same loop reaches the command


def test_line_only_slows_what_runs_near_the_no_load_speed() -> None:
    base = DriveParams(motor_gain_nms_per_rad=0.05, wheel_torque_max_nm=0.3, viscous_v_ns_per_m=6.0)
    line = base.replace(wheel_stall_torque_nm=0.5, wheel_no_load_speed_radps=40.0)
    slow_flat, slow_line = _straight(base, 0.1), _straight(line, 0.1)
    assert np.max(np.abs(slow_flat - slow_line)) < 1e-12  # 2.9 rad/s of 40: not felt
    fast_flat, fast_line = _straight(base, 1.2), _straight(line, 1.2)
    # 32 rad/s of 40: the line's 0.1 N m is below the 0.117 N m the load needs
    assert fast_line[-1] < fast_flat[-1] - 0.03


@settings(max_examples=25, deadline=None)
@given(
    stall=st.floats(0.05, 50.0),
    w0=st.floats(0.5, 100.0),
    dt=st.sampled_from([1.0 / 240.0, 0.02, 0.05]),
)
def test_steep_lines_stay_stable_at_any_step(stall: float, w0: float, dt: float) -> None:
    """The back-EMF term is implicit: even a line 100x steeper than the loop never overshoots
    the no-load speed or oscillates."""
    params = DriveParams(
        motor_gain_nms_per_rad=0.05,
        wheel_stall_torque_nm=stall,
        wheel_no_load_speed_radps=w0,
        viscous_v_ns_per_m=0.1,
    )
    v = _straight(params, 5.0, dt_s=dt)
    assert np.all(np.isfinite(v))
    assert np.max(v) <= w0 * GEO.wheel_radius_m * (1 + 1e-9)
    assert np.all(np.diff(v[-20:]) >= -1e-9)  # settled monotonically


@pytest.mark.slow
@pytest.mark.parametrize("name", ["turtlebot2", "turtlebot3_waffle_pi"])
def test_pybullet_follows_the_line_as_the_reduced_model_does(name: str) -> None:
    spec = load_spec(name)
    g = spec.geometry
    top = spec.max_v_mps / g.wheel_radius_m
    params = spec.drive.replace(
        wheel_stall_torque_nm=3.0 * spec.drive.wheel_torque_max_nm,
        wheel_no_load_speed_radps=1.05 * top,
        speed_loop_ki_per_s=spec.priors["speed_loop_ki_per_s"].nominal,
    )
    vm, wm = spec.max_v_mps, spec.max_w_radps
    cmd_t = 0.1 * np.arange(100)
    cmd_v = np.repeat([vm, -vm, 0.8 * vm, 0.0, 0.5 * vm], 20)
    cmd_w = np.repeat([0.0, 0.3 * wm, -0.4 * wm, wm, 0.0], 20)
    t_out = np.arange(0.0, 10.0, 0.05)
    with PybulletRobot(spec, params=params) as bot:
        got = bot.replay(cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=t_out)
    ref = simulate(params, g, cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=t_out)
    flat = simulate(spec.drive, g, cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=t_out)
    assert float(np.sqrt(np.mean((got.v - ref.v) ** 2))) < 0.003
    assert float(np.sqrt(np.mean((got.w - ref.w) ** 2))) < 0.015
    # and the line does change the response (the test would pass trivially otherwise)
    assert float(np.max(np.abs(ref.v - flat.v))) > 0.02
