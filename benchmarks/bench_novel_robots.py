"""The whole user path on robots nobody here has seen: from a spec to band coverage.

Run: ``.venv/bin/python benchmarks/bench_novel_robots.py [--quick] [--robots neato,p3dx]
[--seed 8] [--no-mass] [--keep DIR]``, then ``python results_page.py`` (from ``benchmarks/``)
to put its figures on ``docs/benchmarks.md``.

For each base in :data:`BASES` only a few published numbers go in, through the user's path:

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
5. for two bases (:data:`MASS_BASES`), plants of 0.5x and 3x the spec's mass (and yaw inertia),
   fitted with the spec (fit on 0-2, calibrate on 3, agree on 4-5): the mass prior must hold
   the fitted mass near the spec's when the logs cannot see mass.

Every CLI command runs in process (:func:`sim2real.cli.main`); a non-zero exit, a crash, a
warning or an error line, a held-out session's coverage outside 80-99 % and a pybullet-reduced
agreement below 99 % are printed as PROBLEM under the base's row. ``--quick`` runs 40 s
sessions and calibrates with 16 robots (the product default is 32): about 1 min CPU; the full
run uses 90 s sessions (about 2.5 min CPU). Coverage follows the fleet drawn (a band calibrated
on two sessions): compare seeds, not single runs.

Columns: ``fit s`` / ``cal s`` CPU; agreement, coverage and widths on the held-out sessions
(5-7, or 4-5 for the mass variants), pooled over active samples; ``plant kg`` the mean mass of
the fitted sessions, ``mass fit/plant`` the fitted total mass over it.
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
from _timing import record

N_SESSIONS = 8
FIT, CAL, VAL = (0, 1, 2), (3, 4), (5, 6, 7)


@dataclass(frozen=True)
class Base:
    """A base from published numbers: the ``robots new`` options and where they come from."""

    name: str
    options: str
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
    Base("neato", "--wheel-separation 0.248 --max-speed 0.3"),
    Base("pimouse", "--wheel-separation 0.09 --wheel-radius 0.024 --mass 0.6"),
    Base("create2", "--wheel-separation 0.235 --wheel-radius 0.036 --mass 3.5 --max-speed 0.5"),
    Base("p3dx", "--wheel-separation 0.33 --wheel-radius 0.0975 --mass 9 --max-speed 1.2"),
    Base("heavy60", "--wheel-separation 0.5 --wheel-radius 0.1 --mass 60 --max-speed 1.0"),
    Base(
        "jackal",
        "--wheel-separation 0.37559 --wheel-radius 0.098 --mass 17 --max-speed 2.0 "
        "--max-turn-rate 4.0 --footprint-radius 0.26 --drive skid --driver-track-factor 1.5",
        skid=True,
    ),
)
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
    """A Jackal-like skid plant from the published numbers above (the rest as husky_like).

    Husky's wheel-side inertia and speed-loop gains are scaled by the mass ratio and the square
    of the wheel-radius ratio, its stall torque by the mass and the radius ratio.
    """
    from sim2real.plants.skid import _slip_lat_for, husky_like

    husky = husky_like()
    m, length, width, radius = 17.0, 0.42, 0.31, 0.098
    by_mass, by_radius = m / husky.mass_kg, radius / husky.wheel_radius_m
    base = husky.replace(
        mass_kg=m,
        yaw_inertia_kgm2=m * (length**2 + width**2) / 12.0,
        wheel_radius_m=radius,
        track_m=0.37559,
        wheelbase_m=0.262,
        side_inertia_kgm2=husky.side_inertia_kgm2 * by_mass * by_radius**2,
        kp_nms_per_rad=husky.kp_nms_per_rad * by_mass * by_radius**2,
        ki_nm_per_rad=husky.ki_nm_per_rad * by_mass * by_radius**2,
        stall_torque_nm=husky.stall_torque_nm * by_mass * by_radius,
        **_JACKAL_CONTROL,
        side_speed_max_radps=_JACKAL_CONTROL["max_v_mps"] / radius,
        no_load_speed_radps=1.15 * _JACKAL_CONTROL["max_v_mps"] / radius,
    )
    # the steady in-place effective track of the driver's calibration, 1.5
    return base.replace(slip_lat_mps=_slip_lat_for(base, 1.5))


#: jackal_control/config/control.yaml (see the sources above).
_JACKAL_CONTROL = {
    "separation_multiplier": 1.5,
    "max_v_mps": 2.0,
    "max_w_radps": 4.0,
    "accel_v_mps2": 20.0,
    "accel_w_radps2": 25.0,
}


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
    argv = ["robots", "new", base.name, "-o", str(spec_path), *base.options.split()]
    if cli(argv, row, "robots new") != 0:
        return None
    if base.skid:  # the skid plant's yaw rate is a gyro's, as a user edits the spec to say
        spec_path.write_text(spec_path.read_text().replace("w_source: wheels", "w_source: imu"))
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


def record_row(row: Row, seed: int) -> None:
    """A base's held-out coverage, agreement and pybullet-reduced match for
    ``docs/benchmarks.md``."""
    value = (
        f"cov v {fmt(row.cov_v)} / w {fmt(row.cov_w)} %; agreement {fmt(row.agr)} % (spec "
        f"{fmt(row.spec_agr)} %); pb~red {fmt(row.pb_vs_red)} %; mass fit/plant "
        f"{fmt(row.mass_ratio, 1, '.2f')}"
    )
    met = 0.80 <= row.cov_v <= 0.99 and 0.80 <= row.cov_w <= 0.99 and not row.problems
    record("novel robots", f"{row.name}, seed {seed}: held-out 90 % band", value, "80-99 %", met)


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
        record_row(row, args.seed)
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
            record_row(mrow, args.seed + 1)
    print(f"CPU {time.process_time() - start:.0f} s, wall {time.perf_counter() - wall:.0f} s")


if __name__ == "__main__":
    main()
