"""The whole user path on robots nobody here has seen (issues 11, 12): spec to band coverage.

Run: ``.venv/bin/python benchmarks/bench_novel_robots.py [--quick] [--robots neato,p3dx]
[--keep DIR]``.

For each base below, only a few published numbers go in, through the user's path:

1. ``sim2real robots new NAME --wheel-separation ... -o NAME.yaml`` and ``robots check``;
2. eight recording sessions of the base from a **foreign plant** (:mod:`sim2real.plants.diff_drive`,
   :func:`~sim2real.plants.diff_drive.plant_from_spec` with that spec file; for the skid base a
   Jackal-like :class:`~sim2real.plants.skid.SkidPlantParams`), payload, floor friction,
   battery charge and latency drawn per session, written as MCAP and read back;
3. ``sysid fit`` on sessions 0-2 (a fleet), ``sysid calibrate`` on 3-4, ``agree --ensemble 20
   --engine reduced`` on 5-7 (pooled 90 % band coverage of v and w, target 80-99 %), and once
   with the spec's defaults (``spec agr.``); ``agree --engine pybullet`` on session 5 and the
   pybullet replay against the reduced replay of it (``pb~red``, same tolerances, >= 0.99);
4. a plain-physics check: every params file written loads into the pybullet robot (total mass
   and yaw inertia > 0), and 200 draws of its ``randomization`` block leave the base link with
   mass and yaw inertia > 0;
5. for two bases, plants of 0.5x and 3x the spec's mass (and yaw inertia), fitted with the
   spec (fit on 0-2, calibrate on 3, agree on 4-5).

Every CLI command runs in process (:func:`sim2real.cli.main`); a non-zero exit, a crash, a
warning or an error line, a held-out session's coverage outside 80-99 % and a pybullet-reduced
agreement below 99 % are printed as PROBLEM under the base's row. ``--quick`` runs 40 s
sessions and calibrates with 16 robots (the product default is 32): about 1 min CPU; the full
run uses 90 s sessions.

Columns: ``fit s`` / ``cal s`` CPU; agreement, coverage and widths on the held-out sessions 5-7 (4-5 for
the mass variants), pooled over active samples; ``plant kg`` the mean mass of the fitted
sessions, ``mass fit/plant`` the fitted total mass over it):

Measured with friction per unit mass (2026-11-26 12:20, full run, seed 8; 148 s CPU, 151 s
wall, load 2.5 on 2 shared cores). The table further down is the same run before friction was
fitted per unit mass; a run with ``--seed 9`` of both versions is in the note after it.

| base | fit s | cal s | spec agr. % | agr. % | cov v % | cov w % | width v m/s | width w rad/s | pybullet agr. % | reduced agr. % | pb~red % | plant kg | mass fit/plant |
|---|---|---|---|---|---|---|---|---|---|---|---|---|---|
| neato | 3 | 9 | 68.1 | 87.2 | 91.0 | 93.0 | 0.009 | 0.012 | 86.1 | 86.1 | 100.0 | 4.41 | 0.82 |
| pimouse | 3 | 10 | 33.9 | 59.4 | 91.5 | 93.4 | 0.031 | 0.236 | 63.4 | 63.4 | 100.0 | 0.693 | 0.80 |
| create2 | 4 | 9 | 52.5 | 79.1 | 81.0 | 88.1 | 0.018 | 0.028 | 78.8 | 78.8 | 100.0 | 4.04 | 0.84 |
| create2 x0.5 mass | 4 | 4 | 66.9 | 92.4 | 94.8 | 93.5 | 0.006 | 0.014 | - | - | - | 2.36 | 1.39 |
| create2 x3 mass | 3 | 5 | 32.7 | 63.3 | 94.9 | 87.0 | 0.048 | 0.070 | - | - | - | 14.2 | 0.29 |
| p3dx | 3 | 9 | 45.5 | 53.5 | 76.0 | 91.4 | 0.031 | 0.027 | 50.6 | 51.5 | 94.2 | 10.4 | 0.84 |
| p3dx x0.5 mass | 3 | 5 | 59.8 | 84.0 | 96.1 | 92.8 | 0.024 | 0.018 | - | - | - | 6.07 | 1.33 |
| p3dx x3 mass | 3 | 5 | 22.8 | 43.0 | 92.8 | 90.3 | 0.081 | 0.294 | - | - | - | 36.4 | 0.28 |
| heavy60 | 3 | 9 | 60.7 | 65.8 | 76.9 | 89.1 | 0.032 | 0.012 | 68.6 | 68.6 | 100.0 | 69.3 | 0.85 |
| jackal | 22 | 11 | 8.4 | 45.5 | 92.9 | 94.6 | 0.541 | 0.254 | 44.9 | 45.2 | 88.7 | 19.1 | 0.83 |

Before (friction priors in N; 2026-11-26 morning, same seed; 148 s CPU, 194 s wall, load
average 1.5-1.8):

| base | fit s | cal s | spec agr. % | agr. % | cov v % | cov w % | width v m/s | width w rad/s | pybullet agr. % | reduced agr. % | pb~red % | plant kg | mass fit/plant |
|---|---|---|---|---|---|---|---|---|---|---|---|---|---|
| neato | 3 | 9 | 68.1 | 87.4 | 90.6 | 93.9 | 0.008 | 0.012 | 87.0 | 87.0 | 100.0 | 4.41 | 0.23 |
| pimouse | 4 | 9 | 33.9 | 59.9 | 91.9 | 94.8 | 0.025 | 0.229 | 63.8 | 63.8 | 100.0 | 0.693 | 0.54 |
| create2 | 3 | 9 | 52.5 | 80.0 | 89.2 | 90.3 | 0.015 | 0.019 | 80.2 | 80.2 | 100.0 | 4.04 | 0.38 |
| create2 x0.5 mass | 4 | 5 | 66.9 | 92.5 | 88.8 | 91.7 | 0.004 | 0.014 | - | - | - | 2.36 | 0.83 |
| create2 x3 mass | 3 | 5 | 32.7 | 63.5 | 92.4 | 89.3 | 0.054 | 0.113 | - | - | - | 14.2 | 0.29 |
| p3dx | 3 | 9 | 45.5 | 53.9 | 81.8 | 93.3 | 0.030 | 0.027 | 51.6 | 52.0 | 98.5 | 10.4 | 0.45 |
| p3dx x0.5 mass | 3 | 5 | 59.8 | 85.5 | 91.9 | 90.1 | 0.011 | 0.018 | - | - | - | 6.07 | 0.55 |
| p3dx x3 mass | 4 | 5 | 22.8 | 49.0 | 92.2 | 83.7 | 0.068 | 0.076 | - | - | - | 36.4 | 0.16 |
| heavy60 | 3 | 9 | 60.7 | 68.9 | 87.3 | 92.9 | 0.026 | 0.012 | 70.8 | 70.8 | 100.0 | 69.3 | 0.34 |
| jackal | 22 | 11 | 8.4 | 47.4 | 91.6 | 93.5 | 0.122 | 0.062 | 46.8 | 47.1 | 91.8 | 19.1 | 0.36 |

With ``--seed 9 --no-mass``, old (friction in N) vs new (per unit mass), coverage v % /
mass fit/plant: neato 87.4 / 0.32 -> 89.1 / 0.77, pimouse 90.9 / 0.58 -> 90.4 / 0.68, create2
89.6 / 0.44 -> 91.4 / 0.74, p3dx 87.8 / 0.38 -> 93.5 / 0.75, heavy60 91.4 / 0.33 -> 93.6 /
0.76, jackal 91.9 / 0.36 -> 93.4 / 0.67 (pb~red 95.8 -> 92.2 %). Seed 8's falls of create2,
p3dx and heavy60 below 80 % turn into gains on seed 9: coverage follows the fleet (a band
calibrated on two sessions), the mass follows the coordinates on every base and seed. Finding
1 below (the mass scale) is what friction per unit mass fixed; its ``plant kg`` 0.5x / 3x
variants stay near the spec's mass (1.33-1.39 / 0.28-0.29), as a mass prior must when the
logs cannot see mass.

Two more fleets, same code (2026-11-26 14:30, ``--no-mass``, about 2 min each), held-out
coverage v / w % (pb~red % where below 100, before the tyre-friction fix of finding 2; after
it, full runs at 14:40: p3dx 100.0 / 100.0 %, jackal 99.7 / 100.0 % for seeds 10 / 11, the
0.3 % a hard stop from 1 m/s that tips the base onto a caster and lifts a wheel for 7
physics steps, the same with tyre friction 100):

| base | seed 10 | seed 11 |
|---|---|---|
| neato | 88.1 / 93.6 | 87.0 / 91.5 |
| pimouse | 89.8 / 87.8 | 96.2 / 96.7 |
| create2 | 91.1 / 94.0 | 93.4 / 93.4 |
| p3dx | 90.3 / 86.8 (99.6) | 95.7 / 96.1 (95.8) |
| heavy60 | 89.3 / 90.7 | 95.2 / 93.1 |
| jackal | 93.1 / 96.9 (93.7) | not run (helper's bench) |

Over seeds 8-11, 2 of 23 base-seeds fall below 80 % (seed 8's p3dx and heavy60 in v), and
why is the fleet: seed 8's fitted sessions 0-2 had latencies of 139, 153 and 124 ms and its
validation sessions 93 and 129 ms, while held-out sessions 5 and 7 ran at 81 and 84 ms (the
plant draws 60-160 ms), about 2 sd of the fitted population below its mean. Those two
sessions are the ones under-covered on every base (p3dx v 72.2 / 68.0 %, heavy60 71.8 /
68.0 %, create2 76.4 / 74.0 %; session 6, 121 ms: 87.7, 90.7, 92.7 %), and every base's
point estimate replays them 42-70 ms late (``lag_s_v``). A 90 % band built from five sessions
cannot hold sessions two of its own standard deviations away; the between-session predictive
is already a Student-t with a prior on the spread (:mod:`sysid._fleet`).

With the calibration pooled with the fit's spread by sessions
(:func:`sim2real.agreement.calibration.pooled_factors`; 2026-11-26 17:00, seed 8 full run, seeds 10 and
11 ``--no-mass``), held-out coverage v / w % (before -> after; seed 8's before is the same
run of main's tree):

| base | seed 8 | seed 10 | seed 11 |
|---|---|---|---|
| neato | 91.0 / 93.0 -> 87.3 / 91.7 | 88.1 / 93.6 -> 85.5 / 93.8 | 87.0 / 91.5 -> 91.2 / 92.8 |
| pimouse | 91.5 / 93.4 -> 80.1 / 91.2 | 89.8 / 87.8 -> 89.5 / 87.8 | 96.2 / 96.7 -> 95.6 / 97.5 |
| create2 | 81.0 / 88.1 -> **76.9** / 87.0 | 91.1 / 94.0 -> 88.6 / 93.7 | 93.4 / 93.4 -> 89.5 / 93.4 |
| p3dx | **76.0** / 91.4 -> **76.4** / 91.8 | 90.3 / 86.8 -> 87.9 / 91.2 | 95.7 / 96.1 -> 93.3 / 95.6 |
| heavy60 | **76.9** / 89.1 -> **74.7** / 87.2 | 89.3 / 90.7 -> 89.7 / 89.7 | 95.2 / 93.1 -> 91.7 / 95.0 |
| jackal | - | 93.1 / 96.9 -> 91.2 / 96.1 | - -> 95.2 / 94.8 |

The pooling moves coverage toward the level (seeds 10-11: 85.5-95.6 % in v, from 87.0-96.2)
and costs seed 8, whose validation sessions asked for a wider spread that its latency-extreme
held-out sessions needed (3 of 6 bases below 80 % in v, was 2); on the Kobuki-sized fleets of
``bench_calibration.py`` (27 fleets, 81 sessions) it cut the sessions whose v band is wider
than 0.10 m/s from 22 to 4, and those wider than 0.35 rad/s in w from 6 to 0.

No crash, no refused spec (every ``robots new`` passed ``robots check``), every params file
loads into pybullet with mass and yaw inertia > 0, and 200 draws of every randomisation stay
physical. What it found:

1. **The fitted mass scale is not physical, and pooling sessions moves it further.** The fitted
   total mass is 0.16-0.83 of the plant's and barely follows it (create2 plants of 2.4 / 4.0 /
   14.2 kg give 2.0 / 1.5 / 4.1 kg; p3dx 6.1 / 10.4 / 36.4 kg give 3.3 / 4.7 / 6.0 kg). Motor
   gain, torque cap and friction scale with it (velocity data fix their ratios to the mass), so
   the reduced replay is right, but the fleet's population mean lies outside every session's
   estimate, on the light side, in 8 of the 10 fleets (heavy60: sessions' added mass -18.3 to
   -19.1 kg, population -38.3 kg, 3.2 prior sd from the spec; total mass with 1 / 2 / 3 / 6
   sessions 43 / 33 / 24 / 29 kg, plant ~69 kg) -- three sessions that each say "lighter"
   weakly are pooled as independent evidence by :func:`sysid._fleet.population` (a data
   estimate recovered from a weakly informed direction is amplified ~1/info). The fit's note
   "the priors keep masses and inertias near theirs" is then not what happened.
2. **pybullet departed from the reduced replay on fast bases** (fixed, issue 11): p3dx 94.2-98.5 %,
   jackal 88.7-92.2 % of samples within tolerance (max |dv| 0.25-2.3 m/s in reversals), not
   because of a light fitted mass (the same with a mass fit/plant of 0.83) but because the
   pybullet wheels spun: the fitted drives brake at up to 14 m/s^2 (p3dx: torque cap 3.96 N m
   plus a viscous drag of 3.8 /s of the mass, both carried by the tyres), which pitches the
   base onto a frictionless caster (up to 83 of its 86 N of weight; jackal 267 N against 151 N)
   and left the tyres' friction 1.5 times that load short (slip up to 2.1 m/s at the tyre in
   0.75 % of the p3dx's physics steps, 5.2 % of the jackal's; mean |dv| 0.10-0.16 m/s where
   the reduced model brakes at > 11 m/s^2, 0.0002-0.0003 below 2 m/s^2). With tyre friction
   3 / 10 on the same files: p3dx 100.0 / 100.0 %, jackal 95.2 / 100.0 %. The pybullet robot
   now gives its tyres the friction the drive can ask
   (:func:`robots.pybullet_robot.tyre_friction`: p3dx 17.9, heavy60 14.8, jackal 32.7 fitted;
   1.5 for the shipped robots and the other bases). ``--quick`` pb~red before / after, seed 8:
   neato 100.0 / 100.0, pimouse 99.5 / 99.5, create2 100.0 / 100.0, p3dx 96.6 / 100.0, heavy60
   97.8 / 100.0, jackal 85.8 / 100.0; seed 9: 100.0 / 100.0 for neato, pimouse, create2 and
   heavy60, p3dx 99.7 / 100.0, jackal 97.5 / 100.0 (2026-11-26 14:25, 63-67 s CPU each, load
   0.3-1.0); every other column unchanged (the reduced path is untouched). The pimouse's 99.5 %
   (seed 8) is not traction (the same with tyre friction 1.5, 3.3 and 10): a yaw-rate
   difference of 0.11 rad/s at 5.9 rad/s in one turn. The tables above predate the fix.
3. **Coverage**: pooled v/w 81.8-92.4 % / 83.7-94.8 %, inside 80-99 % for every base; two of
   the three held-out p3dx sessions are below (v 78.4 %, 76.1 %) after a calibration on two
   sessions. With ``--quick`` (40 s sessions, 16 calibration robots; 60 s CPU) pooled v falls
   to 75.7 % (create2) and 77.4 % (heavy60): shorter sessions are not enough for the band.
4. **Agreement's absolute tolerances (0.02 m/s, 0.1 rad/s) judge fast bases harder**: FIT %
   80-94 on every held-out session, but agreement 47 % on the 2 m/s jackal, 54 % on the 1.2
   m/s p3dx and 60 % on the Pi Mouse (its w: 2 v_max / b = 13 rad/s top yaw rate) against
   87 % on the 0.3 m/s Neato.
5. Fixed here: ``agree`` with several logs and ``--ensemble`` printed no coverage at all (it
   reached only ``--json``, as ``coverage_mean``); it now prints cov. v / cov. w per log and
   pooled, and the band verdict on the pooled coverage.

Also probed by hand on the same files (not in this loop): the calibrated params on held-out
sessions of other command profiles (``teleop``, ``goals``, ``steps``; 3 x 90 s each) cover v
89.4-96.6 % and w 89.5-94.3 % for neato, create2, p3dx and heavy60; the jackal sessions
written as ROS 1 bag and rosbag2 (sqlite3, mcap) fit to the same numbers as the MCAP files;
the pybullet ensemble's coverage is within 2 points of the reduced one (p3dx v 78.1 / 78.4 %,
jackal v 91.5 / 93.4 %). Two more problems: ``agree`` refuses a spin-in-place log (profile
``turns``, v = 0 throughout: "figure 'lag_s_v' cannot be computed ... compare on a log in
which the robot drives and turns"), which ``sysid fit`` accepts, and one such log among
several aborts the whole multi-log ``agree`` with no row printed for the others; and
calibrating on one 60 s session of a far-out base (``robots new d --wheel-separation 0.05
--mass 0.05``: dynamics factor x0.34) leaves a held-out session's w coverage at 50.5 % (a
500 kg base: v 73.2 %, w 73.7 %).

Reproduction of 1 and 2 (a minute)::

    sim2real robots new heavy60 --wheel-separation 0.5 --wheel-radius 0.1 --mass 60 \
        --max-speed 1.0 -o heavy60.yaml
    python -c "from sim2real.plants.diff_drive import write_fleet, plant_from_spec; \
        write_fleet('.', plant_from_spec('heavy60.yaml'), 3, seed=8)"
    sim2real sysid fit session_0.mcap session_1.mcap session_2.mcap --robot heavy60.yaml \
        -o p.yaml      # added_mass_kg -38.3 (population) vs -18.5, -18.3, -19.1 (sessions)
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

N_SESSIONS = 8
FIT, CAL, VAL = (0, 1, 2), (3, 4), (5, 6, 7)


@dataclass(frozen=True)
class Base:
    """A base from published numbers: the ``robots new`` options and where they come from."""

    name: str
    options: tuple[str, ...]
    skid: bool = False


# Sources of the numbers (the only facts given to `robots new`):
# - Neato Botvac D-series: wheel separation 0.248 m, top speed 0.3 m/s (the numbers of the
#   `robots new` help example, from the neato_robot ROS driver's BASE_WIDTH 248 mm and
#   MAX_SPEED 300 mm/s).
# - Raspberry Pi Mouse (RT Corporation): tread ~0.09 m, wheel diameter 48 mm, ~0.6 kg
#   (the maker's product page; raspimouse_description).
# - iRobot Create 2: Open Interface spec -- wheel base 235 mm, wheel diameter 72 mm, top
#   speed 500 mm/s; ~3.5 kg (iRobot Create 2 manual).
# - Pioneer 3-DX (Adept MobileRobots datasheet): swing 0.33 m, wheel diameter 195 mm, 9 kg,
#   top speed 1.2 m/s.
# - heavy60: a 60 kg differential-drive base (no maker): separation 0.5 m, wheel radius 0.1 m,
#   top speed 1.0 m/s -- the heavy end of indoor AMRs.
# - jackal: Clearpath Jackal -- jackal_description/urdf/jackal.urdf.xacro: track 0.37559 m,
#   wheelbase 0.262 m, wheel radius 0.098 m, chassis 16.523 kg + 4 x 0.477 kg wheels (~18.4
#   kg; the brief's 17 kg is the maker's page figure, used here), chassis 0.42 x 0.31 m;
#   jackal_control/config/control.yaml: 2.0 m/s, 4.0 rad/s, 20 m/s^2, 25 rad/s^2,
#   cmd_vel_timeout 0.25 s, wheel_separation_multiplier 1.5.
BASES = (
    Base("neato", ("--wheel-separation", "0.248", "--max-speed", "0.3")),
    Base("pimouse", ("--wheel-separation", "0.09", "--wheel-radius", "0.024", "--mass", "0.6")),
    Base(
        "create2",
        (
            "--wheel-separation", "0.235", "--wheel-radius", "0.036", "--mass", "3.5",
            "--max-speed", "0.5",
        ),
    ),
    Base(
        "p3dx",
        (
            "--wheel-separation", "0.33", "--wheel-radius", "0.0975", "--mass", "9",
            "--max-speed", "1.2",
        ),
    ),
    Base(
        "heavy60",
        (
            "--wheel-separation", "0.5", "--wheel-radius", "0.1", "--mass", "60",
            "--max-speed", "1.0",
        ),
    ),
    Base(
        "jackal",
        (
            "--wheel-separation", "0.37559", "--wheel-radius", "0.098", "--mass", "17",
            "--max-speed", "2.0", "--max-turn-rate", "4.0", "--footprint-radius", "0.26",
            "--drive", "skid", "--driver-track-factor", "1.5",
        ),
        skid=True,
    ),
)  # fmt: skip
#: Bases that also get plants of 0.5x and 3x the spec's mass.
MASS_BASES = ("create2", "p3dx")


@dataclass
class Row:
    """What one base (or one mass variant) gave."""

    name: str
    fit_s: float = math.nan
    spec_agr: float = math.nan
    agr: float = math.nan
    cov_v: float = math.nan
    cov_w: float = math.nan
    width_v: float = math.nan
    width_w: float = math.nan
    pb_agr: float = math.nan
    red_agr: float = math.nan
    pb_vs_red: float = math.nan
    cal_s: float = math.nan
    mass_ratio: float = math.nan
    plant_mass_kg: float = math.nan
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def cli(argv: list[str], row: Row, what: str) -> int:
    """Run ``sim2real ARGV`` in process; record a non-zero exit and warning/error lines."""
    from sim2real.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main(argv)
        except SystemExit as exc:  # argparse
            rc = int(exc.code or 0)
        except Exception as exc:  # a traceback is a finding, not the end of the bench
            rc = -1
            row.problems.append(f"{what}: CRASH {type(exc).__name__}: {exc}")
    text = out.getvalue() + err.getvalue()
    for line in text.splitlines():
        low = line.lower()
        if "warning" in low or "error" in low:
            row.notes.append(f"{what}: {line.strip()[:300]}")
    if rc not in (0,):
        row.problems.append(f"{what}: exit {rc}: {err.getvalue().strip()[-400:]}")
    return rc


# --- plants ----------------------------------------------------------------------------------


def jackal_plant() -> Any:
    """A Jackal-like skid plant from the published numbers above (the rest as husky_like)."""
    from sim2real.plants.skid import _slip_lat_for, husky_like

    m, length, width = 17.0, 0.42, 0.31
    base = husky_like().replace(
        mass_kg=m,
        yaw_inertia_kgm2=m * (length**2 + width**2) / 12.0,
        wheel_radius_m=0.098,
        track_m=0.37559,
        wheelbase_m=0.262,
        side_inertia_kgm2=0.4 * (17.0 / 50.0) * (0.098 / 0.165) ** 2,  # husky's, scaled
        separation_multiplier=1.5,
        max_v_mps=2.0,
        max_w_radps=4.0,
        accel_v_mps2=20.0,
        accel_w_radps2=25.0,
        side_speed_max_radps=2.0 / 0.098,
        kp_nms_per_rad=20.0 * (17.0 / 50.0) * (0.098 / 0.165) ** 2,
        ki_nm_per_rad=50.0 * (17.0 / 50.0) * (0.098 / 0.165) ** 2,
        stall_torque_nm=80.0 * (17.0 / 50.0) * (0.098 / 0.165),
        no_load_speed_radps=1.15 * 2.0 / 0.098,
    )
    # the steady in-place effective track of the driver's calibration, 1.5
    return base.replace(slip_lat_mps=_slip_lat_for(base, 1.5))


def skid_sessions(n: int, *, seed: int, duration_s: float) -> tuple[list[Any], list[float]]:
    """Sessions of :func:`jackal_plant`: payload, ground, battery (motor line) and latency drawn
    per session with the ranges of :class:`sim2real.plants.diff_drive.SessionVariation`."""
    from sim2real.plants.diff_drive import SessionVariation, command_profile
    from sim2real.plants.skid import run_skid_plant

    base, var = jackal_plant(), SessionVariation()
    out, masses = [], []
    for i in range(n):
        rng = np.random.default_rng([seed, i])
        payload = rng.uniform(*var.payload_fraction) * base.mass_kg
        mu = base.mu * rng.uniform(0.85, 1.15)  # same kind of ground, another day
        charge = rng.uniform(*var.battery_charge)
        latency = rng.uniform(*var.latency_s)
        p = base.replace(
            mass_kg=base.mass_kg + payload,
            yaw_inertia_kgm2=base.yaw_inertia_kgm2 + payload * 0.1**2,
            mu=mu,
            stall_torque_nm=base.stall_torque_nm * charge,
            no_load_speed_radps=base.no_load_speed_radps * charge,
            latency_s=latency,
        )
        t, v, w = command_profile(
            "mixed", duration_s, rng=rng, max_v_mps=p.max_v_mps, max_w_radps=p.max_w_radps
        )
        out.append(run_skid_plant(p, t, v, w, duration_s=duration_s, rng=rng, name=f"s{i}"))
        masses.append(p.mass_kg)
    return out, masses


def plant_masses(base: Any, n: int, *, seed: int) -> list[float]:
    """The mass of each session of ``make_fleet(base, n, seed=seed)`` (its first draw)."""
    from sim2real.plants.diff_drive import draw_session

    return [draw_session(base, np.random.default_rng([seed, i])).mass_kg for i in range(n)]


def write_sessions(folder: Path, traces: list[Any], row: Row) -> list[Path]:
    """Write MCAP, read back, check the round trip."""
    from sim2real.logs import read_trace, write_trace

    paths = []
    for i, tr in enumerate(traces):
        path = write_trace(folder / f"session_{i}.mcap", tr)
        back = read_trace(path)
        if back.meas_t_ns.size != tr.meas_t_ns.size or not np.allclose(
            back.meas_v, tr.meas_v, atol=1e-9
        ):
            row.problems.append(f"session_{i}: MCAP round trip changed the measurements")
        paths.append(path)
    return paths


# --- checks ----------------------------------------------------------------------------------


def physics_check(spec_path: Path, params_path: Path, row: Row, what: str) -> None:
    """The params file loads into pybullet (mass, yaw inertia > 0); its draws stay physical."""
    import pybullet as p

    from robots.pybullet_robot import PybulletRobot
    from robots.spec import load_spec, lumped_base_inertia, lumped_base_mass_kg
    from sysid.result import SysidResult

    spec = load_spec(spec_path)
    result = SysidResult.load(params_path)
    try:
        with PybulletRobot(spec, params=result.params) as robot:
            c, body = robot.client, robot.body_id
            masses = [
                p.getDynamicsInfo(body, j, physicsClientId=c)[0]
                for j in range(-1, p.getNumJoints(body, physicsClientId=c))
            ]
            izz = p.getDynamicsInfo(body, -1, physicsClientId=c)[2][2]
            if not (sum(masses) > 0 and izz > 0):
                row.problems.append(f"{what}: pybullet mass {sum(masses)} / izz {izz}")
    except Exception as exc:
        row.problems.append(f"{what}: pybullet refused the params: {type(exc).__name__}: {exc}")
    dist = result.randomization
    if dist is None:
        row.problems.append(f"{what}: no randomization block")
        return
    draws = dist.sample(np.random.default_rng(0), 200)
    m0, izz0 = lumped_base_mass_kg(spec), lumped_base_inertia(spec)[2]
    bad = [d for d in draws if m0 + d.added_mass_kg <= 0 or izz0 + d.added_yaw_inertia_kgm2 <= 0]
    if bad:
        row.problems.append(
            f"{what}: {len(bad)}/200 draws leave the base link with mass or yaw inertia <= 0"
        )
    fit = result.params
    if what != "params.yaml":
        return  # the calibration keeps the point estimate
    row.mass_ratio = (spec.geometry.mass_kg + fit.added_mass_kg) / row.plant_mass_kg
    row.notes.append(
        f"{what}: delay {fit.delay_s:.3f} s, added mass {fit.added_mass_kg:+.3g} kg "
        f"(spec {spec.geometry.mass_kg:.3g}), added izz {fit.added_yaw_inertia_kgm2:+.3g}"
    )


def pybullet_vs_reduced(spec_path: Path, params_path: Path, log: Path) -> float:
    """Share of active samples where the pybullet and reduced replays agree (default tols)."""
    from robots.spec import load_spec
    from sim2real.agreement.figures import DEFAULT_TOL_V, DEFAULT_TOL_W
    from sim2real.agreement.replay import replay
    from sim2real.logs import read_trace
    from sysid.result import SysidResult

    spec = load_spec(spec_path)
    params = SysidResult.load(params_path).params
    trace = read_trace(log)
    window = spec.odometry.v_window_s
    red = replay(trace, robot=spec, params=params, engine="reduced", odom_v_window_s=window)
    pb = replay(trace, robot=spec, params=params, engine="pybullet", odom_v_window_s=window)
    ok = (np.abs(red.v - pb.v) <= DEFAULT_TOL_V) & (np.abs(red.w - pb.w) <= DEFAULT_TOL_W)
    moving = (np.abs(red.v) > 1e-3) | (np.abs(red.w) > 1e-2) | (np.abs(pb.v) > 1e-3)
    return float(np.mean(ok[moving])) if moving.any() else math.nan


def pooled(figures: list[dict[str, Any]], key: str) -> float:
    n = [int(f.get("n_active") or 0) for f in figures]
    vals = [(float(f[key]), k) for f, k in zip(figures, n, strict=True) if f.get(key) is not None]
    total = sum(k for _, k in vals)
    return sum(v * k for v, k in vals) / total if total else math.nan


def median_of(figures: list[dict[str, Any]], key: str) -> float:
    vals = [float(f[key]) for f in figures if f.get(key) is not None]
    return float(np.median(vals)) if vals else math.nan


# --- one base --------------------------------------------------------------------------------


def run_base(
    row: Row,
    spec_path: Path,
    logs: list[Path],
    folder: Path,
    *,
    fit: tuple[int, ...],
    cal: tuple[int, ...],
    val: tuple[int, ...],
    cal_ensemble: int,
    pybullet: bool,
) -> None:
    """fit -> calibrate -> agree (ensemble) -> pybullet checks, all through the CLI."""
    spec = str(spec_path)
    params, calibrated = folder / "params.yaml", folder / "calibrated.yaml"
    t0 = time.process_time()
    rc = cli(
        ["sysid", "fit", *[str(logs[i]) for i in fit], "--robot", spec, "-o", str(params)],
        row,
        "sysid fit",
    )
    row.fit_s = time.process_time() - t0
    if rc != 0:
        return
    physics_check(spec_path, params, row, "params.yaml")
    t0 = time.process_time()
    cal_argv = ["sysid", "calibrate", str(params), *[str(logs[i]) for i in cal]]
    cal_argv += ["--robot", spec, "-o", str(calibrated), "--ensemble", str(cal_ensemble)]
    rc = cli(cal_argv, row, "sysid calibrate")
    row.cal_s = time.process_time() - t0
    if rc != 0:
        return
    physics_check(spec_path, calibrated, row, "calibrated.yaml")
    vals = [str(logs[i]) for i in val]
    spec_json = folder / "agree_spec.json"
    agree = ["agree", *vals, "--robot", spec, "--engine", "reduced"]
    if cli([*agree, "--json", str(spec_json)], row, "agree (spec)") == 0:
        row.spec_agr = json.loads(spec_json.read_text())["summary"]["agreement"]
    band_json = folder / "agree_band.json"
    argv = [*agree, "--params", str(calibrated), "--ensemble", "20", "--json", str(band_json)]
    if cli(argv, row, "agree --ensemble 20") == 0:
        doc = json.loads(band_json.read_text())
        figs = doc["logs"]
        row.agr = doc["summary"]["agreement"]
        row.cov_v, row.cov_w = pooled(figs, "coverage_v"), pooled(figs, "coverage_w")
        row.width_v = median_of(figs, "band_width_v_mps")
        row.width_w = median_of(figs, "band_width_w_radps")
        for f in figs:
            for key in ("coverage_v", "coverage_w"):
                c = f.get(key)
                if c is not None and not 0.8 <= c <= 0.99:
                    row.problems.append(f"{Path(f['log_file']).name}: {key} {100 * c:.1f} %")
    if not pybullet:
        return
    one = str(logs[val[0]])
    for engine in ("pybullet", "reduced"):
        out = folder / f"agree_{engine}.json"
        argv = ["agree", one, "--robot", spec, "--params", str(calibrated)]
        if cli([*argv, "--engine", engine, "--json", str(out)], row, f"agree {engine}") == 0:
            value = json.loads(out.read_text())["agreement"]
            if engine == "pybullet":
                row.pb_agr = value
            else:
                row.red_agr = value
    try:
        row.pb_vs_red = pybullet_vs_reduced(spec_path, calibrated, logs[val[0]])
    except Exception as exc:
        row.problems.append(f"pybullet vs reduced: {type(exc).__name__}: {exc}")
    if not row.pb_vs_red >= 0.99:
        row.problems.append(f"pybullet vs reduced replay agree on {100 * row.pb_vs_red:.1f} %")


def new_spec(base: Base, folder: Path, row: Row) -> Path | None:
    spec_path = folder / f"{base.name}.yaml"
    argv = ["robots", "new", base.name, "-o", str(spec_path), *base.options]
    if cli(argv, row, "robots new") != 0:
        return None
    cli(["robots", "check", str(spec_path)], row, "robots check")
    return spec_path


def fmt(x: float, scale: float = 100.0, spec: str = ".1f") -> str:
    return "-" if not math.isfinite(x) else format(scale * x, spec)


def print_row(row: Row) -> None:
    print(
        f"| {row.name} | {fmt(row.fit_s, 1, '.0f')} | {fmt(row.cal_s, 1, '.0f')} | "
        f"{fmt(row.spec_agr)} | {fmt(row.agr)} | {fmt(row.cov_v)} | {fmt(row.cov_w)} | "
        f"{fmt(row.width_v, 1, '.3f')} | {fmt(row.width_w, 1, '.3f')} | {fmt(row.pb_agr)} | "
        f"{fmt(row.red_agr)} | {fmt(row.pb_vs_red)} | {fmt(row.plant_mass_kg, 1, '.3g')} | "
        f"{fmt(row.mass_ratio, 1, '.2f')} |",
        flush=True,
    )
    for line in row.problems:
        print(f"    PROBLEM {line}", flush=True)
    for line in row.notes:
        print(f"    note {line}", flush=True)


HEADER = (
    "| base | fit s | cal s | spec agr. % | agr. % | cov v % | cov w % | width v m/s | "
    "width w rad/s | pybullet agr. % | reduced agr. % | pb~red % | plant kg | mass fit/plant |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="40 s sessions, calibrate with 16")
    ap.add_argument("--robots", default="", help="comma-separated subset of the bases")
    ap.add_argument("--no-mass", action="store_true", help="skip the 0.5x / 3x mass plants")
    ap.add_argument("--keep", default="", help="keep the files in this folder")
    ap.add_argument("--seed", type=int, default=8)
    args = ap.parse_args()
    from sim2real.plants.diff_drive import make_fleet, plant_from_spec

    duration = 40.0 if args.quick else 90.0
    cal_ensemble = 16 if args.quick else 32
    chosen = [b for b in BASES if not args.robots or b.name in args.robots.split(",")]
    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="novel_"))
    root.mkdir(parents=True, exist_ok=True)
    start, wall = time.process_time(), time.perf_counter()
    print(f"{len(chosen)} bases, {duration:.0f} s sessions, files in {root}")
    print(HEADER)
    for base in chosen:
        folder = root / base.name
        folder.mkdir(exist_ok=True)
        row = Row(base.name)
        spec_path = new_spec(base, folder, row)
        if spec_path is None:
            print_row(row)
            continue
        if base.skid:
            traces, masses = skid_sessions(N_SESSIONS, seed=args.seed, duration_s=duration)
        else:
            plant = plant_from_spec(str(spec_path))
            traces = make_fleet(plant, N_SESSIONS, seed=args.seed, duration_s=duration)
            masses = plant_masses(plant, N_SESSIONS, seed=args.seed)
        row.plant_mass_kg = float(np.mean([masses[i] for i in FIT]))
        logs = write_sessions(folder, traces, row)
        run_base(
            row, spec_path, logs, folder, fit=FIT, cal=CAL, val=VAL,
            cal_ensemble=cal_ensemble, pybullet=True,
        )  # fmt: skip
        print_row(row)
        if args.no_mass or base.name not in MASS_BASES:
            continue
        for factor in (0.5, 3.0):
            name = f"{base.name} x{factor:g} mass"
            sub = folder / f"mass_{factor:g}"
            sub.mkdir(exist_ok=True)
            mrow = Row(name)
            plant = plant_from_spec(str(spec_path))
            plant = plant.replace(
                mass_kg=factor * plant.mass_kg, yaw_inertia_kgm2=factor * plant.yaw_inertia_kgm2
            )
            traces = make_fleet(plant, 6, seed=args.seed + 1, duration_s=duration)
            mrow.plant_mass_kg = float(np.mean(plant_masses(plant, 3, seed=args.seed + 1)))
            logs = write_sessions(sub, traces, mrow)
            run_base(
                mrow, spec_path, logs, sub, fit=(0, 1, 2), cal=(3,), val=(4, 5),
                cal_ensemble=cal_ensemble, pybullet=False,
            )  # fmt: skip
            print_row(mrow)
    print(f"CPU {time.process_time() - start:.0f} s, wall {time.perf_counter() - wall:.0f} s")


if __name__ == "__main__":
    main()
