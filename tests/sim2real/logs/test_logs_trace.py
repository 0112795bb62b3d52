"""Trace: time views, zero-order hold, windows, validation."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.errors import Sim2RealValueError
from sim2real.logs import Trace, TraceMeta

MS = 1_000_000
BASE = 1_600_000_000 * 10**9


def _trace(**kw) -> Trace:
    args = dict(
        cmd_t_ns=BASE + np.array([100, 300, 500]) * MS,
        cmd_v=np.array([0.1, 0.2, 0.3]),
        cmd_w=np.array([-1.0, 0.0, 1.0]),
        meas_t_ns=BASE + np.array([0, 100, 200, 300, 400, 600]) * MS,
        meas_v=np.arange(6.0),
        meas_w=-np.arange(6.0),
        meta=TraceMeta(path="mem", cmd_count=3, meas_count=6),
    )
    args.update(kw)
    return Trace(**args)


def test_time_views_are_seconds_since_first_sample():
    tr = _trace()
    assert tr.t0_ns == BASE
    np.testing.assert_allclose(tr.cmd_t_s, [0.1, 0.3, 0.5], rtol=0, atol=1e-15)
    np.testing.assert_allclose(tr.meas_t_s, [0, 0.1, 0.2, 0.3, 0.4, 0.6], rtol=0, atol=1e-15)
    assert tr.duration_s == pytest.approx(0.6)
    assert tr.cmd_t_s.dtype == np.float64 and tr.cmd_t_ns.dtype == np.int64


def test_zero_order_hold_is_zero_before_first_command_and_holds_after():
    v, w = _trace().cmd_at_meas()
    np.testing.assert_array_equal(v, [0.0, 0.1, 0.1, 0.2, 0.2, 0.3])
    np.testing.assert_array_equal(w, [0.0, -1.0, -1.0, 0.0, 0.0, 1.0])


def test_window_keeps_the_command_in_force_at_its_start():
    tr = _trace()
    part = tr.window(0.35, 0.65)
    np.testing.assert_array_equal(part.meas_t_ns, BASE + np.array([400, 600]) * MS)
    np.testing.assert_array_equal(part.cmd_t_ns, BASE + np.array([300, 500]) * MS)
    v, _ = part.cmd_at_meas()
    np.testing.assert_array_equal(v, [0.2, 0.3])  # same as the full trace at those times
    assert (part.meta.cmd_count, part.meta.meas_count, part.meta.path) == (2, 2, "mem")


def test_window_bounds_are_checked():
    tr = _trace()
    with pytest.raises(Sim2RealValueError, match=r"end_s > start_s"):
        tr.window(0.5, 0.5)
    with pytest.raises(Sim2RealValueError, match=r"no measurement"):
        tr.window(10.0, 11.0)
    with pytest.raises(Sim2RealValueError, match=r"finite"):
        tr.window(float("nan"), 1.0)


def test_arrays_are_read_only_copies_and_dataclass_is_frozen():
    src = np.arange(6.0)
    tr = _trace(meas_v=src)
    src[0] = 99.0
    assert tr.meas_v[0] == 0.0
    with pytest.raises(ValueError, match="read-only"):
        tr.meas_v[0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        tr.cmd_v = np.zeros(3)  # type: ignore[misc]
    with pytest.raises(TypeError, match="positional argument"):
        Trace(np.zeros(1))  # type: ignore[misc]  # keyword-only


def test_length_mismatch_and_partial_pose_are_rejected():
    with pytest.raises(Sim2RealValueError, match=r"cmd_v has 2 samples"):
        _trace(cmd_v=np.zeros(2))
    with pytest.raises(Sim2RealValueError, match=r"pose_x, pose_y and pose_yaw"):
        _trace(pose_x=np.zeros(6))


@settings(max_examples=60, deadline=None)
@given(
    cmd=st.lists(st.integers(0, 10_000), min_size=1, max_size=30, unique=True),
    meas=st.lists(st.integers(0, 10_000), min_size=1, max_size=30, unique=True),
    lo=st.floats(0.0, 10.0),
    span=st.floats(0.001, 10.0),
)
def test_window_hold_equals_full_hold(cmd, meas, lo, span):
    """Property: inside any window the ZOH values equal those of the full trace."""
    ct = BASE + np.sort(np.array(cmd, dtype=np.int64)) * MS
    mt = BASE + np.sort(np.array(meas, dtype=np.int64)) * MS
    tr = Trace(
        cmd_t_ns=ct,
        cmd_v=np.arange(ct.size) + 1.0,
        cmd_w=-np.arange(ct.size) - 1.0,
        meas_t_ns=mt,
        meas_v=np.zeros(mt.size),
        meas_w=np.zeros(mt.size),
    )
    full_v, full_w = tr.cmd_at_meas()
    try:
        part = tr.window(lo, lo + span)
    except Sim2RealValueError:
        t_s = tr.meas_t_s
        # bounds are rounded to whole ns, so only samples >= 1 ns inside the window count
        assert not np.any((t_s >= lo + 1e-9) & (t_s < lo + span - 1e-9)) or span < 1e-6
        return
    keep = np.isin(tr.meas_t_ns, part.meas_t_ns)
    v, w = part.cmd_at_meas()
    np.testing.assert_array_equal(v, full_v[keep])
    np.testing.assert_array_equal(w, full_w[keep])


def test_fractional_nanoseconds_are_rejected():
    with pytest.raises(Sim2RealValueError, match="cmd_t_ns must hold integer nanoseconds"):
        _trace(cmd_t_ns=np.array([0.1, 0.3, 0.5]))
    ok = _trace(cmd_t_ns=(BASE + np.array([100, 300, 500]) * MS).astype(np.float64))
    assert ok.cmd_t_ns.dtype == np.int64
