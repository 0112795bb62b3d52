"""``sim2real agree``: replay a log in simulation and measure sim-vs-real agreement.

The work is done by the library (:func:`sim2real.agreement.study.run_study`, also used by
``sim2real demo``); the handler only parses arguments into a
:class:`~sim2real.agreement.study.StudyConfig`, prints the summary table and turns ``--min-agreement``
into the exit code.
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
from pathlib import Path

# light (stdlib-only at import); re-exported for callers of the old names (sim2real demo)
from sim2real.agreement.study import (
    StudyConfig,
    StudyResult,
    parse_odom_v_window,
    provenance_rows,
    summary_table,
    write_json,
)
from sim2real.cli._common import add_command, add_read_arguments

#: The old name of :class:`sim2real.agreement.study.StudyResult`.
AgreeOutcome = StudyResult

__all__ = [
    "AgreeOutcome",
    "parse_odom_v_window",
    "provenance_rows",
    "register",
    "run_agree",
    "study_config",
    "summary_table",
    "write_json",
]


_EXAMPLES = """\
  sim2real agree val.mcap --robot turtlebot3_burger
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --report report.html
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --json agree.json \\
      --min-agreement 0.9          # CI gate: exit 1 below 90 %
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --ensemble 20 --seed 1
  sim2real agree test.mcap --robot turtlebot2 --params calibrated.yaml --ensemble 30 \\
      --band-level 0.9 --json agree.json   # coverage_v/_w and band widths of the 90 % band
  sim2real agree val.mcap --robot turtlebot3_burger --engine reduced --sim-out sim.mcap
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml \\
      --odom-v-window 0            # compare the instantaneous simulated v
  sim2real agree neato.bag --robot neato.yaml --params p.yaml --odom-velocity pose
  sim2real agree 'fleet/*.mcap' --robot turtlebot3_burger --params params.yaml \\
      --json fleet.json --ray auto # one Ray task per log; {"logs": [...], "summary": {...}}
"""

_DESCRIPTION = """\
Replay the commanded velocities of LOG.mcap, at their logged times, on the simulated robot
(pybullet by default, or the reduced drive model) with the spec's default drive parameters or
a sysid result (--params), and compare the simulated base velocity with the measured one at
every odometry time.

Only active samples count (a command is held or the robot moves). A sample agrees when
|v_sim - v_real| <= tol_v and |w_sim - w_real| <= tol_w. --json writes agreement,
agreement_v, agreement_w, fit_percent_v, fit_percent_w, rmse_v, rmse_w, lag_s_v, lag_s_w,
n_samples, n_active, tol_v, tol_w, robot, params_file, log_file, log_sha256. The simulated
v is averaged over the preceding --odom-v-window, as wheel-encoder odometry reports v; the
default 'auto' takes it from the robot spec (one odometry period for an encoder base), like
'sysid fit'.

With --ensemble N, N robots are drawn from the params file's 'randomization' block (the
sampler DynamicsRandomizer.from_sysid uses in training: same --seed, same robots), each
simulated trace gets the file's odometry noise (as VelocityObservationNoise adds it), and the
central --band-level band of these traces is the predictive band; --json then adds coverage,
coverage_v, coverage_w (share of active real samples inside the band), band_level,
band_width_v_mps, band_width_w_radps (median width), ensemble_n and coverage_by_level, and a
sentence says whether the band is too narrow, calibrated (80-99 % for a 90 % band) or too
wide. Fit the spread to a validation log with 'sim2real sysid calibrate'.
A figure undefined on the log (the lag of v on a spin in place) is left out of the JSON,
with a note naming it; the JSON never holds null for a number. With several logs, a log that
cannot be used gets a row saying why and the others go on.
Exit codes: 0 ok, 1 agreement below --min-agreement, 2 bad input (also when nothing can be
compared: no active sample, no measured motion, or no log of several could be used).
"""


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``sim2real agree``."""
    p = add_command(
        sub,
        "agree",
        help="replay a log in simulation and measure sim-vs-real velocity agreement",
        description=_DESCRIPTION,
        examples=_EXAMPLES,
    )
    p.add_argument(
        "log",
        metavar="LOG",
        nargs="+",
        help=(
            "the real log(s): .mcap files, ROS 1 .bag, rosbag2 folders or .csv; paths or quoted "
            "globs ('fleet/*.mcap'); several logs print one row each and a fleet summary"
        ),
    )
    p.add_argument("--robot", required=True, help="robot name (see 'sim2real robots list')")
    p.add_argument("--params", metavar="PARAMS.yaml", help="sysid result (default: spec values)")
    p.add_argument(
        "--engine", choices=("pybullet", "reduced"), default="pybullet", help="simulator"
    )
    p.add_argument("--tol-v", type=float, default=0.02, help="tolerance on v, m/s")
    p.add_argument("--tol-w", type=float, default=0.1, help="tolerance on w, rad/s")
    p.add_argument("--json", metavar="OUT.json", help="write the figures as JSON")
    p.add_argument("--report", metavar="OUT.html", help="write the HTML report (+ PNGs)")
    p.add_argument("--sim-out", metavar="SIM.mcap", help="write the simulated run as MCAP")
    p.add_argument(
        "--min-agreement", type=float, metavar="F", help="exit 1 when agreement < F (0..1)"
    )
    p.add_argument(
        "--ensemble",
        type=int,
        metavar="N",
        help="also replay N robots drawn from the params file's randomisation (N >= 2) and "
        "measure how much of the log their predictive band covers",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the ensemble draws")
    p.add_argument(
        "--spread",
        type=float,
        default=1.0,
        help="multiply every standard deviation of the ensemble draws, dynamics and noise "
        "(1 = the params file's; prefer 'sim2real sysid calibrate' over tuning this by hand)",
    )
    p.add_argument(
        "--band-level",
        type=float,
        default=0.9,
        metavar="P",
        help="central probability of the ensemble's predictive band, in (0, 1) (default 0.9)",
    )
    p.add_argument(
        "--odom-v-window",
        default="auto",
        metavar="S|auto",
        help=(
            "odometry v is a wheel-encoder tick difference over this window, s; the simulated v "
            "is averaged the same way (default 'auto': from the spec's odometry, one period for "
            "an encoder base, e.g. 1/30 s on a TurtleBot3, 0 otherwise; like 'sysid fit'); "
            "0 = compare the instantaneous simulated v"
        ),
    )
    add_read_arguments(p)
    p.add_argument(
        "--ray",
        metavar="auto|ADDRESS",
        help=(
            "with several logs, run one Ray task per log: 'auto' joins the running cluster or "
            "starts a local one, ADDRESS is a head node (needs the [cluster] extra)"
        ),
    )
    p.set_defaults(handler=_handle)


def run_agree(
    *,
    log: str | Path,
    robot: str,
    params_path: str | Path | None = None,
    engine: str = "pybullet",
    tol_v: float = 0.02,
    tol_w: float = 0.1,
    ensemble_n: int | None = None,
    seed: int = 0,
    spread: float = 1.0,
    band_level: float = 0.9,
    odom_v_window: float | str = "auto",
    cmd_topic: str | None = None,
    odom_topic: str | None = None,
    json_path: str | Path | None = None,
    report_path: str | Path | None = None,
    sim_out: str | Path | None = None,
    command_line: str = "",
    title: str = "sim2real agreement report",
) -> StudyResult:
    """Keyword form of :func:`sim2real.agreement.study.run_study` (kept for callers of the old API)."""
    from sim2real.agreement.study import StudyConfig, run_study

    return run_study(
        StudyConfig(
            log=log,
            robot=robot,
            params_path=params_path,
            engine=engine,
            tol_v=tol_v,
            tol_w=tol_w,
            ensemble_n=ensemble_n,
            seed=seed,
            spread=spread,
            band_level=band_level,
            odom_v_window=odom_v_window,
            cmd_topic=cmd_topic,
            odom_topic=odom_topic,
            json_path=json_path,
            report_path=report_path,
            sim_out=sim_out,
            command_line=command_line,
            title=title,
        )
    )


def _single_log(args: argparse.Namespace) -> str:
    """The one log of ``args`` (``log`` is a list of one after parsing)."""
    log = args.log
    return str(log[0]) if isinstance(log, list) else str(log)


def _command_line(args: argparse.Namespace) -> str:
    parts = ["sim2real", "agree", _single_log(args), "--robot", args.robot]
    for flag, value in (
        ("--params", args.params),
        ("--engine", args.engine),
        ("--tol-v", args.tol_v),
        ("--tol-w", args.tol_w),
        ("--json", args.json),
        ("--report", args.report),
        ("--sim-out", args.sim_out),
        ("--min-agreement", args.min_agreement),
        ("--ensemble", args.ensemble),
        ("--seed", args.seed if args.ensemble is not None else None),
        ("--spread", args.spread if args.ensemble is not None else None),
        ("--band-level", args.band_level if args.ensemble is not None else None),
        ("--odom-v-window", args.odom_v_window if args.odom_v_window != "auto" else None),
        ("--cmd-topic", args.cmd_topic),
        ("--odom-topic", args.odom_topic),
        ("--time-source", args.time_source if args.time_source != "auto" else None),
        ("--odom-velocity", args.odom_velocity if args.odom_velocity != "auto" else None),
    ):
        if value is not None:
            parts += [flag, str(value)]
    if getattr(args, "keep_all", False):
        parts.append("--keep-all")
    return shlex.join(parts)


def study_config(args: argparse.Namespace) -> StudyConfig:
    """The :class:`~sim2real.agreement.study.StudyConfig` of parsed ``sim2real agree`` arguments.

    ``sim2real demo`` parses the README tour's ``agree`` command line and runs this config, so
    the demo and the tour compute the same figures.
    """
    return StudyConfig(
        log=_single_log(args),
        robot=args.robot,
        params_path=args.params,
        engine=args.engine,
        tol_v=args.tol_v,
        tol_w=args.tol_w,
        ensemble_n=args.ensemble,
        seed=args.seed,
        spread=args.spread,
        band_level=args.band_level,
        odom_v_window=args.odom_v_window,
        cmd_topic=args.cmd_topic,
        odom_topic=args.odom_topic,
        time_source=args.time_source,
        odom_velocity=args.odom_velocity,
        keep_all=args.keep_all,
        json_path=args.json,
        report_path=args.report,
        sim_out=args.sim_out,
        command_line=_command_line(args),
    )


def _refuse_ensemble_options(args: argparse.Namespace) -> None:
    """Refuse --seed/--spread/--band-level without --ensemble (they would be silently ignored)."""
    from sim2real.errors import Sim2RealValueError

    given = [
        flag
        for flag, value, default in (
            ("--seed", args.seed, 0),
            ("--spread", args.spread, 1.0),
            ("--band-level", args.band_level, 0.9),
        )
        if value != default
    ]
    if given:
        raise Sim2RealValueError(
            f"{', '.join(given)} only shape the ensemble's predictive band, which needs "
            "--ensemble N; add e.g. --ensemble 20 --params params.yaml, or drop "
            f"{', '.join(given)}"
        )


def _run_with_bar(config: StudyConfig, n: int | None) -> StudyResult:
    """Run the study; with an ensemble, a progress bar on a terminal (stderr), none in a pipe."""
    from sim2real.agreement.study import run_study

    if n is None:  # one replay: no bar (and no rich to import)
        return run_study(config)
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    err = Console(stderr=True)
    with Progress(
        TextColumn("[bold]agree[/] ensemble"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err,
        transient=True,
        disable=not err.is_terminal,
    ) as bar:
        task = bar.add_task("ensemble", total=n)
        return run_study(config, progress=lambda done, _: bar.update(task, completed=done))


def _handle(args: argparse.Namespace) -> int:
    from sim2real.errors import Sim2RealValueError

    gate = args.min_agreement
    if gate is not None and not (math.isfinite(gate) and 0.0 <= gate <= 1.0):
        raise Sim2RealValueError(
            f"--min-agreement must be a fraction between 0 and 1, got {gate!r}; "
            "e.g. --min-agreement 0.9 for 90 %"
        )
    if args.ensemble is None:
        _refuse_ensemble_options(args)
    from sim2real.cluster import expand_logs

    logs = expand_logs(args.log)
    if len(logs) > 1:
        from sim2real.cli._agree_many import handle_many

        return handle_many(args, logs, study_config(args))
    args.log = str(logs[0])
    result = _run_with_bar(study_config(args), args.ensemble)
    for warning in result.warnings:  # data repaired while reading: say so, do not hide it
        print(f"sim2real: warning: {args.log}: {warning}", file=sys.stderr)
    print(f"{args.log}: robot {args.robot}, engine {args.engine}")
    print(summary_table(result.runs, result.ensemble))
    if result.verdict is not None:  # the one verdict, as the report words it
        print("\n".join(result.verdict.lines()))
    for note in result.notes:
        print(f"note: {note}")
    if result.time_note:
        print(f"note: {result.time_note}")
    for path in result.written:
        print(f"wrote {path}")
    agreement = result.main.agreement
    if gate is not None and not (math.isfinite(agreement) and agreement >= gate):
        print(
            f"agreement {100 * agreement:.1f} % is below --min-agreement {100 * gate:.1f} %",
            file=sys.stderr,
        )
        return 1
    return 0
