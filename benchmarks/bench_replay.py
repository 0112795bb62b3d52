"""Benchmark: replaying a 10-minute log in pybullet must run >= 50x faster than real time.

A synthetic 10-minute TurtleBot3 Burger log (commands at 10 Hz, odometry at 30 Hz, written to
and read back from MCAP) is replayed with the pybullet engine (240 Hz physics) and with the
reduced engine, alternated, the same number of times (3; 1 with ``BENCH_QUICK=1``). Prints
min/median/max wall and CPU times, the pybullet speed-up over real time (target >= 50x) and the
ratio between the two engines, all measured in this run, and the whole ``sim2real agree``
command a user runs on that log with each engine (cold and warm). A missed target is recorded
for ``docs/benchmarks.md``, not an error (exit 0).

Run: ``.venv/bin/python benchmarks/bench_replay.py``
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
from _timing import QUICK, alternate, command_times, machine, paired_ratios, record

from robots.reduced import simulate
from robots.spec import load_spec
from robots.units import nanoseconds
from sim2real.agreement.replay import replay
from sim2real.logs import read_trace, write_velocity_log

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
        cmd_t_ns=t0 + nanoseconds(cmd_t),
        cmd_v=cmd_v,
        cmd_w=cmd_w,
        meas_t_ns=t0 + nanoseconds(meas_t),
        meas_v=true.v + rng.normal(0.0, 0.003, meas_t.size),
        meas_w=true.w + rng.normal(0.0, 0.02, meas_t.size),
    )


def main() -> int:
    repeats = 1 if QUICK else 3
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "ten_minutes.mcap"
        _make_log(path)
        trace = read_trace(path)
        agree = [sys.executable, "-m", "sim2real", "agree", str(path), "--robot"]
        commands = {
            engine: [*agree, "turtlebot3_burger", "--engine", engine]
            for engine in ("pybullet", "reduced")
        }
        whole = command_times(commands, repeats)
    span = float(trace.meas_t_s[-1] - trace.meas_t_s[0])
    replay(trace.window(0.0, 5.0), robot="turtlebot3_burger", engine="pybullet")  # warm-up
    st = alternate(
        {
            engine: (lambda e=engine: replay(trace, robot="turtlebot3_burger", engine=e))
            for engine in ("pybullet", "reduced")
        },
        repeats,
        warmup=False,
    )
    print(f"machine: {machine()}")
    print(f"log: {span:.0f} s simulated ({trace.cmd_t_ns.size} commands, "
          f"{trace.meas_t_ns.size} odometry samples); {repeats} alternated repeats")  # fmt: skip
    for engine, s in st.items():
        print(
            f"{engine:<8} replay: wall {s.fmt(1.0, 's')}, CPU {s.cpu().fmt(1.0, 's')}; "
            f"{span / s.median:,.0f}x real time (wall), {span / s.cpu().median:,.0f}x (CPU)"
        )
    pb = st["pybullet"]
    speedup, cpu_speedup = span / pb.median, span / pb.cpu().median
    for engine, (cold, warm) in whole.items():
        print(
            f"sim2real agree --engine {engine} (whole process): cold {cold:.2f} s, warm "
            f"{warm.fmt(1.0, 's')}, warm CPU median {warm.cpu().median:.2f} s"
        )
    lo, med, hi = paired_ratios(pb, st["reduced"])
    print(f"pybullet / reduced wall time: {lo:.0f}/{med:.0f}/{hi:.0f}x (min/median/max)")
    ok = speedup >= TARGET_SPEEDUP
    print(f"target >= {TARGET_SPEEDUP:.0f}x real time in pybullet: {'PASS' if ok else 'FAIL'}")
    record(
        "robots",
        "pybullet replay of a 10-minute log, x real time (in process)",
        f"wall {speedup:.0f}x (min {span / pb.max:.0f}, max {span / pb.min:.0f}); CPU "
        f"{cpu_speedup:.0f}x; reduced engine {span / st['reduced'].median:,.0f}x; whole "
        f"`sim2real agree --engine pybullet`: warm {whole['pybullet'][1].median:.1f} s "
        f"(CPU {whole['pybullet'][1].cpu().median:.1f} s), cold {whole['pybullet'][0]:.1f} s",
        f">= {TARGET_SPEEDUP:.0f}x",
        ok,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
