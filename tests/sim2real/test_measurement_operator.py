"""The measurement operator: a pose derivative and a zero-order hold, in fit and replay alike.

Golden numbers on plant logs with a known transport latency (0.25 s), written as real MCAP and
read back. Tolerances: the operator recovers the delay the plant's own twist gives within
0.06 s on 7 Hz pose odometry (0.71 s windows) and within 0.02 s on a 3-sample hold at 20 Hz;
without the operator the fit is off by more than 0.15 s and 0.03 s.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.errors import RobotsValueError
from robots.measurement import MeasurementModel, hold_model, pose_model
from robots.spec import load_spec
from sim2real.agreement.replay import replay
from sim2real.cli import main as cli_main
from sim2real.fitting import fit_logs
from sim2real.logs import ReadOptions, read_trace, write_trace
from sim2real.logs._pose_velocity import _update_derivative, pose_changes
from sim2real.plants.diff_drive import command_profile, plant_from_spec, run_plant, run_to_trace
from sysid import fit_drive
from sysid._logs import as_log_arrays, crop_log

LATENCY_S = 0.25
ROBOT = "turtlebot3_burger"


def _plant_trace(rate_hz: float, seed: int = 3):  # type: ignore[no-untyped-def]
    """A 60 s teleop session of the plant, w from the wheels, and its run."""
    p = plant_from_spec(
        ROBOT, latency_s=LATENCY_S, latency_jitter_s=0.0, odom_rate_hz=rate_hz, w_source="wheels"
    )
    rng = np.random.default_rng(seed)
    t, v, w = command_profile("teleop", 60.0, rng=rng, max_v_mps=0.2, max_w_radps=1.5)
    run = run_plant(p, t, v, w, duration_s=60.0, rng=rng)
    return p, run, run_to_trace(run, name="plant")


def _encoder_pose(p, run) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """The pose a wheel-odometry driver integrates from the encoder counts (exact at each tick)."""
    k = run.kept
    step = 2.0 * math.pi / p.ticks_per_rev * p.wheel_radius_m
    dl = np.diff(run.ticks_l[k], prepend=run.ticks_l[k][0]) * step
    dr = np.diff(run.ticks_r[k], prepend=run.ticks_r[k][0]) * step
    dth = (dr - dl) / p.wheel_separation_m
    yaw = np.cumsum(dth)
    mid = yaw - 0.5 * dth
    ds = 0.5 * (dl + dr)
    return (
        np.cumsum(ds * np.cos(mid)),
        np.cumsum(ds * np.sin(mid)),
        np.arctan2(np.sin(yaw), np.cos(yaw)),
    )


def _delay(path: Path, **kw: object) -> float:
    return fit_logs([path], robot=ROBOT, **kw).result.params.delay_s  # type: ignore[arg-type]


def _delay_without_operator(path: Path) -> float:
    spec = load_spec(ROBOT)
    log = replace(as_log_arrays(read_trace(path)), measurement=None)
    result = fit_drive(
        [log],
        geometry=spec.geometry,
        base_params=spec.drive,
        priors=spec.priors,
        robot=spec.name,
        odom_v_window_s=spec.odometry.v_window_s,
    )
    return result.params.delay_s


@pytest.mark.slow
def test_pose_derived_velocity_keeps_the_plant_delay(tmp_path: Path) -> None:
    p, run, trace = _plant_trace(7.0)
    x, y, yaw = _encoder_pose(p, run)
    # a driver whose twist is zero: the reader takes the velocities from the pose
    posed = replace(
        trace, meas_v=0 * trace.meas_v, meas_w=0 * trace.meas_w, pose_x=x, pose_y=y, pose_yaw=yaw
    )
    path = write_trace(tmp_path / "pose.mcap", posed)
    read = read_trace(path)
    model = read.measurement
    assert model is not None and model.kind == "pose"
    assert model.window_s == pytest.approx(5 / 7, abs=0.02)
    with_op = _delay(path)
    assert with_op == pytest.approx(LATENCY_S, abs=0.06)
    assert _delay_without_operator(path) < LATENCY_S - 0.15  # the centred window's pull to 0


@pytest.mark.slow
def test_held_readings_keep_the_plant_delay(tmp_path: Path) -> None:
    _, _, trace = _plant_trace(20.0)
    k = (np.arange(trace.meas_v.size) // 3) * 3  # a new reading every third message
    held = replace(trace, meas_v=trace.meas_v[k], meas_w=trace.meas_w[k])
    path = write_trace(tmp_path / "held.mcap", held)
    model = read_trace(path).measurement
    assert model is not None and model.kind == "hold"
    assert model.update_period_s == pytest.approx(0.15, abs=0.01)
    twist = write_trace(tmp_path / "twist.mcap", trace)
    reference = _delay(twist, read=ReadOptions(odom_velocity="twist"))
    assert reference == pytest.approx(LATENCY_S, abs=0.02)
    assert _delay(path, read=ReadOptions(odom_velocity="twist")) == pytest.approx(
        reference, abs=0.02
    )
    assert _delay_without_operator(path) > reference + 0.03  # the hold's mean age, 0.05 s


def test_the_operator_reproduces_the_readers_pose_derivative() -> None:
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.12, 0.17, 300))
    fine = np.linspace(-1.0, t[-1] + 1.0, 100_001)

    def speed(s: np.ndarray) -> np.ndarray:
        return 0.3 * (1.0 - np.exp(-np.clip(s - 5.0, 0.0, None) / 0.2)) * (s < 30.0)

    def yaw_rate(s: np.ndarray) -> np.ndarray:
        return np.sin(0.5 * s)

    dt = np.diff(fine, prepend=fine[0])
    yaw_f = np.cumsum(yaw_rate(fine) * dt)
    x_f = np.cumsum(speed(fine) * np.cos(yaw_f) * dt)
    y_f = np.cumsum(speed(fine) * np.sin(yaw_f) * dt)
    pose = tuple(np.interp(t, fine, a) for a in (x_f, y_f, yaw_f))
    v, w, window = _update_derivative((t * 1e9).astype(np.int64), pose)
    op = pose_model(t, pose_changes(pose), window).operator(t)
    assert np.abs(op.apply(yaw_rate(op.t_query)) - w).max() < 1e-3
    # v differentiates the path length, the reader the projection: equal up to the chord
    assert np.abs(op.apply(speed(op.t_query)) - v).max() < 0.006
    assert np.abs(speed(t) - v).max() > 0.04  # the operator is not the identity


@settings(max_examples=30, deadline=None)
@given(
    period=st.floats(0.03, 0.3),
    half_periods=st.integers(1, 4),
    level=st.floats(-1.0, 1.0),
    slope=st.floats(-0.5, 0.5),
    seed=st.integers(0, 3),
)
def test_pose_operator_is_exact_on_linear_velocities(
    period: float, half_periods: int, level: float, slope: float, seed: int
) -> None:
    t = np.arange(60) * period
    # window edges half-way between samples: every inner window is symmetric
    window = (2 * half_periods + 1) * period
    op = pose_model(t, np.ones(t.size, dtype=bool), window).operator(t)
    inner = slice(half_periods, t.size - half_periods)
    # a centred local-linear slope of a quadratic path is its derivative at the centre
    got = op.apply(level + slope * op.t_query)
    assert np.allclose(got[inner], (level + slope * t)[inner], atol=1e-9)
    # a steady speed reads as itself when the pose is held between updates (interpolated),
    # the window spanning a few updates as the reader's does
    every = 1 + seed % 4
    changed = np.arange(t.size) % every == 0
    held = pose_model(t, changed, 2.5 * every * period).operator(t)
    assert np.allclose(held.apply(np.full(held.t_query.size, level)), level, atol=1e-9)


def test_hold_reads_the_last_reading_and_crops_with_the_log() -> None:
    t = np.arange(0.0, 10.0, 0.05)
    v = np.repeat(np.linspace(0.1, 1.0, 50), 4)
    model = hold_model(t, v, 0 * v)
    assert model is not None and model.update_period_s == pytest.approx(0.2)
    op = model.operator(t)
    assert np.allclose(op.apply(np.sin(op.t_query)), np.sin(t[(np.arange(t.size) // 4) * 4]))
    assert hold_model(t, t, 0 * t) is None  # a reading that changes every sample
    log = as_log_arrays(_HeldLog(t, v, model))
    part = crop_log(log, 2.0, 5.0)
    assert part.measurement is not None and part.measurement.fresh.size == part.meas_t_s.size
    with pytest.raises(RobotsValueError, match="slice the model"):
        model.operator(t[:-1])
    with pytest.raises(RobotsValueError, match="kind"):
        MeasurementModel(kind="median")


class _HeldLog:
    def __init__(self, t: np.ndarray, v: np.ndarray, model: MeasurementModel) -> None:
        self.cmd_t_s, self.cmd_v, self.cmd_w = t, v, 0 * v
        self.meas_t_s, self.meas_v, self.meas_w = t, v, 0 * v
        self.measurement = model


def test_replay_reads_the_simulation_through_the_logs_operator(tmp_path: Path) -> None:
    _, _, trace = _plant_trace(20.0, seed=5)
    k = (np.arange(trace.meas_v.size) // 4) * 4
    held = read_trace(
        write_trace(
            tmp_path / "h.mcap", replace(trace, meas_v=trace.meas_v[k], meas_w=trace.meas_w[k])
        )
    )
    plain = read_trace(write_trace(tmp_path / "p.mcap", trace))
    a = replay(held, robot=ROBOT, engine="reduced")
    b = replay(plain, robot=ROBOT, engine="reduced")
    assert a.measurement == "hold" and b.measurement == ""
    fresh = held.measurement.fresh  # type: ignore[union-attr]
    last = np.maximum.accumulate(np.where(fresh, np.arange(fresh.size), 0))
    assert np.allclose(a.v, b.v[last], atol=1e-9)
    assert not np.allclose(a.v, b.v)


@pytest.mark.realdata
def test_real_logs_carry_the_operator_of_their_velocity_source(realdata_dir: Path) -> None:
    """Neato (pose-derived, 7 Hz): a pose operator of 0.75 s windows; Husky (20 Hz rows of
    wheel speeds updated every 0.15 s): a hold; TurtleBot3 (encoder twist): none."""
    neato = read_trace(realdata_dir / "neato_olin2018_teleop.mcap", time_source="auto")
    model = neato.measurement
    assert model is not None and model.kind == "pose"
    assert model.window_s == pytest.approx(0.749, abs=0.01)
    assert model.update_period_s == pytest.approx(0.150, abs=0.005)
    husky = read_trace(realdata_dir / "husky_lifted_a" / "trace.csv", time_source="auto")
    held = husky.measurement
    assert held is not None and held.kind == "hold"
    assert held.update_period_s == pytest.approx(0.152, abs=0.005)
    tb3 = read_trace(realdata_dir / "tb3wp_drexel_goal.mcap", time_source="auto")
    assert tb3.measurement is None


@pytest.mark.realdata
@pytest.mark.slow
def test_the_neato_teleop_fit_keeps_its_delay(realdata_dir: Path, tmp_path: Path) -> None:
    """The centred pose window drove the fitted delay of this log to 0 (5e-14 s); read
    through the operator it is the log's lag (the README's rough cross-correlation: 0.3 s)."""
    spec_path = tmp_path / "neato.yaml"
    args = ["robots", "new", "neato", "--wheel-separation", "0.248", "--max-speed", "0.3"]
    assert cli_main([*args, "-o", str(spec_path)]) == 0
    fit = fit_logs([realdata_dir / "neato_olin2018_teleop.mcap"], robot=str(spec_path))
    assert fit.result.params.delay_s == pytest.approx(0.21, abs=0.05)
    assert (
        fit.result.settings["measurement"][str(realdata_dir / "neato_olin2018_teleop.mcap")]["kind"]
        == "pose"
    )
