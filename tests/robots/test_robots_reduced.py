"""The reduced drive model: golden numbers for first-order response, friction and limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robots.errors import RobotsValueError
from robots.params import BaseGeometry, DriveParams
from robots.reduced import ReducedDrive, delayed_step_average, simulate

GEO = BaseGeometry(
    mass_kg=1.0, yaw_inertia_kgm2=0.01, wheel_radius_m=0.033, wheel_separation_m=0.16
)


def _step_response(params: DriveParams, v_cmd: float, w_cmd: float, t_end: float = 3.0):
    t = np.arange(0.0, t_end, 0.01)
    return t, simulate(
        params,
        GEO,
        cmd_t_s=np.array([0.0]),
        cmd_v=np.array([v_cmd]),
        cmd_w=np.array([w_cmd]),
        t_out_s=t,
        dt_s=0.001,
    )


def test_first_order_time_constant_matches_theory() -> None:
    k = 0.0054  # N m s/rad; T_v = m r^2 / (2K) = 0.1008 s
    t, r = _step_response(DriveParams(motor_gain_nms_per_rad=k), 0.2, 0.0)
    tau = GEO.mass_kg * GEO.wheel_radius_m**2 / (2 * k)
    expected = 0.2 * (1 - np.exp(-t / tau))
    assert np.max(np.abs(r.v - expected)) < 2e-3
    assert np.allclose(r.w, 0.0)


def test_coulomb_and_viscous_give_the_steady_state_droop() -> None:
    k, fc, bv = 0.0054, 0.1, 0.2
    p = DriveParams(motor_gain_nms_per_rad=k, coulomb_v_fwd_n=fc, viscous_v_ns_per_m=bv)
    _, r = _step_response(p, 0.2, 0.0)
    kv = 2 * k / GEO.wheel_radius_m**2
    v_ss = (kv * 0.2 - fc) / (kv + bv)
    assert r.v[-1] == pytest.approx(v_ss, rel=1e-4)
    assert v_ss < 0.2 * 0.95  # the droop real bases show


def test_coulomb_friction_holds_a_weak_command_at_rest() -> None:
    # drive force at rest = 2K/r^2 * v_ref = 9.92 * 0.005 = 0.05 N < 0.1 N of Coulomb friction
    p = DriveParams(motor_gain_nms_per_rad=0.0054, coulomb_v_fwd_n=0.1, coulomb_v_bwd_n=0.1)
    _, r = _step_response(p, 0.005, 0.0)
    assert np.all(r.v == 0.0)


def test_delay_shifts_the_response_exactly() -> None:
    t, r0 = _step_response(DriveParams(), 0.2, 0.5)
    _, r1 = _step_response(DriveParams(delay_s=0.25), 0.2, 0.5)
    shifted = np.interp(t - 0.25, t, r0.v, left=0.0)
    assert np.max(np.abs(r1.v - shifted)) < 1e-3
    assert r1.v[t < 0.25].max() == 0.0


def test_acceleration_limit_makes_a_ramp() -> None:
    p = DriveParams(accel_lim_v_mps2=0.5, motor_gain_nms_per_rad=0.05)
    t, r = _step_response(p, 0.2, 0.0)
    # reference ramps at 0.5 m/s^2 for 0.4 s; the fast loop (T = 11 ms) follows it closely
    i = np.searchsorted(t, 0.2)
    assert r.v[i] == pytest.approx(0.1, abs=0.01)


def test_wheel_speed_cap_scales_both_axes_on_an_arc() -> None:
    # v = 0.2, w = 1.0 -> outer wheel (0.2 + 0.08)/0.033 = 8.48 rad/s; cap 6.06 rad/s (0.2 m/s)
    cap = 0.2 / GEO.wheel_radius_m
    p = DriveParams(wheel_speed_max_radps=cap, motor_gain_nms_per_rad=0.05)
    _, r = _step_response(p, 0.2, 1.0)
    s = cap / ((0.2 + 1.0 * 0.08) / 0.033)
    assert r.v[-1] == pytest.approx(0.2 * s, rel=1e-3)
    assert r.w[-1] == pytest.approx(1.0 * s, rel=1e-3)


def test_torque_saturation_limits_the_acceleration() -> None:
    tmax = 0.002  # N m per wheel -> max force 2*0.002/0.033 = 0.121 N -> 0.121 m/s^2 on 1 kg
    p = DriveParams(motor_gain_nms_per_rad=0.05, wheel_torque_max_nm=tmax)
    t, r = _step_response(p, 0.2, 0.0)
    a = np.gradient(r.v, t)[10:50].max()
    assert a == pytest.approx(2 * tmax / GEO.wheel_radius_m / GEO.mass_kg, rel=0.05)


def test_python_loop_and_numba_kernel_agree() -> None:
    rng = np.random.default_rng(3)
    ct = np.arange(0.0, 20.0, 0.1)
    cv = rng.uniform(-0.2, 0.2, ct.size)
    cw = rng.uniform(-1.0, 1.0, ct.size)
    p = DriveParams(
        delay_s=0.13,
        coulomb_v_fwd_n=0.1,
        coulomb_v_bwd_n=0.2,
        coulomb_w_nm=0.003,
        wheel_torque_max_nm=0.01,
        accel_lim_w_radps2=3.0,
    )
    t = np.arange(0.0, 20.0, 0.033)
    kw = {"cmd_t_s": ct, "cmd_v": cv, "cmd_w": cw, "t_out_s": t}
    a = simulate(p, GEO, **kw)
    b = simulate(p, GEO, python=True, **kw)
    assert np.array_equal(a.v, b.v) and np.array_equal(a.w, b.w)


def test_step_average_is_continuous_in_delay() -> None:
    ct, cv = np.array([0.0, 1.0]), np.array([1.0, 0.0])
    grid = np.arange(0.0, 2.0, 0.1)
    prev = delayed_step_average(ct, cv, grid, 0.1, delay_s=0.0)
    for d in np.linspace(0.001, 0.3, 50):
        cur = delayed_step_average(ct, cv, grid, 0.1, delay_s=float(d))
        assert np.max(np.abs(cur - prev)) <= 0.3 / 49 / 0.1 + 1e-9
        prev = cur


def test_command_timeout_stops_the_base() -> None:
    p = DriveParams(cmd_timeout_s=0.5, motor_gain_nms_per_rad=0.05)
    _, r = _step_response(p, 0.2, 0.0, t_end=2.0)
    assert r.v[40] == pytest.approx(0.2, rel=0.01)
    assert abs(r.v[-1]) < 1e-3


def test_stepping_drive_matches_batch_simulation() -> None:
    p = DriveParams(delay_s=0.15, coulomb_v_fwd_n=0.05)
    drive = ReducedDrive(p, GEO)
    cmds = [(0.1, 0.0), (0.2, 0.5), (0.2, -0.5), (0.0, 0.0)] * 5
    vs = [drive.step(v, w, 0.1)[0] for v, w in cmds]
    ct = 0.1 * np.arange(len(cmds))
    batch = simulate(
        p,
        GEO,
        cmd_t_s=ct,
        cmd_v=np.array([c[0] for c in cmds]),
        cmd_w=np.array([c[1] for c in cmds]),
        t_out_s=np.concatenate(([0.0], ct + 0.1)),
    )
    assert np.allclose(vs, batch.v[1:], atol=1e-9)


@pytest.mark.parametrize(
    ("field", "value"),
    [("delay_s", -0.1), ("motor_gain_nms_per_rad", 0.0), ("coulomb_v_fwd_n", math.nan)],
)
def test_non_physical_parameters_are_refused_by_name(field: str, value: float) -> None:
    with pytest.raises(RobotsValueError, match=field):
        DriveParams(**{field: value})


@pytest.mark.parametrize("delay_s", [0.05, 12.0])
def test_stepping_drive_keeps_its_history_right_past_the_buffer(delay_s: float) -> None:
    """600 commands overflow the 256-row history: it compacts (short delay) or grows (12 s)."""
    rng = np.random.default_rng(7)
    p = DriveParams(delay_s=delay_s, coulomb_v_fwd_n=0.05, accel_lim_w_radps2=4.0)
    drive = ReducedDrive(p, GEO)
    cv, cw = rng.uniform(-0.2, 0.2, 600), rng.uniform(-1.0, 1.0, 600)
    got = np.array([drive.step(v, w, 1 / 30)[0] for v, w in zip(cv, cw, strict=True)])
    ct = np.arange(600) / 30
    batch = simulate(
        p, GEO, cmd_t_s=ct, cmd_v=cv, cmd_w=cw, t_out_s=np.concatenate(([0.0], ct + 1 / 30))
    )
    assert np.abs(got).max() > 0.05
    assert np.allclose(got, batch.v[1:], atol=1e-9)


def _pi_params(ki: float, **kw: float) -> DriveParams:
    return DriveParams(motor_gain_nms_per_rad=0.0054, speed_loop_ki_per_s=ki, **kw)


def test_integral_term_gives_the_continuous_pi_loops_step_response() -> None:
    """PI on an inertia: V/V_ref = k_v (s + k_i) / (m s^2 + k_v s + k_v k_i), an overshoot."""
    from scipy import signal

    ki = 20.0
    t, r = _step_response(_pi_params(ki), 0.2, 0.0)
    kv = 2 * 0.0054 / GEO.wheel_radius_m**2
    _, exact = signal.step(([kv, kv * ki], [GEO.mass_kg, kv, kv * ki]), T=t)
    assert np.max(np.abs(r.v - 0.2 * exact)) < 2e-3
    assert float(np.max(r.v)) > 1.3 * 0.2  # a clear overshoot
    assert r.v[-1] == pytest.approx(0.2, abs=1e-4)
    # k_i = 0 is the P loop: first order, no overshoot
    _, p_only = _step_response(_pi_params(0.0), 0.2, 0.0)
    assert float(np.max(p_only.v)) <= 0.2 + 1e-12


def test_integral_term_removes_the_coulomb_droop() -> None:
    kw = {"coulomb_v_fwd_n": 0.3, "coulomb_w_nm": 0.01}
    _, p_only = _step_response(_pi_params(0.0, **kw), 0.2, 1.0)
    _, pi = _step_response(_pi_params(10.0, **kw), 0.2, 1.0)
    assert p_only.v[-1] < 0.2 - 0.01 and p_only.w[-1] < 1.0 - 0.05
    assert pi.v[-1] == pytest.approx(0.2, abs=1e-3) and pi.w[-1] == pytest.approx(1.0, abs=5e-3)


def test_integrator_does_not_wind_up_at_the_torque_cap() -> None:
    """A step that saturates the torque for ~1 s overshoots no more than the linear loop."""
    ki = 20.0
    _, linear = _step_response(_pi_params(ki), 0.2, 0.0)
    _, capped = _step_response(_pi_params(ki, wheel_torque_max_nm=0.002), 0.2, 0.0, t_end=5.0)
    ramp = 2 * 0.002 / GEO.wheel_radius_m / GEO.mass_kg  # m/s^2 at the cap
    assert 0.2 / ramp > 1.0  # saturated for over a second
    assert float(np.max(capped.v)) <= float(np.max(linear.v)) + 1e-9
    assert capped.v[-1] == pytest.approx(0.2, abs=1e-3)


def test_a_stop_clears_the_integrator() -> None:
    """Coulomb friction loads the integrator; after a stop the same step gives the same run."""
    params = _pi_params(10.0, coulomb_v_fwd_n=0.3, coulomb_v_bwd_n=0.3)
    t = np.arange(0.0, 6.0, 0.01)
    r = simulate(
        params, GEO, cmd_t_s=np.array([0.0, 2.0, 3.0, 5.0]), cmd_v=np.array([0.2, 0.0, 0.2, 0.0]),
        cmd_w=np.zeros(4), t_out_s=t, dt_s=0.001,
    )  # fmt: skip
    first, again = r.v[(t >= 0.0) & (t < 2.0)], r.v[(t >= 3.0) & (t < 5.0)]
    assert np.max(np.abs(first - again)) < 1e-9
    assert np.all(r.v[(t > 2.8) & (t < 3.0)] == 0.0)  # no creep at rest
