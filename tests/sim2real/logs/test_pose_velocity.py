"""Measured velocities from the odometry pose when the twist is zero or spiky (read_trace)."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.logs import Trace, TraceMeta, read_trace, write_trace
from sim2real.logs._pose_velocity import pose_derivative, velocities_from_pose

T0_NS = 1_700_000_000 * 10**9


def _drive(seed: int = 0, n: int = 400, rate_hz: float = 10.0):
    """A smooth path: v and w as slow sines, stamps at 10 Hz, the exact pose."""
    t = np.arange(n) / rate_hz
    v = 0.25 + 0.1 * np.sin(0.3 * t)
    w = 0.8 * np.sin(0.2 * t)
    yaw = 0.8 / 0.2 * (1 - np.cos(0.2 * t))
    dt = 1e-3
    fine = np.arange(0, t[-1] + dt, dt)
    vf, yf = np.interp(fine, t, v), 0.8 / 0.2 * (1 - np.cos(0.2 * fine))
    x = np.interp(t, fine, np.cumsum(vf * np.cos(yf)) * dt)
    y = np.interp(t, fine, np.cumsum(vf * np.sin(yf)) * dt)
    return t, v, w, x, y, np.arctan2(np.sin(yaw), np.cos(yaw))


def _log(tmp_path: Path, meas_v: np.ndarray, meas_w: np.ndarray, t_s=None) -> Path:
    t, v, w, x, y, yaw = _drive()
    t_s = t if t_s is None else t_s
    ns = T0_NS + np.round(t_s * 1e9).astype(np.int64)
    tr = Trace(
        cmd_t_ns=ns,
        cmd_v=v,
        cmd_w=w,
        meas_t_ns=ns,
        meas_v=meas_v,
        meas_w=meas_w,
        pose_x=x,
        pose_y=y,
        pose_yaw=yaw,
        meta=TraceMeta(),
    )
    return write_trace(tmp_path / "run.mcap", tr)


def test_pose_derivative_recovers_body_velocities() -> None:
    t, v, w, x, y, yaw = _drive()
    pv, pw = pose_derivative(t, x, y, yaw, 0.5)
    inner = slice(5, -5)
    assert np.max(np.abs(pv[inner] - v[inner])) < 0.005
    assert np.max(np.abs(pw[inner] - w[inner])) < 0.01


def test_zero_twist_is_replaced(tmp_path: Path) -> None:
    _, v, w, *_ = _drive()
    tr = read_trace(_log(tmp_path, np.zeros_like(v), np.zeros_like(w)))
    assert len(tr.meta.warnings) == 1 and "is zero in 100% of the samples" in tr.meta.warnings[0]
    assert np.median(np.abs(tr.meas_v - v)) < 0.005 and np.median(np.abs(tr.meas_w - w)) < 0.01


def test_jittered_backward_difference_is_spiky(tmp_path: Path) -> None:
    """A driver differencing the pose over stamps that jitter by +-30 %: both channels spiky."""
    t, v, _, x, y, yaw = _drive()
    rng = np.random.default_rng(1)
    stamps = t + rng.uniform(-0.03, 0.03, t.size)  # the pose was sampled at t, stamped here
    dt = np.diff(stamps, prepend=stamps[0] - 0.1)
    tv = np.hypot(np.diff(x, prepend=x[0]), np.diff(y, prepend=y[0])) / dt
    tw = np.diff(np.unwrap(yaw), prepend=yaw[0]) / dt
    tr = read_trace(_log(tmp_path, tv, tw, t_s=stamps))
    assert any("is spiky" in m for m in tr.meta.warnings)
    inner = slice(10, -10)
    err_pose = np.median(np.abs(tr.meas_v[inner] - v[inner]))
    err_twist = np.median(np.abs(tv[inner] - v[inner]))
    assert err_pose < 0.5 * err_twist
    kept = read_trace(tmp_path / "run.mcap", odom_velocity="twist")
    assert np.array_equal(kept.meas_v, tv) and kept.meta.warnings == ()


def test_clean_twist_or_gyro_yaw_rate_is_kept(tmp_path: Path) -> None:
    _, v, w, *_ = _drive()
    rng = np.random.default_rng(2)
    # encoder v with a little noise; a gyro w that differs from the pose's yaw rate by ~20 %
    mv = v + rng.normal(0, 0.003, v.size)
    mw = 1.2 * w + rng.normal(0, 0.02, w.size)
    tr = read_trace(_log(tmp_path, mv, mw))
    assert tr.meta.warnings == ()
    assert np.array_equal(tr.meas_v, mv) and np.array_equal(tr.meas_w, mw)
    forced = read_trace(tmp_path / "run.mcap", odom_velocity="pose")
    assert "as asked" in forced.meta.warnings[0]


def test_bad_mode(tmp_path: Path) -> None:
    _, v, w, *_ = _drive()
    with pytest.raises(ValueError, match="odom_velocity must be one of"):
        read_trace(_log(tmp_path, v, w), odom_velocity="imu")


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(5, 300),
    block=st.integers(1, 64),
    seed=st.integers(0, 2**32 - 1),
    window_s=st.floats(0.05, 2.0),
)
def test_blockwise_derivative_equals_one_block(n, block, seed, window_s) -> None:
    """Blocks with their halos give every sample the window a whole-log fit gives it."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 0.3, n))
    x, y = np.cumsum(rng.normal(0, 0.05, (2, n)), axis=1)
    yaw = np.angle(np.exp(1j * np.cumsum(rng.normal(0, 0.4, n))))  # wrapped, with jumps
    v1, w1 = pose_derivative(t, x, y, yaw, window_s, block=n)
    vb, wb = pose_derivative(t, x, y, yaw, window_s, block=block)
    np.testing.assert_allclose(vb, v1, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(wb, w1, rtol=1e-6, atol=1e-6)


def test_pose_velocity_memory_is_outputs_plus_scratch() -> None:
    """No full-size temporaries: beyond its two outputs, the pose check holds at most three
    scratch columns of the moving samples (the twist-vs-pose verdict) and one block's work."""
    n = 200_000
    rng = np.random.default_rng(5)
    t_ns = T0_NS + np.cumsum(rng.integers(15_000_000, 25_000_000, n))
    yaw = np.cumsum(rng.normal(0, 0.02, n))
    cols = {
        "v": rng.normal(0.3, 0.05, n),
        "w": rng.normal(0.5, 0.1, n),
        "x": np.cumsum(0.006 * np.cos(yaw)),
        "y": np.cumsum(0.006 * np.sin(yaw)),
        "yaw": np.angle(np.exp(1j * yaw)),
    }
    velocities_from_pose(t_ns, cols, "/odom", [])  # warm-up (imports, caches)
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        velocities_from_pose(t_ns, cols, "/odom", [], mode="pose")
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    column = n * 8
    assert peak <= 5 * column + 2 * 2**20, f"{peak / column:.1f} columns"


def test_read_trace_hands_its_arrays_over_without_copies(tmp_path: Path) -> None:
    _, v, w, *_ = _drive()
    tr = read_trace(_log(tmp_path, v, w))
    for a in (tr.cmd_t_ns, tr.cmd_v, tr.meas_t_ns, tr.meas_v, tr.meas_w, tr.pose_x, tr.pose_yaw):
        assert a is not None and not a.flags.writeable
    # the public constructor still copies what it is given
    mine = np.array(tr.meas_v)
    built = Trace(
        cmd_t_ns=tr.cmd_t_ns,
        cmd_v=tr.cmd_v,
        cmd_w=tr.cmd_w,
        meas_t_ns=tr.meas_t_ns,
        meas_v=mine,
        meas_w=tr.meas_w,
    )
    assert built.meas_v is not mine and mine.flags.writeable


def _held(values: np.ndarray, every: int) -> np.ndarray:
    """``values`` as a driver republishing its last pose: updated every ``every`` messages."""
    return values[(np.arange(values.size) // every) * every]


def test_held_pose_is_differentiated_over_its_updates() -> None:
    """A pose republished at 30 Hz and updated every third message (a 10 Hz pose, the
    2017 Neato driver): the velocity follows the updates, not the staircase of repeats, and
    a pose held through a stop reads 0."""
    t, v, w, x, y, yaw = _drive(n=1200, rate_hz=30.0)
    stop = (t > 20.0) & (t < 25.0)
    x, y, yaw = x.copy(), y.copy(), yaw.copy()
    for a in (x, y, yaw):  # the robot stands still from 20 s to 25 s, then goes on
        i0 = np.flatnonzero(stop)[0]
        a[stop] = a[i0]
        a[t >= 25.0] -= a[np.flatnonzero(t >= 25.0)[0]] - a[i0]
    cols = {"v": np.zeros_like(v), "w": np.zeros_like(w),
            "x": _held(x, 3), "y": _held(y, 3), "yaw": _held(yaw, 3)}  # fmt: skip
    ns = T0_NS + np.round(t * 1e9).astype(np.int64)
    warnings: list[str] = []
    out = velocities_from_pose(ns, cols, "/odom", warnings, mode="pose")
    assert "over 0.50 s windows" in warnings[0]  # 5 pose updates of 0.1 s, not 5 messages
    moving = (t > 2.0) & (t < 18.0)
    assert np.max(np.abs(out["v"][moving] - v[moving])) < 0.01
    assert np.max(np.abs(out["w"][moving] - w[moving])) < 0.02
    still = (t > 21.0) & (t < 24.0)
    assert np.max(np.abs(out["v"][still])) < 1e-9 and np.max(np.abs(out["w"][still])) < 1e-9
    # every message a new pose: the same fit as before (all samples)
    _, _, _, x0, y0, yaw0 = _drive(n=1200, rate_hz=30.0)
    fresh = velocities_from_pose(
        ns, {**cols, "x": x0, "y": y0, "yaw": yaw0}, "/odom", [], mode="pose"
    )
    pv, pw = pose_derivative(t, x0, y0, yaw0, 0.3)
    assert np.allclose(fresh["v"], pv) and np.allclose(fresh["w"], pw)
