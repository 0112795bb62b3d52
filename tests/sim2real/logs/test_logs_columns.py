"""Decoded arrays sized from the summary (issue 16.3): the message counts of the summary's
Statistics record size each channel's arrays once, so decoded chunks go straight to their final
place; the counts are a hint only: wrong, missing or absurd counts give the same trace."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from logs_helpers import make_arrays
from mcap.reader import make_reader
from mcap.writer import CompressionType

from sim2real.logs import Trace, read_trace, write_velocity_log
from sim2real.logs import _summary as summary_mod
from sim2real.logs._mcap import Columns

_ARR = make_arrays(n_cmd=4_000, n_meas=12_000, seed=5)


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Commands and odometry over many chunks (zstd, 1 MiB chunks)."""
    return write_velocity_log(tmp_path_factory.mktemp("cols") / "run.mcap", **_ARR.kwargs())


def _counts(path: Path) -> dict[int, int]:
    with path.open("rb") as fh:
        stats = make_reader(fh).get_summary().statistics  # type: ignore[union-attr]
    return dict(stats.channel_message_counts)


def _chunks(path: Path) -> int:
    with path.open("rb") as fh:
        return len(make_reader(fh).get_summary().chunk_indexes)  # type: ignore[union-attr]


def _same(a: Trace, b: Trace) -> None:
    for key in ("cmd_t_ns", "cmd_v", "cmd_w", "meas_t_ns", "meas_v", "meas_w", "pose_yaw"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key))
    assert a.meta.warnings == b.meta.warnings


def test_stated_counts_are_the_statistics_record(log: Path) -> None:
    with log.open("rb") as fh:
        got = summary_mod.stated_counts(fh, log.stat().st_size)
    assert got == _counts(log)
    assert sorted(got.values()) == [4_000, 12_000]
    assert _chunks(log) >= 5  # the arrays are filled from several chunks


@pytest.mark.parametrize("scale", [0.0, 0.3, 1.0, 3.0])
def test_any_count_hint_gives_the_same_trace(log: Path, monkeypatch, scale: float) -> None:
    """Too few (the arrays grow), none, exact or too many (trimmed): one result."""
    exact = read_trace(log)
    np.testing.assert_array_equal(exact.meas_t_ns, _ARR.meas_t_ns)
    np.testing.assert_array_equal(exact.cmd_v, _ARR.cmd_v)

    def hint(fh: object, size: int) -> dict[int, int]:
        return {k: int(v * scale) for k, v in _counts(log).items()}

    monkeypatch.setattr(summary_mod, "stated_counts", hint)
    _same(read_trace(log), exact)


def test_an_absurd_statistics_count_is_capped_and_changes_nothing(log: Path, tmp_path) -> None:
    """A Statistics record claiming 2**60 odometry messages reserves at most size // 16."""
    data = bytearray(log.read_bytes())
    counts = _counts(log)
    odom = max(counts, key=lambda k: counts[k])
    entry = struct.pack("<HQ", odom, counts[odom])
    at = data.rfind(entry)  # in the Statistics record's channel_message_counts map
    assert at > 0 and data.count(entry) == 1
    data[at : at + 10] = struct.pack("<HQ", odom, 2**60)
    bad = tmp_path / "absurd.mcap"
    bad.write_bytes(bytes(data))
    with bad.open("rb") as fh:
        stated = summary_mod.stated_counts(fh, len(data))
    assert stated[odom] == len(data) // 16
    _same(read_trace(bad), read_trace(log))


def test_a_file_without_statistics_states_no_counts(tmp_path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "nostats.mcap"
    with path.open("wb") as fh:
        w = Writer(fh, use_statistics=False, compression=CompressionType.NONE)
        w.start(profile="ros2", library="t")
        w.finish()
    with path.open("rb") as fh:
        assert summary_mod.stated_counts(fh, path.stat().st_size) == {}
    with path.open("rb") as fh:
        assert summary_mod.stated_counts(fh, 40) == {}  # too short for a footer


def test_columns_grow_trim_and_hand_over() -> None:
    parts = [{"v": np.arange(n, dtype=np.float64) + 10 * n} for n in (3, 5, 2)]
    whole = np.concatenate([p["v"] for p in parts])
    for capacity in (0, 4, 10, 25):
        cols = Columns(parts[0], capacity)
        for p in parts[1:]:
            assert cols.fits(p)
            cols.add(p)
        got = cols.take()["v"]
        np.testing.assert_array_equal(got, whole)
        assert got.size == 10
        # exact size: the arrays themselves; otherwise a trimmed copy
        assert np.shares_memory(got, cols.arrays["v"]) == (cols.arrays["v"].size == 10)
    timed = Columns({"log_ns": np.array([5, 6], np.int64), "v": np.zeros(2)}, 8)
    timed.add({"log_ns": np.array([7], np.int64), "v": np.ones(1)})
    np.testing.assert_array_equal(timed.log_times(), [5, 6, 7])
    assert not cols.fits({"v": np.zeros(1, np.float32)})
    assert not cols.fits({"w": np.zeros(1)})


_RSS_PROG = """
import json, sys
from sim2real.logs import read_trace

def hwm():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM"):
            return int(line.split()[1]) * 1024

read_trace(sys.argv[2])  # imports and first-use caches outside the measurement
before = hwm()
tr = read_trace(sys.argv[1])
arrays = [tr.cmd_t_ns, tr.cmd_v, tr.cmd_w, tr.meas_t_ns, tr.meas_v, tr.meas_w]
arrays += [a for a in (tr.pose_x, tr.pose_y, tr.pose_yaw) if a is not None]
print(json.dumps({"growth": hwm() - before, "output": sum(a.nbytes for a in arrays),
                  "n": int(tr.meas_t_ns.size)}))
"""


@pytest.mark.slow
def test_resident_peak_of_a_decode_follows_its_output(tmp_path, log: Path) -> None:
    """The RSS form of the bound (VmHWM of the process, not only Python's allocations)."""
    n = 200_000
    rng = np.random.default_rng(9)
    t = 1_700_000_000 * 10**9 + np.arange(n, dtype=np.int64) * 20_000_000
    big = write_velocity_log(
        tmp_path / "big.mcap",
        cmd_t_ns=t[::2] + 1_000,
        cmd_v=rng.uniform(-0.2, 0.2, n // 2),
        cmd_w=rng.uniform(-1, 1, n // 2),
        meas_t_ns=t,
        meas_v=rng.normal(0.1, 0.05, n),
        meas_w=rng.normal(0, 0.3, n),
        meas_log_t_ns=t + rng.integers(1_000_000, 5_000_000, n),
    )
    res = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(_RSS_PROG), str(big), str(log)],
        capture_output=True,
        text=True,
        check=True,
    )
    got = json.loads(res.stdout.strip().splitlines()[-1])
    assert got["n"] == n
    with big.open("rb") as fh:
        chunk = max(
            c.compressed_size + c.uncompressed_size
            for c in make_reader(fh).get_summary().chunk_indexes  # type: ignore[union-attr]
        )
    bound = 2 * (got["output"] + chunk)
    print(f"VmHWM growth {got['growth'] / 2**20:.1f} MiB, bound {bound / 2**20:.1f} MiB")
    assert got["growth"] <= bound, (
        f"VmHWM grew {got['growth'] / 2**20:.1f} MiB > bound {bound / 2**20:.1f} MiB"
    )
