"""The skid-steer target, per seed, and how far a fit carries to another ground.

Run: ``.venv/bin/python benchmarks/bench_skid.py [--seeds 101,...,110] [--husky-seeds 0,...,4]``
(3.3 min CPU at load 2).

1. **Target** (what ``tests/sim2real/plants/test_skid_plant.py`` asserts): per seed, one robot on one
   ground (:func:`sim2real.plants.skid.skid_robot`: slip 1.5-1.9, mu 0.6-0.95), two 90 s teleop
   sessions on different days (mu +-5 %); the drive is fitted on the first and its agreement
   measured on the second (reduced engine) with three specs written from the Husky's
   published numbers and its driver's settings (multiplier 1.875): ``skid`` (``sim2real
   robots new husky --drive skid``, ``track_factor`` fitted), ``diff`` (``--drive diff``:
   geometric track, the driver's 1.875; the test's "plain differential-drive fit") and
   ``both 1`` (the skid spec with both track factors 1, a driver without the multiplier);
   ``margin`` is skid minus diff. The rows ``H<n>`` are the canonical plant,
   :func:`sim2real.plants.skid.husky_like` (defined from published figures before any
   measurement), with the sessions of command seed n.
2. **Ground sensitivity**: :func:`sim2real.plants.skid.husky_like` at mu 0.8 fitted on one
   session, measured on a session on a ground with mu x (0.8, 0.9, 1.0, 1.2).

Prints one line per seed and the CPU time.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

SENSITIVITY = (0.8, 0.9, 1.0, 1.2)


def _husky(drive_type: str = "skid") -> Any:
    from robots.spec import load_spec
    from robots.template import spec_text
    from sim2real.plants.skid import plant_odometry

    path = Path(tempfile.mkdtemp()) / f"husky_{drive_type}.yaml"
    text = spec_text(
        "husky",
        wheel_separation_m=0.555,
        wheel_radius_m=0.165,
        mass_kg=50.0,
        max_speed_mps=1.0,
        drive=drive_type,
    )
    path.write_text(text)
    spec = plant_odometry(load_spec(path))  # the plant's yaw rate is a gyro's
    drive = spec.drive.replace(
        cmd_timeout_s=0.25, accel_lim_v_mps2=3.0, accel_lim_w_radps2=6.0, driver_track_factor=1.875
    )
    return dataclasses.replace(spec, drive=drive)


def _fixed(spec: Any, **values: float) -> dict[str, Any]:
    from robots.params import Prior

    priors = dict(spec.priors)
    for name, value in values.items():
        priors[name] = Prior(name=name, nominal=value, sd=0.0, session_sd=0.0, source="spec")
    return priors


def _agreement(spec: Any, params: Any, trace: Any) -> float:
    from sim2real.agreement.figures import measure_agreement
    from sim2real.agreement.replay import replay

    sim = replay(trace, robot=spec, params=params, engine="reduced")
    return float(measure_agreement(trace, sim).agreement)


def _fit(spec: Any, trace: Any, *, plain: bool = False) -> Any:
    from sysid.fit import fit_drive

    if plain:
        base = spec.drive.replace(track_factor=1.0, driver_track_factor=1.0)
        priors = _fixed(spec, driver_track_factor=1.0, track_factor=1.0)
    else:
        # the skid spec's track factor has a prior (fitted), the diff spec's is 1 with sd 0
        base, priors = spec.drive, _fixed(spec, driver_track_factor=1.875)
    return fit_drive([trace], geometry=spec.geometry, base_params=base, priors=priors).params


def target(seeds: list[int], husky_seeds: list[int]) -> None:
    from sim2real.plants.skid import (
        effective_track_factor,
        husky_like,
        make_skid_sessions,
        skid_robot,
    )

    spec, diff_spec = _husky("skid"), _husky("diff")
    print("seed  chi   mu    skid   diff   margin  both 1  fitted chi")
    rows = [(str(s), skid_robot(s), s) for s in seeds]
    rows += [(f"H{s}", husky_like(), s) for s in husky_seeds]
    for label, robot, seed in rows:
        fit_log, held = make_skid_sessions(robot, 2, seed=seed, duration_s=90.0, profile="teleop")
        skid_params = _fit(spec, fit_log)
        skid, skid_chi = _agreement(spec, skid_params, held), skid_params.track_factor
        diff = _agreement(diff_spec, _fit(diff_spec, fit_log), held)
        both = _agreement(spec, _fit(spec, fit_log, plain=True), held)
        print(
            f"{label:>4}  {effective_track_factor(robot, 0.0, 1.0):.2f}  {robot.mu:.2f}  "
            f"{skid:.3f}  {diff:.3f}  {skid - diff:+.3f}  {both:.3f}   {skid_chi:.2f}",
            flush=True,
        )


def sensitivity(seeds: list[int]) -> None:
    from sim2real.plants.diff_drive import command_profile
    from sim2real.plants.skid import husky_like, run_skid_plant

    spec = _husky()
    base = husky_like()

    def session(mu: float, seed: int, i: int) -> Any:
        rng = np.random.default_rng([seed, i, 7])
        t, v, w = command_profile(
            "teleop", 90.0, rng=rng, max_v_mps=base.max_v_mps, max_w_radps=base.max_w_radps
        )
        return run_skid_plant(base.replace(mu=mu), t, v, w, duration_s=90.0, rng=rng)

    print("seed  agreement on a held-out ground with mu x " + " ".join(map(str, SENSITIVITY)))
    for seed in seeds:
        params = _fit(spec, session(base.mu, seed, 0))
        row = [_agreement(spec, params, session(base.mu * f, seed, 1)) for f in SENSITIVITY]
        print(f"{seed:4d}  " + "  ".join(f"{a:.3f}" for a in row), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="101,102,103,104,105,106,107,108,109,110")
    parser.add_argument("--husky-seeds", default="0,1,2,3,4", help="husky_like's session seeds")
    parser.add_argument("--ground-seeds", default="1,2,3,4", help="sensitivity seeds")
    args = parser.parse_args()
    t0 = time.process_time()
    target([int(s) for s in args.seeds.split(",")], [int(s) for s in args.husky_seeds.split(",")])
    sensitivity([int(s) for s in args.ground_seeds.split(",")])
    print(f"CPU {time.process_time() - t0:.1f} s")


if __name__ == "__main__":
    main()
