"""Accuracy of the drive fit on synthetic ground truth (reduced model, realistic odometry)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sysid import SysidResult, fit_drive
from sysid._coords import Mapper
from sysid.synthetic import (
    WAFFLE_LIKE_BASE,
    WAFFLE_LIKE_GEOMETRY,
    WAFFLE_LIKE_TRUTH,
    step_commands,
    synthetic_log,
)

GEO, BASE, TRUTH = WAFFLE_LIKE_GEOMETRY, WAFFLE_LIKE_BASE, WAFFLE_LIKE_TRUTH
# what the fit must recover within 10 % (the combinations velocity data identify)
IDENTIFIABLE = (
    "time_constant_v_s",
    "time_constant_w_s",
    "gain_v",
    "gain_w",
    "coulomb_v_fwd_per_mass_mps2",
    "coulomb_v_bwd_per_mass_mps2",
    "coulomb_w_per_inertia_radps2",
    "viscous_v_per_mass_1ps",
    "viscous_w_per_inertia_1ps",
    "accel_lim_v_mps2",
    "accel_lim_w_radps2",
    "wheel_speed_max_radps",
    "mass_per_motor_gain_kg_per_nms",
)


@pytest.fixture(scope="module")
def fitted() -> SysidResult:
    t, v, w = step_commands(120.0, seed=3)
    log = synthetic_log(TRUTH, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=4)
    tv, vv, wv = step_commands(60.0, seed=10)  # a different command sequence
    val = synthetic_log(
        TRUTH, GEO, cmd_t_s=tv, cmd_v=vv, cmd_w=wv, seed=11, spike_mps=None, name="val"
    )
    # the synthetic odometry's v is an encoder tick difference over each 20 ms period
    return fit_drive(
        [log],
        geometry=GEO,
        base_params=BASE,
        validate=[val],
        robot="synthetic",
        odom_v_window_s=0.02,
    )


@pytest.mark.slow
def test_delay_within_10_ms(fitted: SysidResult) -> None:
    assert abs(fitted.params.delay_s - TRUTH.delay_s) <= 0.010


@pytest.mark.slow
@pytest.mark.parametrize("name", IDENTIFIABLE)
def test_identifiable_within_10_percent(fitted: SysidResult, name: str) -> None:
    truth = Mapper(GEO, BASE).identifiable(TRUTH)[name][0]
    est = fitted.estimate(name)
    assert est.status in ("fitted", "derived")
    assert est.value == pytest.approx(truth, rel=0.10)


@pytest.mark.slow
def test_every_free_parameter_fitted_and_spike_reported(fitted: SysidResult) -> None:
    statuses = {e.name: e.status for e in fitted.estimates}
    for name in ("delay_s", "coulomb_v_bwd_n", "viscous_w_nms_per_rad", "wheel_speed_max_radps"):
        assert statuses[name] == "fitted"
    # MAP: the mass/gain family is fitted together, its split resting on the priors
    assert statuses["added_mass_kg"] == "fitted"
    assert statuses["motor_gain_nms_per_rad"] == "fitted"
    # the firmware clamps are fitted against their priors, which the log barely narrows
    clamp = fitted.estimate("speed_lim_v_mps")
    assert clamp.status == "fitted" and clamp.sd_ratio is not None and clamp.sd_ratio > 0.8
    assert any("spike" in w and "1.35" in w for w in fitted.warnings)


def test_encoder_window_removes_the_half_period_bias() -> None:
    t, v, w = step_commands(40.0, seed=31)
    log = synthetic_log(TRUTH, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=31, spike_mps=None)
    free = ["delay_s", "added_mass_kg"]
    near = NEAR.replace(added_yaw_inertia_kgm2=0.02)
    plain = fit_drive([log], geometry=GEO, base_params=near, free=free, weights=(1.0, 0.0))
    windowed = fit_drive(
        [log], geometry=GEO, base_params=near, free=free, weights=(1.0, 0.0), odom_v_window_s=0.02
    )
    # fitted on v alone: instantaneous v reads the 20 ms tick difference ~10 ms late; what
    # remains (~3 ms) is the dt = 5 ms discretisation of the model (the w channel shows it too)
    assert plain.params.delay_s - windowed.params.delay_s == pytest.approx(0.010, abs=0.003)
    assert abs(windowed.params.delay_s - TRUTH.delay_s) < 0.006


@pytest.mark.slow
def test_validation_fit_percent_at_least_90(fitted: SysidResult) -> None:
    (val,) = fitted.scores_validation
    assert val.fit_percent_v >= 90.0
    assert val.fit_percent_w >= 90.0
    assert val.agreement >= 0.95


@pytest.mark.slow
def test_intervals_are_finite_and_contain_estimate(fitted: SysidResult) -> None:
    for est in fitted.estimates:
        if est.status in ("fitted", "derived"):
            assert est.std is not None and math.isfinite(est.std) and est.std > 0
            assert est.ci95_low is not None and est.ci95_high is not None
            assert est.ci95_low <= est.value <= est.ci95_high
    corr = np.array(fitted.correlation)
    assert corr.shape == (len(fitted.correlation_names),) * 2
    assert np.allclose(np.diag(corr), 1.0)
    assert np.all(np.abs(corr) <= 1.0 + 1e-9)


@pytest.mark.slow
def test_linear_model_figures_match_first_order_theory(fitted: SysidResult) -> None:
    lin = fitted.linear["v"]
    tau = fitted.estimate("time_constant_v_s").value
    # first order + dead time: 10-90 % rise time ln(9) T; -3 dB bandwidth ~ 1/T
    assert lin["rise_time_s"] == pytest.approx(math.log(9.0) * tau, rel=0.05)
    assert lin["bandwidth_radps"] == pytest.approx(1.0 / tau, rel=0.05)


# a prior that is right except for the delay and the payload
NEAR = TRUTH.replace(delay_s=0.05, added_mass_kg=0.0, added_yaw_inertia_kgm2=0.0)


def test_fit_is_reproducible_and_reports_progress() -> None:
    t, v, w = step_commands(30.0, seed=5)
    log = synthetic_log(TRUTH, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=6, spike_mps=None)
    seen: list[tuple[str, float]] = []
    a = fit_drive(
        [log],
        geometry=GEO,
        base_params=NEAR,
        free=["delay_s", "added_mass_kg", "added_yaw_inertia_kgm2"],
        progress=lambda stage, frac: seen.append((stage, frac)),
    )
    b = fit_drive(
        [log],
        geometry=GEO,
        base_params=NEAR,
        free=["delay_s", "added_mass_kg", "added_yaw_inertia_kgm2"],
    )
    assert a.params == b.params
    fractions = [f for _, f in seen]
    assert fractions[0] == 0.0 and fractions[-1] == 1.0
    assert fractions == sorted(fractions)
    assert {"fitting", "done"} <= {s for s, _ in seen}
    # only the listed parameters move; the rest keep the prior
    assert a.params.coulomb_v_fwd_n == NEAR.coulomb_v_fwd_n
    assert abs(a.params.delay_s - TRUTH.delay_s) < 0.01
    assert a.params.total_mass_kg(GEO) == pytest.approx(TRUTH.total_mass_kg(GEO), rel=0.1)


def test_two_logs_fit_jointly() -> None:
    logs = []
    for seed in (21, 22):
        t, v, w = step_commands(25.0, seed=seed)
        logs.append(
            synthetic_log(TRUTH, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed, spike_mps=None)
        )
    free = ["delay_s", "added_mass_kg", "added_yaw_inertia_kgm2"]
    res = fit_drive(logs, geometry=GEO, base_params=NEAR, free=free, odom_v_window_s=0.02)
    assert len(res.scores_fit) == 2
    assert [d.role for d in res.data] == ["fit", "fit"]
    assert abs(res.params.delay_s - TRUTH.delay_s) < 0.01
    assert all(s.fit_percent_v > 85 for s in res.scores_fit)


@pytest.mark.parametrize("truth_ki", [0.0, 15.0])
def test_integral_gain_of_the_wheel_loops_is_identified(truth_ki: float) -> None:
    """The overshoot of each step fixes k_i: a PI plant gives it back, a P plant gives ~0
    although the spec's prior is centred on 20 /s.

    The P plant's interval holds its truth (0, at the bound). The PI plant's does not:
    measured 17.33 /s, interval 16.10-18.56 (truth 15, 3.7 sd) in the basin without
    acceleration limits (the truth's structure, 5 log-posterior units below the basin with a
    spurious limit, which gave 14.7): its interval is too narrow, as the pooled coverage test
    (tests/sysid/test_sysid_calibration.py, 105 of 120 plants) reports; here only the
    identification is asserted."""
    from robots.spec import load_spec

    spec = load_spec("turtlebot3_burger")
    truth = spec.drive.replace(speed_loop_ki_per_s=truth_ki, delay_s=0.08)
    t, v, w = step_commands(25.0, seed=5, v_max_mps=0.2, w_max_radps=1.5)
    log = synthetic_log(truth, spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=6, spike_mps=None)
    res = fit_drive(
        [log], geometry=spec.geometry, base_params=spec.drive, priors=spec.priors,
        odom_v_window_s=0.02,
    )  # fmt: skip
    est = res.estimate("speed_loop_ki_per_s")
    assert est.status == "fitted"
    assert est.ci95_low is not None and est.ci95_high is not None
    if truth_ki == 0.0:
        assert est.ci95_low - 0.5 <= truth_ki <= est.ci95_high + 0.5
    assert abs(est.value - truth_ki) < 0.15 * truth_ki + 1.0
    assert est.ci95_high - est.ci95_low < 0.5 * spec.priors["speed_loop_ki_per_s"].sd


@pytest.mark.parametrize("truth_ki", [0.0, 15.0])
def test_validation_logs_judge_the_integral_term(truth_ki: float) -> None:
    """With a validation log, the fit is also made with P loops and the loop structure that
    predicts the validation log better is returned, with a note saying both errors: a P
    plant's fit gets P loops, a PI plant's keeps its integral term."""
    from robots.spec import load_spec

    spec = load_spec("turtlebot3_burger")
    truth = spec.drive.replace(speed_loop_ki_per_s=truth_ki, delay_s=0.08)
    logs = []
    for seed, name in ((5, "fit"), (7, "val")):
        t, v, w = step_commands(25.0, seed=seed, v_max_mps=0.2, w_max_radps=1.5)
        logs.append(
            synthetic_log(
                truth, spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed + 1,
                spike_mps=None, name=name,
            )
        )  # fmt: skip
    res = fit_drive(
        logs[:1], geometry=spec.geometry, base_params=spec.drive, priors=spec.priors,
        validate=logs[1:], odom_v_window_s=0.02,
    )  # fmt: skip
    est = res.estimate("speed_loop_ki_per_s")
    judged = [w for w in res.warnings if "judged the wheel loops' integral term" in w]
    assert len(judged) == 1
    if truth_ki == 0.0:
        assert (est.status, est.value) == ("fixed", 0.0)
        assert judged[0].endswith("P loops are kept (speed_loop_ki_per_s 0)")
    else:
        assert est.status == "fitted"
        assert abs(est.value - truth_ki) < 0.15 * truth_ki + 1.0
        assert judged[0].endswith("it is kept")
    # the file keeps the spec's prior of the gain, whichever structure won
    assert res.priors["speed_loop_ki_per_s"]["sd"] == spec.priors["speed_loop_ki_per_s"].sd


def test_no_judging_without_validation_logs() -> None:
    from robots.spec import load_spec

    spec = load_spec("turtlebot3_burger")
    t, v, w = step_commands(15.0, seed=5, v_max_mps=0.2, w_max_radps=1.5)
    log = synthetic_log(
        spec.drive.replace(delay_s=0.08), spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=6,
        spike_mps=None,
    )  # fmt: skip
    res = fit_drive([log], geometry=spec.geometry, base_params=spec.drive, priors=spec.priors)
    assert not any("integral term" in w for w in res.warnings)
    assert res.estimate("speed_loop_ki_per_s").status == "fitted"
