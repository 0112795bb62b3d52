"""Benchmark the lidar identification (``sysid.sensors``) on scans with known truth.

Each draw is one 60 s recording from the project's ray caster in a static room
(``tests/sysid/sensor_truth.py``: noise std 5 mm growing to 15-40 mm at 5 m, dropout 0-10 %,
a 30 ms stamp offset, a 2 degree mounting yaw, odometry with scale errors and speed noise).
Per quantity it prints how many draws meet the target (std within 15 % at the near, middle
and far range bins, dropout within 1.5 points, offset within 10 ms, yaw within 0.5 degree)
and how many 95 % intervals hold the truth (target >= 85 %); the ``moving_*`` rows are the
noise std of a second recording per draw whose base never stands still (the noise from the
matched moving scans alone). It times one identification (the estimate alone) and the whole
command, ``python -m sim2real sysid sensors`` on the first draw written as a ROS 2 MCAP file
(target <= 5 s; its CPU time is printed too, which a loaded machine does not inflate).

Run: ``.venv/bin/python benchmarks/bench_sensors.py [--draws 20]`` (``BENCH_QUICK=1``: 5 draws)
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _timing import QUICK, record, timed_run

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from sim2real.cli import main as sim2real_main  # noqa: E402
from sysid.sensors import SensorEstimate, estimate_sensor  # noqa: E402
from tests.sim2real.test_sysid_sensors_cli import _write as write_recording  # noqa: E402
from tests.sysid.sensor_truth import (  # noqa: E402
    MOUNT_XY_M,
    Truth,
    draw_truth,
    synthetic_recording,
)

TARGETS = {
    "std_near": "15 %",
    "std_mid": "15 %",
    "std_far": "15 %",
    "dropout": "1.5 points",
    "offset": "10 ms",
    "yaw": "0.5 deg",
    "moving_near": "15 %",
    "moving_mid": "15 %",
    "moving_far": "15 %",
}


def one_draw(seed: int) -> tuple[dict[str, tuple[float, bool, bool]], float]:
    """Per quantity: (error in the target's unit, within target, interval holds truth)."""
    truth = draw_truth(np.random.default_rng(seed))
    scans, odom = synthetic_recording(truth, seed)
    start = time.perf_counter()
    est = estimate_sensor(scans, odom, mount_xy_m=MOUNT_XY_M, seed=seed)
    elapsed = time.perf_counter() - start
    out = _std_rows(est, truth, "std")
    err = 100.0 * (est.dropout - truth.dropout)
    lo, hi = est.dropout_ci
    out["dropout"] = (err, abs(err) <= 1.5, lo <= truth.dropout <= hi)
    err = 1e3 * (est.time_offset_s - truth.offset_s)
    lo, hi = est.time_offset_ci
    out["offset"] = (err, abs(err) <= 10.0, lo <= truth.offset_s <= hi)
    err = math.degrees(est.mounting_yaw_rad - truth.yaw_rad)
    lo, hi = est.mounting_yaw_ci
    out["yaw"] = (err, abs(err) <= 0.5, lo <= truth.yaw_rad <= hi)
    scans, odom = synthetic_recording(truth, seed, stops=False)
    est = estimate_sensor(scans, odom, mount_xy_m=MOUNT_XY_M, seed=seed)
    out |= _std_rows(est, truth, "moving")
    return out, elapsed


def _std_rows(
    est: SensorEstimate, truth: Truth, prefix: str
) -> dict[str, tuple[float, bool, bool]]:
    """Noise std at the near, middle and far range bins: error %, within 15 %, covered."""
    out = {}
    mid = len(est.noise_range_m) // 2
    for name, i in (("near", 0), ("mid", mid), ("far", -1)):
        t = truth.std_at(est.noise_range_m[i])
        err = 100.0 * (est.noise_std_m[i] / t - 1.0)
        covered = est.noise_std_lo_m[i] <= t <= est.noise_std_hi_m[i]
        out[f"{prefix}_{name}"] = (err, abs(err) <= 15.0, covered)
    return out


def whole_command() -> tuple[float, float]:
    """Wall-clock and CPU seconds of ``python -m sim2real sysid sensors`` on a 60 s MCAP."""
    truth = draw_truth(np.random.default_rng(1000))
    scans, odom = synthetic_recording(truth, 1000)
    with tempfile.TemporaryDirectory() as tmp:
        log = write_recording(Path(tmp) / "r2", scans, odom, ros1=False)
        spec = Path(tmp) / "base.yaml"
        argv = ["robots", "new", "base", "--wheel-separation", "0.25", "--max-speed", "0.3"]
        with contextlib.redirect_stdout(io.StringIO()):
            sim2real_main([*argv, "-o", str(spec)])
        spec.write_text(
            spec.read_text().replace(
                "xyz_m: [0.0, 0.0,", f"xyz_m: [{MOUNT_XY_M[0]}, {MOUNT_XY_M[1]},"
            )
        )
        cmd = [sys.executable, "-m", "sim2real", "sysid", "sensors", str(log), "--robot", str(spec)]
        return timed_run([*cmd, "-o", str(Path(tmp) / "s.yaml")])


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
    wall, cpu = whole_command()
    print(f"whole command on a 60 s MCAP: {wall:.2f} s wall clock, {cpu:.2f} s CPU")
    record("sensors", "whole command (CPU)", f"{cpu:.2f} s", "<= 5 s", bool(cpu <= 5.0))
    record(
        "sensors",
        "identification time (median)",
        f"{median_s:.2f} s",
        "<= 5 s",
        bool(median_s <= 5.0),
    )


if __name__ == "__main__":
    main()
