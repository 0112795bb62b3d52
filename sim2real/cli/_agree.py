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

from sim2real.agreement.study import StudyConfig, StudyResult, run_study, summary_table
from sim2real.cli._agree_many import handle_many
from sim2real.cli._common import gate_line, read_options
from sim2real.cli._progress import progress_bar
from sim2real.cluster import expand_logs
from sim2real.errors import Sim2RealValueError

__all__ = ["handle_agree", "study_config"]


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
        read=read_options(args),
        json_path=args.json,
        report_path=args.report,
        sim_out=args.sim_out,
        command_line=_command_line(args),
    )


def _refuse_ensemble_options(args: argparse.Namespace) -> None:
    """Refuse --seed/--spread/--band-level without --ensemble (they would be silently ignored)."""
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
    if n is None:  # one replay: no bar (and no rich to import)
        return run_study(config)
    with progress_bar("[bold]agree[/] ensemble", n, counted=True) as update:
        return run_study(config, progress=lambda done, _: update(done))


def _check_gate(gate: float | None) -> None:
    if gate is not None and not (math.isfinite(gate) and 0.0 <= gate <= 1.0):
        raise Sim2RealValueError(
            f"--min-agreement must be a fraction between 0 and 1, got {gate!r}; "
            "e.g. --min-agreement 0.9 for 90 %"
        )


def handle_agree(args: argparse.Namespace) -> int:
    """``agree LOG...``: replay, print the table and the band's verdict, apply the gate."""
    _check_gate(args.min_agreement)
    if args.ensemble is None:
        _refuse_ensemble_options(args)
    logs = expand_logs(args.log)
    if len(logs) > 1:
        return handle_many(args, logs, study_config(args))
    args.log = str(logs[0])
    result = _run_with_bar(study_config(args), args.ensemble)
    for warning in result.warnings:  # data repaired while reading: say so, do not hide it
        print(f"sim2real: warning: {args.log}: {warning}", file=sys.stderr)
    print(f"{args.log}: robot {args.robot}, engine {args.engine}")
    print(
        summary_table(result.runs, result.ensemble, latency=result.latency, ceiling=result.ceiling)
    )
    if result.verdict is not None:  # the one verdict, as the report words it
        print("\n".join(result.verdict.lines()))
    for note in result.notes:
        print(f"note: {note}")
    if result.time_note:
        print(f"note: {result.time_note}")
    for path in result.written:
        print(f"wrote {path}")
    if args.min_agreement is None:
        return 0
    line, code = gate_line(result.main.agreement, args.min_agreement)
    print(line, file=sys.stderr if code else sys.stdout)
    return code
