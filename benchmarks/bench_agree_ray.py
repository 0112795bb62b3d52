"""Fleet agreement on Ray vs serial: 100 one-minute logs through ``agree``, same figures.

Run (needs the [cluster] extra)::

    .venv/bin/python benchmarks/bench_agree_ray.py --logs 100 --repeats 2

Target (issue 15): ``sim2real agree 'fleet/*.mcap' --ray auto`` >= 1.7x faster than the serial
path on 2 cores, with identical figures.

Both sides run :func:`sim2real.cluster.agree_many` on the same configs (pybullet engine, spec
parameters): serial is the in-process loop, Ray one task per log on a local Ray started once
before the timing (``ray start --head`` on a workstation; its start-up time is printed
separately). The sides alternate, each ``--repeats`` times; min / median / max are printed and
the speed-up is median serial / median Ray. The figures of every run must be identical.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import statistics
import sys
import time
from pathlib import Path

from sim2real.cluster import agree_many, write_synthetic_fleet
from sim2real.study import StudyConfig


def fleet(folder: Path, n: int) -> list[Path]:
    """``n`` one-minute synthetic sessions (written once, reused)."""
    folder.mkdir(parents=True, exist_ok=True)
    have = sorted(folder.glob("session_*.mcap"))
    if len(have) >= n:
        return have[:n]
    return write_synthetic_fleet(folder, n, duration_s=60.0, seed=1000)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--logs", type=int, default=100)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--engine", default="pybullet")
    ap.add_argument("--folder", type=Path, default=Path("bench-fleet"))
    args = ap.parse_args(argv)
    logs = fleet(args.folder, args.logs)
    configs = [StudyConfig(log=str(p), robot="turtlebot3_burger", engine=args.engine) for p in logs]
    import ray

    t0 = time.perf_counter()
    ray.init(include_dashboard=False, logging_level="ERROR")
    startup_s = time.perf_counter() - t0
    cpus = int(ray.cluster_resources().get("CPU", 0))
    times: dict[str, list[float]] = {"serial": [], "ray": []}
    figures: dict[str, list[object]] = {"serial": [], "ray": []}
    try:
        for _ in range(args.repeats):
            for side, address in (("serial", None), ("ray", "auto")):
                t = time.perf_counter()
                out = agree_many(configs, address=address)
                times[side].append(time.perf_counter() - t)
                figures[side].append([fig for fig, _ in out])
                print(f"{side}: {times[side][-1]:.1f} s", flush=True)
    finally:
        ray.shutdown()
    reference = figures["serial"][0]
    identical = all(run == reference for runs in figures.values() for run in runs)
    print(
        f"{len(logs)} one-minute logs, engine {args.engine}, Ray with {cpus} CPUs "
        f"(start-up {startup_s:.1f} s, not in the timings), {args.repeats} repeats per side"
    )
    for side, ts in times.items():
        print(
            f"  {side:6s} min {min(ts):7.1f} s  median {statistics.median(ts):7.1f} s  "
            f"max {max(ts):7.1f} s"
        )
    ratio = statistics.median(times["serial"]) / statistics.median(times["ray"])
    print(f"speed-up (median serial / median Ray): {ratio:.2f}x (target >= 1.7x)")
    print(f"figures identical across all runs: {identical}")
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
