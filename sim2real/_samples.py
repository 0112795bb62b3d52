"""Generator of the bundled sample logs in ``data/`` (private): two sessions of a foreign plant.

``python -m sim2real._samples data`` (``make data``) regenerates ``data/demo_train.mcap`` and
``data/demo_validate.mcap``. They are two sessions of one TurtleBot3-Burger-sized base
simulated by :mod:`sim2real.plants.diff_drive`, a plant that is deliberately *not* the project's drive
model (PI wheel loops with anti-windup, a DC-motor torque-speed line with battery sag,
per-wheel asymmetric friction, caster scrub, quantised encoders, a gyro, latency jitter):

- the base is :func:`sim2real.plants.diff_drive.plant_from_spec` of ``turtlebot3_burger``;
- each session draws its payload, floor friction, battery charge and command latency from
  :data:`DEMO_VARIATION` (one afternoon's variation: a battery running down, a small payload
  added, the floor changing between rooms) with its own seed;
- the training session is driven by the ``mixed`` excitation profile (steps, ramps, arcs,
  reversals, in-place turns, teleop holds), the validation session by ``goals`` (go-to-goal
  legs) — a different kind of driving;
- commands (``/cmd_vel`` Twist) at 10 Hz as published; odometry (``/odom``) at the spec's
  30 Hz, v from 4096-tick encoders, w from the gyro (the spec's odometry sources), stamps
  jittered by 1 ms, 1 % of the messages lost.

Everything random comes from ``numpy.random.default_rng([seed, 0])`` per session, so the
files are byte-for-byte reproducible for a given numpy version.

Examples
--------
>>> from sim2real._samples import build_sample
>>> run = build_sample("validate")
>>> run.params.robot, round(float(run.tick_t_s[-1]))
('turtlebot3_burger', 120)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from sim2real.logs import write_trace
from sim2real.plants.diff_drive import (
    PlantParams,
    PlantRun,
    SessionVariation,
    command_profile,
    draw_session,
    plant_from_spec,
    run_plant,
    run_to_trace,
)

__all__ = [
    "DEMO_VARIATION",
    "ROBOT",
    "SAMPLE_FILES",
    "build_sample",
    "main",
    "sample_base",
    "write_samples",
]

#: The robot the sample logs are for.
ROBOT = "turtlebot3_burger"

#: Session variation of the demo's two sessions (see :class:`sim2real.plants.diff_drive.SessionVariation`).
DEMO_VARIATION = SessionVariation(
    payload_fraction=(0.0, 0.25),
    floor_friction=(0.85, 1.2),
    battery_charge=(0.94, 1.03),
    latency_s=(0.08, 0.14),
)

#: File name, seed, command profile and duration (s) of each sample log.
SAMPLE_FILES: dict[str, tuple[str, int, str, float]] = {
    "train": ("demo_train.mcap", 11, "mixed", 150.0),
    "calibrate": ("demo_calibrate.mcap", 33, "mixed", 120.0),
    "validate": ("demo_validate.mcap", 22, "goals", 120.0),
}


def sample_base() -> PlantParams:
    """The demo base before the session draws (the foreign plant of :data:`ROBOT`)."""
    return plant_from_spec(ROBOT)


def build_sample(kind: str) -> PlantRun:
    """Simulate one sample session (``kind`` is ``"train"`` or ``"validate"``)."""
    if kind not in SAMPLE_FILES:
        raise ValueError(f"sample kind must be one of {sorted(SAMPLE_FILES)}, got {kind!r}")
    _name, seed, profile, duration_s = SAMPLE_FILES[kind]
    rng = np.random.default_rng([seed, 0])
    params = draw_session(sample_base(), rng, DEMO_VARIATION)
    t, v, w = command_profile(
        profile, duration_s, rng=rng, max_v_mps=params.max_v_mps, max_w_radps=params.max_w_radps
    )
    return run_plant(params, t, v, w, duration_s=duration_s, rng=rng)


def write_samples(out_dir: str | Path) -> list[Path]:
    """Build both sample logs and write them as MCAP into ``out_dir``; returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for kind, (name, *_rest) in SAMPLE_FILES.items():
        run = build_sample(kind)
        path = write_trace(out / name, run_to_trace(run, name=name))
        p = run.params
        print(
            f"wrote {path} ({run.tick_t_s[-1]:.0f} s, {path.stat().st_size} bytes; session: "
            f"mass {p.mass_kg:.3f} kg, latency {p.latency_s:.3f} s, battery {p.battery_v:.2f} V, "
            f"Coulomb fwd {p.coulomb_fwd_n[0]:.3f}/{p.coulomb_fwd_n[1]:.3f} N)"
        )
        paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> int:
    """``python -m sim2real._samples OUT_DIR``."""
    parser = argparse.ArgumentParser(prog="python -m sim2real._samples", description=__doc__)
    parser.add_argument("out_dir", help="folder to write the sample logs into (e.g. data)")
    args = parser.parse_args(argv)
    write_samples(args.out_dir)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
