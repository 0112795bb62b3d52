"""The calibration's optimum is pooled with the file's spread by sessions, not by samples."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from _agreement_fixtures import ROBOT, hidden_params, write_logs
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chi2

from sim2real.agreement.calibration import (
    NARROW_MIN,
    calibrate,
    calibrate_traces,
    pooled_factors,
    pooled_narrowing,
)
from sim2real.cli import main
from sim2real.errors import Sim2RealValueError
from sim2real.logs import read_trace
from sysid import spread_degrees_of_freedom
from tests.randomization_block import distribution_around, write_params_file

factors = st.floats(0.05, 10.0)
sessions = st.integers(1, 50)


def test_pooled_factors_golden() -> None:
    # nu = 3 - 1 + 3 = 5, m = 2: a^2 = (5 + 2 * 0.04) / 7, b^2 = 2 * 1 / 7
    a, b = pooled_factors(0.2, 1.0, fit_sessions=3, validation_sessions=2)
    assert a == pytest.approx(math.sqrt(5.08 / 7.0), rel=1e-12)
    assert b == pytest.approx(math.sqrt(2.0 / 7.0), rel=1e-12)
    assert spread_degrees_of_freedom(3) == 5.0 and spread_degrees_of_freedom(1) == 3.0


@settings(max_examples=200, deadline=None)
@given(a=factors, b=st.floats(0.0, 4.0), n=sessions, m=sessions)
def test_pooled_factors_lie_between_the_file_and_the_optimum(
    a: float, b: float, n: int, m: int
) -> None:
    ac, bc = pooled_factors(a, b, fit_sessions=n, validation_sessions=m)
    assert min(1.0, a) - 1e-12 <= ac <= max(1.0, a) + 1e-12
    assert 0.0 <= bc <= b + 1e-12
    # more validation sessions move the result toward the optimum, more fitted ones toward 1
    ac_more, _ = pooled_factors(a, b, fit_sessions=n, validation_sessions=m + 5)
    assert abs(ac_more - a) <= abs(ac - a) + 1e-12
    ac_fit, _ = pooled_factors(a, b, fit_sessions=n + 5, validation_sessions=m)
    assert abs(ac_fit - 1.0) <= abs(ac - 1.0) + 1e-12


def test_many_validation_sessions_reach_the_optimum() -> None:
    ac, bc = pooled_factors(0.3, 2.0, fit_sessions=3, validation_sessions=10_000)
    assert ac == pytest.approx(0.3, rel=5e-3) and bc == pytest.approx(2.0, rel=5e-3)


@pytest.fixture(scope="module")
def two_logs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    a, b = write_logs(tmp_path_factory.mktemp("calsessions"), (1, 3))
    return a, b


def test_alike_validation_sessions_cannot_shrink_a_fleets_spread_to_nothing(
    two_logs: tuple[Path, Path],
) -> None:
    # the file is 20x wider than these two logs need: the likelihood alone shrinks it hard, the
    # pooled factor keeps the share the fit's 4 sessions (+ 3 prior) vouch for
    dist = distribution_around(hidden_params(), ROBOT, rel=0.2, noise_v=0.003, noise_w=0.02)
    traces = [read_trace(p) for p in two_logs]
    res = calibrate_traces(traces, robot=ROBOT, distribution=dist, n=8, fit_sessions=4)
    nu, m = 6.0, 2.0
    # measured 0.05, the search's lower bound (seeds 0-2, n 8-16): the logs need far less
    assert res.likelihood_dynamics_factor < 0.5
    assert res.dynamics_factor**2 == pytest.approx(
        (nu + m * res.likelihood_dynamics_factor**2) / (nu + m), rel=1e-9
    )
    assert res.session_factor**2 == pytest.approx(
        m * res.likelihood_session_factor**2 / (nu + m), rel=1e-9, abs=1e-12
    )
    assert res.dynamics_factor >= math.sqrt(nu / (nu + m)) - 1e-12
    assert (res.fit_sessions, res.validation_sessions) == (4, 2)
    # the noise is matched at the pooled factors and the over-covering spread narrowed only as
    # far as 2 alike sessions weigh against the fit's 3 beyond its mean: the written band covers
    # at least 90 % of the logs, and may cover more than the matching range's top (95 %)
    assert 0.895 <= res.coverage_v <= 0.99 and 0.895 <= res.coverage_w <= 0.99
    assert all(scale >= math.sqrt(3.0 / 5.0) - 1e-9 for _, scale in res.narrowing)


def test_calibrate_reads_the_fits_session_count(
    two_logs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    params = write_params_file(
        tmp_path / "p.yaml", hidden_params(), ROBOT, rel=0.05, extra={"settings": {"sessions": 5}}
    )
    res = calibrate(params, [two_logs[0]], robot=ROBOT, n=4)
    assert (res.fit_sessions, res.validation_sessions) == (5, 1)
    out = tmp_path / "cal.yaml"
    argv = ["sysid", "calibrate", str(params), str(two_logs[0]), "--robot", ROBOT, "-o", str(out)]
    assert main([*argv, "--ensemble", "4"]) == 0
    assert "pooled by sessions with the fit's 5 log(s)" in capsys.readouterr().out
    cal = yaml.safe_load(out.read_text())["calibration"]
    assert (cal["fit_sessions"], cal["validation_sessions"]) == (5, 1)
    assert cal["dynamics_factor"] == pytest.approx(
        pooled_factors(
            cal["likelihood_dynamics_factor"],
            cal["likelihood_session_factor"],
            fit_sessions=5,
            validation_sessions=1,
        )[0]
    )
    # a file without the count (written by hand) counts as one fitted session
    bare = write_params_file(tmp_path / "bare.yaml", hidden_params(), ROBOT, rel=0.05)
    assert calibrate(bare, [two_logs[0]], robot=ROBOT, n=4).fit_sessions == 1


@pytest.mark.parametrize("bad", [0, -2, 1.5, True])
def test_bad_fit_session_count_is_refused(two_logs: tuple[Path, Path], bad: object) -> None:
    dist = distribution_around(hidden_params(), ROBOT)
    with pytest.raises(Sim2RealValueError, match="fit_sessions"):
        calibrate_traces(
            [read_trace(two_logs[0])],
            robot=ROBOT,
            distribution=dist,
            n=4,
            fit_sessions=bad,  # type: ignore[arg-type]
        )


@pytest.mark.parametrize("bad", [0, -3, 2.5, "three", True])
def test_a_bad_session_count_in_the_file_is_refused_in_one_sentence(
    two_logs: tuple[Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    bad: object,
) -> None:
    params = write_params_file(
        tmp_path / "p.yaml", hidden_params(), ROBOT, extra={"settings": {"sessions": bad}}
    )
    out = tmp_path / "cal.yaml"
    argv = ["sysid", "calibrate", str(params), str(two_logs[0]), "--robot", ROBOT, "-o", str(out)]
    assert main([*argv, "--ensemble", "4"]) == 2
    err = capsys.readouterr().err
    assert "settings.sessions" in err and str(params) in err and repr(bad) in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


@settings(max_examples=200, deadline=None)
@given(s=st.floats(NARROW_MIN, 1.0), n=sessions, m=sessions)
def test_pooled_narrowing_lies_between_the_file_and_the_validation_scale(
    s: float, n: int, m: int
) -> None:
    sc = pooled_narrowing(s, fit_sessions=n, validation_sessions=m)
    assert s - 1e-12 <= sc <= 1.0 + 1e-12
    # more validation sessions move it toward their scale, more fitted ones toward the file's
    assert sc - 1e-12 <= pooled_narrowing(s, fit_sessions=n + 5, validation_sessions=m)
    assert pooled_narrowing(s, fit_sessions=n, validation_sessions=m + 5) <= sc + 1e-12
    # a one-log fit's spread has no fitted session beyond its mean: the validation scale
    assert pooled_narrowing(s, fit_sessions=1, validation_sessions=m) == pytest.approx(s)


def test_pooled_narrowing_recovers_a_known_between_session_spread_within_its_interval() -> None:
    # a between-session sd of 0.2 (any unit); the file's spread is the sample sd of n fitted
    # sessions about their mean, the validation scale the m validation sessions' sd about the
    # (known) mean relative to it. The pooled spread is the pooled variance: its chi-square
    # interval with nu + m degrees of freedom holds the true spread 95 % of the time, and it
    # is tighter than the interval of the validation sessions alone
    rng = np.random.default_rng(7)
    sigma, n, m, trials = 0.2, 4, 2, 4000
    held = held_alone = 0
    widths, widths_alone = [], []
    for _ in range(trials):
        fitted = rng.normal(0.0, sigma, n)
        file_var = float(np.var(fitted, ddof=1))
        val_var = float(np.mean(rng.normal(0.0, sigma, m) ** 2))
        scale = math.sqrt(val_var / file_var)
        pooled = file_var * pooled_narrowing(scale, fit_sessions=n, validation_sessions=m) ** 2
        df = n - 1 + m
        lo, hi = df * pooled / chi2.ppf(0.975, df), df * pooled / chi2.ppf(0.025, df)
        held += lo <= sigma**2 <= hi
        widths.append(math.sqrt(hi) - math.sqrt(lo))
        lo_a, hi_a = m * val_var / chi2.ppf(0.975, m), m * val_var / chi2.ppf(0.025, m)
        held_alone += lo_a <= sigma**2 <= hi_a
        widths_alone.append(math.sqrt(hi_a) - math.sqrt(lo_a))
    assert 0.93 <= held / trials <= 0.97
    assert 0.93 <= held_alone / trials <= 0.97
    assert np.median(widths) < 0.5 * np.median(widths_alone)
