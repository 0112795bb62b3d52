"""Ensemble of replays drawn from the sysid uncertainty, and its coverage."""

from __future__ import annotations

import numpy as np
import pytest
from _agreement_fixtures import ROBOT, hidden_params, spec, write_log
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.agreement import run_ensemble, sample_drive_params, sampled_parameters
from sim2real.errors import Sim2RealValueError
from sim2real.logs import read_trace

STDS = {"delay_s": 0.02, "added_mass_kg": 0.1, "accel_lim_v_mps2": 0.1, "coulomb_v_fwd_n": 0.1}


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return read_trace(write_log(tmp_path_factory.mktemp("ens") / "log.mcap", duration_s=20.0))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.1, 5.0))
def test_draws_are_seeded_and_scale_with_spread(seed: int, spread: float) -> None:
    geo = spec().geometry
    base = hidden_params()
    a = sample_drive_params(
        base, STDS, n=40, rng=np.random.default_rng(seed), geometry=geo, spread=spread
    )
    b = sample_drive_params(
        base, STDS, n=40, rng=np.random.default_rng(seed), geometry=geo, spread=spread
    )
    assert a == b
    delays = np.array([p.delay_s for p in a])
    assert np.all(delays >= 0.0)
    assert np.all(np.abs(delays - base.delay_s) <= 3 * spread * STDS["delay_s"] + 1e-12)
    # unlisted parameters keep the base value
    assert {p.motor_gain_nms_per_rad for p in a} == {base.motor_gain_nms_per_rad}


def test_draw_statistics_match_the_std() -> None:
    base = hidden_params()
    draws = sample_drive_params(
        base, {"added_mass_kg": 0.1}, n=4000, rng=np.random.default_rng(1), geometry=spec().geometry
    )
    x = np.array([p.added_mass_kg for p in draws])
    assert x.mean() == pytest.approx(base.added_mass_kg, abs=0.01)
    assert x.std() == pytest.approx(0.1 * 0.986, rel=0.05)  # N(0,1) truncated at 3 sigma


def test_draws_are_clipped_to_physical_ranges() -> None:
    geo = spec().geometry
    base = hidden_params().replace(coulomb_v_bwd_n=0.2)
    draws = sample_drive_params(
        base,
        {"coulomb_v_bwd_n": 1.0, "added_mass_kg": 3.0, "accel_lim_v_mps2": 5.0},
        n=200,
        rng=np.random.default_rng(2),
        geometry=geo,
    )
    assert min(p.coulomb_v_bwd_n for p in draws) == 0.0
    assert min(p.added_mass_kg for p in draws) == pytest.approx(-0.9 * geo.mass_kg)
    assert min(p.accel_lim_v_mps2 for p in draws) == pytest.approx(0.05 * 0.6)


def test_bad_ensemble_size_is_refused() -> None:
    with pytest.raises(Sim2RealValueError, match="--ensemble"):
        sample_drive_params(
            hidden_params(), STDS, n=1, rng=np.random.default_rng(0), geometry=spec().geometry
        )


#: Uncertainty on every parameter that moves the steady state too (friction), so the band
#: does not collapse where the robot cruises.
WIDE_STDS = {
    **STDS,
    "coulomb_v_bwd_n": 0.1,
    "coulomb_w_nm": 0.005,
    "viscous_v_ns_per_m": 0.2,
    "viscous_w_nms_per_rad": 0.002,
}


def test_wider_spread_raises_coverage(trace) -> None:  # type: ignore[no-untyped-def]
    # centre off the truth, so a narrow band misses the real samples
    centre = hidden_params().replace(delay_s=0.12, added_mass_kg=0.2)
    cov = [
        run_ensemble(
            trace, robot=ROBOT, params=centre, stds=WIDE_STDS, n=12, seed=5, spread=s,
            engine="reduced",
        )
        for s in (0.2, 1.0, 2.0)
    ]  # fmt: skip
    values = [c.coverage for c in cov]
    assert values[0] < values[1] < values[2]
    assert values[0] < 0.3 and values[2] > 0.8
    for c in cov:
        assert np.all(c.lo_v <= c.hi_v) and c.lo_v.shape == trace.meas_v.shape
        assert 0.0 <= c.coverage <= min(c.coverage_v, c.coverage_w) <= 1.0


def test_ensemble_is_reproducible_and_needs_stds(trace) -> None:  # type: ignore[no-untyped-def]
    kw = {"robot": ROBOT, "params": hidden_params(), "n": 4, "engine": "reduced"}
    a = run_ensemble(trace, stds=STDS, seed=9, **kw)
    b = run_ensemble(trace, stds=STDS, seed=9, **kw)
    c = run_ensemble(trace, stds=STDS, seed=10, **kw)
    np.testing.assert_array_equal(a.lo_v, b.lo_v)
    assert a.params == b.params and a.params != c.params
    with pytest.raises(Sim2RealValueError, match="std"):
        run_ensemble(trace, stds={"delay_s": 0.0}, seed=0, **kw)


def test_meaningless_std_is_not_sampled(trace) -> None:  # type: ignore[no-untyped-def]
    base = hidden_params()
    stds = {"delay_s": 3e6, "added_mass_kg": 0.1, "coulomb_w_nm": 0.0, "no_such": 1.0}
    assert sampled_parameters(base, stds) == ["added_mass_kg"]
    ens = run_ensemble(trace, robot=ROBOT, params=base, stds=stds, n=3, seed=0, engine="reduced")
    assert ens.sampled == ("added_mass_kg",) and ens.skipped == ("delay_s",)
    assert {p.delay_s for p in ens.params} == {base.delay_s}


def test_parameter_fitted_at_zero_is_sampled_relative_to_the_spec_default() -> None:
    base = hidden_params().replace(coulomb_v_fwd_n=1e-10)
    stds = {"coulomb_v_fwd_n": 0.003}
    assert sampled_parameters(base, stds) == []
    assert sampled_parameters(base, stds, reference=spec().drive) == ["coulomb_v_fwd_n"]
