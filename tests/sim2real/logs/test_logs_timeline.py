"""Time validation: far stamp outliers, gaps -> segments, far commands, --time-source auto."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from logs_helpers import T0_NS

from robots.errors import RobotsValueError
from robots.reduced import MAX_SIM_STEPS, simulate
from robots.spec import load_spec
from sim2real.agreement.replay import replay
from sim2real.errors import LogValueError
from sim2real.logs import TWIST_STAMPED, Trace, read_trace, write_velocity_log
from sim2real.logs._timeline import gap_threshold_ns, scratch_median, segment_bounds
from sysid.metrics import xcorr_lag_s

YEAR_NS = 365 * 86_400 * 10**9


def _steady(n_meas: int = 300, rate_hz: float = 30.0, seed: int = 0) -> dict[str, np.ndarray]:
    """10 s of a robot driving square waves: commands at 10 Hz, odometry at ``rate_hz``."""
    rng = np.random.default_rng(seed)
    cmd_t = np.arange(0, n_meas / rate_hz, 0.1)
    cmd_v = np.where((cmd_t // 2) % 2 == 0, 0.2, 0.0)
    cmd_w = np.where((cmd_t // 3) % 2 == 0, 0.5, -0.5)
    meas_t = np.arange(n_meas) / rate_hz + 0.004
    idx = np.searchsorted(cmd_t, meas_t - 0.15, side="right") - 1
    hold_v = np.where(idx >= 0, cmd_v[np.maximum(idx, 0)], 0.0)
    hold_w = np.where(idx >= 0, cmd_w[np.maximum(idx, 0)], 0.0)
    return {
        "cmd_t_ns": T0_NS + np.round(cmd_t * 1e9).astype(np.int64),
        "cmd_v": cmd_v,
        "cmd_w": cmd_w,
        "meas_t_ns": T0_NS + np.round(meas_t * 1e9).astype(np.int64),
        "meas_v": hold_v + rng.normal(0, 0.003, n_meas),
        "meas_w": hold_w + rng.normal(0, 0.01, n_meas),
    }


def _write(tmp_path: Path, name: str, **kw: np.ndarray) -> Path:
    return write_velocity_log(tmp_path / f"{name}.mcap", **kw)


def test_one_far_header_stamp_is_dropped_with_a_note(tmp_path: Path) -> None:
    a = _steady()
    stamps = a["meas_t_ns"].copy()
    stamps[150] += 10 * YEAR_NS  # a flipped byte in one header stamp
    path = _write(tmp_path, "outlier", **{**a, "meas_t_ns": stamps}, meas_log_t_ns=a["meas_t_ns"])
    tr = read_trace(path, time_source="auto")
    assert tr.meas_t_ns.size == 299 and tr.meas_t_ns[-1] == a["meas_t_ns"][-1]
    assert len(tr.segments()) == 1
    assert any("dropped 1 of 300 samples of topic '/odom'" in w for w in tr.meta.warnings)
    assert tr.duration_s < 11.0


def test_a_year_long_pause_splits_the_log_into_segments(tmp_path: Path) -> None:
    a = _steady()
    mt, ct = a["meas_t_ns"].copy(), a["cmd_t_ns"].copy()
    mt[150:] += YEAR_NS
    ct[ct >= a["meas_t_ns"][150]] += YEAR_NS
    tr = read_trace(_write(tmp_path, "gap", **{**a, "meas_t_ns": mt, "cmd_t_ns": ct}))
    first, second = tr.segments()
    assert (first.meas_t_ns.size, second.meas_t_ns.size) == (150, 150)
    assert first.cmd_t_ns.size + second.cmd_t_ns.size == tr.cmd_t_ns.size == ct.size
    assert first.duration_s < 6 and second.duration_s < 6
    assert (first.meta.segment, second.meta.segment) == ("1/2", "2/2")
    assert second.meta.path.endswith("gap.mcap (segment 2/2)")
    assert any("used as 2 separate segments" in w for w in tr.meta.warnings)
    assert second.meta.warnings == ()  # the reader's notes travel with the first segment only


def test_replay_of_a_log_with_a_gap_equals_the_replays_of_its_parts(tmp_path: Path) -> None:
    a = _steady()
    mt, ct = a["meas_t_ns"].copy(), a["cmd_t_ns"].copy()
    mt[150:] += YEAR_NS
    ct[ct >= a["meas_t_ns"][150]] += YEAR_NS
    whole = read_trace(_write(tmp_path, "gap", **{**a, "meas_t_ns": mt, "cmd_t_ns": ct}))
    sim = replay(whole, robot="turtlebot3_burger", engine="reduced")
    parts = [replay(s, robot="turtlebot3_burger", engine="reduced") for s in whole.segments()]
    assert np.array_equal(sim.v, np.concatenate([p.v for p in parts]))
    assert np.array_equal(sim.t_ns, whole.meas_t_ns)
    assert sim.t_s[-1] == pytest.approx(YEAR_NS / 1e9 + 10.0, abs=0.1)


def test_commands_far_from_every_measurement_are_dropped(tmp_path: Path) -> None:
    a = _steady()
    ct = a["cmd_t_ns"].copy()
    ct[5] -= 10 * YEAR_NS  # sent "ten years before" the recording
    tr = read_trace(_write(tmp_path, "far_cmd", **{**a, "cmd_t_ns": ct}))
    assert tr.cmd_t_ns.size == ct.size - 1 and tr.duration_s < 11
    assert any("more than 60 s away from every measurement" in w for w in tr.meta.warnings)


def test_gap_threshold_is_robust_to_bursts() -> None:
    t = np.cumsum(np.r_[0, np.full(50, 33_000_000), 1_300_000_000, np.full(50, 33_000_000)])
    assert gap_threshold_ns(t) == 2_000_000_000  # a 1.3 s rosserial burst is not a gap
    assert len(segment_bounds(t)) == 1
    slow = np.arange(100, dtype=np.int64) * 500_000_000  # 2 Hz odometry: 10 s threshold
    assert gap_threshold_ns(slow) == 10_000_000_000


def test_auto_time_source_keeps_aligned_header_stamps(tmp_path: Path) -> None:
    a = _steady()
    log_t = a["meas_t_ns"] + 3_000_000  # 3 ms transport delay
    tr = read_trace(_write(tmp_path, "ok", **a, meas_log_t_ns=log_t), time_source="auto")
    assert (tr.meta.cmd_time_source, tr.meta.meas_time_source) == ("log", "header")
    assert tr.meta.time_note.startswith("time source auto: header stamps of '/odom'")
    assert np.array_equal(tr.meas_t_ns, a["meas_t_ns"])


def test_auto_time_source_switches_to_log_times_on_a_clock_offset(tmp_path: Path) -> None:
    a = _steady()
    stamps = a["meas_t_ns"] - 15 * 10**9  # odometry stamped by a clock 15 s behind
    path = _write(tmp_path, "off", **{**a, "meas_t_ns": stamps}, meas_log_t_ns=a["meas_t_ns"])
    tr = read_trace(path, time_source="auto")
    assert (tr.meta.cmd_time_source, tr.meta.meas_time_source) == ("log", "log")
    assert "log times, because the header stamps of '/odom' are -15.000 s" in tr.meta.time_note
    assert np.array_equal(tr.meas_t_ns, a["meas_t_ns"])
    header = read_trace(path, time_source="header")  # explicit header: a warning, no switch
    assert header.meta.meas_time_source == "header" and header.meta.time_note == ""
    assert any("another clock" in w for w in header.meta.warnings)


def test_auto_time_source_with_two_stamped_streams_on_different_clocks(tmp_path: Path) -> None:
    a = _steady()
    path = _write(
        tmp_path,
        "two",
        **{**a, "cmd_t_ns": a["cmd_t_ns"] + 4 * 10**9},
        cmd_type=TWIST_STAMPED,
        cmd_log_t_ns=a["cmd_t_ns"],
    )
    tr = read_trace(path, time_source="auto")
    assert (tr.meta.cmd_time_source, tr.meta.meas_time_source) == ("log", "log")
    assert "-4.000 s (median) off those of '/cmd_vel'" in tr.meta.time_note
    same = _write(tmp_path, "same", **a, cmd_type=TWIST_STAMPED)
    assert read_trace(same, time_source="auto").meta.cmd_time_source == "header"


def _trace(n: int = 40, **over: object) -> Trace:
    kw: dict[str, object] = {
        "cmd_t_ns": np.arange(5) * 10**8,
        "cmd_v": np.full(5, 0.1),
        "cmd_w": np.zeros(5),
        "meas_t_ns": np.arange(n) * 10**7,
        "meas_v": np.full(n, 0.1),
        "meas_w": np.zeros(n),
    }
    kw.update(over)
    return Trace(**kw)  # type: ignore[arg-type]


def test_absurd_values_are_dropped_with_a_note() -> None:
    v = np.full(40, 0.1)
    v[7] = 4.5e306
    spec = load_spec("turtlebot3_burger")
    out = _trace(meas_v=v).without_absurd(max_v_mps=spec.max_v_mps, max_w_radps=spec.max_w_radps)
    assert out.meas_v.size == 39 and np.all(out.meas_v == 0.1)
    assert out.meta.warnings == (
        "dropped 1 of 40 measurement samples with |v| > 2.2 m/s or |w| > 28.4 rad/s "
        "(10x the robot's limits: not physical)",
    )


def test_mostly_absurd_values_are_a_unit_mistake() -> None:
    with pytest.raises(LogValueError, match=r"40 of 40 measurement samples .* another unit"):
        _trace(meas_v=np.full(40, 200.0)).without_absurd(max_v_mps=0.22, max_w_radps=2.84)


def test_too_little_left_is_an_error() -> None:
    v = np.full(12, 0.1)
    v[:3] = 1e9
    with pytest.raises(LogValueError, match=r"only 9 usable measurement samples"):
        _trace(12, meas_v=v).without_absurd(max_v_mps=0.22, max_w_radps=2.84)


def test_simulate_refuses_a_span_beyond_its_step_budget() -> None:
    spec = load_spec("turtlebot3_burger")
    t_out = np.array([0.0, 1.0, (MAX_SIM_STEPS + 10) * 0.005])
    with pytest.raises(RobotsValueError, match=r"integration steps .*Trace\.segments"):
        simulate(
            spec.drive,
            spec.geometry,
            cmd_t_s=np.array([0.0]),
            cmd_v=np.array([0.1]),
            cmd_w=np.array([0.0]),
            t_out_s=t_out,
        )


def test_xcorr_lag_closes_long_pauses() -> None:
    t = np.arange(0, 20, 0.02)
    real = np.sin(t)
    sim = np.sin(t - 0.2)
    lag = xcorr_lag_s(t, real, sim)
    t_gap = np.where(t < 10, t, t + 3.0e7)  # a year-long pause in the middle
    assert xcorr_lag_s(t_gap, real, sim) == pytest.approx(lag, abs=0.02)
    assert lag == pytest.approx(0.2, abs=0.02)


def test_csv_row_with_a_far_time_is_dropped(tmp_path: Path) -> None:
    rows = [f"{0.1 * k:.1f},0.2,0,0.19,0" for k in range(30)] + ["315360000.0,0.2,0,0.19,0"]
    path = tmp_path / "far.csv"
    path.write_text("t,cmd_v,cmd_w,meas_v,meas_w\n" + "\n".join(rows) + "\n")
    tr = read_trace(path)
    assert tr.meas_t_ns.size == 30 and tr.duration_s < 3.0
    assert tr.meta.warnings[0].startswith("dropped 1 of 31 samples of topic 't'")


def test_scratch_median_is_numpys_median_bit_for_bit():
    """Odd and even sizes, ints near the int64 limits, -0.0, infinities and NaN: the same
    float64 bits (and type) as ``np.median(a, overwrite_input=True)``."""
    rng = np.random.default_rng(5)
    special = np.array([0.0, -0.0, 1.5, np.nan, np.inf, -np.inf, 1e308, -1e308])
    checked = {"nan": 0, "neg_zero_in": 0}
    for trial in range(4000):
        n = int(rng.integers(1, 40))
        kind = trial % 4
        if kind == 0:
            a = rng.normal(size=n)
        elif kind == 1:
            a = rng.integers(-5, 5, n).astype(np.int64)
        elif kind == 2:
            a = rng.integers(-(2**62), 2**62, n, dtype=np.int64)
        else:
            a = rng.choice(special, n)
            checked["nan"] += bool(np.isnan(a).any())
            checked["neg_zero_in"] += bool((np.signbit(a) & (a == 0)).any())
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # inf - inf, as numpy warns
            want = np.median(a.copy(), overwrite_input=True)
            got = scratch_median(a.copy())
        assert type(got) is type(want)
        assert np.asarray(got).tobytes() == np.asarray(want).tobytes(), (a, got, want)
    assert checked["nan"] > 100 and checked["neg_zero_in"] > 100
    assert float(scratch_median(np.array([-0.0]))) == 0.0
    assert not np.signbit(scratch_median(np.array([-0.0])))


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.uint8, np.int32, np.uint64])
def test_scratch_median_matches_numpy_in_other_dtypes(dtype: type) -> None:
    """numpy's mean sums float16 in float32: the median of two float16 60000s is 60000
    (it was inf, their float16 sum); uint64 and int32 extremes as float64."""
    info = np.finfo(dtype) if np.issubdtype(dtype, np.floating) else np.iinfo(dtype)
    big = info.max
    cases: list[np.ndarray] = [
        np.array([big, big], dtype),
        np.array([big, info.min, big, 0], dtype),
    ]
    rng = np.random.default_rng(6)
    cases += [(rng.normal(size=int(rng.integers(1, 12))) * 100).astype(dtype) for _ in range(300)]
    if dtype is np.float16:
        assert float(scratch_median(cases[0].copy())) == 65504.0
    for a in cases:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            want = np.median(a.copy(), overwrite_input=True)
            got = scratch_median(a.copy())
        assert type(got) is type(want), (a, got, want)
        assert np.asarray(got).tobytes() == np.asarray(want).tobytes(), (a, got, want)
