"""The noise ceiling weighs each scored sample with its own motion's noise.

A log that drives straight half the time and spins in place the other half: v scatters by
1.2 cm/s while driving and reads 0 to the bit while spinning; w scatters by 0.05 rad/s while
spinning and by 0.005 while driving. Pooled over both, the v noise is the spinning's (half
the samples read 0), and the ceiling promises what no model could reach while driving.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robots.randomization import ObservationNoise
from sim2real.agreement.latency import log_noise, motion_ceiling, noise_ceiling
from sim2real.logs import Trace
from sysid.steady import motion_noise

T0_NS = 1_700_000_000_000_000_000
SD_DRIVE_V, SD_SPIN_W, SD_DRIVE_W = 0.012, 0.05, 0.005


def _chance(tol: float, sd: float) -> float:
    return math.erf(tol / (math.sqrt(2.0) * sd)) if sd > 0 else 1.0


def _drive_and_spin(seed: int, drive_share: float = 0.5) -> Trace:
    """60 s at 20 Hz: commands held 4 s each, straight (0.3 m/s) or spinning (1 rad/s)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 60.0, 0.05)
    block = (t // 4.0).astype(int)
    drive = (np.arange(block.max() + 1) < drive_share * (block.max() + 1))[block]
    cmd_v, cmd_w = np.where(drive, 0.3, 0.0), np.where(drive, 0.0, 1.0)
    meas_v = np.where(drive, 0.3 + rng.normal(0.0, SD_DRIVE_V, t.size), 0.0)
    meas_w = np.where(
        drive, rng.normal(0.0, SD_DRIVE_W, t.size), 1.0 + rng.normal(0.0, SD_SPIN_W, t.size)
    )
    stamps = T0_NS + np.rint(t * 1e9).astype(np.int64)
    return Trace(cmd_t_ns=stamps, cmd_v=cmd_v, cmd_w=cmd_w, meas_t_ns=stamps, meas_v=meas_v,
                 meas_w=meas_w)  # fmt: skip


def test_each_axis_noise_is_measured_while_it_moves() -> None:
    trace = _drive_and_spin(0)
    cv, cw = trace.cmd_at_meas()
    moving, still = motion_noise(trace.meas_t_s, cv, cw, trace.meas_v, trace.meas_w)
    assert moving.std_v_mps == pytest.approx(SD_DRIVE_V, rel=0.15)
    assert moving.std_w_radps == pytest.approx(SD_SPIN_W, rel=0.15)
    assert still.std_v_mps == 0.0
    assert still.std_w_radps == pytest.approx(SD_DRIVE_W, rel=0.15)
    assert log_noise(trace).std_v_mps < 0.5 * SD_DRIVE_V  # pooled: the spinning's zeros


@pytest.mark.parametrize("drive_share", [0.5, 0.8])
def test_the_ceiling_is_the_mean_chance_of_the_scored_samples(drive_share: float) -> None:
    """Golden: the expected ceiling of the two motions by their shares of the samples, from
    the noises the log shows; the pooled one stays above it (measured 100.0 vs 92.9 % at half
    and half, 97.6 vs 91.7 % at 80 % driving)."""
    trace = _drive_and_spin(1, drive_share)
    own = log_noise(trace)
    noise = ObservationNoise(std_v_mps=own.std_v_mps, std_w_radps=own.std_w_radps)
    honest = motion_ceiling(trace, noise, tol_v=0.02, tol_w=0.1)
    pooled = noise_ceiling(noise, tol_v=0.02, tol_w=0.1)
    cv, cw = trace.cmd_at_meas()
    moving, still = motion_noise(trace.meas_t_s, cv, cw, trace.meas_v, trace.meas_w)
    drive = float(np.mean(cv != 0))
    expected = drive * _chance(0.02, moving.std_v_mps) * _chance(0.1, still.std_w_radps) + (
        1.0 - drive
    ) * _chance(0.1, moving.std_w_radps)
    assert honest.agreement == pytest.approx(expected, abs=1e-12)
    # with the true noises: 0.5 x (0.904 x 1) + 0.5 x 0.954 = 0.929 at half and half
    truth = drive * _chance(0.02, SD_DRIVE_V) + (1.0 - drive) * _chance(0.1, SD_SPIN_W)
    assert honest.agreement == pytest.approx(truth, abs=0.02)
    assert pooled.agreement > honest.agreement + 0.04
    assert honest.band_width_v_mps == pooled.band_width_v_mps  # the band keeps its noise
    assert "while driving" in honest.note


def test_one_motion_only_keeps_the_pooled_ceiling() -> None:
    """A log that only drives: its own pooled noise is its driving noise, and the ceiling of
    its spin class (none) falls back on it: the same ceiling as before."""
    trace = _drive_and_spin(2, 1.0)
    own = log_noise(trace)
    noise = ObservationNoise(std_v_mps=own.std_v_mps, std_w_radps=own.std_w_radps)
    honest = motion_ceiling(trace, noise, tol_v=0.02, tol_w=0.1)
    assert honest.agreement == pytest.approx(
        noise_ceiling(noise, tol_v=0.02, tol_w=0.1).agreement, abs=1e-12
    )
    assert "nan" in honest.note
