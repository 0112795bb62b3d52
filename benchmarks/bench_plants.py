"""Benchmark: a 90 s session of the foreign plant (sim2real.plants.diff_drive) against the reduced model.

The same 90 s ``mixed`` command profile of a TurtleBot3 Burger is simulated, alternately and
with the same repeat count, by

- the foreign plant (:func:`sim2real.plants.diff_drive.run_plant`: 0.5 ms physics step, 100 Hz PI loop,
  encoders, gyro, jitter), and
- the reduced drive model (:func:`robots.reduced.simulate` at its default 1/240 s step, with
  output on the same 30 Hz odometry grid): the baseline a fit runs thousands of times.

Prints min/median/max wall time of each, the per-repeat ratio plant/reduced and the plant's
real-time factor (simulated s per wall s); the target is a 90 s session in well under a
second.

Run: ``.venv/bin/python benchmarks/bench_plants.py [--repeats N]``
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from _timing import alternate, fmt_ratio, paired_ratios

from robots.reduced import simulate
from robots.spec import load_spec
from sim2real.plants.diff_drive import command_profile, plant_from_spec, run_plant

ROBOT = "turtlebot3_burger"
DURATION_S = 90.0
TARGET_S = 1.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args(argv)
    plant = plant_from_spec(ROBOT)
    spec = load_spec(ROBOT)
    t, v, w = command_profile(
        "mixed", DURATION_S, rng=np.random.default_rng(0), max_v_mps=0.22, max_w_radps=2.84
    )
    grid = np.arange(0.0, DURATION_S, 1.0 / 30.0)

    def foreign() -> object:
        return run_plant(plant, t, v, w, duration_s=DURATION_S, rng=np.random.default_rng(1))

    def reduced() -> object:
        return simulate(spec.drive, spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, t_out_s=grid)

    stats = alternate({"plant": foreign, "reduced": reduced}, args.repeats)
    plant_s, reduced_s = stats["plant"], stats["reduced"]
    print(f"{DURATION_S:g} s session, {args.repeats} alternated repeats each (after a warm-up)")
    print(f"  foreign plant     {plant_s.fmt()}")
    print(f"  reduced model     {reduced_s.fmt()}  (baseline)")
    print(f"  plant / reduced   {fmt_ratio(plant_s, reduced_s)}")
    lo, med, hi = plant_s.rate(DURATION_S)
    print(f"  plant real-time factor {lo:.0f}/{med:.0f}/{hi:.0f} x (slowest/median/fastest)")
    ok = plant_s.median < TARGET_S
    print(f"target: a {DURATION_S:g} s session in < {TARGET_S:g} s: {'met' if ok else 'MISSED'}")
    _, ratio, _ = paired_ratios(plant_s, reduced_s)
    return 0 if ok and np.isfinite(ratio) else 1


if __name__ == "__main__":
    sys.exit(main())
