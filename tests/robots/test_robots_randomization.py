"""The one drive-parameter distribution: seeded draws, physical draws, moments, files, errors."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from robots import load_spec
from robots.errors import ParamsFileError, RobotsValueError
from robots.params import SCHEMA
from robots.randomization import TRUNCATE_SIGMA, DriveDistribution, ObservationNoise

SPEC = load_spec("turtlebot3_burger")
GEO = SPEC.geometry


def _dist(spread: float = 1.0) -> DriveDistribution:
    return DriveDistribution.from_priors(SPEC.name, GEO, SPEC.priors).scaled(spread)


def _write(tmp_path: Path, block: Any, robot: str = SPEC.name) -> Path:
    path = tmp_path / "params.yaml"
    doc = {"format": "sim2real.sysid/1", "robot": robot, "parameters": {}, "randomization": block}
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


@settings(max_examples=25)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 20), spread=st.floats(0.0, 3.0))
def test_same_seed_same_draws_and_every_draw_is_physical(seed: int, n: int, spread: float) -> None:
    dist = _dist(spread=2.0)  # wide: mass and limits drawn far from the nominal
    a = dist.sample(np.random.default_rng(seed), n, spread=spread)
    b = dist.sample(np.random.default_rng(seed), n, spread=spread)
    assert a == b and len(a) == n
    for p in a:
        assert p.total_mass_kg(GEO) > 0 and p.total_yaw_inertia_kgm2(GEO) > 0
        assert p.motor_gain_nms_per_rad > 0 and p.wheel_speed_max_radps > 0
        assert p.delay_s >= 0 and p.coulomb_v_fwd_n >= 0
        assert p.cmd_timeout_s == SPEC.drive.cmd_timeout_s  # sd 0 in the spec: fixed


#: Draws per example of the moment test, and its false-alarm rate per example.
_N_DRAWS = 50_000
_FALSE_ALARM = 1e-7


@settings(max_examples=10, derandomize=True)  # the same examples with or without CI=true
@given(seed=st.integers(0, 2**32 - 2))
def test_empirical_mean_and_covariance_match(seed: int) -> None:
    r"""Sample moments within what the sampling distribution allows (false alarm ~1e-7).

    The mean: :math:`n\,d^T\Sigma^{-1}d \sim \chi^2_k`. Each covariance entry:
    :math:`\mathrm{sd}(S_{ij}) = \sqrt{(\Sigma_{ij}^2 + \Sigma_{ii}\Sigma_{jj})/n}` (Gaussian
    fourth moments), bound at the two-sided normal quantile of the false-alarm rate over the
    entries, plus the tiny variance the truncation at ``TRUNCATE_SIGMA`` removes.
    """
    from scipy.stats import chi2, norm

    rng = np.random.default_rng(seed)
    k = 3
    a = rng.normal(size=(k, k))
    cov = 0.01 * (a @ a.T + 0.1 * np.eye(k))
    names = ("motor_gain_nms_per_rad", "added_mass_kg", "wheel_speed_max_radps")
    fixed = {n: v for n, v in SPEC.drive.to_dict().items() if n not in names}
    dist = DriveDistribution(
        robot="x",
        geometry=GEO,
        names=names,
        mean=(math.log(0.01), math.log(1.2), math.log(7.0)),
        covariance=tuple(tuple(r) for r in cov.tolist()),
        fixed=fixed,
    )
    n = _N_DRAWS
    z = dist.sample_coords(np.random.default_rng(seed + 1), n)
    d = z.mean(axis=0) - dist.mean_array
    assert n * d @ np.linalg.solve(cov, d) < chi2.ppf(1 - _FALSE_ALARM, k)
    emp = np.cov(z.T)
    sd = np.sqrt((cov**2 + np.outer(np.diag(cov), np.diag(cov))) / n)
    quantile = norm.isf(_FALSE_ALARM / (2 * k * (k + 1) / 2))
    c = TRUNCATE_SIGMA  # a clipped standard normal has variance 1 - loss
    loss = 2 * (c * norm.pdf(c) + (1 - c**2) * norm.sf(c))
    assert np.all(np.abs(emp - cov) < quantile * sd + loss * np.abs(cov))
    # and the values are the coordinates mapped back through the schema
    p = dist.sample(np.random.default_rng(seed + 1), 1)[0]
    assert math.log(p.total_mass_kg(GEO)) == pytest.approx(z[0, 1])


def test_scaled_and_noise() -> None:
    dist = _dist()
    assert np.allclose(dist.scaled(2.0).covariance_array, 4.0 * dist.covariance_array)
    noisy = DriveDistribution(
        **{**dist.__dict__, "noise": ObservationNoise(std_v_mps=0.01, quantum_v_mps=0.005)}
    )
    v, w = noisy.sample_noise(np.random.default_rng(0), np.zeros(2000), np.ones(2000))
    assert np.std(v) == pytest.approx(0.01, rel=0.1)
    assert np.allclose(np.round(v / 0.005) * 0.005, v)
    assert np.all(w == 1.0)
    with pytest.raises(RobotsValueError, match="finite number >= 0"):
        dist.scaled(math.nan)
    with pytest.raises(RobotsValueError, match="integer >= 1"):
        dist.sample(np.random.default_rng(0), 0)


def test_params_file_round_trip(tmp_path: Path) -> None:
    dist = _dist()
    path = _write(tmp_path, dist.to_dict())
    back = DriveDistribution.from_params_file(path, robot=SPEC.name)
    assert back == dist
    rng = np.random.default_rng(3)
    assert back.sample(rng, 4) == dist.sample(np.random.default_rng(3), 4)


def _bad(block: dict[str, Any], key: str, value: Any) -> dict[str, Any]:
    out = dict(block)
    out[key] = value
    return out


def _cov00(b: dict[str, Any], value: float) -> dict[str, Any]:
    rows = [list(r) for r in b["covariance"]]
    rows[0][0] = value
    return _bad(b, "covariance", rows)


def _first(b: dict[str, Any], key: str, value: Any) -> dict[str, Any]:
    return _bad(b, key, [value, *b[key][1:]])


_NOISE_BAD = {
    "v": {"std_mps": -1.0, "quantum_mps": 0.0},
    "w": {"std_radps": 0.0, "quantum_radps": 0.0},
}


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda b: _bad(b, "robot", "turtlebot2"), "another robot"),
        (lambda b: {}, "non-empty mapping"),
        (
            lambda b: {**b, "names": [], "coords": [], "mean": [], "covariance": []},
            "at least one",
        ),
        (lambda b: _first(b, "mean", math.nan), "'delay_s' must be a finite"),
        (lambda b: _cov00(b, math.nan), "variance of 'delay_s'"),
        (lambda b: _cov00(b, -1.0), "variance of 'delay_s' must be a finite number >= 0"),
        (lambda b: _cov00(b, 100.0), "absurd"),
        (lambda b: _first(b, "coords", "log"), "entry of 'delay_s' must be 'lin'"),
        (lambda b: _bad(b, "fixed", {}), "missing"),
        (lambda b: _bad(b, "noise", _NOISE_BAD), "std_v_mps"),
    ],
)
def test_bad_blocks_are_refused_naming_the_key(tmp_path: Path, change: Any, words: str) -> None:
    path = _write(tmp_path, change(_dist().to_dict()))
    with pytest.raises(ParamsFileError, match=str(path).replace(".", r"\.")) as info:
        DriveDistribution.from_params_file(path, robot=SPEC.name)
    assert words in str(info.value)


def test_file_of_another_robot_and_file_without_block(tmp_path: Path) -> None:
    path = _write(tmp_path, _dist().to_dict(), robot="turtlebot2")
    with pytest.raises(ParamsFileError, match="identified for robot 'turtlebot2'"):
        DriveDistribution.from_params_file(path, robot=SPEC.name)
    path.write_text(yaml.safe_dump({"robot": SPEC.name, "parameters": {}}))
    with pytest.raises(ParamsFileError, match="no 'randomization' block"):
        DriveDistribution.from_params_file(path, robot=SPEC.name)


def test_a_non_psd_covariance_is_refused() -> None:
    names = ("delay_s", "added_mass_kg")
    fixed = {n: v for n, v in SPEC.drive.to_dict().items() if n not in names}
    with pytest.raises(ParamsFileError, match="positive semi-definite"):
        DriveDistribution(
            robot="x",
            geometry=GEO,
            names=names,
            mean=(0.1, 0.0),
            covariance=((0.01, 0.02), (0.02, 0.01)),
            fixed=fixed,
        )


def test_every_field_is_either_varied_or_fixed() -> None:
    dist = _dist()
    assert set(dist.names) | set(dist.fixed) == set(SCHEMA)
    assert "cmd_timeout_s" in dist.fixed  # sd 0
    assert "accel_lim_v_mps2" in dist.fixed  # inf: no prior centre
    assert "motor_gain_nms_per_rad" in dist.names


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    sd=st.floats(0.01, 1.0),
    eps=st.floats(-1e-12, 1e-12),
)
def test_draws_move_continuously_with_the_covariance(seed: int, sd: float, eps: float) -> None:
    """Two equal variances (a repeated eigenvalue): a last-digit change of the covariance, as a
    params file rewritten with other rounding gives, moves every draw by a last-digit amount.

    An eigenvector factor :math:`V\\Lambda^{1/2}` fails this: ``eigh`` may return any rotation
    of the eigenvectors of a repeated eigenvalue, and a 1e-16 change picks another one."""
    names = ("motor_gain_nms_per_rad", "added_mass_kg")
    fixed = {n: v for n, v in SPEC.drive.to_dict().items() if n not in names}
    var = sd**2

    def dist(off: float) -> DriveDistribution:
        return DriveDistribution(
            robot="x",
            geometry=GEO,
            names=names,
            mean=(math.log(0.01), math.log(1.2)),
            covariance=((var, off * var), (off * var, var)),
            fixed=fixed,
        )

    a = dist(0.0).sample_coords(np.random.default_rng(seed), 8)
    b = dist(eps).sample_coords(np.random.default_rng(seed), 8)
    assert np.max(np.abs(a - b)) <= 1e-9 * sd


def _format_1(dist: DriveDistribution) -> dict[str, Any]:
    """``dist`` as the format-1 block an earlier sim2real wrote: frictions as values (``lin``),
    mapped at the mean with the Jacobian of F = z T (T = e^{z_T} when the total varies)."""
    block = dist.to_dict()
    names = list(dist.names)
    mean = dist.mean_array
    jac = np.eye(len(names))
    for i, n in enumerate(names):
        per = SCHEMA[n].per_field
        if per is None:
            continue
        j = names.index(per)
        total = math.exp(mean[j])
        jac[i, i], jac[i, j] = total, mean[i] * total
    cov = jac @ dist.covariance_array @ jac.T
    block |= {
        "format": "sim2real.randomization/1",
        "coords": ["lin" if SCHEMA[n].per_field else SCHEMA[n].coord for n in names],
        "mean": (np.diag(jac) * mean).tolist(),
        "covariance": (0.5 * (cov + cov.T)).tolist(),
    }
    return block


def test_a_format_1_block_is_read_in_the_per_mass_coordinates(tmp_path: Path) -> None:
    """A params file of the previous format (friction coordinates = the values) is converted,
    not refused: the same mean robot, and the covariance mapped back to what it was."""
    dist = _dist()
    assert "coulomb_v_fwd_n" in dist.names and "added_mass_kg" in dist.names
    path = _write(tmp_path, _format_1(dist))
    back = DriveDistribution.from_params_file(path, robot=SPEC.name)
    for name in SCHEMA:
        a, b = getattr(back.mean_params(), name), getattr(dist.mean_params(), name)
        assert a == pytest.approx(b, rel=1e-9, abs=1e-12), name
    np.testing.assert_allclose(back.covariance_array, dist.covariance_array, rtol=1e-9, atol=1e-15)
    assert back.to_dict()["format"] == "sim2real.randomization/2"


def test_a_draw_scales_its_friction_with_its_own_mass() -> None:
    """Per-kg friction: each of 500 draws of the Burger prior carries the drawn Coulomb force
    per kg times its own drawn total mass (and the yaw friction per kg m^2 times its own yaw
    inertia), so a heavier draw has proportionally more friction."""
    dist = _dist()
    z = dist.sample_coords(np.random.default_rng(5), 500)
    names = list(dist.names)
    i_f, i_m = names.index("coulomb_v_fwd_n"), names.index("added_mass_kg")
    i_w = names.index("coulomb_w_nm")
    for row in z:
        p = dist.params_at(row)
        assert p.coulomb_v_fwd_n == pytest.approx(max(row[i_f], 0.0) * p.total_mass_kg(GEO))
        assert p.coulomb_w_nm == pytest.approx(max(row[i_w], 0.0) * p.total_yaw_inertia_kgm2(GEO))
        assert p.total_mass_kg(GEO) == pytest.approx(math.exp(row[i_m]), rel=1e-9) or (
            row[i_m] <= SCHEMA["added_mass_kg"].coord_bounds(GEO)[0]
        )
