"""Benchmark: replaying a 10-minute log in pybullet must run >= 50x faster than real time.

A synthetic 10-minute TurtleBot3 Burger log (commands at 10 Hz, odometry at 30 Hz, written to
and read back from MCAP) is replayed with the pybullet engine (240 Hz physics) and with the
reduced engine. Prints both wall times, the pybullet speed-up over real time (target >= 50x)
and the ratio between the two engines, all measured in this run.

Run: ``.venv/bin/python benchmarks/bench_replay.py``
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from robots.reduced import DEFAULT_DT_S, simulate
from robots.spec import load_spec
from sim2real.logs import read_trace, write_velocity_log
from sim2real.replay import replay

DURATION_S = 600.0
TARGET_SPEEDUP = 50.0


def _make_log(path: Path) -> None:
    spec = load_spec("turtlebot3_burger")
    rng = np.random.default_rng(0)
    n_cmd = int(DURATION_S * 10)
    cmd_t = np.arange(n_cmd) / 10.0
    hold = 25  # a new command every 2.5 s, repeated at 10 Hz
    cmd_v = np.repeat(rng.uniform(-0.2, 0.2, n_cmd // hold + 1), hold)[:n_cmd]
    cmd_w = np.repeat(rng.uniform(-1.5, 1.5, n_cmd // hold + 1), hold)[:n_cmd]
    meas_t = np.arange(int(DURATION_S * 30)) / 30.0
    true = simulate(
        spec.drive.replace(delay_s=0.15), spec.geometry,
        cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=meas_t,
    )  # fmt: skip
    t0 = 1_700_000_000_000_000_000
    write_velocity_log(
        path,
        cmd_t_ns=t0 + np.rint(cmd_t * 1e9).astype(np.int64),
        cmd_v=cmd_v,
        cmd_w=cmd_w,
        meas_t_ns=t0 + np.rint(meas_t * 1e9).astype(np.int64),
        meas_v=true.v + rng.normal(0.0, 0.003, meas_t.size),
        meas_w=true.w + rng.normal(0.0, 0.02, meas_t.size),
    )


def _timed(trace, engine: str) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    start = time.perf_counter()
    sim = replay(trace, robot="turtlebot3_burger", engine=engine)
    return time.perf_counter() - start, sim.duration_s


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "ten_minutes.mcap"
        _make_log(path)
        trace = read_trace(path)
    replay(trace.window(0.0, 5.0), robot="turtlebot3_burger", engine="reduced")  # JIT warm-up
    reduced_s, span = _timed(trace, "reduced")
    pybullet_s, _ = _timed(trace, "pybullet")
    speedup = span / pybullet_s
    print(f"log: {span:.0f} s simulated ({trace.cmd_t_ns.size} commands, "
          f"{trace.meas_t_ns.size} odometry samples)")  # fmt: skip
    print(f"pybullet replay (240 Hz physics): {pybullet_s:8.3f} s  = {speedup:7.1f}x real time")
    print(
        f"reduced  replay ({1 / DEFAULT_DT_S:.0f} Hz, numba):  {reduced_s:8.3f} s  = "
        f"{span / reduced_s:7.0f}x real time"
    )
    print(f"pybullet / reduced wall time: {pybullet_s / reduced_s:.0f}x")
    ok = speedup >= TARGET_SPEEDUP
    print(f"target >= {TARGET_SPEEDUP:.0f}x real time in pybullet: {'PASS' if ok else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
