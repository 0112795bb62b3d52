"""Benchmark: do the fit's 95 % intervals cover the truth when commands arrive with jitter?

Known truth: logs of the drive model itself (the TurtleBot3 Burger's spec drive with PI wheel
loops, ``speed_loop_ki_per_s`` 20, delay 70 ms, viscous friction off its prior's nominal),
driven by the base's 90 s excitation plan (:func:`sysid.plan.plan_excitation`) whose commands
reach it late or early by a normal draw of sd ``--jitter`` each (order kept; the log keeps the
published times), integrated at 0.5 ms and sampled at 30 Hz with 4 mm/s and 0.02 rad/s white
noise. One draw per seed (noise and arrival times from ``numpy.random.default_rng(seed)``),
one ``sysid.fit_drive`` with the spec's priors each; the table counts the draws whose reported
95 % interval holds the true delay and viscous friction, with the mean and sd of the
standardised error (estimate - truth) / reported sd: an honest interval covers about 95 % with
a z of mean 0 and sd 1.

Run: ``.venv/bin/python benchmarks/bench_jitter.py [--jitter 0.01] [--draws 40]`` (about 10 s
per fit on one core).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from robots.params import DriveParams
from robots.spec import load_spec
from sysid import fit_drive
from sysid._logs import LogArrays
from sysid.plan import plan_excitation
from sysid.synthetic import jittered_model_log

ROBOT = "turtlebot3_burger"
#: The parameters whose intervals are judged.
JUDGED = ("delay_s", "viscous_v_ns_per_m", "viscous_w_nms_per_rad")


def truth() -> DriveParams:
    """The drive the logs come from."""
    return load_spec(ROBOT).drive.replace(
        speed_loop_ki_per_s=20.0,
        delay_s=0.07,
        viscous_v_ns_per_m=0.3,
        viscous_w_nms_per_rad=0.004,
    )


def jittered_log(jitter_s: float, seed: int, duration_s: float = 90.0) -> LogArrays:
    """One draw: the plan on :func:`truth`, each command ``jitter_s`` late or early."""
    spec = load_spec(ROBOT)
    plan = plan_excitation(spec, duration_s)
    return jittered_model_log(
        truth(), spec.geometry, plan, seed=seed, arrival_jitter_s=jitter_s, dt_s=0.0005
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jitter", type=float, default=0.01, help="arrival-time sd, s")
    ap.add_argument("--draws", type=int, default=40)
    ap.add_argument("--first-seed", type=int, default=1)
    args = ap.parse_args()
    spec, true = load_spec(ROBOT), truth()
    z: dict[str, list[float]] = {n: [] for n in JUDGED}
    hits = dict.fromkeys(JUDGED, 0)
    started = time.perf_counter()
    for seed in range(args.first_seed, args.first_seed + args.draws):
        t0 = time.perf_counter()
        res = fit_drive(
            [jittered_log(args.jitter, seed)],
            geometry=spec.geometry,
            base_params=spec.drive,
            priors=spec.priors,
        )
        (jit,) = res.settings["command_jitter"]
        row = [
            f"seed {seed:3d} ({time.perf_counter() - t0:4.1f} s): jitter read "
            f"{1e3 * jit.get('jitter_s', 0.0):5.2f} ms, whitened {jit.get('whitened', False)!s:5}"
        ]
        for name in JUDGED:
            e = res.estimate(name)
            lo, hi, sd = e.ci95_low, e.ci95_high, e.std
            if lo is None or hi is None or not sd:
                raise SystemExit(f"{name} was not fitted on seed {seed}")
            value = getattr(true, name)
            hits[name] += lo <= value <= hi
            z[name].append((e.value - value) / sd)
            row.append(
                f"{name} {e.value:.4g} [{lo:.4g}, {hi:.4g}]{'' if lo <= value <= hi else ' MISS'}"
            )
        print(" | ".join(row), flush=True)
    print(
        f"\njitter {1e3 * args.jitter:g} ms, {args.draws} draws "
        f"({time.perf_counter() - started:.0f} s): the truth inside the reported 95 % interval"
    )
    print("| parameter | truth | covered | z mean | z sd |\n|---|---|---|---|---|")
    for name in JUDGED:
        zs = np.array(z[name])
        print(
            f"| {name} | {getattr(true, name):g} | {hits[name]}/{args.draws} "
            f"({hits[name] / args.draws:.2f}) | {zs.mean():+.2f} | {zs.std(ddof=1):.2f} |"
        )


if __name__ == "__main__":
    main()
