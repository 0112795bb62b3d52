"""`sim2real agree` with several logs: one study per log (serial or Ray tasks), fleet summary."""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path
from typing import Any

from sim2real._io import check_output_path
from sim2real.agreement.figures import band_verdict
from sim2real.agreement.study import write_json
from sim2real.cli._common import gate_line
from sim2real.cli._progress import progress_bar
from sim2real.cluster import agree_many, fleet_summary
from sim2real.errors import LogValueError, Sim2RealValueError

__all__ = ["handle_many"]


def _pct(x: Any) -> str:
    return f"{100 * float(x):.1f} %" if x is not None and math.isfinite(float(x)) else "n/a"


def _num(x: Any, spec: str) -> str:
    return format(float(x), spec) if x is not None and math.isfinite(float(x)) else "n/a"


def _row(name: str, figures: dict[str, Any], *, band: bool, fit: bool = True) -> tuple[str, ...]:
    """One row of :func:`table`: agreement, FIT % (blank when not ``fit``: the pooled row),
    coverage with a ``band``, active samples."""
    fit_percent = (
        (_num(figures.get("fit_percent_v"), ".1f"), _num(figures.get("fit_percent_w"), ".1f"))
        if fit
        else ("", "")
    )
    return (
        name,
        _pct(figures.get("agreement")),
        _pct(figures.get("agreement_v")),
        _pct(figures.get("agreement_w")),
        *fit_percent,
        *((_pct(figures.get("coverage_v")), _pct(figures.get("coverage_w"))) if band else ()),
        str(figures.get("n_active")),
    )


def table(figures: list[dict[str, Any]], summary: dict[str, Any]) -> str:
    """One row per log and a pooled summary row, plain text; with an ensemble, the band's
    coverage of v and w in each. A log that could not be used gets a row saying why."""
    band = "coverage_v" in summary  # an ensemble ran: its band's coverage per log and pooled
    left_out = [f for f in figures if "error" in f]
    figures = [f for f in figures if "error" not in f]
    head: tuple[str, ...] = ("log", "agreement", "agr. v", "agr. w", "FIT % v", "FIT % w")
    head += ("cov. v", "cov. w", "active") if band else ("active",)
    rows = [_row(Path(str(f.get("log_file"))).name, f, band=band) for f in figures]
    rows.append(_row(f"pooled ({summary['n_logs']} logs)", summary, band=band, fit=False))
    widths = [max(len(r[i]) for r in (head, *rows)) for i in range(len(head))]
    lines = [
        "  ".join(
            c.ljust(w) if i == 0 else c.rjust(w)
            for i, (c, w) in enumerate(zip(r, widths, strict=True))
        )
        for r in (head, *rows)
    ]
    why = [f"{Path(str(f['log_file'])).name}  left out: {f['error']}" for f in left_out]
    lines[-1:-1] = why  # under the logs' rows, above the pooled row
    per_log = (
        f"per log: mean {_pct(summary['agreement_mean'])}, min {_pct(summary['agreement_min'])} "
        f"({Path(str(summary['worst_log'])).name}), max {_pct(summary['agreement_max'])}"
    )
    return "\n".join([*lines, per_log])


def handle_many(args: argparse.Namespace, logs: list[Path], base: Any) -> int:
    """Run ``base`` (a StudyConfig) on every log; print, write --json, apply --min-agreement."""
    if args.report is not None or args.sim_out is not None:
        raise Sim2RealValueError(
            f"--report and --sim-out take one log, got {len(logs)} logs; drop them, or run "
            "agree once per log for its report"
        )
    if args.json:
        check_output_path(args.json, what="--json file")
    figures = _run_all(args, logs, base)
    summary = fleet_summary(figures)
    where = "serial" if args.ray is None else f"Ray ({args.ray})"
    print(f"{len(logs)} logs: robot {args.robot}, engine {args.engine}, {where}")
    print(table(figures, summary))
    for f in figures:
        for note in f.get("notes", ()):
            print(f"note: {Path(str(f.get('log_file'))).name}: {note}")
    if summary.get("coverage_v") is not None and summary.get("coverage_w") is not None:
        verdict = band_verdict(
            coverage_v=summary["coverage_v"],
            coverage_w=summary["coverage_w"],
            band_level=summary["band_level"],
        )
        print(f"pooled over the {summary['n_logs']} logs: {verdict[0].lower()}{verdict[1:]}")
    if args.json:
        write_json(args.json, {"logs": figures, "summary": summary})
        print(f"wrote {args.json}")
    if args.min_agreement is None:
        return 0
    line, code = gate_line(summary["agreement"], args.min_agreement, what="pooled agreement")
    print(line, file=sys.stderr if code else sys.stdout)
    return code


def _run_all(args: argparse.Namespace, logs: list[Path], base: Any) -> list[dict[str, Any]]:
    """Each log's figures (a row saying why for a log that could not be used), with a bar;
    the reading warnings on stderr; refused when no log could be used."""
    configs = [dataclasses.replace(base, log=str(p), json_path=None, command_line="") for p in logs]
    with progress_bar("[bold]agree[/] logs", len(configs), counted=True) as update:
        results = agree_many(
            configs,
            address=args.ray,
            on_done=update,
            release=True,  # a local Ray started for this command stops as its work ends
        )
    for path, (_, warnings) in zip(logs, results, strict=True):
        for warning in warnings:
            print(f"sim2real: warning: {path}: {warning}", file=sys.stderr)
    figures = [fig for fig, _ in results]
    if all("error" in f for f in figures):
        raise LogValueError(
            f"none of the {len(logs)} logs could be used; the first: {figures[0]['error']}"
        )
    return figures
