"""The noise ceiling of pose-derived 7 Hz odometry whose stamps jitter.

A robot drives and spins under commands held 4 s each (0.3 and 0.15 m/s straight, 2 and
-1 rad/s in place, an arc, a stop); its driver publishes the exact pose at ~7 Hz with a zero
twist, stamped with Gaussian jitter of 25 ms (the Neato's: its pose-derived v scatters by
~6 % of the speed). The file is a real MCAP written by the project's writer; the reader
derives the velocities from the pose. A velocity differenced over jittered stamps is off by
a share of the speed, so the noise grows with speed.

The true ceiling is Monte Carlo: the share of the active samples where the jittered
odometry is within tolerance of the same session's odometry with exact stamps (what a
perfect model, replayed through the same pose derivative, would predict), over 8 draws of
the jitter (0.842). Tolerance: the ceiling of each of three 300 s logs within 0.035 of it
(measured 0.815-0.868 over six logs, mean 0.848; without the jitter's timing term where the
velocity changes, jitter_timing_s, 0.827-0.877, mean 0.858); one constant noise per axis
misses it by over 0.1.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robots.measurement import MeasurementModel
from robots.randomization import ObservationNoise
from sim2real.agreement.latency import jitter_timing_s, log_noise, motion_ceiling, noise_ceiling
from sim2real.logs import read_trace, write_velocity_log
from sim2real.logs._pose_velocity import _update_derivative
from sysid.metrics import active_mask

T0_NS = 1_700_000_000_000_000_000
JITTER_S = 0.025
MOTIONS = ((0.3, 0.0), (0.0, 2.0), (0.15, 0.0), (0.0, -1.0), (0.2, 0.8), (0.0, 0.0))
TOL_V, TOL_W = 0.02, 0.1


def _session(
    seed: int, jitter_s: float, duration_s: float = 300.0
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Commands (10 Hz) and the exact pose at ~7 Hz true times, stamped with jitter (the
    :func:`write_velocity_log` keywords), and the true sample of each stamped one."""
    rng = np.random.default_rng(seed)
    dt = 1e-3
    t = np.arange(0.0, duration_s, dt)
    k = (t // 4.0).astype(int) % len(MOTIONS)
    v = np.array([m[0] for m in MOTIONS])[k]
    w = np.array([m[1] for m in MOTIONS])[k]
    yaw = np.cumsum(w) * dt
    x, y = np.cumsum(v * np.cos(yaw)) * dt, np.cumsum(v * np.sin(yaw)) * dt
    true_s = np.cumsum(rng.uniform(0.9, 1.1, int(duration_s * 7.0)) / 7.0)
    true_s = true_s[true_s < duration_s - 0.5]
    at = np.searchsorted(t, true_s)
    draw = np.random.default_rng(seed + 1000).normal(0.0, 1.0, true_s.size)
    order = np.argsort(true_s + jitter_s * draw)  # a stamp order the driver could send
    cmd_s = np.arange(0.0, duration_s, 0.1)
    ci = np.searchsorted(t, cmd_s)
    return {
        "cmd_t_ns": T0_NS + np.rint(cmd_s * 1e9).astype(np.int64),
        "cmd_v": v[ci],
        "cmd_w": w[ci],
        "meas_t_ns": T0_NS + np.rint((true_s + jitter_s * draw)[order] * 1e9).astype(np.int64),
        "meas_v": np.zeros(true_s.size),
        "meas_w": np.zeros(true_s.size),
        "pose_x": x[at][order],
        "pose_y": y[at][order],
        "pose_yaw": np.arctan2(np.sin(yaw[at]), np.cos(yaw[at]))[order],
    }, order


def _pose_velocity(s: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The reader's pose derivative of a session's odometry."""
    v, w, _ = _update_derivative(s["meas_t_ns"], (s["pose_x"], s["pose_y"], s["pose_yaw"]))
    return v, w


def _true_ceiling(draws: int = 8) -> float:
    shares = []
    for seed in range(draws):
        (jittered, order), (exact, _) = _session(seed, JITTER_S), _session(seed, 0.0)
        (v, w), (v0, w0) = _pose_velocity(jittered), _pose_velocity(exact)
        cmd_t, meas_t = jittered["cmd_t_ns"], jittered["meas_t_ns"]
        held = np.clip(np.searchsorted(cmd_t, meas_t, "right") - 1, 0, cmd_t.size - 1)
        active = active_mask(
            jittered["cmd_v"][held], jittered["cmd_w"][held], v, w, tol_v=TOL_V, tol_w=TOL_W
        )
        ok = (np.abs(v - v0[order]) < TOL_V) & (np.abs(w - w0[order]) < TOL_W)
        shares.append(float(np.mean(ok[active])))
    return float(np.mean(shares))


@pytest.fixture(scope="module")
def truth() -> float:
    return _true_ceiling()


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_the_ceiling_of_jittered_pose_odometry(tmp_path: Path, truth: float, seed: int) -> None:
    path = write_velocity_log(tmp_path / "jitter.mcap", **_session(seed, JITTER_S)[0])
    trace = read_trace(path)
    assert trace.measurement is not None and trace.measurement.kind == "pose"
    own = log_noise(trace)
    noise = ObservationNoise(std_v_mps=own.std_v_mps, std_w_radps=own.std_w_radps)
    ceiling = motion_ceiling(trace, noise, tol_v=TOL_V, tol_w=TOL_W)
    assert 0.7 < truth < 0.95  # the jitter matters at these speeds
    assert ceiling.agreement == pytest.approx(truth, abs=0.035)
    constant = noise_ceiling(noise, tol_v=TOL_V, tol_w=TOL_W)
    assert constant.agreement > truth + 0.1
    assert "at its own speed" in ceiling.note


def test_the_jitters_timing_term_is_the_pose_windows_alone() -> None:
    """sqrt(sum u^4 / sum u^2) of the updates in the window: 1.84 periods for 5 of them, 0 for
    a reading that is not a pose derivative (a twist, a hold)."""
    pose = MeasurementModel(kind="pose", window_s=5 * 0.143, update_period_s=0.143)
    assert jitter_timing_s(pose) == pytest.approx(0.143 * (34 / 10) ** 0.5, rel=1e-12)
    assert jitter_timing_s(MeasurementModel(kind="hold", update_period_s=0.5)) == 0.0
    assert jitter_timing_s(None) == 0.0
