"""`sim2real sysid show`, and the tables of a sysid result that `sysid fit` prints too.

Light: rich and :class:`sysid.SysidResult` only, so ``sysid show`` loads no fitting code.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from sysid import ParameterEstimate, SysidResult

__all__ = ["handle_show", "print_result", "stdout_console"]


def handle_show(args: argparse.Namespace) -> int:
    """``sysid show PARAMS.yaml``: print a result file's tables."""
    print_result(stdout_console(), SysidResult.load(args.params))
    return 0


def stdout_console() -> Console:
    """stdout console; wide when not a terminal so piped tables keep one row per line."""
    probe = Console()
    return probe if probe.is_terminal else Console(width=160)


def _fmt(x: float | None) -> str:
    if x is None:
        return "-"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if math.isnan(x):
        return "nan"
    return f"{x:.4g}"


def _prior_text(result: SysidResult, name: str) -> str:
    p = result.priors.get(name)
    if not p or not p.get("sd"):
        return "-"
    return f"{_fmt(p['nominal'])} ± {_fmt(p['sd'])} ({p['coord']})"


def _estimate_rows(
    result: SysidResult, estimates: tuple[ParameterEstimate, ...], boot: dict[str, float]
) -> list[tuple[str, ...]]:
    rows: list[tuple[str, ...]] = []
    for e in estimates:
        ci = "-" if e.ci95_low is None else f"[{_fmt(e.ci95_low)}, {_fmt(e.ci95_high)}]"
        row: tuple[str, ...] = (e.name, _fmt(e.value), _fmt(e.std), ci, e.unit, e.status)
        if e.coord is not None:
            row = (*row, _prior_text(result, e.name), _fmt(e.sd_ratio))
        rows.append((*row, _fmt(boot.get(e.name))) if boot else row)
    return rows


def _print_population(console: Console, result: SysidResult) -> None:
    """The randomisation distribution (and the per-session estimates of a fleet)."""
    dist = result.randomization
    if dist is None:
        return
    title = (
        f"randomization: population of {len(result.sessions)} sessions"
        if result.sessions
        else "randomization: posterior + default between-session spread"
    )
    table = Table(title=title, title_justify="left")
    for col in ("parameter", "coordinate", "mean value", "sd (coordinate)"):
        table.add_column(col)
    sessions = [s["log"] for s in result.sessions]
    for name in sessions:
        table.add_column(Path(name).name)
    mean = dist.mean_params()
    for name, coord, sd in zip(dist.names, dist.coords, dist.std().values(), strict=True):
        per_log = [s["parameters"].get(name, {}).get("value") for s in result.sessions]
        table.add_row(name, coord, _fmt(getattr(mean, name)), _fmt(sd), *[_fmt(v) for v in per_log])
    console.print(table)
    n = dist.noise
    console.print(
        f"odometry noise: v {n.std_v_mps:.4g} m/s (quantum {n.quantum_v_mps:.4g}), "
        f"w {n.std_w_radps:.4g} rad/s (quantum {n.quantum_w_radps:.4g})"
    )


def _fit_pct(x: float) -> str:
    return f"{x:.1f}" if math.isfinite(x) else "-"


def _undefined_scores(result: SysidResult) -> list[str]:
    """One note per FIT % that a log leaves undefined (its measured axis is constant)."""
    return [
        f"FIT % {axis} is undefined on {Path(s.log).name}: its measured {axis} is constant "
        f"(a log that {'spins in place' if axis == 'v' else 'drives straight'})"
        for s in (*result.scores_fit, *result.scores_validation)
        for axis, x in (("v", s.fit_percent_v), ("w", s.fit_percent_w))
        if not math.isfinite(x)
    ]


def _scores_table(result: SysidResult) -> Table:
    """FIT %, agreement and RMSE of each fitting and validation log."""
    scores = Table(title="scores", title_justify="left")
    for col in (
        "log",
        "role",
        "FIT % v",
        "FIT % w",
        "agreement",
        "agr. v",
        "agr. w",
        "RMSE v",
        "RMSE w",
    ):
        scores.add_column(col)
    for role, items in (("fit", result.scores_fit), ("validation", result.scores_validation)):
        for s in items:
            scores.add_row(
                Path(s.log).name,
                role,
                _fit_pct(s.fit_percent_v),
                _fit_pct(s.fit_percent_w),
                f"{100 * s.agreement:.1f} %",
                f"{100 * s.agreement_v:.1f} %",
                f"{100 * s.agreement_w:.1f} %",
                f"{s.rmse_v:.4f}",
                f"{s.rmse_w:.4f}",
            )
    return scores


def print_result(console: Console, result: SysidResult) -> None:
    """A result's tables (estimates, identifiable combinations, population, scores) and notes."""
    for title, estimates, boot in (
        (f"drive parameters of {result.robot}", result.estimates, result.bootstrap_std),
        (
            "identifiable combinations (independent of the motor-gain prior)",
            result.identifiable,
            {},
        ),
    ):
        table = Table(title=title, title_justify="left")
        cols = ["parameter", "value", "std", "95 % interval", "unit", "status"]
        if any(e.coord is not None for e in estimates):
            cols += ["prior (coordinate sd)", "post/prior sd"]
        for col in cols + (["bootstrap std"] if boot else []):
            table.add_column(col, justify="right" if "std" in col or col == "value" else "left")
        for row in _estimate_rows(result, estimates, boot):
            table.add_row(*row)
        console.print(table)
    _print_population(console, result)
    console.print(_scores_table(result))
    for note in _undefined_scores(result):
        console.print(f"[cyan]note:[/] {escape(note)}", highlight=False)
    for axis, stats in result.linear.items():
        if stats:
            console.print(
                f"linear {axis}: {stats['tf']}  rise {stats['rise_time_s']:.3f} s, settling "
                f"{stats['settling_time_s']:.3f} s, bandwidth {stats['bandwidth_radps']:.2f} rad/s"
            )
    if result.settings.get("note"):
        note = escape(str(result.settings["note"]))
        console.print(f"[cyan]identifiability:[/] {note}", highlight=False)
    for warning in result.warnings:
        console.print(f"[yellow]note:[/] {escape(warning)}", highlight=False)
