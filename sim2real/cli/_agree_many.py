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
from sim2real.agreement.report import write_fleet_report
from sim2real.agreement.study import write_json
from sim2real.agreement.verdict import AgreementVerdict
from sim2real.cli._common import gate_line
from sim2real.cli._progress import progress_bar
from sim2real.cluster import agree_many, fleet_summary
from sim2real.errors import LogValueError, Sim2RealValueError

__all__ = ["handle_many", "table", "verdict_lines"]


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


def _table_rows(
    figures: list[dict[str, Any]], summary: dict[str, Any]
) -> tuple[tuple[str, ...], list[tuple[str, ...]]]:
    """The fleet table's header and rows: one per log that could be used, then the pooled."""
    band = "coverage_v" in summary  # an ensemble ran: its band's coverage per log and pooled
    head: tuple[str, ...] = ("log", "agreement", "agr. v", "agr. w", "FIT % v", "FIT % w")
    head += ("cov. v", "cov. w", "active") if band else ("active",)
    rows = [
        _row(Path(str(f.get("log_file"))).name, f, band=band) for f in figures if "error" not in f
    ]
    rows.append(_row(f"pooled ({summary['n_logs']} logs)", summary, band=band, fit=False))
    return head, rows


def table(figures: list[dict[str, Any]], summary: dict[str, Any]) -> str:
    """One row per log and a pooled summary row, plain text; with an ensemble, the band's
    coverage of v and w in each. A log that could not be used gets a row saying why."""
    left_out = [f for f in figures if "error" in f]
    head, rows = _table_rows(figures, summary)
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


def verdict_lines(figures: list[dict[str, Any]]) -> list[str]:
    """Each usable log's verdict as ``agree`` prints it for that log alone, its name in the
    first line (``verdict (a.mcap): ...``)."""
    out: list[str] = []
    for f in figures:
        if isinstance(f.get("verdict"), dict):
            name = Path(str(f.get("log_file"))).name
            out += AgreementVerdict.from_dict(f["verdict"]).lines(about=name)
    return out


def handle_many(args: argparse.Namespace, logs: list[Path], base: Any) -> int:
    """Run ``base`` (a StudyConfig) on every log; print, write --json, apply --min-agreement."""
    if args.sim_out is not None:
        raise Sim2RealValueError(
            f"--sim-out takes one log, got {len(logs)} logs; drop it, or run agree once per "
            "log for its simulated log"
        )
    for path, what in ((args.json, "--json file"), (args.report, "report file")):
        if path:
            check_output_path(path, what=what)
    figures = _run_all(args, logs, base)
    summary = fleet_summary(figures)
    where = "serial" if args.ray is None else f"Ray ({args.ray})"
    subtitle = f"{len(logs)} logs: robot {args.robot}, engine {args.engine}, {where}"
    print(subtitle)
    print(table(figures, summary))
    for line in verdict_lines(figures):
        print(line)
    for f in figures:
        for note in f.get("notes", ()):
            print(f"note: {Path(str(f.get('log_file'))).name}: {note}")
    pooled = ""
    if summary.get("coverage_v") is not None and summary.get("coverage_w") is not None:
        verdict = band_verdict(
            coverage_v=summary["coverage_v"],
            coverage_w=summary["coverage_w"],
            band_level=summary["band_level"],
        )
        pooled = f"pooled over the {summary['n_logs']} logs: {verdict[0].lower()}{verdict[1:]}"
        print(pooled)
    if args.json:
        write_json(args.json, {"logs": figures, "summary": summary})
        print(f"wrote {args.json}")
    if args.report:
        head, rows = _table_rows(figures, summary)
        write_fleet_report(
            args.report, figures=figures, header=head, rows=rows, subtitle=subtitle, pooled=pooled
        )
        print(f"wrote {args.report}")
    if args.min_agreement is None:
        return 0
    line, code = gate_line(summary["agreement"], args.min_agreement, what="pooled agreement")
    print(line, file=sys.stderr if code else sys.stdout)
    return code


def _run_all(args: argparse.Namespace, logs: list[Path], base: Any) -> list[dict[str, Any]]:
    """Each log's figures (a row saying why for a log that could not be used), with a bar;
    the reading warnings on stderr; refused when no log could be used."""
    configs = [
        dataclasses.replace(
            base, log=str(p), json_path=None, report_path=None, sim_out=None, command_line=""
        )
        for p in logs
    ]
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
