"""The agreement measure on hand-built arrays: exact expected numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.agreement.figures import AGREEMENT_KEYS, agreement_from_arrays, check_tolerances
from sim2real.errors import Sim2RealValueError

# index:        0     1     2     3     4     5     6     7     8     9
CMD_V = np.array([0.0, 0.0, 0.2, 0.2, 0.2, 0.2, 0.0, 0.0, 0.0, 0.0])
CMD_W = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0])
REAL_V = np.array([0.0, 0.03, 0.1, 0.2, 0.2, 0.2, 0.0, 0.0, 0.0, 0.0])
REAL_W = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.05, 0.4, 0.2, 0.0])
SIM_V = np.array([1.0, 0.03, 0.1, 0.15, 0.21, 0.2, 0.5, 0.0, 0.0, 0.0])
SIM_W = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.2, 0.5, 0.45, 0.05, 0.0])
ACTIVE = np.array([1, 2, 3, 4, 5, 7, 8])  # 0, 6, 9 are idle (6: |w| = 0.05 <= tol_w)


def _report(**kw: float):  # type: ignore[no-untyped-def]
    return agreement_from_arrays(
        t_s=0.1 * np.arange(10),
        cmd_v=CMD_V,
        cmd_w=CMD_W,
        real_v=REAL_V,
        real_w=REAL_W,
        sim_v=SIM_V,
        sim_w=SIM_W,
        robot="turtlebot3_burger",
        params_file="p.yaml",
        log_file="x.mcap",
        log_sha256="ab" * 32,
        **kw,
    )


def test_counts_and_fractions_are_exact() -> None:
    rep = _report()
    assert rep.n_samples == 10
    assert rep.n_active == 7
    assert rep.agreement == pytest.approx(4 / 7)  # samples 1, 2, 4, 7
    assert rep.agreement_v == pytest.approx(6 / 7)  # all but 3
    assert rep.agreement_w == pytest.approx(5 / 7)  # all but 5 and 8


def test_rmse_and_fit_use_active_samples_only() -> None:
    rep = _report()
    assert rep.rmse_v == pytest.approx(math.sqrt((0.05**2 + 0.01**2) / 7))
    assert rep.rmse_w == pytest.approx(math.sqrt((0.2**2 + 0.05**2 + 0.15**2) / 7))
    y, yh = REAL_V[ACTIVE], SIM_V[ACTIVE]
    expected = 100 * (1 - np.linalg.norm(y - yh) / np.linalg.norm(y - y.mean()))
    assert rep.fit_percent_v == pytest.approx(expected)
    assert rep.fit_percent_v == pytest.approx(78.21, abs=0.01)  # 100 (1 - 0.05099 / 0.23403)


def test_idle_samples_do_not_count() -> None:
    """Making the idle samples' simulation perfect or terrible changes nothing."""
    base = _report()
    sim_v = SIM_V.copy()
    sim_v[[0, 6, 9]] = [-5.0, 5.0, 3.0]
    rep = agreement_from_arrays(
        t_s=0.1 * np.arange(10),
        cmd_v=CMD_V,
        cmd_w=CMD_W,
        real_v=REAL_V,
        real_w=REAL_W,
        sim_v=sim_v,
        sim_w=SIM_W,
        robot="r",
    )
    assert (rep.agreement, rep.agreement_v, rep.n_active) == (
        base.agreement,
        base.agreement_v,
        base.n_active,
    )


def test_tolerances_change_the_verdict() -> None:
    loose = _report(tol_v=0.06, tol_w=0.25)
    # sample 1 (real v 0.03) and 8 (real w 0.2) are idle under the loose tolerances
    assert loose.n_active == 5
    assert loose.agreement == pytest.approx(1.0)
    assert (loose.tol_v, loose.tol_w) == (0.06, 0.25)


def test_to_dict_has_exactly_the_issue_keys() -> None:
    d = _report().to_dict()
    assert tuple(d) == AGREEMENT_KEYS
    assert set(d) == {
        "agreement", "agreement_v", "agreement_w", "fit_percent_v", "fit_percent_w",
        "rmse_v", "rmse_w", "lag_s_v", "lag_s_w", "n_samples", "n_active", "tol_v",
        "tol_w", "robot", "params_file", "log_file", "log_sha256",
    }  # fmt: skip
    assert d["robot"] == "turtlebot3_burger" and d["log_sha256"] == "ab" * 32


def test_no_active_sample_gives_nan_and_null() -> None:
    z = np.zeros(5)
    rep = agreement_from_arrays(
        t_s=np.arange(5.0), cmd_v=z, cmd_w=z, real_v=z, real_w=z, sim_v=z + 1, sim_w=z, robot="r"
    )
    assert rep.n_active == 0 and math.isnan(rep.agreement)
    assert rep.to_dict()["agreement"] is None


def test_lag_sign_is_positive_when_sim_is_late() -> None:
    t = np.arange(0.0, 20.0, 0.02)
    real = np.sin(2 * np.pi * 0.3 * t)
    late = np.sin(2 * np.pi * 0.3 * (t - 0.2))
    ones = np.ones_like(t)
    rep = agreement_from_arrays(
        t_s=t, cmd_v=ones, cmd_w=ones, real_v=real, real_w=real, sim_v=late, sim_w=real, robot="r"
    )
    assert rep.lag_s_v == pytest.approx(0.2, abs=0.01)
    assert rep.lag_s_w == pytest.approx(0.0, abs=0.01)


@pytest.mark.parametrize("tol", [0.0, -0.1, math.nan, math.inf])
def test_bad_tolerance_is_refused_with_the_flag_name(tol: float) -> None:
    with pytest.raises(Sim2RealValueError, match=r"--tol-v"):
        check_tolerances(tol, 0.1)
    with pytest.raises(Sim2RealValueError, match=r"--tol-w"):
        _report(tol_w=tol)


def test_shape_mismatch_is_refused() -> None:
    with pytest.raises(Sim2RealValueError, match="one length"):
        agreement_from_arrays(
            t_s=np.arange(3.0),
            cmd_v=np.zeros(3),
            cmd_w=np.zeros(3),
            real_v=np.zeros(3),
            real_w=np.zeros(3),
            sim_v=np.zeros(2),
            sim_w=np.zeros(3),
            robot="r",
        )


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-0.3, 0.3), min_size=5, max_size=40),
    st.floats(0.0, 0.05),
    st.floats(0.005, 0.1),
)
def test_constant_offset_agrees_iff_within_tolerance(
    values: list[float], offset: float, tol: float
) -> None:
    real = np.asarray(values)
    cmd = np.full(real.size, 0.1)  # every sample active
    rep = agreement_from_arrays(
        t_s=0.1 * np.arange(real.size),
        cmd_v=cmd,
        cmd_w=cmd,
        real_v=real,
        real_w=np.zeros(real.size),
        sim_v=real + offset,
        sim_w=np.zeros(real.size),
        tol_v=tol,
        robot="r",
    )
    assert rep.n_active == real.size
    assert rep.agreement_w == 1.0
    # |(x + d) - x| may differ from d by one ulp; stay away from the boundary
    if abs(offset - tol) > 1e-9:
        assert rep.agreement == (1.0 if offset < tol else 0.0)
    assert 0.0 <= rep.agreement <= rep.agreement_v <= 1.0
