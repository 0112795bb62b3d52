"""The MAP fit: posterior = prior where the log says nothing, the priors split the mass/gain
family, every draw and estimate is physical, non-convergence is reported, noise is estimated."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from robots.params import SCHEMA
from robots.randomization import DriveDistribution
from robots.spec import load_spec
from sysid import SysidResult, fit_drive
from sysid._coords import Mapper
from sysid._excitation import analyse
from sysid._logs import as_log_arrays
from sysid._map import MapOptions, _rho, map_fit
from sysid._summary import quantum
from sysid.plan import plan_excitation
from sysid.synthetic import degrade_odometry, step_commands, synthetic_log

SPEC = load_spec("turtlebot3_burger")
GEO = SPEC.geometry
#: a heavier robot (payload) whose loop is also stiffer than the spec's nominal guess
TRUTH = SPEC.drive.replace(
    delay_s=0.12,
    added_mass_kg=0.3,
    motor_gain_nms_per_rad=1.5 * SPEC.drive.motor_gain_nms_per_rad,
    coulomb_v_fwd_n=0.15,
    coulomb_v_bwd_n=0.15,
    wheel_speed_max_radps=7.0,
)


def _fit(seed: int = 1, duration: float = 30.0, **kw: object) -> SysidResult:
    t, v, w = step_commands(duration, seed=seed, v_max_mps=0.15, w_max_radps=1.2)
    log = synthetic_log(TRUTH, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed, spike_mps=None)
    return fit_drive(
        [log],
        geometry=GEO,
        base_params=SPEC.drive,
        priors=SPEC.priors,
        robot=SPEC.name,
        odom_v_window_s=0.02,
        **kw,  # type: ignore[arg-type]
    )


@pytest.fixture(scope="module")
def fitted() -> SysidResult:
    return _fit()


def test_every_field_has_a_posterior_and_uninformed_ones_are_their_prior(
    fitted: SysidResult,
) -> None:
    by = {e.name: e for e in fitted.estimates}
    assert set(by) == set(SCHEMA)
    for name, e in by.items():
        prior = SPEC.priors[name]
        if e.status == "fixed":  # known exactly or "no limit": nothing to spread
            assert not prior.informative
            assert e.std is None
            continue
        assert e.std is not None and math.isfinite(e.std) and e.std >= 0
        assert e.ci95_low is not None and e.ci95_high is not None
        assert e.ci95_low <= e.value <= e.ci95_high
        if e.status == "prior":
            assert e.value == prior.nominal and e.coord_std == prior.sd
            assert e.sd_ratio == pytest.approx(1.0)
        assert e.status in ("fitted", "prior", "tied")
    # 0.15 m/s commands never reach the wheel cap: fitted against its derated prior, the log
    # leaves it there with the prior's spread (MAP: the posterior is the prior)
    cap = by["wheel_speed_max_radps"]
    assert cap.sd_ratio is not None and cap.sd_ratio > 0.9
    assert cap.coord_std is not None
    assert math.log(cap.value / 7.27) == pytest.approx(0.0, abs=0.3 * cap.coord_std)
    # the log informs the delay strongly (its sd is the log's timing resolution)
    delay = by["delay_s"]
    assert delay.status == "fitted" and delay.sd_ratio is not None and delay.sd_ratio < 0.1
    assert abs(by["delay_s"].value - TRUTH.delay_s) < 0.01


def test_priors_split_the_mass_gain_family(fitted: SysidResult) -> None:
    m_true, k_true = TRUTH.total_mass_kg(GEO), TRUTH.motor_gain_nms_per_rad
    m_hat, k_hat = fitted.params.total_mass_kg(GEO), fitted.params.motor_gain_nms_per_rad
    # the data fix the ratio ...
    assert m_hat / k_hat == pytest.approx(m_true / k_true, rel=0.1)
    # ... not the split: the mass posterior stays of the order of its prior (the delay's is
    # 20 times narrower than its prior), and its interval holds the truth (the spec's
    # friction priors, centred on the truth's friction, tell the fit where the gain is)
    mass = fitted.estimate("added_mass_kg")
    delay_ratio = fitted.estimate("delay_s").sd_ratio
    assert mass.status == "fitted" and mass.sd_ratio is not None and delay_ratio is not None
    assert mass.sd_ratio > 0.25 and mass.sd_ratio > 5 * delay_ratio
    assert mass.ci95_low is not None and mass.ci95_high is not None
    assert mass.ci95_low <= TRUTH.added_mass_kg <= mass.ci95_high
    # with the mass known to 1 %, it stays put and the gain (and the rest) takes the remainder
    tight = dict(SPEC.priors)
    tight["added_mass_kg"] = dataclasses.replace(SPEC.priors["added_mass_kg"], sd=0.01)
    t, v, w = step_commands(30.0, seed=1, v_max_mps=0.15, w_max_radps=1.2)
    log = synthetic_log(TRUTH, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=1, spike_mps=None)
    res = fit_drive([log], geometry=GEO, base_params=SPEC.drive, priors=tight, odom_v_window_s=0.02)
    m2, k2 = res.params.total_mass_kg(GEO), res.params.motor_gain_nms_per_rad
    assert m2 == pytest.approx(GEO.mass_kg, rel=0.03)
    assert m2 / k2 == pytest.approx(m_true / k_true, rel=0.1)


def test_result_carries_distribution_priors_and_noise(fitted: SysidResult, tmp_path: Path) -> None:
    dist = fitted.randomization
    assert dist is not None and dist.robot == SPEC.name
    assert set(dist.names) | set(dist.fixed) == set(SCHEMA)
    # one log, a new session: posterior + the spec's default between-session spread, once for
    # the logged session's own deviation from the mean and once, Student-t widened (3 degrees
    # of freedom: the spread is known from the spec's pseudo-sessions only), for the new one
    sd = dist.std()
    post = fitted.estimate("delay_s").coord_std
    assert post is not None
    factor = (2.3533634 / 1.6448536) ** 2  # (t_{3, 0.95} / z_{0.95})^2
    session = SPEC.priors["delay_s"].session_sd
    expect = math.sqrt(post**2 + (1.0 + factor) * session**2)
    assert sd["delay_s"] == pytest.approx(expect, rel=1e-6)
    # the odometry noise of the synthetic log: v 4 mm/s (plus encoder ticks), gyro 0.02 rad/s
    assert dist.noise.std_v_mps == pytest.approx(0.004, rel=0.35)
    assert dist.noise.std_w_radps == pytest.approx(0.02, rel=0.2)
    path = fitted.save(tmp_path / "p.yaml")
    back = DriveDistribution.from_params_file(path, robot=SPEC.name)
    assert back == dist
    assert SysidResult.load(path).priors["delay_s"]["sd"] == SPEC.priors["delay_s"].sd
    for p in back.sample(np.random.default_rng(0), 50, spread=2.0):
        assert p.total_mass_kg(GEO) > 0 and p.total_yaw_inertia_kgm2(GEO) > 0


def test_evaluation_limit_is_a_stored_warning(tmp_path: Path) -> None:
    res = _fit(seed=2, duration=15.0, max_nfev=2)
    assert not res.converged
    assert any("evaluation limit (2)" in w for w in res.warnings)
    back = SysidResult.load(res.save(tmp_path / "p.yaml"))
    assert back.settings["converged"] is False


def test_quantum_of_encoder_odometry() -> None:
    t = np.arange(2000) * 0.02
    v = 0.15 * np.sin(t)
    _, vq, _ = degrade_odometry(
        t, v, np.zeros_like(t), seed=0, quantum_v_mps=0.005, noise_v_mps=0.0, spike_mps=None
    )
    assert quantum(vq) == pytest.approx(0.005)
    assert quantum(v) == 0.0  # a continuum of values: no lattice


def test_posterior_after_a_dropped_limit_is_the_final_problems() -> None:
    """A limit the log never shows is dropped after the optimiser ran with it in place; the
    posterior is the final problem's (without it), not the optimiser's Jacobian's, in which a
    limit and a torque cap doing the same job leave the cap's column empty."""
    spec = SPEC.drive
    truth = spec.replace(wheel_torque_max_nm=0.05, delay_s=0.1, speed_loop_ki_per_s=20.0)
    plan = plan_excitation(SPEC, 60.0)
    raw = synthetic_log(
        truth, GEO, cmd_t_s=plan.t_s, cmd_v=plan.v_mps, cmd_w=plan.w_radps, seed=1, spike_mps=None
    )
    logs = [as_log_arrays(raw, 0)]
    informative = {n for n, p in SPEC.priors.items() if p.informative}
    exc = analyse(logs, GEO, spec, "auto", informative)
    assert "accel_lim_w_radps2" in exc.free
    kw = {"scale_v": 0.02, "scale_w": 0.1, "dt_s": 1.0 / 240.0}
    options = MapOptions(problem_kw=kw, loss="soft_l1", f_scale=1.0, max_nfev=60)
    notes: list[str] = []
    post = map_fit(logs, Mapper(GEO, spec, SPEC.priors), exc, options, notes=notes)
    assert "accel_lim_w_radps2" not in post.free
    assert any("accel_lim_w_radps2 never limited the response" in n for n in notes)
    # the data information of the final problem at the MAP point, scaled for the robust loss
    # as least_squares scales its Jacobian, over the residual variance s^2 c
    final = post.problem
    jac = final.data_jacobian(post.u, post.coupled)
    z2 = final.data_residuals(post.u) ** 2
    rho = _rho("soft_l1", z2)
    jac = jac * np.sqrt(rho[1] + 2.0 * rho[2] * z2)[:, None]
    _, g = final.schema_coords(post.u)
    g_inv = np.linalg.pinv(g)
    info = g_inv.T @ (jac.T @ jac / final.prior_weight**2) @ g_inv
    np.testing.assert_allclose(post.info, info, rtol=1e-6, atol=1e-9 * float(np.max(info)))
    j = post.free.index("wheel_torque_max_nm")
    assert info[j, j] > 0.0
