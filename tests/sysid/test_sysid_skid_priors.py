"""Priors that keep their weight under a quantised sensor at rest, and a speed-cap prior that
gives way where the log proves it wrong.

- A quantised channel (an encoder's speed: its readings repeat a few levels) reads exactly
  zero at rest, where the model predicts zero too: those residuals say nothing of the noise
  and are left out of its scale (:func:`sysid._map.noise_scale`). A continuous channel (the
  Neato driver's twist, a gyro) keeps every row, its exact zeros included.
- A spec's top speed below what the log measures centres the wheel-speed cap's prior where
  the log contradicts it; the log proves the cap is at least its measured wheel speed
  (:func:`sysid._needs.measured_speeds`), so the prior is centred there.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace
from typing import cast

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.params import BaseGeometry
from robots.spec import RobotSpec
from sim2real.logs import Trace
from sim2real.plants.skid import husky_like, run_skid_plant
from sysid._map import noise_scale
from sysid._needs import measured_speeds
from sysid._problem import Problem, quantised
from sysid.fit import fit_drive
from sysid.synthetic import step_commands
from tests.husky import husky_spec

GEO = BaseGeometry(
    mass_kg=50.0, yaw_inertia_kgm2=5.0, wheel_radius_m=0.165, wheel_separation_m=0.555
)


def _scale(f: np.ndarray, grid: bool) -> float:
    half = f.size // 2
    rows = {"v": np.arange(half), "w": np.arange(half, f.size)}
    prob = SimpleNamespace(rows=rows, quantised=np.full(f.size, grid))
    s2, _ = noise_scale(cast(Problem, prob), f, 5)
    return float(np.sqrt(s2))


def _mad(f: np.ndarray) -> float:
    return 1.4826 * float(np.median(np.abs(f - np.median(f))))


@settings(max_examples=40, deadline=None)
@given(
    zero_share=st.floats(0.0, 0.8),
    sd=st.floats(0.001, 1.0),
    seed=st.integers(0, 2**31 - 1),
)
def test_a_quantised_sensors_zeros_at_rest_leave_the_noise_scale(
    zero_share: float, sd: float, seed: int
) -> None:
    """Quantised: the scale is the moving rows' whatever the share of zeros at rest;
    continuous: every row counts (the exact zeros shrink it)."""
    rng = np.random.default_rng(seed)
    noise = sd * rng.standard_normal(400)
    zeros = np.zeros(int(zero_share * 400 / (1 - zero_share)))
    f = rng.permutation(np.concatenate([zeros, noise]))
    dof = np.sqrt(f.size / (f.size - 5))
    assert _scale(f, grid=True) == pytest.approx(max(_mad(noise) * dof, 1e-6))
    assert _scale(f, grid=False) == pytest.approx(max(_mad(f) * dof, 1e-6))
    assert _scale(f, grid=True) > 0.45 * sd  # never near the floor, however many zeros


def test_all_zero_residuals_keep_the_floor() -> None:
    assert _scale(np.zeros(200), grid=True) == pytest.approx(1e-6)


@settings(max_examples=30, deadline=None)
@given(tick=st.floats(0.02, 0.1), seed=st.integers(0, 2**31 - 1))
def test_encoder_speeds_are_quantised_and_a_twist_is_not(tick: float, seed: int) -> None:
    """300 readings on at most 100 levels (a tick of 2-10 % of the range) repeat them."""
    rng = np.random.default_rng(seed)
    speed = rng.uniform(-1.0, 1.0, 300)
    assert quantised(tick * np.round(speed / tick + 0.1 * rng.standard_normal(300)))
    dt = 0.1 + 0.01 * rng.standard_normal(300)  # a displacement over a jittered step
    assert not quantised(tick * np.round(speed * 0.1 / tick) / dt)
    assert not quantised(np.zeros(300))  # nothing moves: no grid to see


def test_measured_speeds_are_a_percentile_not_a_spike() -> None:
    v = np.full(1000, 1.0)
    v[5] = 40.0  # one odometry spike
    w = np.zeros(1000)
    out = measured_speeds([v], [w], GEO)
    assert out["speed_lim_v_mps"] == pytest.approx(1.0)
    assert out["wheel_speed_max_radps"] == pytest.approx(1.0 / 0.165)
    assert measured_speeds([], [], GEO)["wheel_speed_max_radps"] == 0.0


@pytest.fixture(scope="module")
def plant_log() -> Trace:
    """60 s of a Husky-like skid plant under step commands up to 1 m/s, its encoders reading
    exactly zero while it stands still."""
    t, v, w = step_commands(60.0, seed=4, v_max_mps=1.0, w_max_radps=1.2, hold_s=(1.5, 3.0))
    trace = run_skid_plant(husky_like(), t, v, w, duration_s=60.0, rng=np.random.default_rng(4))
    v_cmd, w_cmd = trace.cmd_at_meas()
    still = (np.abs(trace.meas_v) < 0.02) & (v_cmd == 0.0) & (w_cmd == 0.0)
    zero = np.where(still, 0.0, trace.meas_v), np.where(still, 0.0, trace.meas_w)
    return replace(trace, meas_v=zero[0], meas_w=zero[1])


def _spec(folder: Path, max_speed_mps: float) -> RobotSpec:
    return husky_spec(folder, max_speed_mps=max_speed_mps)


@pytest.mark.slow
def test_a_cap_the_log_exceeds_gives_way(plant_log: Trace, tmp_path: Path) -> None:
    """A spec top speed of 0.4 m/s under a log that drives at ~1 m/s: the cap's prior is
    centred on the measured wheel speed, and the fit drives as fast as the log."""
    spec = _spec(tmp_path, 0.4)
    res = fit_drive([plant_log], geometry=spec.geometry, base_params=spec.drive, priors=spec.priors)
    (note,) = [n for n in res.warnings if "wheel_speed_max_radps" in n and "prior centre" in n]
    assert "the limit is at least that" in note
    seen = measured_speeds([plant_log.meas_v], [plant_log.meas_w], spec.geometry)
    assert seen["wheel_speed_max_radps"] > 2.0 * 0.4 / 0.165
    assert res.params.wheel_speed_max_radps >= 0.9 * seen["wheel_speed_max_radps"]
    assert res.scores_fit[0].agreement_v > 0.6, res.scores_fit[0]
