"""The band's odometry noise per sample: a model share that grows with the replay's rate of
change beside the checked log's own noise of each sample's motion."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.randomization import ObservationNoise
from sim2real.agreement.latency import (
    ModelShare,
    SampleNoise,
    band_log_noise,
    band_noise,
    band_sample_noise,
    fit_model_share,
    replay_rate,
)
from sim2real.logs import Trace
from sysid.hfnoise import response_noise
from sysid.steady import held_at_zero_noise, motion_noise, steady_noise

_FILE = ObservationNoise(std_v_mps=0.016, std_w_radps=0.02, quantum_v_mps=0.001)
_FITTED = {"measurement_noise": {"std_v_mps": 0.012, "std_w_radps": 0.015, "samples": 87}}
_HELD = {
    "model_noise_std_v_mps": 0.002,
    "model_noise_std_w_radps": 0.004,
    "model_noise_timing_v_s": 0.05,
    "model_noise_timing_w_s": 0.04,
}


def _straights_and_spins(seed: int = 1) -> Trace:
    """Commands held 4 s: a straight (0.2 m/s, v noise 0.01 m/s) then three spins in place
    (1 rad/s, v reads a 0.002 m/s offset and 5e-4 m/s of noise); w noise 0.03 rad/s."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, 160_000_000_000, 50_000_000)
    straight = (np.floor(t / 4e9) % 4) == 0
    cmd_v, cmd_w = np.where(straight, 0.2, 0.0), np.where(straight, 0.0, 1.0)
    meas_v = np.where(straight, 0.2 + rng.normal(0.0, 0.01, t.size), 0.002)
    meas_v = meas_v + np.where(straight, 0.0, rng.normal(0.0, 5e-4, t.size))
    return Trace(cmd_t_ns=t, cmd_v=cmd_v, cmd_w=cmd_w, meas_t_ns=t, meas_v=meas_v,
                 meas_w=cmd_w + rng.normal(0.0, 0.03, t.size))  # fmt: skip


def _ramped(trace: Trace) -> SimpleNamespace:
    """A replay that follows the commands with 0.5 s linear ramps (its rate of change: 0.4
    m/s^2 in v, 2 rad/s^2 in w, while it ramps)."""
    t = trace.meas_t_s
    cv, cw = trace.cmd_at_meas()
    kernel = np.ones(10) / 10.0  # 0.5 s at 20 Hz
    return SimpleNamespace(
        v=np.convolve(cv, kernel)[: t.size], w=np.convolve(cw, kernel)[: t.size], t_s=t
    )


def test_each_sample_gets_the_share_at_its_rate_beside_its_motions_own_noise() -> None:
    trace = _straights_and_spins()
    sim = _ramped(trace)
    noise, note = band_sample_noise(_FILE, _FITTED, trace, sim, calibration=_HELD)
    assert isinstance(noise, SampleNoise) and noise.quantum_v_mps == 0.001
    cv, cw = trace.cmd_at_meas()
    args = (trace.meas_t_s, cv, cw, trace.meas_v, trace.meas_w)
    moving, zero, pooled = motion_noise(*args)[0], held_at_zero_noise(*args), steady_noise(*args)
    assert moving.std_v_mps == pytest.approx(0.01, rel=0.15)
    # the offset (robust sd about zero: 1.4826 x its median |v|), not its 5e-4 m/s scatter
    assert zero.std_v_mps == pytest.approx(1.4826 * 0.002, rel=0.15)
    rate_v, rate_w = replay_rate(trace.meas_t_s, sim.v), replay_rate(trace.meas_t_s, sim.w)
    own_v = np.where(cv != 0, moving.std_v_mps, zero.std_v_mps)
    expected_v = np.sqrt(0.002**2 + (0.05 * rate_v) ** 2 + own_v**2)
    expected_w = np.sqrt(0.004**2 + (0.04 * rate_w) ** 2 + pooled.std_w_radps**2)
    np.testing.assert_allclose(noise.std_v_mps, expected_v, rtol=1e-12)
    np.testing.assert_allclose(noise.std_w_radps, expected_w, rtol=1e-12)
    # steady: the floor beside the own noise; ramping w at 2 rad/s^2: 0.08 rad/s more
    steady = (rate_w == 0) & (rate_v == 0)
    assert steady.sum() > 0.5 * steady.size
    ramp = np.isclose(rate_w, 2.0)
    assert ramp.any()
    assert np.all(noise.std_w_radps[ramp] > 0.08) and np.all(noise.std_w_radps[steady] < 0.04)
    assert "0.05 s x the replay's acceleration" in note


def test_a_log_that_cannot_tell_its_noise_keeps_the_files() -> None:
    """A log with no steady stretch at all: the file's noise (0.016 m/s, 0.02 rad/s) beside the
    share, on both axes, as the one-number band keeps it."""
    t = np.arange(0, 1_000_000_000, 50_000_000)  # 1 s: no command held long enough
    cmd = np.full(t.size, 0.2)
    short = Trace(cmd_t_ns=t, cmd_v=cmd, cmd_w=0 * cmd, meas_t_ns=t, meas_v=cmd, meas_w=0 * cmd)
    still = SimpleNamespace(v=cmd, w=0 * cmd)
    noise, _ = band_sample_noise(_FILE, _FITTED, short, still, calibration=_HELD)
    np.testing.assert_allclose(noise.std_v_mps, math.hypot(0.002, 0.016))
    np.testing.assert_allclose(noise.std_w_radps, math.hypot(0.004, 0.02))


def test_a_log_that_never_holds_a_command_takes_what_the_replay_leaves() -> None:
    """A follower's new command every message (20 Hz; v noise 0.006 m/s, w 0.008 rad/s, below
    the file's 0.016 and 0.02): no held command, so v while driving and w take the log's own
    noise by what the replay does not explain (:func:`sysid.hfnoise.response_noise`), not the
    file's; the still class (v held at zero), which nothing tells, the fit logs' own."""
    rng = np.random.default_rng(2)
    t = np.arange(0, 60_000_000_000, 50_000_000)
    s = t / 1e9
    cmd_v = np.where((s % 20.0) < 15.0, 0.2 + 0.1 * np.sin(0.7 * s), 0.0)
    cmd_w = 0.5 * np.sin(0.4 * s + 1.0)
    trace = Trace(cmd_t_ns=t, cmd_v=cmd_v, cmd_w=cmd_w, meas_t_ns=t,
                  meas_v=cmd_v + rng.normal(0.0, 0.006, t.size),
                  meas_w=cmd_w + rng.normal(0.0, 0.008, t.size))  # fmt: skip
    sim = SimpleNamespace(v=cmd_v, w=cmd_w)
    cv, cw = trace.cmd_at_meas()
    own = response_noise(trace.meas_t_s, cv, cw, trace.meas_v, trace.meas_w, (sim.v, sim.w))
    assert not steady_noise(trace.meas_t_s, cv, cw, trace.meas_v, trace.meas_w).measured
    assert own.std_v_mps == pytest.approx(0.006, rel=0.15)
    assert own.std_w_radps == pytest.approx(0.008, rel=0.15)
    noise, _ = band_sample_noise(_FILE, _FITTED, trace, sim, calibration=_HELD)
    rate_v, rate_w = replay_rate(trace.meas_t_s, sim.v), replay_rate(trace.meas_t_s, sim.w)
    own_v = np.where(cv != 0, own.std_v_mps, 0.012)  # still: the fit logs' own
    np.testing.assert_allclose(
        noise.std_v_mps, np.sqrt(0.002**2 + (0.05 * rate_v) ** 2 + own_v**2), rtol=1e-12
    )
    np.testing.assert_allclose(
        noise.std_w_radps,
        np.sqrt(0.004**2 + (0.04 * rate_w) ** 2 + own.std_w_radps**2),
        rtol=1e-12,
    )


@pytest.mark.parametrize(
    "calibration",
    [
        None,
        {},
        {"model_noise_std_v_mps": 0.008, "model_noise_std_w_radps": 0.01},  # no timing: older
        {**_HELD, "model_noise_timing_w_s": None},
    ],
)
def test_without_a_held_out_timing_share_the_band_keeps_the_one_number_rule(
    calibration: object,
) -> None:
    trace = _straights_and_spins()
    out = band_sample_noise(_FILE, _FITTED, trace, _ramped(trace), calibration=calibration)
    assert out == band_noise(_FILE, _FITTED, band_log_noise(trace), calibration=calibration)


@settings(max_examples=50, deadline=None)
@given(std_v=st.floats(0.0, 0.05), std_w=st.floats(0.0, 0.2), seed=st.integers(0, 2**31))
def test_constant_sample_noise_draws_as_the_observation_noise(
    std_v: float, std_w: float, seed: int
) -> None:
    v, w = np.ones((3, 40)), np.zeros((3, 40))
    one = ObservationNoise(std_v_mps=std_v, std_w_radps=std_w, quantum_w_radps=0.01)
    each = SampleNoise(std_v_mps=np.full(40, std_v), std_w_radps=np.full(40, std_w),
                       quantum_w_radps=0.01)  # fmt: skip
    a = one.apply(np.random.default_rng(seed), v, w, spread=1.5)
    b = each.apply(np.random.default_rng(seed), v, w, spread=1.5)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


@pytest.mark.parametrize(("floor", "tau"), [(0.01, 0.04), (0.0, 0.1), (0.02, 0.0)])
def test_the_share_fit_recovers_a_floor_and_a_timing_scale(floor: float, tau: float) -> None:
    """Golden: 4,000 residuals with sd sqrt(0.006^2 + floor^2 + (tau a)^2), a uniform in 0-3:
    the timing within 0.01 s and the floor beyond the 0.006 noise within 0.006."""
    rng = np.random.default_rng(0)
    a = rng.uniform(0.0, 3.0, 4000)
    r = rng.normal(0.0, np.sqrt(0.006**2 + floor**2 + (tau * a) ** 2))
    d0, t = fit_model_share(r, a, measurement_std=0.006)
    assert t == pytest.approx(tau, abs=0.01)
    assert d0 == pytest.approx(floor, abs=0.006)
    share = ModelShare(std_v_mps=d0, std_w_radps=0.0, timing_v_s=t)
    assert share.at(np.array([2.0]), np.zeros(1))[0][0] == pytest.approx(
        math.hypot(floor, 2 * tau), abs=0.01
    )
    # too few residuals for two bins: one robust sd, no timing; a floor the calibration widened
    assert fit_model_share(r[:150], a[:150], measurement_std=0.006)[1] == 0.0
    assert fit_model_share(r, a, measurement_std=0.006, at_least=1.0)[0] == pytest.approx(
        math.sqrt(1.0 - 0.006**2)
    )
    assert all(math.isnan(x) for x in fit_model_share([], [], measurement_std=0.006))
    # a replay exact where it is steady (a quantised log, no noise): its bins' MAD is 0
    exact = np.where(a < 1.0, 0.0, r)
    d0, t = fit_model_share(exact, a, measurement_std=0.0)
    assert math.isfinite(d0) and math.isfinite(t) and t > 0
    assert fit_model_share(0 * r, a, measurement_std=0.0) == (0.0, 0.0)


def test_no_own_noise_is_taken_below_the_quantisations() -> None:
    """Encoder odometry on a 0.001 m/s lattice whose fit logs read a robust sd of 0 (most
    readings on one step): the band's own noise is q / sqrt(12) at least, on both axes."""
    t = np.arange(0, 1_000_000_000, 50_000_000)
    cmd = np.full(t.size, 0.2)
    short = Trace(cmd_t_ns=t, cmd_v=cmd, cmd_w=0 * cmd, meas_t_ns=t, meas_v=cmd, meas_w=0 * cmd)
    lattice = ObservationNoise(std_v_mps=0.0, quantum_v_mps=0.001, quantum_w_radps=0.01)
    zero = {"measurement_noise": {"std_v_mps": 0.0, "std_w_radps": 0.0, "samples": 900}}
    steady = {**_HELD, "model_noise_std_v_mps": 0.0, "model_noise_std_w_radps": 0.0}
    noise, _ = band_sample_noise(lattice, zero, short, SimpleNamespace(v=cmd, w=0 * cmd),
                                 calibration=steady)  # fmt: skip
    np.testing.assert_allclose(noise.std_v_mps, 0.001 / math.sqrt(12.0))
    np.testing.assert_allclose(noise.std_w_radps, 0.01 / math.sqrt(12.0))


def test_a_motion_never_held_is_told_by_what_the_replay_leaves() -> None:
    """Spins held 4 s between straights held 0.8 s (never steady): v where commanded is the
    log's own 0.01 m/s read against the replay (not the fit logs' 0.012), v held at zero and w
    the log's own from the spins."""
    rng = np.random.default_rng(2)
    t = np.arange(0, 96_000_000_000, 50_000_000)
    straight = (t % 4_800_000_000) >= 4_000_000_000
    cmd_v, cmd_w = np.where(straight, 0.2, 0.0), np.where(straight, 0.0, 1.0)
    trace = Trace(cmd_t_ns=t, cmd_v=cmd_v, cmd_w=cmd_w, meas_t_ns=t,
                  meas_v=cmd_v + rng.normal(0.0, 0.01, t.size) * straight,
                  meas_w=cmd_w + rng.normal(0.0, 0.03, t.size))  # fmt: skip
    noise, _ = band_sample_noise(_FILE, _FITTED, trace, SimpleNamespace(v=cmd_v, w=cmd_w),
                                 calibration={**_HELD, "model_noise_std_v_mps": 0.0,
                                              "model_noise_std_w_radps": 0.0,
                                              "model_noise_timing_v_s": 0.0,
                                              "model_noise_timing_w_s": 0.0})  # fmt: skip
    assert np.ptp(noise.std_v_mps[straight]) == 0.0
    assert noise.std_v_mps[straight][0] == pytest.approx(0.01, rel=0.15)
    assert np.all(noise.std_v_mps[~straight] == 0.001 / math.sqrt(12.0))  # exact 0: the floor
    assert noise.std_w_radps[0] == pytest.approx(0.03, rel=0.15)
