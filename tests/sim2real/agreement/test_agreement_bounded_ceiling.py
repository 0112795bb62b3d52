"""The noise ceiling of a log that cannot tell its noise: the fit's, capped by the log's bound.

A controller sends a new command every 50 ms (20 Hz odometry, a new target every 0.4 s, a
first-order drive of 0.1 s), so no command holds long enough to measure the odometry noise
(white, 0.012 m/s and 0.06 rad/s). The truth is Monte Carlo: the share of the active samples
where the noisy readings are within tolerance of the drive's exact response (a perfect
model), over 10 draws (0.820). A model with a known error replays it: 0.1 s late (misses in
every transient, faster than the stencils of ``sysid.hfnoise`` can tell from noise), or 6 %
high (misses that grow with the speed, slowly). What it leaves
(``sysid.hfnoise.response_noise``) bounds the noise from above. Measured over four logs:

- the bound alone: 0.82-0.84 under the high model, but 0.69-0.72 under the late one -- a
  ceiling a fit 0.1 s late would pass by 5 points;
- capped by a fit's noise of the same source: 0.82-0.84 under either model (the truth);
- a fit source twice as noisy: its own ceiling 0.35; capped, 0.82-0.84 under the high model,
  0.69-0.72 under the late one (the misses stay in the bound: never below the fit's own);
- a fit source half as noisy: its own ceiling 0.998, above the truth (a bound cannot raise a
  noise, so the ceiling errs high, which no poor fit can pass).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.randomization import ObservationNoise
from sim2real.agreement.latency import bounded_ceiling, noise_ceiling
from sim2real.logs import Trace
from sysid.metrics import active_mask

T0_NS = 1_700_000_000_000_000_000
SD_V, SD_W = 0.012, 0.06
TOL_V, TOL_W = 0.02, 0.1
DT_S = 0.05
TAU_S = 0.1


def _response(t: np.ndarray, cmd: np.ndarray, *, late: int = 0, gain: float = 1.0) -> np.ndarray:
    """A first-order drive's (0.1 s) exact response to a command held between samples,
    ``late`` samples late and ``gain`` times as large."""
    a = math.exp(-DT_S / TAU_S)
    out = np.zeros(t.size)
    for k in range(1, t.size):
        out[k] = a * out[k - 1] + (1.0 - a) * gain * cmd[max(k - 1 - late, 0)]
    return out


def _controller(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """60 s of commands at 20 Hz: a new target every 0.4 s, a little jitter on every message."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 60.0, DT_S)
    block = (t // 0.4).astype(int)
    cmd_v = rng.uniform(0.05, 0.3, block.max() + 1)[block] + rng.normal(0.0, 0.005, t.size)
    cmd_w = rng.uniform(-1.0, 1.0, block.max() + 1)[block] + rng.normal(0.0, 0.02, t.size)
    return t, cmd_v, cmd_w


def _log(seed: int) -> tuple[Trace, np.ndarray, np.ndarray]:
    """The log, and the drive's exact response (what a perfect model predicts)."""
    t, cmd_v, cmd_w = _controller(seed)
    v, w = _response(t, cmd_v), _response(t, cmd_w)
    rng = np.random.default_rng(seed + 1000)
    stamps = T0_NS + np.rint(t * 1e9).astype(np.int64)
    trace = Trace(cmd_t_ns=stamps, cmd_v=cmd_v, cmd_w=cmd_w, meas_t_ns=stamps,
                  meas_v=v + rng.normal(0.0, SD_V, t.size),
                  meas_w=w + rng.normal(0.0, SD_W, t.size))  # fmt: skip
    return trace, v, w


def _model(trace: Trace, error: str) -> SimpleNamespace:
    """A replay with a known error: ``late`` (by 0.1 s) or ``gain`` (6 % high)."""
    t, cmd_v, cmd_w = trace.meas_t_s, *trace.cmd_at_meas()
    kw = {"late": 2} if error == "late" else {"gain": 1.06}
    return SimpleNamespace(v=_response(t, cmd_v, **kw), w=_response(t, cmd_w, **kw))


def _truth(draws: int = 10) -> float:
    shares = []
    for seed in range(draws):
        trace, v, w = _log(seed)
        cv, cw = trace.cmd_at_meas()
        active = active_mask(cv, cw, trace.meas_v, trace.meas_w, tol_v=TOL_V, tol_w=TOL_W)
        ok = (np.abs(trace.meas_v - v) <= TOL_V) & (np.abs(trace.meas_w - w) <= TOL_W)
        shares.append(float(np.mean(ok[active])))
    return float(np.mean(shares))


@pytest.fixture(scope="module")
def truth() -> float:
    return _truth()


def _fit(factor: float) -> ObservationNoise:
    return ObservationNoise(std_v_mps=factor * SD_V, std_w_radps=factor * SD_W)


@pytest.mark.parametrize("error", ["late", "gain"])
@pytest.mark.parametrize("seed", [21, 22])
def test_the_cap_never_takes_the_models_misses_for_noise(
    truth: float, error: str, seed: int
) -> None:
    trace, _, _ = _log(seed)
    model = _model(trace, error)
    assert 0.78 < truth < 0.86  # the noise matters
    same = bounded_ceiling(_fit(1.0), trace, model, tol_v=TOL_V, tol_w=TOL_W)
    assert same.agreement == pytest.approx(truth, abs=0.03)
    assert "own upper bound" in same.note
    bound = bounded_ceiling(_fit(15.0), trace, model, tol_v=TOL_V, tol_w=TOL_W).agreement
    noisy = bounded_ceiling(_fit(2.0), trace, model, tol_v=TOL_V, tol_w=TOL_W)
    plain = noise_ceiling(_fit(2.0), tol_v=TOL_V, tol_w=TOL_W)
    assert plain.agreement < truth - 0.4
    if error == "late":  # fast misses read as noise: the bound alone is too low a ceiling
        assert bound < truth - 0.08
        assert plain.agreement + 0.3 < noisy.agreement < truth
    else:  # slow misses: the stencils leave them out
        assert bound == pytest.approx(truth, abs=0.03)
        assert noisy.agreement == pytest.approx(truth, abs=0.03)
    # the noise-only band and the sds stay the fit's
    assert noisy.std_v_mps == plain.std_v_mps
    assert noisy.band_width_w_radps == plain.band_width_w_radps
    # a quieter fit source: its own ceiling, above the truth
    quiet = bounded_ceiling(_fit(0.5), trace, model, tol_v=TOL_V, tol_w=TOL_W)
    assert quiet.agreement == noise_ceiling(_fit(0.5), tol_v=TOL_V, tol_w=TOL_W).agreement
    assert quiet.agreement > truth + 0.1


@settings(max_examples=30, deadline=None)
@given(factor=st.floats(0.1, 15.0), error=st.sampled_from(["late", "gain"]))
def test_the_cap_never_lowers_the_fits_ceiling(factor: float, error: str) -> None:
    trace, _, _ = _log(3)
    fit = _fit(factor)
    capped = bounded_ceiling(fit, trace, _model(trace, error), tol_v=TOL_V, tol_w=TOL_W)
    plain = noise_ceiling(fit, tol_v=TOL_V, tol_w=TOL_W)
    assert capped.agreement >= plain.agreement - 1e-12
    assert capped.band_width_v_mps == plain.band_width_v_mps


def test_too_few_readings_keep_the_fits_ceiling() -> None:
    trace, _, _ = _log(4)
    short = trace.window(0.0, 1.0)
    fit = _fit(2.0)
    model = _model(short, "gain")
    assert bounded_ceiling(fit, short, model, tol_v=TOL_V, tol_w=TOL_W) == noise_ceiling(
        fit, tol_v=TOL_V, tol_w=TOL_W
    )
