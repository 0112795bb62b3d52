"""Benchmark: do fits and bands hold on real robots, on recordings the fit never saw?

Data: the real development set in ``../shared/realdata`` (read its README; skipped when
absent). Per base, as a new user would work (the public CLI: ``robots new``, ``sysid fit`` on
the recording alone, ``sysid calibrate``, ``agree --ensemble 30 --json``; ``--validate`` also
validates each fit on its calibration recording, which judges the loops' integral term):

- Neato (spec from ``robots new``: wheel separation 0.248 m, top speed 0.3 m/s): fit on one
  unit's test drive, calibrate on its obstacle avoidance (its longest), check on its three
  other recordings and on four other units' (``--more-neato DIR``: DIR's too).
- TurtleBot3 Waffle Pi with an arm (shipped spec): fit the first half, check the second.
- Husky A200, wheels lifted (``robots new --drive skid``, 0.538 m, r 0.15875 m, 1.0 m/s, driver
  and track factors 1: no slip on a stand; MuJoCo as ``mujoco-lifted``): fit the first half of
  session a, calibrate on its second half, check b.
- Warthog (``--drive skid``, 1.08 m, r 0.3 m, ``--driver-track-factor 1 --wheel-cap
  per-side``: its encoders read each side's commanded wheel speed on the 1.08 m track, clipped
  on its own at ~13.1 rad/s): fit up to 28 s, check 28-40 s (after 40 s the driver holds a
  command with the wheels stopped).

A checked half is written as a log for ``agree``. Per checked recording and engine, one row:
- ``spec``: point agreement of the spec defaults; ``fit``: of the fitted (calibrated) point;
- ``own lat.``: the fitted point at the session's own best command latency (and that
  latency), :func:`sim2real.agreement.latency.session_latency`;
- ``ceiling``: the agreement a perfect model would reach under the checked log's own odometry
  noise (:func:`sim2real.agreement.latency.log_noise`; too few steady samples: the params',
  capped by the log's own bound, :func:`sim2real.agreement.latency.bounded_ceiling`);
- ``cov v / w``: coverage of the 90 % band (30 robots); ``width v / w``: its median width,
  beside the noise-only 90 % band (3.29 noise sd).

Targets (issue 28): ``fit >= spec`` on every row; ``own lat.`` >= 80 % or within 5 points of
``ceiling`` on differential-drive bases; coverage 80-99 % in v and w with a median width <=
20 % of the top speed / yaw rate or <= 1.25x the noise-only band. A closing line counts the
rows that hold each. ``--explain`` adds, per base, where each row's band gets its width and
misses (:func:`sim2real.agreement.sources.band_sources`, reduced engine): the three largest
sources of each axis's variance with their share and width alone; the share of the misses
within 1 s of a command step and above the band; the coverage at the session's own latency.
``--misses``: where the fitted point misses at each session's own latency (:func:`misses`);
``--budget``: the calibrated band's width built up one source at a time (:func:`budget`).
``--quick``: three Neato recordings (fitted unit, another 2018 unit, a 2017 unit), reduced
engine only; ``--base NAME`` runs one base.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from _timing import record

REPO = Path(__file__).resolve().parents[1]
REALDATA = REPO.parent / "shared" / "realdata"
ENSEMBLE_N = 30


@dataclass(frozen=True)
class Base:
    """One base of the development set: spec, fit, calibration and checked recordings."""

    name: str
    spec: tuple[str, ...]  # ``robots new`` arguments, or ("shipped", NAME)
    fit: str
    fit_window: str = ""
    calibrate: str = ""  # a file, or FILE@START:END (a part written as CSV)
    checks: tuple[str, ...] = ()
    quick_checks: tuple[str, ...] = ()
    diff_drive: bool = True
    top_speeds: tuple[float, ...] = ()  # v, w for the width target; () = the spec's
    fit_args: tuple[str, ...] = field(default=())
    lifted: bool = False  # recorded on a stand: MuJoCo replays with the base held up


NEATO_FIT_UNIT = "neato_ksoltan_"
BASES = (
    Base(
        name="neato",
        spec=("--wheel-separation", "0.248", "--max-speed", "0.3"),
        fit="neato_ksoltan_testdrive_2018-09-18-20-17-54.mcap",
        calibrate="neato_ksoltan_obstacle_avoid_demo_2018-09-18-20-30-36.mcap",
        checks=(
            "neato_ksoltan_bag-file-name_2018-09-15-10-16-08.mcap",
            "neato_ksoltan_drunk_wall_follow_demo_2018-09-18-20-35-31.mcap",
            "neato_ksoltan_square_dance_demo_2018-09-18-20-20-05.mcap",
            "neato_olin2018_teleop.mcap",
            "neato_yycho0108_drive_square_demo.mcap",
            "neato_yycho0108_person_follower_demo.mcap",
            "neato_yycho0108_test_drive.mcap",
            "neato_paulruvolo-pr2_drive_square_bag_2017-01-29-18-30-40.mcap",
            "neato_paulruvolo-pr2_finite_state_bag_2017-02-06-00-10-00.mcap",
            "neato_paulruvolo-pr2_person_follower_bag_2017-02-04-15-10-28.mcap",
            "neato_paulruvolo-pr2_wall_follow_2017-01-29-20-38-37.mcap",
            "neato_paulruvolo-pr5_obstacle-avoid_2017-02-06-16-23-52.mcap",
            "neato_paulruvolo-pr5_part_2_rosbag_driving_2017-01-25-21-44-57.mcap",
        ),
        quick_checks=(
            "neato_ksoltan_bag-file-name_2018-09-15-10-16-08.mcap",
            "neato_yycho0108_drive_square_demo.mcap",
            "neato_paulruvolo-pr2_drive_square_bag_2017-01-29-18-30-40.mcap",
        ),
    ),
    Base(
        name="tb3wp",
        spec=("shipped", "turtlebot3_waffle_pi"),
        fit="tb3wp_drexel_goal.mcap",
        fit_window="0:19.4",
        checks=("tb3wp_drexel_goal.mcap@19.4:40",),
    ),
    Base(
        name="husky",
        spec=(
            *("--wheel-separation", "0.538", "--wheel-radius", "0.15875", "--drive", "skid"),
            *("--max-speed", "1.0"),  # Clearpath's datasheet (husky_base's max_speed)
            # on a stand the wheels cannot slip, and the recording's yaw rate is the encoders'
            # on the 0.538 m track, where its commands reach them (measured / commanded w 1.00
            # below 0.9 rad/s)
            *("--driver-track-factor", "1", "--track-factor", "1"),
        ),
        fit="husky_lifted_a/trace.csv",
        fit_window="0:155",
        calibrate="husky_lifted_a/trace.csv@155:310",
        checks=("husky_lifted_b/trace.csv",),
        diff_drive=False,
        lifted=True,
        top_speeds=(1.0, 1.05),  # Clearpath's datasheet; the driver's yaw cap (realdata README)
    ),
    Base(
        name="warthog",
        spec=(
            *("--wheel-separation", "1.08", "--wheel-radius", "0.3", "--drive", "skid"),
            # the recording's driver: its encoders read the commanded wheel speeds of the
            # geometric track (left 10.70 rad/s at -3.72 m/s, -0.95 rad/s), each clipped on its
            # own at ~13.1 rad/s (right 14.11 -> 13.07)
            *("--driver-track-factor", "1", "--wheel-cap", "per-side"),
            # its yaw rate is the wheel encoders' (w_source: wheels), which read the wheels
            # whatever the treads slip: no fit can measure the track factor from it, so 1 is only
            # its prior mean (the readings are the same at any value; a gyro would measure it)
            *("--track-factor", "1"),
        ),
        fit="warthog_close/trace.csv",
        fit_window="0:28",
        checks=("warthog_close/trace.csv@28:40",),
        diff_drive=False,
        top_speeds=(3.7, 3.9),  # the recording's commands (realdata README)
    ),
)


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    """Run ``python -m sim2real ARGS`` as a user would; raise with its stderr on failure."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    cmd = [sys.executable, "-m", "sim2real", *args]
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {out.returncode}: {out.stderr[-2000:]}")
    return out


def log_path(ref: str, tmp: Path) -> Path:
    """``FILE`` or ``FILE@START:END`` (that part of the log, written as CSV)."""
    from sim2real.logs import read_trace, write_csv_trace, write_trace

    name, _, part = ref.partition("@")
    if not part:
        return REALDATA / name
    start, end = (float(x) for x in part.split(":"))
    suffix = Path(name).suffix
    out = tmp / f"{Path(name).parent.name or Path(name).stem}_{start:g}-{end:g}{suffix}"
    if not out.exists():
        trace = read_trace(REALDATA / name, time_source="auto").window(start, end)
        if suffix == ".csv":  # one time column: the commands held at the measurement times
            cmd_v, cmd_w = trace.cmd_at_meas()
            trace = replace(trace, cmd_t_ns=trace.meas_t_ns, cmd_v=cmd_v, cmd_w=cmd_w)
            write_csv_trace(out, trace)
        else:
            write_trace(out, trace)
    return out


def validation_args(base: Base) -> tuple[str, ...]:
    """``sysid fit`` arguments that validate the fit on the calibration recording (it judges
    the wheel loops' integral term: :func:`sysid.fit.fit_drive`); none without one."""
    if not base.calibrate:
        return ()
    name, _, part = base.calibrate.partition("@")
    return ("--validate", str(REALDATA / name), *(("--validate-window", part) if part else ()))


def spec_file(base: Base, tmp: Path) -> str:
    if base.spec[0] == "shipped":
        return base.spec[1]
    out = tmp / f"{base.name}.yaml"
    cli("robots", "new", base.name, *base.spec, "-o", str(out), "--force")
    return str(out)


def reference_figures(log: Path, robot: str, params: Path, engine: str) -> dict[str, float]:
    """The session's own latency and the noise ceiling, from the library."""
    from robots.params import read_params_file
    from robots.randomization import DriveDistribution
    from robots.spec import load_spec
    from sim2real.agreement.latency import noise_ceiling, session_latency
    from sim2real.agreement.study import parse_odom_v_window
    from sim2real.logs import read_trace

    spec = load_spec(robot)
    dist = DriveDistribution.from_params_file(params, robot=spec.name)
    window_s = parse_odom_v_window("auto", spec.odometry.rate_hz, v_source=spec.odometry.v_source)
    trace = read_trace(log, time_source="auto").without_absurd(
        max_v_mps=spec.max_v_mps, max_w_radps=spec.max_w_radps
    )
    lat = session_latency(
        trace, robot=spec, params=dist.mean_params(), engine=engine,
        odom_v_window_s=window_s, tol_v=0.02, tol_w=0.1,
    )  # fmt: skip
    noise, factors = dist.noise, read_params_file(params).document.get("calibration") or {}
    for axis, name in (("v", "std_v_mps"), ("w", "std_w_radps")):  # the fit's noise
        if (factor := factors.get(f"noise_factor_{axis}") or 0) > 0:
            noise = replace(noise, **{name: getattr(noise, name) / factor})
    ceil = noise_ceiling(noise, tol_v=0.02, tol_w=0.1)
    return {
        "best_delay_s": lat.delay_s,
        "agreement_at_best_delay": lat.report.agreement,
        "noise_ceiling": ceil.agreement,
        "noise_band_width_v_mps": ceil.band_width_v_mps,
        "noise_band_width_w_radps": ceil.band_width_w_radps,
    }


def check(base: Base, log: Path, robot: str, params: Path, engine: str, tmp: Path) -> dict:
    out = tmp / "agree.json"
    cli(
        "agree", str(log), "--robot", robot, "--params", str(params), "--engine", engine,
        "--ensemble", str(ENSEMBLE_N), "--seed", "0", "--json", str(out),
    )  # fmt: skip
    fitted = json.loads(out.read_text())
    cli("agree", str(log), "--robot", robot, "--engine", engine, "--json", str(out))
    spec = json.loads(out.read_text())
    if "agreement_at_best_delay" not in fitted:  # an 'agree' without these figures
        fitted |= reference_figures(log, robot, params, engine)
    return {"spec": spec["agreement"], **fitted}


def holds(base: Base, r: dict, robot: str) -> dict[str, bool]:
    from robots.spec import load_spec

    spec = load_spec(robot)
    top_v, top_w = base.top_speeds or (spec.max_v_mps, spec.max_w_radps)
    lat_ok = r["agreement_at_best_delay"] >= 0.8 or (
        r["agreement_at_best_delay"] >= r["noise_ceiling"] - 0.05
    )
    cov_ok = all(0.8 <= r[f"coverage_{a}"] <= 0.99 for a in "vw")
    width_ok = all(
        r[f"band_width_{a}_{u}"] <= max(0.2 * top, 1.25 * r[f"noise_band_width_{a}_{u}"])
        for a, u, top in (("v", "mps", top_v), ("w", "radps", top_w))
    )
    return {
        "fit>=spec": r["agreement"] >= r["spec"],
        "own lat.": lat_ok if base.diff_drive else True,
        "coverage": cov_ok,
        "width": width_ok,
    }


def explain(log: Path, robot: str, params: Path) -> str:
    """One table row: where the band's width and its misses come from."""
    from robots.params import read_params_file
    from robots.randomization import DriveDistribution
    from robots.spec import load_spec
    from sim2real.agreement.latency import band_sample_noise
    from sim2real.agreement.replay import replay
    from sim2real.agreement.sources import band_sources
    from sim2real.agreement.study import parse_odom_v_window
    from sim2real.logs import read_for_robot

    spec = load_spec(robot)
    dist = DriveDistribution.from_params_file(params, robot=spec.name)
    window_s = parse_odom_v_window("auto", spec.odometry.rate_hz, v_source=spec.odometry.v_source)
    trace, _ = read_for_robot(log, spec)
    document = read_params_file(params).document  # agree's band noise
    point = replay(trace, robot=spec, params=dist.mean_params(), odom_v_window_s=window_s)
    noise, _ = band_sample_noise(
        dist.noise, document.get("settings"), trace, point, calibration=document.get("calibration")
    )
    why = band_sources(trace, robot=spec, distribution=dist, n=ENSEMBLE_N,
                       odom_v_window_s=window_s, noise=noise)  # fmt: skip

    def axis(a: str) -> str:
        return ", ".join(
            f"{UNIT.sub('', name) if name != 'delay_s' else 'latency'} {100 * share:.0f} %"
            f" ({width:.3f})"
            for name, share, width in why.largest(a)
        )

    def miss(a: str) -> str:
        near, above = getattr(why, f"near_step_{a}"), getattr(why, f"above_{a}")
        cov = getattr(why, f"coverage_{a}")
        return (
            "-"
            if near != near
            else f"{100 * (1 - cov):.0f} %: {100 * near:.0f} / {100 * above:.0f}"
        )

    return (
        f" | {axis('v')} | {axis('w')} | {miss('v')} | {miss('w')} | {why.own_delay_s:.2f}:"
        f" {100 * why.coverage_own_latency_v:.1f} / {100 * why.coverage_own_latency_w:.1f} |"
    )


#: The steps of :func:`budget`: each adds one source of the calibrated band's spread.
BUDGET_STEPS = ("noise", "posterior", "file's session", "calibrate's b", "widening")


def budget(log: Path, robot: str, fitted: Path, calibrated: Path) -> str:
    """One table row: the calibrated band's median width built up one source at a time.

    The calibrated covariance of a one-log fit is ``N (a^2 (P + (1 + f) S0) + g S0 g) N``
    (:mod:`sim2real.agreement.calibration`): P the fit log's posterior, S0 the spec's
    between-session covariance, which the file holds 1 + f times
    (:func:`sysid._summary.distribution`), a the dynamics factor, g the session factors
    (``pooled_session_factor``, and the widened one on ``session_factor_parameters``), N the
    narrowing. The band (reduced engine, ``agree``'s noise per sample) is rebuilt with the
    noise alone, then adding a^2 P, a^2 (1 + f) S0, the pooled b^2 S0 and the widening; each
    step's share is its increase of the squared width over the calibrated band's. A file
    fitted on several logs has no such split: "-".
    """
    import dataclasses

    import numpy as np

    from robots.params import read_params_file
    from robots.randomization import DriveDistribution, cap_spread
    from robots.spec import load_spec
    from sim2real.agreement.calibration import session_covariance
    from sim2real.agreement.figures import run_ensemble
    from sim2real.agreement.latency import band_sample_noise
    from sim2real.agreement.replay import replay
    from sim2real.agreement.study import parse_odom_v_window
    from sim2real.logs import read_for_robot
    from sysid._fleet import new_session_factor

    spec = load_spec(robot)
    fit_doc, cal_doc = read_params_file(fitted), read_params_file(calibrated)
    if (fit_doc.document.get("settings") or {}).get("sessions", 1) != 1:
        return " | - | - |"
    fit = DriveDistribution.from_params_file(fit_doc, robot=spec.name)
    cal = DriveDistribution.from_params_file(cal_doc, robot=spec.name)
    c = cal_doc.document["calibration"]
    s0, file_cov = session_covariance(fit, spec), fit.covariance_array
    post = file_cov - (1.0 + new_session_factor(1)) * s0
    narrow = c.get("spread_narrowing") or {}
    n = np.array([narrow.get(name, 1.0) for name in fit.names])
    a2, b2 = c["dynamics_factor"] ** 2, (c["pooled_session_factor"] or 0.0) ** 2
    covs = (0.0 * post, a2 * post, a2 * file_cov, a2 * file_cov + b2 * s0, None)
    window_s = parse_odom_v_window("auto", spec.odometry.rate_hz, v_source=spec.odometry.v_source)
    trace, _ = read_for_robot(log, spec)
    point = replay(trace, robot=spec, params=cal.mean_params(), odom_v_window_s=window_s)
    noise, _ = band_sample_noise(cal.noise, cal_doc.document.get("settings"), trace, point,
                                 calibration=c)  # fmt: skip
    widths = []
    for cov in covs:
        dist = cal
        if cov is not None:
            capped = cap_spread(cov * np.outer(n, n), fit.names, fit.geometry)
            dist = dataclasses.replace(cal, covariance=tuple(map(tuple, capped.tolist())))
        ens = run_ensemble(trace, robot=spec, distribution=dist, noise=noise, n=ENSEMBLE_N,
                           seed=0, odom_v_window_s=window_s)  # fmt: skip
        widths.append((ens.band_width_v_mps, ens.band_width_w_radps))

    def axis(k: int) -> str:
        w = [x[k] for x in widths]
        shares = np.diff([0.0, *np.square(w)]) / max(w[-1] ** 2, 1e-300)
        return (
            " -> ".join(f"{x:.3f}" for x in w)
            + " ("
            + " / ".join(f"{100 * sh:.0f}" for sh in shares)
            + " %)"
        )

    return f" | {axis(0)} | {axis(1)} |"


BUDGET_HEAD = (
    f"| checked | v band: {' -> '.join(BUDGET_STEPS)} (share of the squared width) | w band |\n"
    "|---|---|---|"
)

#: Samples this soon after a command change count as at the change, s (the Neato's response
#: to a step is over within ~0.5 s).
NEAR_CHANGE_S = 0.6


def misses(log: Path, robot: str, params: Path) -> str:
    """One table row: where the fitted point misses at the session's own latency (reduced).

    The misses (share of the active samples; on v alone, w alone, both), the share of the
    samples within :data:`NEAR_CHANGE_S` of a command change and the miss rate there and
    elsewhere, the share beyond the |v| or |w| the fit saw (its ``envelope:``) and the miss
    rate there, and the unit's held top speed over the model's (median |v| where the model
    runs at 95 % of its top or more, :func:`sim2real.agreement.verdict.speed_shortfall`'s
    samples) with the agreement the model reaches with its top speed scaled to the unit's.
    """
    import numpy as np

    from robots.params import read_params_file
    from robots.randomization import DriveDistribution
    from robots.spec import load_spec
    from sim2real.agreement.figures import measure_agreement
    from sim2real.agreement.latency import session_latency
    from sim2real.agreement.replay import replay
    from sim2real.agreement.study import parse_odom_v_window
    from sim2real.agreement.verdict import HELD_TOP_SHARE
    from sim2real.logs import read_for_robot
    from sysid.metrics import active_mask

    spec = load_spec(robot)
    dist = DriveDistribution.from_params_file(params, robot=spec.name)
    window_s = parse_odom_v_window("auto", spec.odometry.rate_hz, v_source=spec.odometry.v_source)
    trace, _ = read_for_robot(log, spec)
    tols = {"tol_v": 0.02, "tol_w": 0.1}
    lat = session_latency(
        trace, robot=spec, params=dist.mean_params(), odom_v_window_s=window_s, **tols
    )
    point = dist.mean_params().replace(delay_s=lat.delay_s)
    sim = replay(trace, robot=spec, params=point, odom_v_window_s=window_s)
    t, (cmd_v, cmd_w) = trace.meas_t_s, trace.cmd_at_meas()
    real_v, real_w = np.asarray(trace.meas_v), np.asarray(trace.meas_w)
    active = active_mask(cmd_v, cmd_w, real_v, real_w, **tols)
    miss_v, miss_w = np.abs(sim.v - real_v) > 0.02, np.abs(sim.w - real_w) > 0.1
    miss = (miss_v | miss_w)[active]
    change = np.r_[True, (np.diff(cmd_v) != 0) | (np.diff(cmd_w) != 0)]
    near = (t - t[change][np.cumsum(change) - 1] < NEAR_CHANGE_S)[active]
    env = read_params_file(params).document.get("envelope") or {}
    beyond = (
        (np.abs(real_v) > env.get("v_mps", np.inf)) | (np.abs(real_w) > env.get("w_radps", np.inf))
    )[active]
    s_v, r_v = np.abs(sim.v[active]), np.abs(real_v[active])
    top = s_v >= HELD_TOP_SHARE * float(np.percentile(s_v, 99))
    ratio = float(np.median(r_v[top]) / np.median(s_v[top]))
    scaled = point.replace(wheel_speed_max_radps=ratio * point.wheel_speed_max_radps)
    own_top = measure_agreement(
        trace, replay(trace, robot=spec, params=scaled, odom_v_window_s=window_s), **tols
    )

    def rate(mask: np.ndarray) -> str:
        return f"{100 * miss[mask].mean():.0f}" if mask.any() else "-"

    both = (miss_v & miss_w)[active]
    return (
        f" | {100 * miss.mean():.1f} ({int(miss.sum())}/{int(active.sum())}) |"
        f" {int((miss_v[active] & ~both).sum())} / {int((miss_w[active] & ~both).sum())} /"
        f" {int(both.sum())} | {100 * near.mean():.0f} %: {rate(near)} / {rate(~near)} |"
        f" {100 * beyond.mean():.0f} %: {rate(beyond)} / {rate(~beyond)} |"
        f" {ratio:.3f} ({int(top.sum())}) | {100 * own_top.agreement:.1f} |"
    )


MISSES_HEAD = (
    "| checked | misses at own lat. % | v / w / both | near a command change (< 0.6 s):"
    " share: miss % there / elsewhere | beyond the fit's top v or w: share: miss % there /"
    " inside | unit's top speed / model's (samples) | own lat. at the unit's top speed % |\n"
    "|---|---|---|---|---|---|---|"
)
UNIT = re.compile(r"_(kg|kgm2|nm|n|nms_per_rad|ns_per_m|radps|per_s|mps2|radps2)$")
EXPLAIN_HEAD = (
    "| checked | v: largest sources, share (width alone) | w: largest sources |"
    " v misses: near step / above (%) | w misses | own latency (s): cov v / w |\n"
    "|---|---|---|---|---|---|"
)


def run_base(
    base: Base,
    engines: list[str],
    quick: bool,
    tally: dict[str, list[int]],
    why: bool = False,
    missed: bool = False,
    validate: bool = False,
    built: bool = False,
) -> None:
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        robot = spec_file(base, tmp)
        params = tmp / "params.yaml"
        window = ("--window", base.fit_window) if base.fit_window else ()
        t0 = time.perf_counter()
        validation = validation_args(base) if validate else ()
        cli("sysid", "fit", str(REALDATA / base.fit), "--robot", robot, "-o", str(params),
            *window, *validation, *base.fit_args)  # fmt: skip
        fit_s = time.perf_counter() - t0
        fitted = params
        if base.calibrate:
            calibrated = tmp / "calibrated.yaml"
            cli("sysid", "calibrate", str(params), str(log_path(base.calibrate, tmp)),
                "--robot", robot, "-o", str(calibrated))  # fmt: skip
            params = calibrated
        print(f"\n## {base.name}: fit {base.fit} {base.fit_window} ({fit_s:.1f} s), "
              f"calibrated on {base.calibrate or '-'}")  # fmt: skip
        print("| checked | engine | spec | fit | own lat. (s) | ceiling | cov v / w |"
              " width v / w (noise-only) | holds |")  # fmt: skip
        print("|---|---|---|---|---|---|---|---|---|")
        explained, where, sources = [], [], []
        for ref in base.quick_checks if quick and base.quick_checks else base.checks:
            log = log_path(ref, tmp)
            if why:
                explained.append(f"| {row_name(ref)}{explain(log, robot, params)}")
            if built and base.calibrate:
                sources.append(f"| {row_name(ref)}{budget(log, robot, fitted, params)}")
            if missed and base.diff_drive:
                where.append(f"| {row_name(ref)}{misses(log, robot, params)}")
            for named in engines:
                engine = "mujoco-lifted" if base.lifted and named == "mujoco" else named
                try:
                    r = check(base, log, robot, params, engine, tmp)
                except RuntimeError as exc:  # a row says why, the table goes on
                    print(f"| {row_name(ref)} | {engine} | {str(exc).splitlines()[-1][-160:]} |")
                    continue
                ok = holds(base, r, robot)
                for k, v in ok.items():
                    for key in (k, f"{base.name}: {k}"):
                        tally.setdefault(key, [0, 0])[0] += int(v)
                        tally[key][1] += 1
                name = row_name(ref).split("_20")[0]
                print(
                    f"| {name} | {engine} | {100 * r['spec']:.1f} | {100 * r['agreement']:.1f}"
                    f" | {100 * r['agreement_at_best_delay']:.1f} ({r['best_delay_s']:.2f})"
                    f" | {100 * r['noise_ceiling']:.1f}"
                    f" | {100 * r['coverage_v']:.1f} / {100 * r['coverage_w']:.1f}"
                    f" | {r['band_width_v_mps']:.3f} ({r['noise_band_width_v_mps']:.3f}) /"
                    f" {r['band_width_w_radps']:.3f} ({r['noise_band_width_w_radps']:.3f})"
                    f" | {' '.join(k for k, v in ok.items() if not v) or 'all'} |",
                    flush=True,
                )
        if explained:
            print(f"\nwhere the bands of {base.name} get their width and their misses (reduced)")
            print(EXPLAIN_HEAD)
            print("\n".join(explained), flush=True)
        if sources:
            print(
                f"\nwhat makes {base.name}'s calibrated band wide, one source at a time (reduced)"
            )
            print(BUDGET_HEAD)
            print("\n".join(sources), flush=True)
        if where:
            print(f"\nwhere {base.name}'s fit misses at each session's own latency (reduced)")
            print(MISSES_HEAD)
            print("\n".join(where), flush=True)


def row_name(ref: str) -> str:
    """A checked recording's name in the tables (a file given by its absolute path: its name)."""
    return (Path(ref).name if Path(ref).is_absolute() else ref).removeprefix("neato_")[:34]


def more_neato(folder: str) -> tuple[str, ...]:
    """Every ROS 1 bag and MCAP file in ``folder`` (absolute paths: checks of the Neato base)."""
    found = sorted(
        str(p.resolve()) for p in Path(folder).iterdir() if p.suffix in (".bag", ".mcap")
    )
    if not found:
        raise ValueError(f"{folder!r} holds no .bag or .mcap file; give a folder of recordings")
    return tuple(found)


def neato_split(split: str) -> Base:
    """The Neato base fitted on another of its recordings (``FIT[,CALIBRATE]``): every Neato
    recording that is neither the fit nor the calibration log is checked."""
    fit, _, calibrate = split.partition(",")
    neato = BASES[0]
    every = sorted({neato.fit, neato.calibrate, *neato.checks})
    for name in filter(None, (fit, calibrate)):
        if name not in every:
            raise ValueError(f"{name!r} is not a Neato recording; give one of {', '.join(every)}")
    checks = tuple(n for n in every if n not in (fit, calibrate))
    return replace(neato, fit=fit, calibrate=calibrate, checks=checks, quick_checks=checks[:3])


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument(
        "--engine",
        choices=("reduced", "pybullet", "mujoco", "both", "reduced+mujoco"),
        default="both",
        help="both: reduced and pybullet; mujoco needs the [mujoco] extra",
    )
    parser.add_argument("--quick", action="store_true", help="fewer Neato checks, reduced only")
    parser.add_argument("--base", choices=[b.name for b in BASES], action="append")
    parser.add_argument(
        "--explain", action="store_true", help="where each band's width and misses come from"
    )
    parser.add_argument(
        "--misses",
        action="store_true",
        help="where each row's own-latency agreement misses (steps, envelope, top speed)",
    )
    parser.add_argument(
        "--validate",
        action="store_true",
        help="also validate each fit on its base's calibration recording (sysid fit --validate,"
        " which judges the wheel loops' integral term); the issue's protocol does not",
    )
    parser.add_argument(
        "--more-neato",
        metavar="DIR",
        help="also check every .bag/.mcap recording in DIR on the Neato base (other units'"
        " recordings, e.g. the course repositories docs/agreement.md lists)",
    )
    parser.add_argument(
        "--budget",
        action="store_true",
        help="the calibrated band's width built up source by source (noise, posterior, the"
        " file's session spread, calibrate's session factor, its widening)",
    )
    parser.add_argument(
        "--neato-split",
        metavar="FIT[,CALIBRATE]",
        help="another Neato split: fit on FIT, calibrate on CALIBRATE (none if omitted), check"
        " every other Neato recording (the shipped split's two become checks); a check that"
        " the fixed split is not what the figures owe to",
    )
    args = parser.parse_args()
    engines = {"both": ["reduced", "pybullet"], "reduced+mujoco": ["reduced", "mujoco"]}.get(
        args.engine, [args.engine]
    )
    if args.quick and args.engine == "both":
        engines = ["reduced"]
    try:
        bases = BASES if args.neato_split is None else (neato_split(args.neato_split),)
        if args.more_neato:
            extra = more_neato(args.more_neato)
            bases = tuple(
                replace(b, checks=b.checks + extra) if b.name == "neato" else b for b in bases
            )
    except ValueError as exc:
        parser.error(f"--neato-split / --more-neato: {exc}")  # exit 2
    if not REALDATA.is_dir():
        print(f"skipped: {REALDATA} is absent")
        return
    tally: dict[str, list[int]] = {}
    t0 = time.perf_counter()
    for base in bases:
        if args.base is None or base.name in args.base:
            run_base(
                base, engines, args.quick, tally, args.explain, args.misses, args.validate,
                args.budget,
            )  # fmt: skip
    overall = {k: an for k, an in tally.items() if ":" not in k}
    print(f"\ntargets held (rows): {', '.join(f'{k} {a}/{n}' for k, (a, n) in overall.items())};"
          f" {time.perf_counter() - t0:.0f} s")  # fmt: skip
    # the headline figures of docs/benchmarks.md (results_page.py), of the shipped split only
    if not args.quick and args.neato_split is None and not args.more_neato:
        for key, (held, n) in tally.items():
            record("real bases", f"rows holding '{key}'", f"{held}/{n}", "all rows", held == n)


if __name__ == "__main__":
    main()
