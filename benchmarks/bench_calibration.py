"""Benchmark: does the calibrated band contain the real robot, on sessions no step has seen?

Data (built here, written as ROS 2 MCAP and read back):

1. A fleet of recording sessions of one Kobuki-sized base (``turtlebot2``) from the foreign
   plant :mod:`sim2real.plants.diff_drive` (PI wheel loops, DC-motor torque-speed line with battery sag,
   per-wheel asymmetric friction, caster scrub, quantised encoders, gyro, latency jitter),
   whose payload, floor friction, battery charge and latency differ per session. It is *not*
   the project's drive model. Sessions 0-2 are fitted (``sysid fit``, fleet / random effects),
   sessions 3-4 calibrate the band's spread (``sysid calibrate``), sessions 5.. are checked.
2. The shared real TurtleBot3 Waffle Pi log (``../shared/realdata/tb3wp_drexel_goal.mcap``,
   skipped when absent) in halves: the first half is fitted, the band is built on the second
   (uncalibrated: one log leaves nothing to calibrate on without touching the checked half).

Measured on every checked session, in both engines (reduced and pybullet): coverage of the
90 % band for v and w (share of active samples inside), median band widths, the point
estimate's agreement, and the agreement of pybullet with the reduced model on the same
parameters. Targets (issue 11): coverage 80-99 %, widths <= 0.10 m/s and <= 0.35 rad/s,
point agreement >= 0.90, pybullet vs reduced >= 0.99.

3. Plant variants the drive model was not tuned on (``--variants``): the same base with a
   faster, more aggressive PI loop (integral time 0.05 s instead of 0.1 s, other fleet seed),
   and a fleet of another base (``turtlebot3_burger``, gyro w, no smoother).

The fit uses the spec's priors, as ``sim2real sysid fit`` does. A table of every checked
session closes the output, with the uncalibrated band of the fit (``fit``) beside the
calibrated one as the same run's baseline. ``--seeds``, ``--ti-seeds`` and ``--burger-seeds``
(``11``, ``31-36``, ``11,23``) run more fleets.

Measured (2026-11-26 16:45, calibration pooled with the fit's spread by sessions,
:func:`sim2real.agreement.calibration.pooled_factors`; ``--variants --pybullet-n 20``). Pooled coverage
v / w, reduced | pybullet: Kobuki seed 11 97.1 / 95.3 | 96.4 / 94.5 %, Ti/2 seed 23 88.9 /
85.5 | 88.2 / 84.3 % (was 83.9 / 80.3 | 82.6 / 78.8 %), Burger seed 5 95.1 / 95.0 | 95.0 /
94.6 %, real TB3 half 2 92.4 / 90.8 % (uncalibrated, unchanged); its session 6 (158 ms) 79.9
/ 77.1 | 80.9 / 75.9 % (was 68.6 / 70.4 | 66.6 / 68.8 %). Widths: v <= 0.030 m/s, w <= 0.166
rad/s; pybullet vs reduced 100.0 % on every session.

Across fleets (reduced, 30 members; sessions 0-2 fitted, 3-4 calibrate, 5-7 checked): 36
fleets in three sets of 12 (Kobuki, T_i/2, Burger), set A (seeds 11-15, 23-26, 5-7) chose
the pooling, sets B (31-36, 41-43, 51-53) and C (61-66, 71-73, 81-83) check it (``--seeds
61-66 --ti-seeds 71-73 --burger-seeds 81-83 --variants --pybullet-n 0 --no-real``);
"before" is the likelihood optimum alone (the same fits, main of 2026-11-26 16:30):

====================================  ========================  ========================
27 Kobuki-sized fleets, 81 sessions   before                    pooled by sessions
====================================  ========================  ========================
fleets pooled outside 80-99 %         2 (v 65.6, 79.5 %)        1 (v 99.4 %)
sessions below 80 %                   11 (worst 54.5 %)         9 (worst 67.5 %)
sessions above 99 %                   1                         6
widest band, v / w                    0.329 m/s / 0.708 rad/s   0.142 m/s / 0.283 rad/s
sessions wider than 0.10 m/s (v)      22                        4
sessions wider than 0.35 rad/s (w)    6                         0
====================================  ========================  ========================

The optimum alone shrank the spread to a = 0.05-0.31 in 7 of the 27 fleets (where the two
validation sessions looked alike) and widened it to a = 1.29-1.63 in 9. The sessions still
wider than 0.10 m/s in v owe it to the traction limit's prior (log-sd 0.5, never binding in
the fitted logs): without its spread the widest of set B, 0.137 m/s, is 0.021 m/s at the same
coverage. The 9 Burger fleets: 0 of 27 sessions outside 80-99 % either way.

Then the traction limit's prior made as narrow as its comment says (``wheel_torque_max_nm``
log-sd 0.5 -> 0.3 in the three shipped specs: "mu 0.3-0.8 across floors" as the 90 % range;
2026-11-26 17:25, the same 36 fleets, ``--seeds 11-15,31-36 --ti-seeds 23-26,41-43
--burger-seeds 5-7,51-53`` and set C as above): widest Kobuki-sized band v 0.142 -> 0.101 m/s
(sessions wider than 0.10 m/s 4 -> 1, at 0.1006), w 0.283 -> 0.304 rad/s; fleets pooled
outside 80-99 % 1 (v 99.6 %); sessions below 80 % 11 of 81 (worst 64.6 %), above 99 % 9; mean
pooled coverage 92.2 / 91.1 % (Burger 93.3 / 92.3 %, 0 of 27 sessions outside).

Point agreement (the script's closing line), 108 checked sessions of the 36 fleets: >= 90 %
on 47 at the fleet's estimate, on 97 with only the delay changed to each session's own best
(83.4-98.9 %; set B alone 16 and 34 of 36, before the prior change): the fit is right and the unseen session's latency, which no fit of other
sessions can know, is what a point estimate misses (the plant draws 60-160 ms per session).

Before the pooling (2026-11-26 15:37, after the pybullet tyre friction from the drive,
``--variants --pybullet-n 20``, 2 min 31 s on one core; reduced figures identical to the 12:30
run below).
Pooled coverage v / w, reduced | pybullet: Kobuki seed 11 94.5 / 94.8 | 93.5 / 93.9 %, Ti/2
83.9 / 80.3 | 82.6 / **78.8** %, Burger 94.8 / 89.6 | 94.7 / 89.3 %, real TB3 half 2 92.4 /
90.8 | 92.4 / 90.8 %; pybullet vs reduced on the same parameters 100.0 % on all nine checked
sessions. Per session outside 80-99 %: Ti/2 session 5 w 78.9 | 77.7 %, session 6 68.6 / 70.4 |
66.6 / 68.8 % (its latency 158 ms is 69 ms above the fitted sessions' 71 / 78 / 117 ms, and
the validation sessions ran at 78 / 110 ms: no step saw a session like it). Point agreement
(both engines): Kobuki 86.9, 81.1, 91.1 %; with each session's true latency (the fitted delay
shifted by its plant latency minus the fitted sessions' mean: a diagnosis) 93.1, 92.7, 94.7 %,
each session fitted to itself 96.5, 94.7, 96.4 % (sessions at 81, 128, 64 ms; fitted 63 / 122
/ 88 ms).

Measured (2026-11-26 12:30, friction fitted per unit mass, ``--variants --pybullet-n 0``;
reduced, sessions 5-7, calibrated band; load 2.5-3): pooled coverage v / w: Kobuki seed 11
94.5 / 94.8 %, Ti/2 83.9 / 80.3 %, Burger 94.8 / 89.6 %, real TB3 half 2 92.4 / 90.8 %; point
agreement Kobuki 86.9, 81.1, 91.1 %, Ti/2 82.6, 66.4, 82.1 %, Burger 94.8, 95.5, 96.0 %, real
TB3 98.8 %; outside 80-99 % per session: Ti/2 session 5 w 78.9 %, session 6 v 68.6, w 70.4 %.
The tables below are the same code before friction was per unit mass (reproduced exactly in
the same run of the old tree); the Ti/2 fleet lost 5 points in both axes, the others moved
within +-5 (bench_novel_robots shows that such moves change sign with the fleet's seed).

Measured (2026-11-26, with the coverage matching of ``sysid calibrate``; sessions 5-7,
calibrated band, 30 reduced / 20 pybullet members; load ~2.5 on 2 cores, which changes no
figure here). Per session, reduced (pybullet where it differs by more than 1 point):

=========================  ===============  =======================  =======================
fleet                      point agreement  coverage v               coverage w
=========================  ===============  =======================  =======================
turtlebot2 seed 11         85.9, 82.4, 87.5 94.7, 97.5, 88.9 (87.1)  94.2, 96.6, 93.9
turtlebot2 seed 23, Ti/2   82.5, 66.5, 83.6 90.7, 82.1 (79.6), 95.1  85.2, 79.2 (74.5), 92.7
turtlebot3_burger seed 5   94.8, 95.2, 95.9 92.9, 94.9, 94.7         94.6, 95.2, 95.1
real TB3 Waffle Pi, half 2 97.4             94.1                     87.9
=========================  ===============  =======================  =======================

Pooled over the active held-out samples of sessions 5-7 (the target's "90 % band covers
80-99 % of active held-out samples"), reduced / pybullet; in brackets the same before the
coverage matching (likelihood noise only, same fits):

=========================  ==============  =========================  =========================
fleet                      active samples  coverage v                 coverage w
=========================  ==============  =========================  =========================
turtlebot2 seed 11         11517           93.7 / 92.8 % (96.2/95.9)  94.9 / 94.2 % (94.9/94.2)
turtlebot2 seed 23, Ti/2   11695           89.3 / 87.9 % (91.5/90.9)  85.8 / 84.1 % (85.8/84.1)
turtlebot3_burger seed 5   6523            94.1 / 94.1 % (97.3/97.5)  95.0 / 94.8 % (99.1/99.0)
real TB3 Waffle Pi, half 2 422             94.1 / 94.1 %              87.9 / 87.9 %
=========================  ==============  =========================  =========================

The matching (validation coverage of the 90 % band brought into 90-95 %) narrowed v on all
three fleets and w on the burger, whose likelihood band covered 99.0-99.4 % of every unseen
session (its 50 % band 81-84 %: the Gaussian likelihood widens the noise to cover heavy-tailed
transient errors). Matched to exactly 90 % instead, the pooled figures were 89.5 / 89.2,
82.1 / 83.7 and 90.4 / 89.6 % (reduced) and the demo's unseen session fell to 79 % in v: no
margin for a session unlike the validation ones. Per session outside 80-99 %: 5 of 24
(reduced) before the matching, 1 after (Ti/2 session 6, below).

Widths (median, m/s and rad/s): v 0.0015-0.0292, w 0.048-0.131 (Kobuki target <= 0.10 /
0.35). Pybullet vs reduced on the same parameters: 100.0 % on every session. Outside 80-99 %
per session: seed 23 session 6 w 79.2 % (pybullet v 79.6, w 74.5 %; its latency, 158 ms,
is at the top of the plant's 60-160 ms range: a 2-sd session). A band
calibrated on two sessions covers a typical session more and an extreme one less than its
level; no single band puts every session inside 80-99 % when the sessions' own latency moves
the response by more than the band's width. Before the coverage matching, the burger's
calibrated w band was too wide at its centre (its 50 % band covered 81-84 %): the Gaussian
likelihood of :mod:`sim2real.agreement.calibration` widens the noise to cover heavy-tailed transient
errors. Tried before the matching, not adopted: a Student-t
(nu = 5) predictive likelihood gives burger w 90.6-92.0 % per session (pooled 91.0 %) and
Kobuki seed 11 91.6 %, but drops the between-session factor to 0 on the Ti/2 fleet, whose
extreme session 6 then falls to 68-70 % (pooled 84.9 / 81.9 %).

Measured (2026-11-23, torque-speed line on the Kobuki; sessions 5-7, calibrated band, reduced /
pybullet, load ~5 on 2 cores; the fit of sessions 0-2 finds k_i 9.6 /s, plant 10 /s):

=========================  ===============  ============  ============  ===========
fleet                      point agreement  coverage v    coverage w    width w
=========================  ===============  ============  ============  ===========
turtlebot2 seed 11         85.9, 82.4, 87.5 97.7-99.5 %   92.9-94.2 %   0.049-0.051
turtlebot2 seed 23, Ti/2   83.3, 66.0, 83.8 65.8-98.0 %   67.9-90.4 %   0.049-0.109
turtlebot3_burger seed 5   95.4, 95.7, 96.3 96.7-98.0 %   89.8-90.7 %   0.042-0.043
real TB3 Waffle Pi, half 2 97.4             94.1 %        90.3 %        0.067
=========================  ===============  ============  ============  ===========

Before the torque-speed line (same seeds): 87.2, 79.8, 89.0 / 84.7, 64.9, 80.3 / 96.2, 94.2,
97.1 %. The Kobuki's point agreement misses 90 % because of the session's own command latency,
which no fit of other sessions can know (the plant draws it from 60-160 ms): the same fitted
parameters with the checked session's true latency (the fit's delay shifted by that session's
offset from the fitted sessions' mean; a diagnosis, not a claim) agree 90.9, 92.4, 94.7 % and
93.0, 94.0, 92.5 %. Fitting one session to itself gives 93.9-96.3 %. (P-loop model, session
2: point agreement 59-77 %, w width 0.30-0.54 rad/s.) Pybullet vs reduced on the same
parameters: 100.0 % on every session.

Run: ``.venv/bin/python benchmarks/bench_calibration.py [--sessions 8] [--pybullet-n 20]
[--variants]`` (about 5 minutes on one core per fleet; pybullet replays dominate).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

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


def fleet(
    n_sessions: int,
    n_reduced: int,
    n_pybullet: int,
    folder: Path,
    *,
    robot: str = ROBOT,
    seed: int = 11,
    integral_time_s: float | None = None,
    name: str = "turtlebot2 seed 11",
) -> None:
    from robots.randomization import DriveDistribution
    from robots.spec import load_spec
    from sim2real.agreement.calibration import calibrate, write_calibrated
    from sim2real.agreement.figures import agreement_from_arrays, band_verdict
    from sim2real.logs import read_trace
    from sim2real.plants.diff_drive import plant_from_spec, write_fleet
    from sysid import fit_drive

    spec = load_spec(robot)
    window = spec.odometry.v_window_s
    plant: Any = robot
    if integral_time_s is not None:
        base = plant_from_spec(robot)
        plant = base.replace(ki_nm_per_rad=base.kp_nms_per_rad / integral_time_s)
    paths = write_fleet(folder, plant, n_sessions, seed=seed, duration_s=90.0)
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
    runs: list[dict[str, Any]] = [{"seed": s, "name": f"turtlebot2 seed {s}"} for s in args.seeds]
    if args.variants:
        runs += [
            {"seed": s, "integral_time_s": 0.05, "name": f"turtlebot2 seed {s}, T_i 0.05 s"}
            for s in args.ti_seeds
        ]
        runs += [
            {"seed": s, "robot": "turtlebot3_burger", "name": f"turtlebot3_burger seed {s}"}
            for s in args.burger_seeds
        ]
    for run in runs:
        with tempfile.TemporaryDirectory() as tmp:
            fleet(args.sessions, args.reduced_n, args.pybullet_n, Path(tmp), **run)
    if not args.no_real:
        tb3_halves(args.reduced_n)
    print_table()


if __name__ == "__main__":
    main()
