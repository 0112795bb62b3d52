"""The foreign plant (sim2real.plants.diff_drive): golden numbers for its physics and its sensors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.errors import Sim2RealValueError
from sim2real.logs import read_trace
from sim2real.plants.diff_drive import (
    PROFILES,
    PlantParams,
    command_profile,
    draw_session,
    make_fleet,
    make_sessions,
    plant_from_spec,
    run_plant,
    write_fleet,
)
from sysid.metrics import xcorr_lag_s

ROBOT = "turtlebot3_burger"


def _quiet(p: PlantParams, **kw: object) -> PlantParams:
    """No sensor noise, no jitter, no drops (the physics alone)."""
    base: dict[str, object] = {
        "gyro_noise_radps": 0.0,
        "gyro_bias_radps": 0.0,
        "stamp_jitter_s": 0.0,
        "latency_jitter_s": 0.0,
        "odom_drop_fraction": 0.0,
    }
    base.update(kw)
    return p.replace(**base)


def _hold(v: float, w: float, seconds: float, hz: float = 10.0) -> tuple[np.ndarray, ...]:
    t = np.arange(0.0, seconds, 1.0 / hz)
    return t, np.full(t.size, v), np.full(t.size, w)


def _run(p: PlantParams, v: float, w: float, seconds: float, seed: int = 0):  # type: ignore[no-untyped-def]
    t, cv, cw = _hold(v, w, seconds)
    return run_plant(p, t, cv, cw, duration_s=seconds, rng=np.random.default_rng(seed))


def test_spec_values_reach_the_plant() -> None:
    p = plant_from_spec("turtlebot2")
    assert (p.wheel_radius_m, p.wheel_separation_m, p.odom_rate_hz) == (0.035, 0.230, 50.0)
    assert (p.max_v_mps, p.accel_lim_v_mps2, p.cmd_timeout_s) == (0.7, 1.0, 0.6)
    assert p.latency_s == pytest.approx(0.2)
    assert p.w_source == "imu"


def test_pi_loop_removes_the_friction_error_in_steady_state() -> None:
    # a P loop would settle below the command by F_c / K; the PI loop settles on it
    p = _quiet(plant_from_spec(ROBOT))
    run = _run(p, 0.15, 0.0, 6.0)
    late = run.tick_t_s > 4.0
    assert np.abs(run.true_v[late] - 0.15).max() < 2e-4
    assert np.abs(run.true_w[late]).max() < 2e-3  # asymmetric wheels: the loop holds w = 0


@pytest.mark.parametrize("sag", [0.0, 2.0])
def test_torque_speed_line_and_battery_sag_give_the_top_speed(sag: float) -> None:
    # command far above what the motors can do: each wheel runs where the torque-speed line
    # (sagged voltage) meets the friction: tau = S V/Vn - k w = c r + b r^2 w, V = Vb - 2 sag tau
    c, b = 0.3, 0.4
    p = _quiet(
        plant_from_spec(ROBOT),
        max_v_mps=math.inf,
        wheel_speed_max_radps=math.inf,
        coulomb_fwd_n=(c, c),
        viscous_ns_per_m=(b, b),
        battery_v=11.0,
        sag_v_per_nm=sag,
    )
    r, s, vn, k = p.wheel_radius_m, p.stall_torque_nm, p.battery_nominal_v, None
    k = p.stall_torque_nm / p.no_load_speed_radps
    # unknowns (tau, omega): tau + k omega + 2 sag S/Vn tau = S Vb/Vn ; tau - b r^2 omega = c r
    a = np.array([[1.0 + 2.0 * sag * s / vn, k], [1.0, -b * r * r]])
    tau, omega = np.linalg.solve(a, [s * p.battery_v / vn, c * r])
    run = _run(p, 5.0, 0.0, 4.0)
    assert run.true_v[-1] == pytest.approx(omega * r, rel=2e-3)
    assert 0.1 < omega * r < 0.4 and tau > 0


def test_wheel_targets_are_scaled_together_at_the_cap() -> None:
    # an arc whose outer wheel exceeds the cap keeps its curvature w / v
    p = _quiet(plant_from_spec(ROBOT), stall_torque_nm=1.0, no_load_speed_radps=50.0)
    run = _run(p, 0.2, 2.0, 5.0)
    half, r = 0.5 * p.wheel_separation_m, p.wheel_radius_m
    scale = p.wheel_speed_max_radps / ((0.2 + half * 2.0) / r)
    assert scale < 1
    assert run.true_v[-1] == pytest.approx(0.2 * scale, rel=2e-3)
    assert run.true_w[-1] == pytest.approx(2.0 * scale, rel=2e-3)


def test_encoder_quantisation_is_visible_in_odometry_v() -> None:
    # 0.1 m/s is 16.5 ticks of 1024 per wheel per 1/30 s; v = r tick (n_l + n_r) / 2 / period
    p = _quiet(plant_from_spec(ROBOT), ticks_per_rev=1024)
    run = _run(p, 0.1, 0.0, 5.0)
    quantum = 0.5 * p.wheel_radius_m * 2 * math.pi / 1024 * p.odom_rate_hz
    steps = run.meas_v / quantum
    assert np.allclose(steps, np.round(steps), atol=1e-9)
    late = run.meas_v[run.tick_t_s > 3.0]
    assert set(np.round(late / quantum).astype(int)) <= {32, 33, 34}
    assert len(set(np.round(late / quantum).astype(int))) >= 2  # it toggles between levels
    assert late.mean() == pytest.approx(0.1, abs=0.2 * quantum)


def test_w_from_the_wheels_is_quantised_w_from_the_gyro_is_not() -> None:
    base = _quiet(plant_from_spec(ROBOT), ticks_per_rev=256)
    wheels = _run(base.replace(w_source="wheels"), 0.0, 1.0, 4.0)
    tick = 2 * math.pi / 256 * base.wheel_radius_m
    q = tick / base.wheel_separation_m * base.odom_rate_hz
    # (d_r - d_l) / L / period, each a whole number of ticks
    assert np.allclose(wheels.meas_w / q, np.round(wheels.meas_w / q), atol=1e-9)
    gyro = _run(base.replace(gyro_bias_radps=0.01), 0.0, 1.0, 4.0)
    assert np.allclose(gyro.meas_w, gyro.true_w + 0.01)


def test_latency_measured_by_cross_correlation_is_the_sessions() -> None:
    p = _quiet(plant_from_spec(ROBOT))
    rng = np.random.default_rng(5)
    t, v, w = command_profile("steps", 40.0, rng=rng, max_v_mps=0.22, max_w_radps=2.0)
    runs = {
        lat: run_plant(
            p.replace(latency_s=lat), t, v, w, duration_s=40.0, rng=np.random.default_rng(1)
        )
        for lat in (0.002, 0.132)
    }
    a, b = runs[0.002], runs[0.132]
    assert np.array_equal(a.tick_t_s, b.tick_t_s)
    lag_v = xcorr_lag_s(a.tick_t_s, a.true_v, b.true_v, dt_s=0.005)
    lag_w = xcorr_lag_s(a.tick_t_s, a.meas_w, b.meas_w, dt_s=0.005)
    assert lag_v == pytest.approx(0.130, abs=0.006)
    assert lag_w == pytest.approx(0.130, abs=0.006)


def test_command_timeout_stops_the_base() -> None:
    p = _quiet(plant_from_spec(ROBOT))  # 0.5 s timeout, 0.05 s latency
    run = run_plant(p, [0.0], [0.15], [0.0], duration_s=2.0, rng=np.random.default_rng(0))
    at = lambda s: run.true_v[np.searchsorted(run.tick_t_s, s)]  # noqa: E731
    assert at(0.45) == pytest.approx(0.15, abs=0.01)
    assert abs(at(0.9)) < 1e-9
    never = run_plant(
        p.replace(cmd_timeout_s=math.inf),
        [0.0],
        [0.15],
        [0.0],
        duration_s=2.0,
        rng=np.random.default_rng(0),
    )
    assert never.true_v[-1] == pytest.approx(0.15, abs=1e-3)


def test_velocity_smoother_limits_the_acceleration() -> None:
    p = _quiet(plant_from_spec(ROBOT))
    run = _run(p.replace(accel_lim_v_mps2=0.2), 0.2, 0.0, 3.0)
    free = _run(p, 0.2, 0.0, 3.0)
    # the ramp starts after the 0.05 s latency: 0.2 m/s^2 x 0.55 s = 0.11 m/s at t = 0.6 s,
    # which the PI loop tracks within a few mm/s
    assert run.true_v[np.searchsorted(run.tick_t_s, 0.6)] == pytest.approx(0.11, abs=0.008)
    assert np.diff(run.true_v).max() * p.odom_rate_hz < 0.35
    assert np.diff(free.true_v).max() * p.odom_rate_hz > 1.0


def test_caster_scrub_costs_torque_in_place_turns() -> None:
    # an in-place turn far above what the motors give: each wheel (speed u) runs where
    # (S V/Vn - k u) / r - c - b r u = T_scrub / L (the scrub torque shared by the two wheels)
    c, b = 0.2, 0.3
    p = _quiet(
        plant_from_spec(ROBOT),
        battery_v=6.0,
        sag_v_per_nm=0.0,
        max_w_radps=50.0,
        wheel_speed_max_radps=100.0,
        coulomb_fwd_n=(c, c),
        coulomb_bwd_n=(c, c),
        viscous_ns_per_m=(b, b),
    )
    r, sep = p.wheel_radius_m, p.wheel_separation_m
    k = p.stall_torque_nm / p.no_load_speed_radps
    for scrub in (0.0, 0.02):
        drive = p.stall_torque_nm * p.battery_v / p.battery_nominal_v / r - c - scrub / sep
        u = drive / (k / r + b * r)
        run = _run(p.replace(scrub_nm=scrub), 0.0, 20.0, 3.0)
        assert run.true_w[-1] == pytest.approx(2 * r * u / sep, rel=3e-3)
        assert abs(run.true_v[-1]) < 1e-6


def test_same_seed_same_bytes_other_seed_other_bytes(tmp_path: Path) -> None:
    a = write_fleet(tmp_path, ROBOT, 2, seed=7, duration_s=15.0, prefix="a")
    b = write_fleet(tmp_path, ROBOT, 2, seed=7, duration_s=15.0, prefix="b")
    c = write_fleet(tmp_path, ROBOT, 2, seed=8, duration_s=15.0, prefix="c")
    assert [p.read_bytes() for p in a] == [p.read_bytes() for p in b]
    assert a[0].read_bytes() != c[0].read_bytes()
    tr = read_trace(a[1])
    mem = make_fleet(ROBOT, 2, seed=7, duration_s=15.0)[1]
    assert np.array_equal(tr.meas_t_ns, mem.meas_t_ns)
    assert np.array_equal(tr.meas_v, mem.meas_v) and np.array_equal(tr.cmd_w, mem.cmd_w)


def test_sessions_vary_and_adding_one_keeps_the_others() -> None:
    three = make_sessions(ROBOT, 3, seed=4, duration_s=10.0)
    two = make_sessions(ROBOT, 2, seed=4, duration_s=10.0)
    assert np.array_equal(three[1].meas_v, two[1].meas_v)
    lat = [r.params.latency_s for r in three]
    mass = [r.params.mass_kg for r in three]
    assert len(set(lat)) == 3 and len(set(mass)) == 3
    base = plant_from_spec(ROBOT)
    assert all(0.06 <= x <= 0.16 for x in lat)
    assert all(base.mass_kg <= m <= 1.4 * base.mass_kg for m in mass)


def test_session_draw_changes_only_what_a_session_changes() -> None:
    base = plant_from_spec(ROBOT)
    s = draw_session(base, np.random.default_rng(1))
    same = {"wheel_radius_m", "kp_nms_per_rad", "odom_rate_hz", "stall_torque_nm", "robot"}
    assert all(getattr(s, f) == getattr(base, f) for f in same)
    ratio = s.coulomb_fwd_n[0] / base.coulomb_fwd_n[0]
    assert s.coulomb_bwd_n[1] / base.coulomb_bwd_n[1] == pytest.approx(ratio)
    assert s.scrub_nm / base.scrub_nm == pytest.approx(ratio)


@pytest.mark.parametrize("kind", PROFILES)
def test_profiles_stay_within_the_limits(kind: str) -> None:
    t, v, w = command_profile(
        kind, 30.0, rng=np.random.default_rng(2), max_v_mps=0.2, max_w_radps=2.0
    )
    assert t.size > 100 and np.all(np.diff(t) > 0)
    assert np.abs(v).max() <= 0.2 + 1e-12 and np.abs(w).max() <= 2.0 + 1e-12
    assert np.abs(v).max() + np.abs(w).max() > 0.1


@settings(max_examples=12)
@given(
    v=st.floats(-0.2, 0.2).filter(lambda x: abs(x) > 0.02),
    w=st.floats(-1.5, 1.5),
)
def test_steady_state_follows_any_reachable_command(v: float, w: float) -> None:
    p = _quiet(plant_from_spec(ROBOT))
    run = _run(p, v, w, 5.0)
    half, r = 0.5 * p.wheel_separation_m, p.wheel_radius_m
    scale = min(1.0, p.wheel_speed_max_radps * r / (abs(v) + half * abs(w)))
    assert run.true_v[-1] == pytest.approx(v * scale, abs=2e-3)
    assert run.true_w[-1] == pytest.approx(w * scale, abs=2e-2)


@pytest.mark.parametrize(
    ("change", "word"),
    [
        ({"latency_s": -0.1}, "latency_s"),
        ({"w_source": "odom"}, "w_source"),
        ({"mass_kg": 0.0}, "mass_kg"),
        ({"coulomb_fwd_n": (0.1, math.nan)}, "coulomb_fwd_n"),
    ],
)
def test_bad_parameters_are_named(change: dict[str, object], word: str) -> None:
    with pytest.raises(Sim2RealValueError, match=word):
        plant_from_spec(ROBOT, **change)


def test_bad_commands_and_profiles_are_refused() -> None:
    p = plant_from_spec(ROBOT)
    with pytest.raises(Sim2RealValueError, match="increasing times"):
        run_plant(
            p, [0.0, 0.0], [0.1, 0.1], [0.0, 0.0], duration_s=1.0, rng=np.random.default_rng(0)
        )
    with pytest.raises(Sim2RealValueError, match="one of"):
        command_profile("zigzag", 5.0, rng=np.random.default_rng(0), max_v_mps=0.2, max_w_radps=1.0)
    with pytest.raises(Sim2RealValueError, match="n_sessions"):
        make_fleet(ROBOT, 0, seed=0)


def test_docstring_examples_run() -> None:
    import doctest

    import sim2real._samples
    import sim2real.plants.diff_drive

    for module in (sim2real.plants.diff_drive, sim2real._samples):
        result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
        assert result.attempted >= 1 and result.failed == 0, module.__name__
