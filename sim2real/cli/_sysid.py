"""`sim2real sysid fit` and `sysid plan`: fit drive parameters to logs, plan a recording."""

from __future__ import annotations

import argparse
import math
from typing import Any

from rich.markup import escape

from robots.spec import load_spec
from sim2real._io import atomic_write, check_not_an_input, check_output_path
from sim2real.agreement.study import odom_v_window_seconds
from sim2real.cli._common import read_options
from sim2real.cli._progress import progress_bar
from sim2real.cli._result import print_result, stdout_console
from sim2real.cluster import expand_logs, map_tasks
from sim2real.errors import Sim2RealValueError
from sim2real.fitting import fit_logs
from sim2real.planning import write_plan
from sysid.plan import beyond_session, information_bound

__all__ = ["handle_fit", "handle_plan"]


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
    v_window = None if args.odom_v_window == "auto" else odom_v_window_seconds(args.odom_v_window)
    console = stdout_console()
    with progress_bar("[bold]sysid[/] {description}", 1.0) as update:
        fit = fit_logs(
            args.logs,
            robot=args.robot,
            validate=args.validate,
            window=window,
            validate_window=validate_window,
            free=free,
            read=read_options(args),
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
    print_result(console, fit.result)
    for note in fit.notes:
        console.print(f"[cyan]note:[/] {escape(note)}", highlight=False)
    console.print(f"wrote [bold]{escape(str(out))}[/]")
    return 0


def _print_bound(console: Any, args: argparse.Namespace) -> None:
    """The best case of one session of the plan's length for each smooth parameter, and what
    no session of that length identifies (:func:`sysid.plan.information_bound`)."""
    bound = information_bound(
        load_spec(args.robot), args.duration, rate_hz=args.rate, area_m=args.area
    )
    shown = ", ".join(f"{n} {r:.2f}" for n, r in bound.sd_ratio.items())
    console.print(
        f"best case of one {bound.duration_s:g} s session, post/prior sd: {shown}",
        highlight=False,
    )
    beyond = beyond_session(bound)
    console.print(
        f"no session of {bound.duration_s:g} s can identify:" + ("" if beyond else " none"),
        highlight=False,
    )
    for name, why in beyond.items():
        console.print(f"  {name:<28} {escape(why)}", highlight=False)


def handle_plan(args: argparse.Namespace) -> int:
    """``sysid plan --robot R -o excite.mcap``: write the script, print what it identifies."""
    out = check_output_path(args.output, what="command script")
    plan = write_plan(
        out, args.robot, duration_s=args.duration, area_m=args.area, rate_hz=args.rate
    )
    console = stdout_console()
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
        if name not in plan.weak:
            console.print(f"  {name:<28} by {', '.join(kinds)}", highlight=False)
    if plan.unreachable:
        console.print("no command within the limits can identify:", highlight=False)
        for name, why in plan.unreachable.items():
            console.print(f"  {name:<28} {escape(why)}", highlight=False)
    console.print("excited, but one session may leave near its prior:", highlight=False)
    for name, why in plan.weak.items():
        console.print(f"  {name:<28} {escape(why)}", highlight=False)
    if args.bound:
        _print_bound(console, args)
    console.print(f"wrote [bold]{escape(str(out))}[/]")
    return 0
