"""ROS 1 ``.bag`` reading vs our MCAP reader on the same recording (target: bag <= 3x MCAP).

Run: ``.venv/bin/python benchmarks/bench_bag.py``. One generated recording (50 Hz Odometry x
600 s = 30k messages, 20 Hz Twist = 12k) is written as MCAP by :func:`write_trace` and as a
ROS 1 bag by :func:`write_rosbag` (rosbags' writer, uncompressed chunks as ``rosbag record``
writes by default). Both sides run :func:`sim2real.logs.read_trace` from the file on disk to a
:class:`Trace` (read + SHA-256 the bytes, container, decode, clean); runs alternate MCAP/bag
with the same repeat count. Prints min/median/max of each and the ratio of medians.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

T0_NS = 1_700_000_000 * 10**9
REPEAT = 9


def _recording(n_odom: int = 30_000, n_cmd: int = 12_000) -> object:
    from sim2real.logs import Trace, TraceMeta

    rng = np.random.default_rng(0)
    return Trace(
        cmd_t_ns=T0_NS + np.arange(n_cmd, dtype=np.int64) * 50_000_000 + 1_000,
        cmd_v=rng.uniform(-0.2, 0.2, n_cmd),
        cmd_w=rng.uniform(-1, 1, n_cmd),
        meas_t_ns=T0_NS + np.arange(n_odom, dtype=np.int64) * 20_000_000,
        meas_v=rng.normal(0.1, 0.05, n_odom),
        meas_w=rng.normal(0, 0.3, n_odom),
        meta=TraceMeta(),
    )


def _time(path: Path) -> float:
    from sim2real.logs import read_trace

    t = time.perf_counter()
    read_trace(path)
    return time.perf_counter() - t


def main() -> None:
    from sim2real.logs import read_trace, write_rosbag, write_trace

    with tempfile.TemporaryDirectory() as tmp:
        rec = _recording()
        mcap = write_trace(Path(tmp) / "run.mcap", rec)  # type: ignore[arg-type]
        bag = write_rosbag(Path(tmp) / "run.bag", read_trace(mcap))
        a, b = read_trace(mcap), read_trace(bag)
        if not all(np.array_equal(getattr(a, k), getattr(b, k)) for k in ("meas_t_ns", "meas_v")):
            raise SystemExit("the bag and the MCAP file read differently")
        t_mcap, t_bag = [], []
        for _ in range(REPEAT):
            t_mcap.append(_time(mcap))
            t_bag.append(_time(bag))
    n = a.meta.cmd_count + a.meta.meas_count
    for label, ts in (("mcap (ours)", t_mcap), ("ros1 bag (rosbags)", t_bag)):
        print(
            f"{label:<20} {n} msgs  min {min(ts) * 1e3:7.1f} ms  median "
            f"{statistics.median(ts) * 1e3:7.1f} ms  max {max(ts) * 1e3:7.1f} ms"
        )
    ratio = statistics.median(t_bag) / statistics.median(t_mcap)
    verdict = "meets" if ratio <= 3.0 else "MISSES"
    print(f"bag / mcap read time (medians): {ratio:.2f}x {verdict} the <= 3x target")


if __name__ == "__main__":
    main()
