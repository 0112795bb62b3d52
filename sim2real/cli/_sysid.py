"""`sim2real sysid fit`, `sysid show` and `sysid plan`: fit, show a result, plan a recording."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from sim2real._io import atomic_write, check_not_an_input, check_output_path
from sim2real.cli._common import read_options
from sim2real.cli._progress import progress_bar
from sim2real.cluster import expand_logs, map_tasks
from sim2real.errors import Sim2RealValueError
from sim2real.fitting import fit_logs
from sim2real.planning import write_plan
from sysid import ParameterEstimate, SysidResult
from sysid.plan import MASS_GAIN

__all__ = ["handle_fit", "handle_plan", "handle_show"]


def _window(text: str | None, option: str) -> tuple[float, float] | None:
    if text is None:
        return None
    parts = text.split(":")
    try:
        start, end = (float(p) for p in parts) if len(parts) == 2 else (math.nan, math.nan)
    except ValueError:
        start, end = math.nan, math.nan
    if not (math.isfinite(start) and math.isfinite(end) and end > start >= 0):
        raise Sim2RealValueError(
            f"{option} must be START:END in seconds with 0 <= START < END, got {text!r}; "
            "e.g. --window 0:30"
        )
    return start, end


def _v_window(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and 0.0 <= value <= 1.0):
        raise Sim2RealValueError(
            f"--odom-v-window must be 'auto' or seconds in [0, 1], got {text!r}; e.g. 0.0333"
        )
    return value


def _free(text: str) -> str | list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise Sim2RealValueError(
            f"--free must be 'auto' or comma-separated parameter names, got {text!r}"
        )
    return "auto" if names == ["auto"] else names


def handle_fit(args: argparse.Namespace) -> int:
    """``sysid fit LOG...``: fit, write the params file, print the tables and notes."""
    args.logs = [str(p) for p in expand_logs(args.logs)]
    args.validate = [str(p) for p in expand_logs(args.validate, what="--validate")]
    out = check_output_path(args.output, what="params file")
    check_not_an_input(out, [*args.logs, *args.validate], what="params file")
    window = _window(args.window, "--window")
    validate_window = _window(args.validate_window, "--validate-window")
    free = _free(args.free)
    v_window = None if args.odom_v_window == "auto" else _v_window(args.odom_v_window)
    console = _console()
    with progress_bar("[bold]sysid[/] {description}", 1.0) as update:
        fit = fit_logs(
            args.logs,
            robot=args.robot,
            validate=args.validate,
            window=window,
            validate_window=validate_window,
            free=free,
            **read_options(args),
            odom_v_window_s=v_window,
            loss=args.loss,
            dt_s=args.dt,
            bootstrap=args.bootstrap,
            seed=args.seed,
            progress=lambda stage, fraction: update(fraction, description=stage),
            map_sessions=None
            if args.ray is None
            else lambda fn, groups: map_tasks(fn, groups, address=args.ray),
        )
    with atomic_write(out, "w", what="params file") as fh:
        fh.write(fit.result.to_yaml())
    _print_result(console, fit.result)
    for note in fit.notes:
        console.print(f"[cyan]note:[/] {escape(note)}", highlight=False)
    console.print(f"wrote [bold]{escape(str(out))}[/]")
    return 0


def handle_plan(args: argparse.Namespace) -> int:
    """``sysid plan --robot R -o excite.mcap``: write the script, print what it identifies."""
    out = check_output_path(args.output, what="command script")
    plan = write_plan(
        out, args.robot, duration_s=args.duration, area_m=args.area, rate_hz=args.rate
    )
    console = _console()
    lim = plan.limits
    console.print(
        f"[bold]{escape(plan.robot)}[/]: {plan.t_s.size} commands at {plan.rate_hz:g} Hz over "
        f"{plan.duration_s:g} s; |v| up to {abs(plan.v_mps).max():.3g} m/s, |w| up to "
        f"{abs(plan.w_radps).max():.3g} rad/s (limits {lim['v_mps']:g} m/s, "
        f"{lim['w_radps']:g} rad/s, wheel cap {lim['wheel_radps']:g} rad/s); the ideal path "
        f"stays within {plan.extent_m:.2f} m of the start",
        highlight=False,
    )
    for block in plan.blocks:
        console.print(f"  {block.start_s:6.1f}-{block.end_s:6.1f} s  {block.kind}", highlight=False)
    console.print("designed to identify:", highlight=False)
    for name, kinds in plan.identifies().items():
        console.print(f"  {name:<28} by {', '.join(kinds)}", highlight=False)
    console.print(
        f"velocity data fix each axis's response, not the split of {', '.join(MASS_GAIN)}: "
        "that direction rests on the spec's priors",
        highlight=False,
    )
    console.print(f"wrote [bold]{escape(str(out))}[/]")
    return 0


def handle_show(args: argparse.Namespace) -> int:
    """``sysid show PARAMS.yaml``: print a result file's tables."""
    _print_result(_console(), SysidResult.load(args.params))
    return 0


def _console() -> Console:
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
                f"{s.fit_percent_v:.1f}",
                f"{s.fit_percent_w:.1f}",
                f"{100 * s.agreement:.1f} %",
                f"{100 * s.agreement_v:.1f} %",
                f"{100 * s.agreement_w:.1f} %",
                f"{s.rmse_v:.4f}",
                f"{s.rmse_w:.4f}",
            )
    return scores


def _print_result(console: Console, result: SysidResult) -> None:
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
