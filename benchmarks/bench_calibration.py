"""Does the calibrated band contain the robot, on sessions no step has seen?

Run: ``.venv/bin/python benchmarks/bench_calibration.py [--sessions 8] [--pybullet-n 20]
[--variants] [--seeds 11] [--ti-seeds 23] [--burger-seeds 5] [--no-real]`` (about 5 minutes
on one core per fleet; the pybullet replays dominate). ``make bench`` runs it with defaults.

Data (built here, written as ROS 2 MCAP and read back):

1. A fleet of recording sessions of one Kobuki-sized base (``turtlebot2``) from the foreign
   plant :mod:`sim2real.plants.diff_drive` (PI wheel loops, DC-motor torque-speed line with
   battery sag, per-wheel asymmetric friction, caster scrub, quantised encoders, gyro,
   latency jitter), whose payload, floor friction, battery charge and latency differ per
   session. It is *not* the project's drive model. Sessions 0-2 are fitted (``sysid fit``,
   fleet / random effects, the spec's priors), sessions 3-4 calibrate the band's spread
   (``sysid calibrate``), sessions 5.. are checked.
2. The shared real TurtleBot3 Waffle Pi log (``../shared/realdata/tb3wp_drexel_goal.mcap``,
   skipped when absent) in halves: the first half is fitted, the band is built on the second
   (uncalibrated: one log leaves nothing to calibrate on without touching the checked half).
3. With ``--variants``, plants the drive model was not tuned on: the same base with a faster PI
   loop (integral time 0.05 s instead of 0.1 s) and a fleet of ``turtlebot3_burger`` (gyro w,
   no smoother). ``--seeds``, ``--ti-seeds`` and ``--burger-seeds`` (``11``, ``31-36``,
   ``11,23``) run more fleets.

Measured on every checked session, in both engines (reduced and pybullet): coverage of the
90 % band for v and w (share of active samples inside), median band widths, the point
estimate's agreement, the agreement with only the delay changed to the session's own best
(what a point estimate misses is the unseen session's latency, which no fit of other sessions
can know), and the agreement of pybullet with the reduced model on the same parameters.
Targets: coverage 80-99 %, widths <= 0.10 m/s and <= 0.35 rad/s, point agreement >= 0.90,
pybullet vs reduced >= 0.99. The uncalibrated band of the fit (``fit``) is printed beside the
calibrated one as the same run's baseline; a table of every checked session and the coverage
pooled over each fleet's checked sessions close the output, and the pooled coverage, the
widest bands and the point agreement go to ``docs/benchmarks.md``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from _timing import record

ROBOT = "turtlebot2"
FIT, CAL = (0, 1, 2), (3, 4)
#: Rows of the closing table: (fleet, session, engine, band, point agreement, cov v, cov w,
#: width v, width w).
TABLE: list[tuple[Any, ...]] = []
REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"


def _row(label: str, ens: Any, point: Any) -> str:
    return (
        f"{label:<28} cov v {100 * ens.coverage_v:5.1f} %  cov w {100 * ens.coverage_w:5.1f} %"
        f"  width v {ens.band_width_v_mps:.4f} m/s  width w {ens.band_width_w_radps:.3f} rad/s"
        f"  point agreement {100 * point.agreement:5.1f} % (v {100 * point.agreement_v:.1f}"
        f", w {100 * point.agreement_w:.1f})"
    )


def _check(trace: Any, spec: Any, dist: Any, engine: str, n: int, window_s: float) -> Any:
    from sim2real.agreement.figures import measure_agreement, run_ensemble
    from sim2real.agreement.replay import replay

    ens = run_ensemble(
        trace, robot=spec, distribution=dist, n=n, seed=0, engine=engine, odom_v_window_s=window_s
    )
    sim = replay(
        trace, robot=spec, params=dist.mean_params(), engine=engine, odom_v_window_s=window_s
    )
    return ens, sim, measure_agreement(trace, sim)


#: Per checked session: (fleet, point agreement, agreement with the session's best delay).
POINT: list[tuple[str, float, float]] = []


def _best_delay_agreement(
    trace: Any, spec: Any, params: Any, window_s: float
) -> tuple[float, float]:
    """Point agreement with only the delay changed to the session's best (-80..+80 ms, 10 ms
    steps): what the point estimate would reach had it known this session's latency."""
    from sim2real.agreement.figures import measure_agreement
    from sim2real.agreement.replay import replay

    scores = []
    for shift in np.arange(-0.08, 0.0801, 0.01):
        p = params.replace(delay_s=max(params.delay_s + float(shift), 0.0))
        sim = replay(trace, robot=spec, params=p, engine="reduced", odom_v_window_s=window_s)
        scores.append((measure_agreement(trace, sim).agreement, float(shift)))
    return max(scores)


#: Pooled held-out counts per (fleet, engine, band): [active samples, inside v, inside w].
POOLED: dict[tuple[str, str, str], list[int]] = {}


def _table_row(fleet_name: str, i: int, engine: str, band: str, ens: Any, point: Any) -> None:
    TABLE.append(
        (fleet_name, i, engine, band, point.agreement, ens.coverage_v, ens.coverage_w,
         ens.band_width_v_mps, ens.band_width_w_radps)
    )  # fmt: skip
    n = int(np.count_nonzero(ens.active))
    counts = POOLED.setdefault((fleet_name, engine, band), [0, 0, 0])
    counts[0] += n
    counts[1] += round(ens.coverage_v * n)
    counts[2] += round(ens.coverage_w * n)


@dataclass(frozen=True, kw_only=True)
class Fleet:
    """A fleet of plant sessions: the robot, the seed of its sessions and, for the variant of a
    faster PI loop, the integral time of its wheel loops, s (None: the spec's)."""

    robot: str = ROBOT
    seed: int = 11
    integral_time_s: float | None = None

    @property
    def name(self) -> str:
        """The fleet's label in the output, e.g. ``turtlebot2 seed 23, T_i 0.05 s``."""
        loop = "" if self.integral_time_s is None else f", T_i {self.integral_time_s:g} s"
        return f"{self.robot} seed {self.seed}{loop}"


def fleet(run: Fleet, n_sessions: int, n_reduced: int, n_pybullet: int, folder: Path) -> None:
    from robots.randomization import DriveDistribution
    from robots.spec import load_spec
    from sim2real.agreement.calibration import calibrate, write_calibrated
    from sim2real.agreement.figures import agreement_from_arrays, band_verdict
    from sim2real.logs import read_trace
    from sim2real.plants.diff_drive import plant_from_spec, write_fleet
    from sysid import fit_drive

    robot, name = run.robot, run.name
    spec = load_spec(robot)
    window = spec.odometry.v_window_s
    plant: Any = robot
    if run.integral_time_s is not None:
        base = plant_from_spec(robot)
        plant = base.replace(ki_nm_per_rad=base.kp_nms_per_rad / run.integral_time_s)
    paths = write_fleet(folder, plant, n_sessions, seed=run.seed, duration_s=90.0)
    traces = [read_trace(p) for p in paths]
    t = time.perf_counter()
    result = fit_drive(
        [traces[i] for i in FIT],
        geometry=spec.geometry,
        base_params=spec.drive,
        priors=spec.priors,
        robot=spec.name,
        odom_v_window_s=window,
    )
    fit_s = time.perf_counter() - t
    params = folder / "params.yaml"
    result.save(params)
    t = time.perf_counter()
    cal = calibrate(params, [paths[i] for i in CAL], robot=robot, n=24, seed=0)
    cal_s = time.perf_counter() - t
    calibrated = write_calibrated(params, folder / "calibrated.yaml", cal)
    print(f"fleet {name}: {n_sessions} sessions x 90 s of {robot} (foreign plant)")
    p = result.params
    print(
        f"  fitted population mean: delay {p.delay_s:.3f} s, k_i {p.speed_loop_ki_per_s:.2f} /s, "
        f"total mass {p.total_mass_kg(spec.geometry):.2f} kg"
    )
    print(f"  fit on sessions {FIT}: {fit_s:.1f} s; calibrate on {CAL}: {cal_s:.1f} s")
    print(
        f"  calibration: dynamics factor a = {cal.dynamics_factor:.3f}, session factor b = "
        f"{cal.session_factor:.3f}, noise v {cal.noise_std_v_mps:.4f} m/s, w "
        f"{cal.noise_std_w_radps:.4f} rad/s, log-lik/sample {cal.log_likelihood_before:.3f} -> "
        f"{cal.log_likelihood:.3f}"
    )
    fitted = DriveDistribution.from_params_file(params, robot=robot)
    dist = DriveDistribution.from_params_file(calibrated, robot=robot)
    for i in range(max(CAL) + 1, n_sessions):
        trace = traces[i]
        ens_f, _, point_f = _check(trace, spec, fitted, "reduced", n_reduced, window)
        print(_row(f"session {i} reduced, fit", ens_f, point_f))
        _table_row(name, i, "reduced", "fit", ens_f, point_f)  # the same run's baseline
        ens_r, sim_r, point_r = _check(trace, spec, dist, "reduced", n_reduced, window)
        print(_row(f"session {i} reduced, calibrated", ens_r, point_r))
        _table_row(name, i, "reduced", "calibrated", ens_r, point_r)
        best, shift_s = _best_delay_agreement(trace, spec, dist.mean_params(), window)
        POINT.append((name, point_r.agreement, best))
        print(
            f"  point agreement with this session's own best delay (fitted {shift_s:+.3f} s): "
            f"{100 * best:.1f} % (a diagnosis: no fit of other sessions can know it)"
        )
        if n_pybullet:
            ens_p, sim_p, point_p = _check(trace, spec, dist, "pybullet", n_pybullet, window)
            print(_row(f"session {i} pybullet, calibrated", ens_p, point_p))
            _table_row(name, i, "pybullet", "calibrated", ens_p, point_p)
            cmd_v, cmd_w = trace.cmd_at_meas()
            same = agreement_from_arrays(
                t_s=trace.meas_t_s, cmd_v=cmd_v, cmd_w=cmd_w, real_v=sim_r.v, real_w=sim_r.w,
                sim_v=sim_p.v, sim_w=sim_p.w, robot=robot,
            )  # fmt: skip
            print(f"  pybullet vs reduced, same params: agreement {100 * same.agreement:.1f} %")
        print(
            "  "
            + band_verdict(
                coverage_v=ens_r.coverage_v,
                coverage_w=ens_r.coverage_w,
                band_width_v_mps=ens_r.band_width_v_mps,
                band_width_w_radps=ens_r.band_width_w_radps,
            )
        )
        levels = ", ".join(
            f"{100 * lv:.0f}%: {100 * cv:.0f}/{100 * cw:.0f}"
            for lv, cv, cw in ens_r.coverage_by_level
        )
        print(f"  coverage v/w by level (reduced, calibrated): {levels}")


def tb3_halves(n: int) -> None:
    from robots.randomization import DriveDistribution
    from robots.spec import load_spec
    from sim2real.logs import read_trace
    from sysid import fit_drive

    path = REALDATA / "tb3wp_drexel_goal.mcap"
    if not path.is_file():
        print(f"real TB3 log: {path} absent, skipped")
        return
    spec = load_spec("turtlebot3_waffle_pi")
    window = spec.odometry.v_window_s
    trace = read_trace(path, time_source="header")
    half = 0.5 * trace.duration_s
    first, second = trace.window(0.0, half), trace.window(half, trace.duration_s + 1.0)
    result = fit_drive(
        [first], geometry=spec.geometry, base_params=spec.drive, priors=spec.priors,
        robot=spec.name, odom_v_window_s=window,
    )  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        params = Path(tmp) / "tb3.yaml"
        result.save(params)
        dist = DriveDistribution.from_params_file(params, robot=spec.name)
        print(
            f"real TB3 Waffle Pi log in halves ({trace.duration_s:.1f} s): fit first, band on second"
        )
        p = result.params
        print(
            f"  fitted on the first half: k_i {p.speed_loop_ki_per_s:.2f} /s, total mass "
            f"{p.total_mass_kg(spec.geometry):.2f} kg (spec {spec.geometry.mass_kg:.2f} kg)"
        )
        for engine in ("reduced", "pybullet"):
            ens, _, point = _check(second, spec, dist, engine, n, window)
            print(_row(f"second half {engine}", ens, point))
            _table_row("real TB3 Waffle Pi", 2, engine, "fit", ens, point)


def print_table() -> None:
    """The closing Markdown table of every checked session."""
    print()
    print("| fleet | session | engine | band | point agreement | coverage v | coverage w |"
          " width v m/s | width w rad/s |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for name, i, engine, band, agree, cv, cw, wv, ww in TABLE:
        print(
            f"| {name} | {i} | {engine} | {band} | {100 * agree:.1f} % | {100 * cv:.1f} % |"
            f" {100 * cw:.1f} % | {wv:.4f} | {ww:.3f} |"
        )
    print()
    if POINT:
        at_fit = sum(a >= 0.9 for _, a, _ in POINT)
        at_best = sum(b >= 0.9 for _, _, b in POINT)
        print(
            f"Point agreement >= 90 %: {at_fit} of {len(POINT)} checked sessions at the fleet's "
            f"estimate, {at_best} of {len(POINT)} with each session's own best delay (range "
            f"{100 * min(b for *_, b in POINT):.1f}-{100 * max(b for *_, b in POINT):.1f} %)"
        )
        print()
    print("Pooled over the checked sessions (active held-out samples of all of them):")
    print("| fleet | engine | band | active samples | coverage v | coverage w |")
    print("|---|---|---|---|---|---|")
    for (name, engine, band), (n, inside_v, inside_w) in POOLED.items():
        print(
            f"| {name} | {engine} | {band} | {n} | {100 * inside_v / n:.1f} % |"
            f" {100 * inside_w / n:.1f} % |"
        )


def record_figures() -> None:
    """The headline figures for ``docs/benchmarks.md``: pooled coverage per fleet, engine and
    band, the widest calibrated bands and the point agreement."""
    for (name, engine, band), (n, inside_v, inside_w) in POOLED.items():
        cov_v, cov_w = inside_v / n, inside_w / n
        baseline = band == "fit"  # the fit's own band: the same run's baseline, no target
        record(
            "calibration",
            f"{band} 90 % band, {name}, {engine}: pooled coverage of {n} held-out samples",
            f"v {100 * cov_v:.1f} %, w {100 * cov_w:.1f} %",
            "baseline" if baseline else "80-99 %",
            None if baseline else all(0.80 <= c <= 0.99 for c in (cov_v, cov_w)),
        )
    calibrated = [r for r in TABLE if r[3] == "calibrated"]
    if calibrated:
        wv, ww = max(r[7] for r in calibrated), max(r[8] for r in calibrated)
        record(
            "calibration",
            f"widest calibrated band (median width) over {len(calibrated)} checked sessions",
            f"v {wv:.4f} m/s, w {ww:.3f} rad/s",
            "<= 0.10 m/s, <= 0.35 rad/s",
            wv <= 0.10 and ww <= 0.35,
        )
    if POINT:
        at_fit = sum(a >= 0.9 for _, a, _ in POINT)
        at_best = sum(b >= 0.9 for _, _, b in POINT)
        record(
            "calibration",
            "point agreement >= 90 % on checked sessions: at the fleet's estimate; with each "
            "session's own best delay",
            f"{at_fit} of {len(POINT)}; {at_best} of {len(POINT)}",
            ">= 0.90",
            at_fit == len(POINT),
        )


def _seeds(text: str) -> list[int]:
    """``11``, ``31-36`` or ``11,23,31-33`` -> the seeds."""
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, default=8, help="fleet size (>= 6)")
    parser.add_argument("--reduced-n", type=int, default=30, help="ensemble size, reduced")
    parser.add_argument(
        "--pybullet-n", type=int, default=20, help="ensemble size, pybullet (0: skip)"
    )
    parser.add_argument(
        "--variants", action="store_true", help="also the plant variants the model was not tuned on"
    )
    parser.add_argument("--no-real", action="store_true", help="skip the real TB3 log")
    parser.add_argument(
        "--seeds", type=_seeds, default=[11], help="Kobuki fleet seeds: 11 or 31-36"
    )
    parser.add_argument(
        "--ti-seeds", type=_seeds, default=[23], help="T_i/2 fleet seeds (--variants)"
    )
    parser.add_argument(
        "--burger-seeds", type=_seeds, default=[5], help="Burger seeds (--variants)"
    )
    args = parser.parse_args()
    np.seterr(all="ignore")
    runs = [Fleet(seed=s) for s in args.seeds]
    if args.variants:
        runs += [Fleet(seed=s, integral_time_s=0.05) for s in args.ti_seeds]
        runs += [Fleet(seed=s, robot="turtlebot3_burger") for s in args.burger_seeds]
    for run in runs:
        with tempfile.TemporaryDirectory() as tmp:
            fleet(run, args.sessions, args.reduced_n, args.pybullet_n, Path(tmp))
    if not args.no_real:
        tb3_halves(args.reduced_n)
    print_table()
    record_figures()


if __name__ == "__main__":
    main()
