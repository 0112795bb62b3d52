"""The posterior's data information (Godambe sandwich) and the odometry-noise estimate:
numbers against closed forms on residuals with known structure (no fit needed)."""

from __future__ import annotations

import numpy as np
import pytest

from sysid._logs import LogArrays
from sysid._map import data_information, score_covariance
from sysid._summary import estimate_noise


def _ar1(rng: np.random.Generator, n: int, rho: float, sd: float) -> np.ndarray:
    e = np.empty(n)
    e[0] = rng.normal(0.0, sd)
    innov = rng.normal(0.0, sd * np.sqrt(1.0 - rho**2), n)
    for i in range(1, n):
        e[i] = rho * e[i - 1] + innov[i]
    return e


def test_white_residuals_give_the_gauss_newton_information() -> None:
    rng = np.random.default_rng(1)
    n, sd = 20000, 0.3
    jac = rng.normal(size=(2 * n, 3))  # v rows then w rows of one log
    f = rng.normal(0.0, sd, 2 * n)
    meat = score_covariance([n], jac * f[:, None], lags=3)
    info = data_information(jac, meat)
    expect = jac.T @ jac / sd**2
    assert np.allclose(np.diag(info), np.diag(expect), rtol=0.1)


@pytest.mark.parametrize("rho", [0.5, 0.8])
def test_autocorrelated_residuals_count_as_fewer_samples(rho: float) -> None:
    # the mean of an AR(1) series: its variance is s^2 (1 + rho) / (1 - rho) / n
    rng = np.random.default_rng(2)
    n, sd = 20000, 0.1
    f = np.concatenate([_ar1(rng, n, rho, sd), np.zeros(n)])  # w rows carry nothing
    jac = np.concatenate([np.ones((n, 1)), np.zeros((n, 1))])
    info = data_information(jac, score_covariance([n], jac * f[:, None], lags=80))
    expect = n / (sd**2 * (1.0 + rho) / (1.0 - rho))
    assert float(info[0, 0]) == pytest.approx(expect, rel=0.15)
    white = n / sd**2
    assert float(info[0, 0]) < 0.5 * white


def test_heteroscedastic_residuals_widen_only_the_directions_they_inform() -> None:
    # column 0 sees only the noisy half of the log (transients), column 1 only the quiet half
    rng = np.random.default_rng(3)
    n = 6000
    noisy = np.arange(n) < n // 2
    sd = np.where(noisy, 0.5, 0.05)
    f = np.concatenate([rng.normal(0.0, 1.0, n) * sd, np.zeros(n)])
    jac = np.zeros((2 * n, 2))
    jac[:n, 0] = noisy
    jac[:n, 1] = ~noisy
    info = data_information(jac, score_covariance([n], jac * f[:, None], lags=0))
    assert float(info[0, 0]) == pytest.approx((n // 2) / 0.5**2, rel=0.1)
    assert float(info[1, 1]) == pytest.approx((n // 2) / 0.05**2, rel=0.1)


def test_a_direction_the_data_never_see_carries_no_information() -> None:
    rng = np.random.default_rng(4)
    n = 1000
    jac = np.column_stack([rng.normal(size=2 * n), np.zeros(2 * n)])  # motor gain: invisible
    f = rng.normal(0.0, 0.2, 2 * n)
    info = data_information(jac, score_covariance([n], jac * f[:, None], lags=5))
    assert np.all(np.isfinite(info))
    assert info[1, 1] == 0.0 and info[0, 1] == 0.0


def test_noise_is_estimated_on_the_samples_where_the_robot_moves() -> None:
    # half the log parked (exact zeros, model zero too), half moving with 3 mm/s noise
    rng = np.random.default_rng(5)
    n = 2000
    t = np.arange(n) * 0.02
    moving = t >= t[n // 2]
    cmd_v = np.where(moving, 0.2, 0.0)
    res_v = np.where(moving, rng.normal(0.0, 0.003, n), 0.0)
    res_w = np.where(moving, rng.normal(0.0, 0.02, n), 0.0)
    log = LogArrays(
        cmd_t_s=t,
        cmd_v=cmd_v,
        cmd_w=np.zeros(n),
        meas_t_s=t,
        meas_v=cmd_v + res_v,
        meas_w=res_w,
        name="half_parked",
    )
    noise = estimate_noise([log], res_v, res_w)
    assert noise.std_v_mps == pytest.approx(0.003, rel=0.1)
    assert noise.std_w_radps == pytest.approx(0.02, rel=0.1)
