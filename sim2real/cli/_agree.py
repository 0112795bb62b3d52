"""``sim2real agree``: replay a log in simulation and measure sim-vs-real agreement.

The work is done by :func:`run_agree` (also used by ``sim2real demo``); the handler only
parses arguments, prints the summary table and turns ``--min-agreement`` into the exit code.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import shlex
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sim2real.cli._common import add_command

if TYPE_CHECKING:  # the CLI imports the heavy modules inside the handlers only
    from sim2real.agreement import AgreementReport, EnsembleResult
    from sim2real.report import ReportRun

__all__ = ["AgreeOutcome", "parse_odom_v_window", "register", "run_agree", "summary_table"]

_EXAMPLES = """\
  sim2real agree val.mcap --robot turtlebot3_burger
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --report report.html
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --json agree.json \\
      --min-agreement 0.9          # CI gate: exit 1 below 90 %
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --ensemble 20 --seed 1
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --ensemble 20 \
      --spread 5                   # is a 5x wider randomisation wide enough? (coverage)
  sim2real agree val.mcap --robot turtlebot3_burger --engine reduced --sim-out sim.mcap
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml \
      --odom-v-window auto         # compare v as the encoder odometry reports it
"""

_DESCRIPTION = """\
Replay the commanded velocities of LOG.mcap, at their logged times, on the simulated robot
(pybullet by default, or the reduced drive model) with the spec's default drive parameters or
a sysid result (--params), and compare the simulated base velocity with the measured one at
every odometry time.

Only active samples count (a command is held or the robot moves). A sample agrees when
|v_sim - v_real| <= tol_v and |w_sim - w_real| <= tol_w. --json writes agreement,
agreement_v, agreement_w, fit_percent_v, fit_percent_w, rmse_v, rmse_w, lag_s_v, lag_s_w,
n_samples, n_active, tol_v, tol_w, robot, params_file, log_file, log_sha256 (plus coverage
with --ensemble). With --odom-v-window the simulated v is averaged over the preceding window,
as wheel-encoder odometry reports v (use the same window as 'sysid fit --odom-v-window').
Exit codes: 0 ok, 1 agreement below --min-agreement, 2 bad input.
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
    p.add_argument("log", metavar="LOG.mcap", help="the real log (ROS 2 MCAP)")
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
        "--ensemble", type=int, metavar="N", help="also run N sims sampled from the params' std"
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the ensemble draws")
    p.add_argument(
        "--spread",
        type=float,
        default=1.0,
        help="multiply every std of the ensemble draws (1 = the sysid uncertainty)",
    )
    p.add_argument(
        "--odom-v-window",
        default="0",
        metavar="S|auto",
        help=(
            "odometry v is a wheel-encoder tick difference over this window, s ('auto': one "
            "period of the spec's odometry rate, e.g. 1/30 s on a TurtleBot3); the simulated v "
            "is averaged the same way; 0 = compare the instantaneous simulated v (default)"
        ),
    )
    p.add_argument("--cmd-topic", help="command topic (default: auto-detect)")
    p.add_argument("--odom-topic", help="odometry topic (default: auto-detect)")
    p.set_defaults(handler=_handle)


@dataclass(frozen=True, kw_only=True)
class AgreeOutcome:
    """What :func:`run_agree` computed.

    Attributes
    ----------
    main : AgreementReport
        The figures of the requested configuration (the params file, else the spec defaults).
    runs : tuple of ReportRun
        Every replay made (spec defaults first, then the params file when given).
    ensemble : EnsembleResult or None
        The ensemble, when requested.
    warnings : tuple of str
        Repairs made while reading the log (dropped NaN samples, re-sorted stamps, ...).
    """

    main: AgreementReport
    runs: tuple[ReportRun, ...]
    ensemble: EnsembleResult | None
    warnings: tuple[str, ...] = ()


def _sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _versions() -> str:
    import platform
    from importlib.metadata import PackageNotFoundError, version

    parts = [f"python {platform.python_version()}"]
    for dist in ("sim2real", "numpy", "scipy", "pybullet", "mcap", "matplotlib"):
        try:
            parts.append(f"{dist} {version(dist)}")
        except PackageNotFoundError:
            parts.append(f"{dist} (not installed)")
    return ", ".join(parts)


def provenance_rows(
    *,
    files: Sequence[tuple[str, str | Path]],
    robot: Any,
    engine: str,
    seed: int | None,
    command_line: str,
    odom_v_window_s: float = 0.0,
) -> list[tuple[str, str]]:
    """Provenance lines of a report: files with SHA-256, spec, versions, seed, command."""
    rows = [(role, f"{path}  (sha256 {_sha256(path)})") for role, path in files]
    spec_path = getattr(robot, "path", None)
    rows.append(("robot spec", f"{robot.name}" + (f"  ({spec_path})" if spec_path else "")))
    rows.append(("engine", engine))
    if odom_v_window_s:
        rows.append(("odometry v window", f"{odom_v_window_s:.4g} s (simulated v averaged)"))
    rows.append(("ensemble seed", "n/a" if seed is None else str(seed)))
    rows.append(("versions", _versions()))
    rows.append(("command line", command_line))
    return rows


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
    odom_v_window: float | str = 0.0,
    cmd_topic: str | None = None,
    odom_topic: str | None = None,
    report_path: str | Path | None = None,
    sim_out: str | Path | None = None,
    command_line: str = "",
    title: str = "sim2real agreement report",
) -> AgreeOutcome:
    """Replay ``log`` with spec defaults (and ``params_path``), measure, write the outputs.

    ``odom_v_window`` is the odometry window of v in seconds, or ``"auto"`` for one period of
    the spec's odometry rate (see :func:`sim2real.replay.replay`).
    """
    from robots.params import load_drive_params, read_params_file
    from robots.spec import load_spec
    from sim2real._io import check_not_an_input, check_output_path
    from sim2real.agreement import check_tolerances, measure_agreement, run_ensemble
    from sim2real.errors import Sim2RealValueError
    from sim2real.logs import read_trace
    from sim2real.replay import replay
    from sim2real.report import ReportInput, ReportRun, param_rows, write_report

    check_tolerances(tol_v, tol_w)
    for path, what in ((report_path, "report file"), (sim_out, "--sim-out file")):
        if path is not None:
            check_output_path(path, what=what)
            check_not_an_input(path, [log, params_path], what=what)
    if ensemble_n is not None and params_path is None:
        raise Sim2RealValueError(
            "--ensemble needs --params: the ensemble draws parameters from the standard "
            "deviations of a sysid result; add --params params.yaml"
        )
    spec = load_spec(robot)
    window_s = parse_odom_v_window(odom_v_window, spec.odometry.rate_hz)
    params = None
    if params_path is not None:
        params = load_drive_params(params_path, robot=spec.name, base=spec.drive)
    trace = read_trace(log, cmd_topic=cmd_topic, odom_topic=odom_topic)
    runs = []
    configs: list[tuple[str, Any, str | None]] = [("spec defaults", spec.drive, None)]
    if params is not None:
        configs.append(("sysid params", params, str(params_path)))
    for label, p, pfile in configs:
        sim = replay(trace, robot=spec, params=p, engine=engine, odom_v_window_s=window_s)
        rep = measure_agreement(trace, sim, tol_v=tol_v, tol_w=tol_w, params_file=pfile)
        runs.append(ReportRun(label=label, replay=sim, agreement=rep))
    ensemble = None
    if ensemble_n is not None and params is not None:
        stds = read_params_file(params_path).stds  # type: ignore[arg-type]
        ensemble = run_ensemble(
            trace,
            robot=spec,
            params=params,
            stds=stds,
            n=ensemble_n,
            seed=seed,
            spread=spread,
            engine=engine,
            tol_v=tol_v,
            tol_w=tol_w,
            odom_v_window_s=window_s,
        )
    if sim_out is not None:
        _write_sim_log(sim_out, trace, runs[-1].replay)
    if report_path is not None:
        files: list[tuple[str, str | Path]] = [("log", log)]
        if params_path is not None:
            files.append(("params", params_path))
        write_report(
            report_path,
            ReportInput(
                trace=trace,
                runs=tuple(runs),
                ensemble=ensemble,
                params=param_rows(spec.drive, runs[-1].replay.params, params_path),
                provenance=provenance_rows(
                    files=files,
                    robot=spec,
                    engine=engine,
                    seed=seed if ensemble is not None else None,
                    command_line=command_line,
                    odom_v_window_s=window_s,
                ),
                title=title,
            ),
        )
    return AgreeOutcome(
        main=runs[-1].agreement, runs=tuple(runs), ensemble=ensemble, warnings=trace.meta.warnings
    )


def parse_odom_v_window(value: float | str, rate_hz: float) -> float:
    """Seconds of ``--odom-v-window``: a number in [0, 1] or ``"auto"`` (``1 / rate_hz``)."""
    from sim2real.errors import Sim2RealValueError

    if isinstance(value, str) and value.strip() == "auto":
        return 1.0 / rate_hz
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        seconds = math.nan
    if not (math.isfinite(seconds) and 0.0 <= seconds <= 1.0):
        raise Sim2RealValueError(
            f"--odom-v-window must be 'auto' or seconds in [0, 1], got {value!r}; e.g. "
            "--odom-v-window auto (one odometry period) or 0.0333"
        )
    return seconds


def _write_sim_log(path: str | Path, trace: Any, sim: Any) -> None:
    """The replayed commands and the simulated velocities (at the real stamps) as MCAP.

    The odometry pose is dead-reckoned from the simulated (v, w) by the writer.
    """
    from sim2real.logs import write_velocity_log

    write_velocity_log(
        path,
        cmd_t_ns=trace.cmd_t_ns,
        cmd_v=trace.cmd_v,
        cmd_w=trace.cmd_w,
        meas_t_ns=sim.t_ns,
        meas_v=sim.v,
        meas_w=sim.w,
    )


def summary_table(runs: Sequence[Any], ensemble: Any = None) -> str:
    """A plain-text table of the agreement figures, one column per replay."""

    def pct(x: float) -> str:
        return f"{100 * x:.1f} %" if math.isfinite(x) else "n/a"

    def num(x: float, spec: str) -> str:
        return format(x, spec) if math.isfinite(x) else "n/a"

    lines = [("", [r.label for r in runs])]
    a = [r.agreement for r in runs]
    lines += [
        ("agreement", [pct(x.agreement) for x in a]),
        ("agreement v", [pct(x.agreement_v) for x in a]),
        ("agreement w", [pct(x.agreement_w) for x in a]),
        ("FIT % v", [num(x.fit_percent_v, ".1f") for x in a]),
        ("FIT % w", [num(x.fit_percent_w, ".1f") for x in a]),
        ("RMSE v [m/s]", [num(x.rmse_v, ".4f") for x in a]),
        ("RMSE w [rad/s]", [num(x.rmse_w, ".4f") for x in a]),
        ("lag v [s]", [num(x.lag_s_v, "+.3f") for x in a]),
        ("lag w [s]", [num(x.lag_s_w, "+.3f") for x in a]),
        ("active/samples", [f"{x.n_active}/{x.n_samples}" for x in a]),
    ]
    if ensemble is not None:
        lines.append((f"coverage (N={ensemble.n})", ["", pct(ensemble.coverage)][-len(runs) :]))
    w0 = max(len(k) for k, _ in lines)
    widths = [max(len(row[i]) for _, row in lines) for i in range(len(runs))]
    out = []
    for key, row in lines:
        cells = "  ".join(c.rjust(w) for c, w in zip(row, widths, strict=True))
        out.append(f"{key.ljust(w0)}  {cells}")
    return "\n".join(out)


def _command_line(args: argparse.Namespace) -> str:
    parts = ["sim2real", "agree", str(args.log), "--robot", args.robot]
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
        ("--odom-v-window", args.odom_v_window if args.odom_v_window != "0" else None),
        ("--cmd-topic", args.cmd_topic),
        ("--odom-topic", args.odom_topic),
    ):
        if value is not None:
            parts += [flag, str(value)]
    return shlex.join(parts)


def write_json(path: str | Path, figures: dict[str, Any]) -> None:
    """Write ``figures`` as pretty JSON (NaN already mapped to null) via a temp file."""
    from sim2real._io import atomic_write

    with atomic_write(path, "wb", what="--json file") as fh:
        fh.write((json.dumps(figures, indent=2, allow_nan=False) + "\n").encode("utf-8"))


def _handle(args: argparse.Namespace) -> int:
    from sim2real._io import check_not_an_input, check_output_path
    from sim2real.errors import Sim2RealValueError

    gate = args.min_agreement
    if gate is not None and not (math.isfinite(gate) and 0.0 <= gate <= 1.0):
        raise Sim2RealValueError(
            f"--min-agreement must be a fraction between 0 and 1, got {gate!r}; "
            "e.g. --min-agreement 0.9 for 90 %"
        )
    if args.ensemble is not None and args.ensemble < 2:
        raise Sim2RealValueError(
            f"--ensemble must be an integer >= 2, got {args.ensemble}; e.g. --ensemble 20"
        )
    if args.json is not None:
        check_output_path(args.json, what="--json file")
        check_not_an_input(args.json, [args.log, args.params], what="--json file")
    outcome = run_agree(
        log=args.log,
        robot=args.robot,
        params_path=args.params,
        engine=args.engine,
        tol_v=args.tol_v,
        tol_w=args.tol_w,
        ensemble_n=args.ensemble,
        seed=args.seed,
        spread=args.spread,
        odom_v_window=args.odom_v_window,
        cmd_topic=args.cmd_topic,
        odom_topic=args.odom_topic,
        report_path=args.report,
        sim_out=args.sim_out,
        command_line=_command_line(args),
    )
    for warning in outcome.warnings:  # data repaired while reading: say so, do not hide it
        print(f"sim2real: warning: {args.log}: {warning}", file=sys.stderr)
    figures = outcome.main.to_dict()
    if outcome.ensemble is not None:
        cov = outcome.ensemble.coverage
        figures["coverage"] = cov if math.isfinite(cov) else None
    if args.json is not None:
        write_json(args.json, figures)
    print(f"{args.log}: robot {args.robot}, engine {args.engine}")
    print(summary_table(outcome.runs, outcome.ensemble))
    for path in (args.json, args.report, args.sim_out):
        if path is not None:
            print(f"wrote {path}")
    agreement = outcome.main.agreement
    if gate is not None and not (math.isfinite(agreement) and agreement >= gate):
        print(
            f"agreement {100 * agreement:.1f} % is below --min-agreement {100 * gate:.1f} %",
            file=sys.stderr,
        )
        return 1
    return 0
