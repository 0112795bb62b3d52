"""Command arrival-time jitter in the fit (sysid._timing): the whitening, the estimate, the fit.

Known truth: logs of the drive model itself whose commands reach it after a normal jitter of
known sd (the log keeps the published times), sampled at 30 Hz with white noise and nothing
else, so that the only error the model does not have is the commands' timing.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.reduced import DEFAULT_DT_S, simulate
from robots.spec import load_spec
from sysid import fit_drive
from sysid._coords import Mapper
from sysid._logs import LogArrays
from sysid._problem import ARRIVAL_NODES, Problem, _arrival_nodes
from sysid._timing import (
    MIN_COMMANDS,
    Whitener,
    arrival_sensitivities,
    arrival_whitener,
    estimate_jitter,
    logs_key,
)
from sysid.plan import plan_excitation
from sysid.synthetic import jittered_model_log, step_commands, synthetic_log

SPEC = load_spec("turtlebot3_burger")
#: The Burger's spec drive with the PI loops the prior centres on (no smoother: every command
#: is a step, where timing matters most).
TRUTH = SPEC.drive.replace(speed_loop_ki_per_s=20.0)


def _log(jitter_s: float, seed: int, duration_s: float = 90.0) -> LogArrays:
    """The planned script on the model, its commands ``jitter_s`` late or early each (order
    kept), v and w sampled at 30 Hz with 4 mm/s and 0.02 rad/s white noise."""
    plan = plan_excitation(SPEC, duration_s)
    return jittered_model_log(TRUTH, SPEC.geometry, plan, seed=seed, arrival_jitter_s=jitter_s)


def _problem(log: LogArrays) -> Problem:
    return Problem(
        [log], Mapper(SPEC.geometry, TRUTH), (), {}, scale_v=0.01, scale_w=0.05, dt_s=DEFAULT_DT_S
    )


@settings(max_examples=30, deadline=None)
@given(
    n=st.integers(3, 12),
    m=st.integers(1, 5),
    seed=st.integers(0, 2**31 - 1),
)
def test_whitener_without_jitter_is_the_identity(n: int, m: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    g = rng.normal(size=(2 * n, m))
    w = Whitener.build([g], sigma_t_s=0.0, scale_v=0.3, scale_w=2.0, key=((0.0, 1.0, n),))
    x = rng.normal(size=(3, 2 * n))
    np.testing.assert_allclose(w.apply(x), x, rtol=1e-12, atol=1e-12)


def test_whitened_timing_noise_has_the_channel_scales() -> None:
    """Residuals made of white noise plus each command's sensitivity times a normal arrival
    error: whitened, every row has its channel's white variance and no correlation."""
    rng = np.random.default_rng(3)
    n, m, s_v, s_w, sigma = 40, 6, 0.2, 1.5, 0.01
    g = np.zeros((2 * n, m))
    for k in range(m):  # each command moves a transient of a few instants after it
        a = 5 * k + 2
        g[a : a + 8, k] = 40.0 * np.exp(-np.arange(8) / 3.0)
        g[n + a : n + a + 8, k] = -300.0 * np.exp(-np.arange(8) / 2.0)
    w = Whitener.build([g], sigma_t_s=sigma, scale_v=s_v, scale_w=s_w, key=((0.0, 1.0, n),))
    draws = 4000
    noise = rng.normal(size=(draws, 2 * n)) * np.repeat([s_v, s_w], n)
    x = noise + (sigma * rng.normal(size=(draws, m))) @ g.T
    y = w.apply(x) / np.repeat([s_v, s_w], n)
    cov = y.T @ y / draws
    assert np.max(np.abs(np.diag(cov) - 1.0)) < 0.12
    assert np.max(np.abs(cov - np.diag(np.diag(cov)))) < 0.1
    raw = x / np.repeat([s_v, s_w], n)
    assert np.max(np.diag(raw.T @ raw / draws)) > 2.0  # the timing noise was there to remove


@pytest.mark.parametrize("jitter_s", [0.005, 0.01])
@pytest.mark.parametrize("seed", [1, 2])
def test_jitter_is_recovered_at_the_truth(jitter_s: float, seed: int) -> None:
    prob = _problem(_log(jitter_s, seed))
    f = prob.scaled_sim(TRUTH) - prob.meas
    est = estimate_jitter(arrival_sensitivities(prob, TRUTH), f, max_jitter_s=0.05)
    assert est.significant
    # ~55 commands inform it (the rest are ramp steps): sampling error ~15 %; on the model's
    # sharp transients the linearisation attenuates early arrivals (10 ms early reads 7.7):
    # 0.6-0.8 of the truth on seeds 1-3
    assert 0.55 * jitter_s <= est.sigma_t_s <= 1.3 * jitter_s
    assert est.scale_v == pytest.approx(0.004 / 0.01, rel=0.1)  # white v, in scaled units


@pytest.mark.parametrize("seed", [1, 2])
def test_no_jitter_is_within_the_model_step(seed: int) -> None:
    """A log without jitter (the model on another grid phase) shows at most the step's own
    timing error: no whitening."""
    prob = _problem(_log(0.0, seed))
    est, timing = arrival_whitener(prob, TRUTH, prob.scaled_sim(TRUTH) - prob.meas)
    assert est.sigma_t_s < DEFAULT_DT_S
    assert not est.significant
    assert timing is None


def test_jitter_is_bounded_by_half_the_command_period() -> None:
    """Beyond what an ordered 10 Hz link can do the linearisation fails: the estimate stays at
    half the command period and nothing is whitened."""
    prob = _problem(_log(0.2, 1))
    est, timing = arrival_whitener(prob, TRUTH, prob.scaled_sim(TRUTH) - prob.meas)
    assert est.sigma_t_s <= 0.05 + 1e-9
    assert timing is None or est.sigma_t_s < 0.05


def test_a_few_missed_transients_do_not_make_jitter() -> None:
    """Residuals of white noise with three transients the model misses (a response 50 ms
    off): the robust estimate does not read them as jitter of every command."""
    prob = _problem(_log(0.0, 2))
    sens = arrival_sensitivities(prob, TRUTH)
    f = prob.scaled_sim(TRUTH) - prob.meas
    n = sens[0].n
    for s_, v_, w_ in list(zip(sens[0].start, sens[0].v, sens[0].w, strict=True))[10:13]:
        f[s_ : s_ + v_.size] += 0.05 * v_
        f[n + s_ : n + s_ + w_.size] += 0.05 * w_
    est = estimate_jitter(sens, f, max_jitter_s=0.05)
    assert est.sigma_t_s < DEFAULT_DT_S


def test_a_whitener_of_other_logs_is_not_used() -> None:
    log = _log(0.01, 1)
    prob = _problem(log)
    est, timing = arrival_whitener(prob, TRUTH, prob.scaled_sim(TRUTH) - prob.meas)
    assert timing is not None and est.significant
    other = _problem(_log(0.01, 1, duration_s=60.0))
    other.set_timing(timing)
    assert other.timing is None
    same = _problem(log)
    same.set_timing(timing)
    assert same.timing is timing
    raw = _problem(log).data_residuals(np.zeros(0))
    assert not np.allclose(same.data_residuals(np.zeros(0)), raw)


def test_synthetic_log_arrival_jitter() -> None:
    t, v, w = step_commands(20.0, seed=4)
    geo = SPEC.geometry
    plain = synthetic_log(TRUTH, geo, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=4)
    zero = synthetic_log(TRUTH, geo, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=4, arrival_jitter_s=0.0)
    late = synthetic_log(TRUTH, geo, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=4, arrival_jitter_s=0.01)
    np.testing.assert_array_equal(zero.meas_v, plain.meas_v)
    np.testing.assert_array_equal(late.cmd_t_s, plain.cmd_t_s)  # the log keeps the times
    np.testing.assert_array_equal(late.meas_t_s, plain.meas_t_s)  # same noise draws
    assert float(np.max(np.abs(late.meas_w - plain.meas_w))) > 0.05  # the response moved


@pytest.mark.slow
def test_fit_whitens_a_jittered_log_and_reports_it() -> None:
    log = _log(0.01, 3)
    res = fit_drive([log], geometry=SPEC.geometry, base_params=SPEC.drive, priors=SPEC.priors)
    (jit,) = res.settings["command_jitter"]
    assert jit["whitened"] is True
    assert 0.005 <= jit["jitter_s"] <= 0.015
    assert "arrival-time jitter" in res.settings["optimizer_status"]


def test_few_changing_commands_are_not_whitened() -> None:
    """40 s of the plan: 31 commands change the target, too few to tell a jitter (its robust
    scale would be known to +-42 %): estimated, reported, not whitened."""
    prob = _problem(_log(0.01, 1, duration_s=40.0))
    est, timing = arrival_whitener(prob, TRUTH, prob.scaled_sim(TRUTH) - prob.meas)
    assert est.commands < MIN_COMMANDS
    assert est.sigma_t_s > DEFAULT_DT_S and est.spread > 1.3
    assert not est.significant and timing is None


@settings(max_examples=30, deadline=None)
@given(sigma=st.floats(1e-4, 0.05))
def test_arrival_nodes_have_the_jitter_moments(sigma: float) -> None:
    nodes = _arrival_nodes(sigma)
    shift = np.array([d for d, _ in nodes])
    weight = np.array([w for _, w in nodes])
    assert len(nodes) == ARRIVAL_NODES and weight.min() > 0.0
    assert weight.sum() == pytest.approx(1.0, abs=1e-12)
    assert float(weight @ shift) == pytest.approx(0.0, abs=1e-12 * sigma)
    assert float(weight @ shift**2) == pytest.approx(sigma**2, rel=1e-9)
    assert float(weight @ shift**4) == pytest.approx(3.0 * sigma**4, rel=1e-9)
    assert _arrival_nodes(0.0) == [(0.0, 1.0)]


def test_a_whitened_problem_models_the_expected_response() -> None:
    """Known truth: the mean of 200 runs of the model whose commands arrive with a 10 ms
    jitter each (100 antithetic pairs), less the run without jitter, is what the jitter does to the data's mean. The problem
    with that jitter's whitening predicts it (three-point Gauss-Hermite over the arrival time,
    on the model's own step) to within half its size in each channel: 0.31 of it in v, 0.45
    in w, where the transients are sharpest (no prediction: an error of its whole size)."""
    plan = plan_excitation(SPEC, 30.0)
    t = np.arange(0.0, plan.duration_s, 1.0 / 30.0)
    rng = np.random.default_rng(5)

    def run(arrive_s: np.ndarray) -> np.ndarray:
        out = simulate(
            TRUTH,
            SPEC.geometry,
            cmd_t_s=arrive_s,
            cmd_v=plan.v_mps,
            cmd_w=plan.w_radps,
            t_out_s=t,
            dt_s=0.0005,
        )
        return np.concatenate([out.v, out.w])

    jittered = []
    for _ in range(100):  # antithetic pairs: the first-order timing noise cancels in the mean
        late = 0.01 * rng.standard_normal(plan.t_s.size)
        jittered += [run(np.maximum.accumulate(plan.t_s + d)) for d in (late, -late)]
    effect = np.mean(jittered, axis=0) - run(plan.t_s)
    log = LogArrays(
        cmd_t_s=plan.t_s,
        cmd_v=plan.v_mps,
        cmd_w=plan.w_radps,
        meas_t_s=t,
        meas_v=np.zeros(t.size),
        meas_w=np.zeros(t.size),
    )
    prob = _problem(log)
    n = t.size
    at_mean = prob.scaled_sim(TRUTH)
    # the jitter's whitening with no timing columns: the identity, the expectation only
    prob.set_timing(
        Whitener.build(
            [np.zeros((2 * n, 0))], sigma_t_s=0.01, scale_v=1.0, scale_w=1.0, key=logs_key([log])
        )
    )
    predicted = prob.scaled_sim(TRUTH) - at_mean
    scaled = np.concatenate([effect[:n] / 0.01, effect[n:] / 0.05])  # the problem's scales
    for rows in (slice(0, n), slice(n, 2 * n)):
        miss = np.linalg.norm(predicted[rows] - scaled[rows])
        assert miss < 0.5 * np.linalg.norm(scaled[rows])
