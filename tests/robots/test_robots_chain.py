"""The one drive-step kernel (robots._kernel): compiled equals interpreted, the Python view
(robots._chain) and the pybullet substep give its numbers, friction is bounded."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from robots import ReducedDrive, _kernel, load_spec, simulate
from robots._chain import CommandShaper, drive_step, friction_of
from robots._kernel import pack_params, pybullet_substep
from robots.reduced import _step

SPEC = load_spec("turtlebot3_burger")


@settings(max_examples=300, deadline=None)
@given(
    v=st.floats(-0.4, 0.4),
    w=st.floats(-4.0, 4.0),
    ref_v=st.floats(-0.3, 0.3),
    ref_w=st.floats(-3.0, 3.0),
    u_v=st.floats(-1.0, 1.0),
    u_w=st.floats(-5.0, 5.0),
    dt=st.floats(1e-3, 0.02),
    added=st.floats(0.0, 2.0),
    tmax=st.sampled_from([0.02, 0.081, math.inf]),
    ki=st.sampled_from([0.0, 12.0]),
    ir=st.floats(-0.5, 0.5),
    il=st.floats(-0.5, 0.5),
)
def test_shaper_and_drive_step_match_the_reduced_kernel(
    v: float,
    w: float,
    ref_v: float,
    ref_w: float,
    u_v: float,
    u_w: float,
    dt: float,
    added: float,
    tmax: float,
    ki: float,
    ir: float,
    il: float,
) -> None:
    params = SPEC.drive.replace(
        added_mass_kg=added,
        wheel_torque_max_nm=tmax,
        accel_lim_v_mps2=2.0,
        accel_lim_w_radps2=9.0,
        speed_loop_ki_per_s=ki,
    )
    geo = SPEC.geometry
    packed = pack_params(params, geo)
    # the reduced model's compiled step
    state = np.array([v, w, ref_v, ref_w, ir, il])
    _step(state, u_v, u_w, dt, packed)
    # the same arithmetic interpreted by Python (numba's py_func all the way down)
    ref_v1, ref_w1, wr, wl = _kernel.shape_command.py_func(u_v, u_w, ref_v, ref_w, dt, packed)
    v1, w1, ir1, il1, tr, tl = _kernel.wheel_loops.py_func(v, w, wr, wl, ir, il, dt, packed)
    assert np.allclose(state, [v1, w1, ref_v1, ref_w1, ir1, il1], rtol=1e-12, atol=1e-12)
    # the Python view used step by step
    shaper = CommandShaper(params, geo)
    shaper.reset(ref_v, ref_w)
    assert np.allclose(shaper.wheel_targets(u_v, u_w, dt), (wr, wl), rtol=1e-12, atol=1e-12)
    out = drive_step(v, w, wr, wl, dt, params, geo, integral_r_rad=ir, integral_l_rad=il)
    assert math.isclose(out.v1, v1, rel_tol=1e-12, abs_tol=1e-12)
    assert (out.integral_r_rad, out.integral_l_rad) == (ir1, il1)
    assert math.isclose(out.w1, w1, rel_tol=1e-12, abs_tol=1e-12)
    assert math.isclose(shaper.ref_v, ref_v1, rel_tol=1e-12, abs_tol=1e-12)
    assert math.isclose(shaper.ref_w, ref_w1, rel_tol=1e-12, abs_tol=1e-12)
    assert abs(out.torque_l) <= tmax + 1e-12 and abs(out.torque_r) <= tmax + 1e-12
    # the pybullet substep on a base heading along +x whose wheels roll without slip: the
    # model's torques plus the axis friction carried by the wheels
    r, half_l = geo.wheel_radius_m, 0.5 * geo.wheel_separation_m
    dt_yaw = 0.25
    state = np.array([ref_v, ref_w, -dt * w + dt_yaw, ir, il])
    got = pybullet_substep(
        state, u_v, u_w, (v - w * half_l) / r, (v + w * half_l) / r,
        v * math.cos(dt_yaw), v * math.sin(dt_yaw), w, dt, packed, SPEC.wheels.spin_inertia_kgm2,
    )  # fmt: skip
    force, torque = friction_of(out, v, w, dt, packed[12], packed[13], geo)
    assert np.allclose(state, [ref_v1, ref_w1, dt_yaw, ir1, il1], rtol=1e-12, atol=1e-12)
    carried = (
        0.5 * r * force - r * torque / (2 * half_l),
        0.5 * r * force + r * torque / (2 * half_l),
    )
    assert np.allclose(got, (tl + carried[0], tr + carried[1]), rtol=1e-9, atol=1e-9)
    # = the generalised forces that take the rolling base to the model's (v1, w1)
    m, inertia = packed[12], packed[13]
    assert math.isclose(sum(got), r * m * (v1 - v) / dt, rel_tol=1e-6, abs_tol=1e-9)
    assert math.isclose(
        got[1] - got[0], 2 * r * inertia * (w1 - w) / (2 * half_l * dt), rel_tol=1e-6, abs_tol=1e-9
    )


@settings(max_examples=200, deadline=None)
@given(v=st.floats(-0.3, 0.3), w=st.floats(-3.0, 3.0), u=st.floats(-0.3, 0.3))
def test_friction_never_exceeds_coulomb_plus_viscous(v: float, w: float, u: float) -> None:
    params, geo = SPEC.drive, SPEC.geometry
    r = geo.wheel_radius_m
    dt = 1.0 / 240.0
    wheel = u / r
    out = drive_step(v, w, wheel, wheel, dt, params, geo)
    force, torque = friction_of(out, v, w, dt, geo.mass_kg, geo.yaw_inertia_kgm2, geo)
    limit_v = params.coulomb_v_fwd_n + params.viscous_v_ns_per_m * abs(out.v1)
    limit_w = params.coulomb_w_nm + params.viscous_w_nms_per_rad * abs(out.w1)
    assert abs(force) <= limit_v * (1 + 1e-9) + 1e-12
    assert abs(torque) <= limit_w * (1 + 1e-9) + 1e-12
    # friction opposes the motion it ends with (or holds the base when it stops)
    if out.v1 != 0.0:
        assert force * out.v1 <= 1e-12


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    delay=st.floats(0.0, 0.35),
    period=st.sampled_from([0.1, 1.0 / 30.0, 0.2]),
    ki=st.sampled_from([0.0, 20.0]),
)
@example(seed=0, delay=0.0, period=0.2, ki=20.0)  # parted by 1e-3 m/s with an exact-zero test
def test_reduced_drive_steps_like_simulate(
    seed: int, delay: float, period: float, ki: float
) -> None:
    """ReducedDrive's compiled history kernel gives simulate()'s numbers on the same grid, P
    or PI wheel loops (a timed-out command ends inside a step: both paths clear the
    integrators, though their held averages differ by rounding there)."""
    rng = np.random.default_rng(seed)
    params = SPEC.drive.replace(
        delay_s=delay, cmd_timeout_s=0.15, speed_loop_ki_per_s=ki
    )  # < 0.2 s: timeouts fire
    n = 40
    v = rng.uniform(-0.3, 0.3, n)
    w = rng.uniform(-3.0, 3.0, n)
    dt = period / round(period / 0.005)
    drive = ReducedDrive(params, SPEC.geometry, dt_s=dt)
    got = np.array([drive.step(float(a), float(b), period) for a, b in zip(v, w, strict=True)])
    t = period * np.arange(n + 1)
    ref = simulate(params, SPEC.geometry, cmd_t_s=t[:-1], cmd_v=v, cmd_w=w, t_out_s=t, dt_s=dt)
    assert np.max(np.abs(got[:, 0] - ref.v[1:])) < 1e-9
    assert np.max(np.abs(got[:, 1] - ref.w[1:])) < 1e-9
