"""Benchmark: what one 90 s session identifies, planned (``sysid plan``) against go-to-goal.

For each base and seed, one plant session is drawn (``draw_session`` with
``numpy.random.default_rng([seed, 0])``, the session ``make_fleet(robot, 1, seed=seed)`` drives
too); it drives the base's 90 s excitation plan (:func:`sysid.plan.plan_excitation`) and,
separately, a go-to-goal profile of the same length (``make_fleet(..., profile="goals")``). A
fit of each (``sysid.fit_drive`` with the spec's priors and odometry model, as ``sysid fit``
reads a base's logs: v the mean over the encoder window, w from the spec's source) gives each parameter's posterior over
prior sd; the table counts those above 0.5 (the data hardly informed them) and lists them.
This is the table of docs/transfer.md, "What a planned session identifies".

Parameters above 0.5 that no command within the base's limits can identify are counted apart,
with their reason: those :func:`sysid.plan.unreachable` proves so from the spec (a torque cap
far above the largest torque the commands ask), and, in a planned session (which asks the
most torque any command within the limits asks, :func:`sysid.plan.torque_cap_reach`), a torque
cap the fit proves the base never reached (``randomization.lower``: the log bounds it only
from below); and those no session of this length can identify
(:func:`sysid.plan.beyond_session`: even the best case, the Fisher information of the plan or
one of its block kinds alone on the drive model, leaves them above half their prior sd),
outside the mass-gain direction. The rest is counted: the mass-gain direction
(:data:`sysid.plan.MASS_GAIN`) and anything else. Each base's best case is printed first.

Run: ``.venv/bin/python benchmarks/bench_plan.py [--robots turtlebot2 turtlebot3_burger]
[--seeds 1 2 3 4 5 6] [--profiles planned goals]`` (about 90 s per fit on one core).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from robots.spec import load_spec
from sim2real.plants.diff_drive import draw_session, make_fleet, plant_from_spec
from sim2real.plants.recording import record_plan
from sysid import fit_drive
from sysid.plan import MASS_GAIN, beyond_session, information_bound, plan_excitation, unreachable

#: A parameter whose posterior sd is above this fraction of its prior sd is poorly informed.
POOR = 0.5


def _apart(
    robot: str,
    profile: str,
    ratios: dict[str, float],
    lower: dict[str, float],
    beyond: dict[str, str],
) -> dict[str, str]:
    """Poorly informed parameters no command within the limits, or no session of this length
    (``beyond``, outside the mass-gain direction), can identify, and why."""
    spec = load_spec(robot)
    out = {
        n: f"by the spec: {why}" for n, why in unreachable(spec).items() if ratios.get(n, 0) > POOR
    }
    out |= {
        n: f"beyond one session of this length: {why}"
        for n, why in beyond.items()
        if n not in MASS_GAIN and ratios.get(n, 0) > POOR and n not in out
    }
    cap = "wheel_torque_max_nm"
    if profile == "planned" and cap in lower and ratios.get(cap, 0.0) > POOR and cap not in out:
        out[cap] = (
            f"never reached: the fitted response needs {lower[cap]:.3g} N m per wheel at most "
            "and never saturates, so the log bounds the cap only from below"
        )
    return out


def _ratios(
    robot: str, seed: int, profile: str, duration_s: float
) -> tuple[dict[str, float], dict[str, float]]:
    spec = load_spec(robot)
    if profile == "planned":
        params = draw_session(plant_from_spec(robot), np.random.default_rng([seed, 0]))
        trace = record_plan(plan_excitation(spec, duration_s), params, seed=seed)
    else:
        trace = make_fleet(robot, 1, seed=seed, profile=profile, duration_s=duration_s)[0]
    # as ``sysid fit`` reads a base's odometry (sim2real.fitting.fit_logs): v is the mean over
    # the spec's encoder window, w from the spec's source
    res = fit_drive(
        [trace],
        geometry=spec.geometry,
        base_params=spec.drive,
        priors=spec.priors,
        robot=robot,
        odom_v_window_s=spec.odometry.v_window_s,
        w_source=spec.odometry.w_source,
    )
    lower = dict(res.randomization.lower) if res.randomization is not None else {}
    return {e.name: float(e.sd_ratio) for e in res.estimates if e.sd_ratio is not None}, lower


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=["turtlebot2", "turtlebot3_burger"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3, 4, 5, 6])
    ap.add_argument("--profiles", nargs="+", default=["planned", "goals"])
    ap.add_argument("--duration", type=float, default=90.0)
    args = ap.parse_args()
    counts: dict[tuple[str, str], list[tuple[int, int, int]]] = {}
    for robot in args.robots:
        bound = information_bound(load_spec(robot), args.duration)
        beyond = beyond_session(bound)
        print(
            f"{robot}: best case of one {args.duration:g} s session: "
            + ", ".join(f"{k} {r:.2f}" for k, r in bound.sd_ratio.items())
            + f"; beyond it: {', '.join(beyond) or 'none'}",
            flush=True,
        )
        for profile in args.profiles:
            for seed in args.seeds:
                t0 = time.perf_counter()
                ratios, lower = _ratios(robot, seed, profile, args.duration)
                poor = {k: r for k, r in ratios.items() if r > POOR}
                apart = _apart(robot, profile, ratios, lower, beyond)
                counted = {k: r for k, r in poor.items() if k not in apart}
                mass_gain = sum(k in MASS_GAIN for k in counted)
                counts.setdefault((robot, profile), []).append(
                    (len(counted), mass_gain, len(apart))
                )
                listed = ", ".join(f"{k} {r:.2f}" for k, r in sorted(counted.items()))
                print(
                    f"{robot} {profile} seed {seed}: {len(counted)} of {len(ratios)} above "
                    f"{POOR} ({mass_gain} mass-gain), {len(apart)} apart "
                    f"({time.perf_counter() - t0:.0f} s): {listed}",
                    flush=True,
                )
                for k, why in apart.items():
                    print(f"  apart: {k} {ratios[k]:.2f}: {why}", flush=True)
                print("  all: " + ", ".join(f"{k} {r:.2f}" for k, r in ratios.items()), flush=True)
    seeds = " ".join(map(str, args.seeds))
    print(
        f"\n| base | profile | post/prior sd > 0.5, seeds {seeds} (of them mass-gain) | "
        "counted apart (no command within the limits identifies them) |"
    )
    print("|---|---|---|---|")
    for (robot, profile), n in counts.items():
        shown = ", ".join(f"{c} ({m})" for c, m, _ in n)
        print(f"| {robot} | {profile} | {shown} | {', '.join(str(a) for *_, a in n)} |")


if __name__ == "__main__":
    main()
