"""A band that over-covers the calibration samples with the noise at what the log shows is
narrowed by the spread of the parameters that move the over-covered axis, not by the noise."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from _agreement_fixtures import ROBOT, hidden_params, write_log
from hypothesis import given
from hypothesis import strategies as st

from robots.spec import load_spec
from sim2real.agreement.calibration import NARROW_MIN, calibrate_traces, narrowing_floor
from sim2real.agreement.figures import run_ensemble
from sim2real.logs import read_trace
from tests.randomization_block import distribution_around


@pytest.fixture(scope="module")
def sessions(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two 30 s sessions of the same plant (noise 0.003 m/s and 0.02 rad/s)."""
    root = tmp_path_factory.mktemp("narrow")
    return write_log(root / "cal.mcap", seed=5), write_log(root / "check.mcap", seed=6)


def test_a_too_wide_spread_is_narrowed_on_its_axis_and_holds_on_another_session(
    sessions: tuple[Path, Path],
) -> None:
    # every parameter's spread is 0.3x its prior's around the plant's own values: far wider
    # than one plant varies (it does not), so the band over-covers both axes
    wide = distribution_around(hidden_params(), ROBOT, rel=0.3)
    res = calibrate_traces([read_trace(sessions[0])], robot=ROBOT, distribution=wide, n=16)
    note = next(n for n in res.notes if "the spread is narrowed" in n)
    assert "on the parameters that move v" in note
    # the noise stays at the truth: the log's steady stretches show it
    assert res.noise_std_v_mps == pytest.approx(0.003, rel=0.3)
    assert res.noise_std_w_radps == pytest.approx(0.02, rel=0.3)
    # the calibration samples: covered at the top of the matching range, and above it by
    # no more than what the parameters these samples cannot tell keep of their spread
    assert 0.9 <= res.coverage_v <= 0.99 and 0.9 <= res.coverage_w <= 0.99
    # the parameters the note names are narrowed, from the pooled spread (the session
    # factor's share of the spec's session spread aside), those the samples cannot tell no
    # further than the spec's between-session sd
    named = note.split("move v (")[1].split(")")[0].split(", ")
    kept = note.split("%); ")[1].split(" no further")[0].split(", ")
    assert "coulomb_w_nm" not in named and named
    session = {n: p.session_sd for n, p in load_spec(ROBOT).priors.items()}
    for name in named:
        pooled = res.dynamics_factor * wide.std()[name]
        now = res.distribution.std()[name]
        if name in kept:
            assert now >= min(pooled, session[name]) * (1 - 1e-9)
        else:
            assert NARROW_MIN * pooled * 0.99 <= now < 0.8 * pooled
    # another session of the plant: still covered, by a narrower band than the pooled one
    trace = read_trace(sessions[1])
    before = run_ensemble(trace, robot=ROBOT, distribution=wide, n=20, seed=1)
    after = run_ensemble(trace, robot=ROBOT, distribution=res.distribution, n=20, seed=1)
    assert after.coverage_v >= 0.85 and after.coverage_w >= 0.85
    assert after.band_width_v_mps < 0.8 * before.band_width_v_mps
    assert np.isfinite(after.band_width_w_radps)


def test_a_spread_the_log_needs_is_not_narrowed(sessions: tuple[Path, Path]) -> None:
    # a narrow spread (2 % of the prior's) over-covers nothing: no narrowing
    tight = distribution_around(hidden_params(), ROBOT, rel=0.02)
    res = calibrate_traces([read_trace(sessions[0])], robot=ROBOT, distribution=tight, n=16)
    assert not any("the spread is narrowed" in n for n in res.notes)


def test_a_fleets_spread_is_narrowed_only_as_far_as_the_validation_sessions_weigh(
    sessions: tuple[Path, Path],
) -> None:
    # the same over-covering spread, said to be fitted on 5 sessions: one alike validation
    # session weighs 1 against their 4 degrees of freedom, so no sd goes below sqrt(4 / 5)
    wide = distribution_around(hidden_params(), ROBOT, rel=0.3)
    res = calibrate_traces(
        [read_trace(sessions[0])], robot=ROBOT, distribution=wide, n=16, fit_sessions=5
    )
    floor = math.sqrt(4.0 / 5.0)
    assert res.narrowing, "the band over-covers: some group is narrowed"
    for name, scale in res.narrowing:
        assert floor - 1e-9 <= scale < 1.0, name
    unpooled = math.sqrt(max((5.0 * min(s for _, s in res.narrowing) ** 2 - 4.0), 0.0))
    assert unpooled < 0.5  # what one session alone asked for: a much narrower spread


finite = st.floats(min_value=1e-6, max_value=10.0, allow_nan=False)


@given(
    st.lists(st.tuples(finite, finite, finite, finite), min_size=1, max_size=8),
    finite,
    finite,
)
def test_the_narrowing_floor_is_the_session_sd_of_what_the_samples_cannot_tell(
    rows: list[tuple[float, float, float, float]], noise_v: float, noise_w: float
) -> None:
    pooled, session, var_v, var_w = (np.array(c) for c in zip(*rows, strict=True))
    floor = narrowing_floor(pooled, session, np.c_[var_v, var_w], (noise_v, noise_w))
    told = (var_v >= noise_v) | (var_w >= noise_w)
    # told apart from the noise on either axis: free to narrow (to NARROW_MIN)
    assert np.all(floor[told] == 0.0)
    # buried under it on both: the spec's between-session sd, or no narrowing at all
    np.testing.assert_allclose(floor[~told], np.minimum(1.0, session / pooled)[~told])
    assert np.all((floor >= 0.0) & (floor <= 1.0))
