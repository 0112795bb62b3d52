"""Speed of CarCrossing-v0 and Race-v0, each beside its pybullet back-end measured in the same run.

Run: ``.venv/bin/python benchmarks/bench_car_race.py [--repeats 3] [--seconds 2]`` (one core:
BLAS threads pinned to 1).

Targets: CarCrossing-v0 >= 1,000 env steps/s and Race-v0 (circuit, 4 ORCA
opponents) >= 500 env steps/s on dynamics="reduced". The baseline of each is the same env on
dynamics="pybullet"; ours and the baseline alternate, with the same number of repeats, and the
rates (random actions, resets included) are printed as min / median / max, in wall-clock and in
process-CPU time (the machine may be shared with other jobs).
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse
import statistics
import time
from typing import Any

import gymnasium as gym
import numpy as np
from _timing import QUICK, record

import sim2real.envs  # noqa: F401  (registers the ids)


def steps_per_s(env_id: str, seconds: float, **kw: Any) -> tuple[float, float]:
    """(wall-clock, CPU-time) env steps per second with random actions, resets included."""
    env: Any = gym.make(env_id, **kw)
    env.action_space.seed(0)
    env.reset(seed=0)
    env.step(env.action_space.sample())  # warm-up (numba cache load)
    n, t0, c0 = 0, time.perf_counter(), time.process_time()
    while time.perf_counter() - t0 < seconds:
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        n += 1
        if term or trunc:
            env.reset()
    rates = n / (time.perf_counter() - t0), n / (time.process_time() - c0)
    env.close()
    return rates


def _fmt(rates: list[float]) -> str:
    return f"{min(rates):8.0f} / {statistics.median(rates):8.0f} / {max(rates):8.0f}"


def bench(name: str, env_id: str, target: float, repeats: int, seconds: float, **kw: Any) -> None:
    ours: list[tuple[float, float]] = []
    base: list[tuple[float, float]] = []
    for i in range(repeats):  # alternate ours and the baseline, the order flipping each round
        for dynamics in ("reduced", "pybullet")[:: 1 if i % 2 == 0 else -1]:
            rates = steps_per_s(env_id, seconds, dynamics=dynamics, **kw)
            (ours if dynamics == "reduced" else base).append(rates)
    print(f"{name}  (steps/s, min / median / max over {repeats} runs of {seconds:g} s)")
    for label, rates in (("reduced ", ours), ("pybullet", base)):
        print(f"  {label} wall {_fmt([r[0] for r in rates])}   cpu {_fmt([r[1] for r in rates])}")
    med_ours = statistics.median(r[0] for r in ours)
    med_base = statistics.median(r[0] for r in base)
    med_cpu = statistics.median(r[1] for r in ours)
    print(
        f"  reduced is {med_ours / med_base:.1f}x pybullet (median wall); target {target:,.0f} "
        f"steps/s: {'met' if med_ours >= target else 'MISSED'} (wall), "
        f"{'met' if med_cpu >= target else 'MISSED'} (cpu)"
    )
    record(
        "envs",
        f"{name}, dynamics=reduced, env steps/s",
        f"wall {med_ours:,.0f} (min {min(r[0] for r in ours):,.0f}), CPU {med_cpu:,.0f}; "
        f"{med_ours / med_base:.1f}x the pybullet back-end",
        f">= {target:,.0f}",
        med_ours >= target,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2 if QUICK else 3)
    ap.add_argument("--seconds", type=float, default=1.0 if QUICK else 2.0)
    args = ap.parse_args()
    np.random.default_rng(0)
    bench("CarCrossing-v0", "sim2real/CarCrossing-v0", 1000.0, args.repeats, args.seconds)
    bench(
        "Race-v0 circuit, 4 opponents",
        "sim2real/Race-v0",
        500.0,
        args.repeats,
        args.seconds,
        track="circuit",
        num_opponents=4,
    )


if __name__ == "__main__":
    main()
