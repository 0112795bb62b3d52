"""The fitted top speed under a pose-derived velocity: the plateau the log shows on straights.

A saturating straight command holds the base at its top speed; read through the centred pose
derivative (:mod:`robots.measurement`, operator ``"pose"``) the measured velocity plateaus at
the same speed once the command has been held longer than the window. The fit's top speed
(the tighter of the speed limit and the wheel-speed cap) stays within 5 % of that plateau, on
a plant log with a known cap and on a real Neato fit log.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from robots.params import DriveParams
from robots.spec import load_spec
from sim2real.cli import main as cli_main
from sim2real.fitting import fit_logs
from sim2real.logs import read_trace, write_trace
from sim2real.plants.diff_drive import plant_from_spec, run_plant, run_to_trace

ROBOT = "turtlebot3_burger"


def top_speed(params: DriveParams, wheel_radius_m: float) -> float:
    """The model's top forward speed, m/s: the speed limit or the wheel cap, whichever binds."""
    return min(params.speed_lim_v_mps, params.wheel_speed_max_radps * wheel_radius_m)


def straight_plateau(path: Path, above_mps: float) -> tuple[float, int]:
    """Median measured v (m/s) and row count on straights commanded above ``above_mps``, held
    for 1 s before the row and half a pose window after it."""
    trace = read_trace(path)
    cmd_v, cmd_w = (np.asarray(c) for c in trace.cmd_at_meas())
    t = np.asarray(trace.meas_t_s)
    half = 0.5 * (trace.measurement.window_s if trace.measurement is not None else 0.0)
    straight = (np.abs(cmd_w) < 0.05) & (cmd_v > above_mps)
    rows = [
        i
        for i in np.flatnonzero(straight)
        if np.all(straight[(t >= t[i] - 1.0) & (t <= t[i] + half)])
    ]
    return float(np.median(np.asarray(trace.meas_v)[rows])), len(rows)


def _encoder_pose(run) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """The pose a driver integrates from the plant's body velocities (trapezoid per sample)."""
    t, v, w = (np.asarray(a) for a in (run.meas_t_s, run.meas_v, run.meas_w))
    dt = np.diff(t, prepend=t[0])
    yaw = np.cumsum(w * dt)
    return np.cumsum(v * dt * np.cos(yaw)), np.cumsum(v * dt * np.sin(yaw)), yaw


@pytest.mark.slow
def test_plant_top_speed_under_a_pose_derived_velocity(tmp_path: Path) -> None:
    spec = load_spec(ROBOT)
    p = plant_from_spec(ROBOT, latency_s=0.15, latency_jitter_s=0.0, odom_rate_hz=7.0)
    true_top = min(p.max_v_mps, p.wheel_speed_max_radps * spec.geometry.wheel_radius_m)
    rng = np.random.default_rng(5)
    # blocks of 4 s at 10 Hz: a straight beyond the cap, a pause, a slow straight, an in-place turn
    levels = [(1.5 * true_top, 0.0), (0.0, 0.0), (0.5 * true_top, 0.0), (0.0, 1.5)] * 4
    v = np.repeat(np.array([lv for lv, _ in levels], dtype=np.float64), 40)
    w = np.repeat(np.array([lw for _, lw in levels], dtype=np.float64), 40)
    t = 1.5 + 0.1 * np.arange(v.size, dtype=np.float64)
    run = run_plant(p, t, v, w, duration_s=60.0, rng=rng)
    trace = run_to_trace(run, name="plant")
    x, y, yaw = _encoder_pose(trace)
    posed = replace(
        trace, meas_v=0 * trace.meas_v, meas_w=0 * trace.meas_w, pose_x=x, pose_y=y, pose_yaw=yaw
    )
    path = write_trace(tmp_path / "pose.mcap", posed)
    read = read_trace(path)
    assert read.measurement is not None and read.measurement.kind == "pose"
    plateau, n = straight_plateau(path, above_mps=1.05 * true_top)
    assert n >= 10
    assert plateau == pytest.approx(true_top, rel=0.03)
    fitted = top_speed(fit_logs([path], robot=ROBOT).result.params, spec.geometry.wheel_radius_m)
    assert math.isfinite(fitted)
    assert fitted == pytest.approx(plateau, rel=0.05), (fitted, plateau, true_top)


@pytest.mark.realdata
@pytest.mark.slow
def test_neato_fit_top_speed_is_the_straight_plateau(realdata_dir: Path, tmp_path: Path) -> None:
    """The benchmark's Neato fit log: full-speed straights (1 m/s commanded) plateau near
    0.30 m/s; the fitted top speed lands within 5 % of the plateau."""
    spec_path = tmp_path / "neato.yaml"
    args = ["robots", "new", "neato", "--wheel-separation", "0.248", "--max-speed", "0.3"]
    assert cli_main([*args, "-o", str(spec_path)]) == 0
    log = realdata_dir / "neato_ksoltan_testdrive_2018-09-18-20-17-54.mcap"
    plateau, n = straight_plateau(log, above_mps=0.6)
    assert n >= 20 and 0.28 < plateau < 0.32
    fit = fit_logs([log], robot=str(spec_path))
    fitted = top_speed(fit.result.params, load_spec(spec_path).geometry.wheel_radius_m)
    assert fitted == pytest.approx(plateau, rel=0.05), (fitted, plateau)
