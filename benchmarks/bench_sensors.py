"""Benchmark the lidar identification (``sysid.sensors``) on scans with known truth.

Each draw is one 60 s recording from the project's ray caster in a static room
(``tests/sysid/sensor_truth.py``: noise std 5 mm growing to 15-40 mm at 5 m, dropout 0-10 %,
a 30 ms stamp offset, a 2 degree mounting yaw, odometry with scale errors and speed noise).
Per quantity it prints how many draws meet the target (std within 15 % at the near, middle
and far range bins, dropout within 1.5 points, offset within 10 ms, yaw within 0.5 degree)
and how many 95 % intervals hold the truth (target >= 85 %), and the time of one
identification (target <= 5 s for the whole command; the estimate alone here).

Run: ``.venv/bin/python benchmarks/bench_sensors.py [--draws 20]`` (``BENCH_QUICK=1``: 5 draws)
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from _timing import QUICK, record

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from sysid.sensors import estimate_sensor  # noqa: E402
from tests.sysid.sensor_truth import MOUNT_XY_M, draw_truth, synthetic_recording  # noqa: E402

TARGETS = {
    "std_near": "15 %",
    "std_mid": "15 %",
    "std_far": "15 %",
    "dropout": "1.5 points",
    "offset": "10 ms",
    "yaw": "0.5 deg",
}


def one_draw(seed: int) -> tuple[dict[str, tuple[float, bool, bool]], float]:
    """Per quantity: (error in the target's unit, within target, interval holds truth)."""
    truth = draw_truth(np.random.default_rng(seed))
    scans, odom = synthetic_recording(truth, seed)
    start = time.perf_counter()
    est = estimate_sensor(scans, odom, mount_xy_m=MOUNT_XY_M, seed=seed)
    elapsed = time.perf_counter() - start
    out: dict[str, tuple[float, bool, bool]] = {}
    mid = len(est.noise_range_m) // 2
    for name, i in (("std_near", 0), ("std_mid", mid), ("std_far", -1)):
        t = truth.std_at(est.noise_range_m[i])
        err = 100.0 * (est.noise_std_m[i] / t - 1.0)
        out[name] = (err, abs(err) <= 15.0, est.noise_std_lo_m[i] <= t <= est.noise_std_hi_m[i])
    err = 100.0 * (est.dropout - truth.dropout)
    lo, hi = est.dropout_ci
    out["dropout"] = (err, abs(err) <= 1.5, lo <= truth.dropout <= hi)
    err = 1e3 * (est.time_offset_s - truth.offset_s)
    lo, hi = est.time_offset_ci
    out["offset"] = (err, abs(err) <= 10.0, lo <= truth.offset_s <= hi)
    err = math.degrees(est.mounting_yaw_rad - truth.yaw_rad)
    lo, hi = est.mounting_yaw_ci
    out["yaw"] = (err, abs(err) <= 0.5, lo <= truth.yaw_rad <= hi)
    return out, elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=5 if QUICK else 20)
    args = parser.parse_args()
    rows, times = [], []
    for i in range(args.draws):
        row, elapsed = one_draw(1000 + i)
        rows.append(row)
        times.append(elapsed)
    n = len(rows)
    print(f"{n} synthetic 60 s recordings (5 Hz, 360 beams, 20 Hz odometry)")
    print(f"{'quantity':10s} {'target':>10s} {'within':>7s} {'covered':>8s} {'max |err|':>10s}")
    for name, target in TARGETS.items():
        within = sum(r[name][1] for r in rows)
        covered = sum(r[name][2] for r in rows)
        worst = max(abs(r[name][0]) for r in rows)
        print(f"{name:10s} {target:>10s} {within:>4d}/{n} {covered:>5d}/{n} {worst:>10.2f}")
        record("sensors", f"{name} within {target}", f"{within}/{n}", f"{n}/{n}", bool(within == n))
        record(
            "sensors",
            f"{name} 95 % coverage",
            f"{covered}/{n}",
            ">= 85 %",
            bool(covered >= 0.85 * n),
        )
    median_s = statistics.median(times)
    print(f"identification: median {median_s:.2f} s, max {max(times):.2f} s per recording")
    record(
        "sensors",
        "identification time (median)",
        f"{median_s:.2f} s",
        "<= 5 s",
        bool(median_s <= 5.0),
    )


if __name__ == "__main__":
    main()
