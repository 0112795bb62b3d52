"""`sim2real envs`: list the reference envs, evaluate a controller on one, robustness."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from sim2real._io import atomic_write, check_output_path
from sim2real.cli._policy import ci_text, policy_settings, prepare, robustness
from sim2real.cli._progress import progress_bar
from sim2real.envs import PAPER_RHO_OBS, PRESETS, SCENARIOS
from sim2real.envs.baselines import evaluate
from sim2real.errors import Sim2RealValueError
from sim2real.training.environment import build_env
from sim2real.training.evaluation import outcome_intervals

__all__ = ["handle_eval", "handle_list", "handle_robustness"]

_KNOWN = (
    "sim2real/CrowdNav-v0",
    "sim2real/RandomMap-v0",
    "sim2real/CarCrossing-v0",
    "sim2real/Race-v0",
)


def _env_id(name: str) -> str:
    key = name.lower().removeprefix("sim2real/")
    for env_id in _KNOWN:
        if env_id.lower().removeprefix("sim2real/") == key:
            return env_id
    raise Sim2RealValueError(
        f"unknown env '{name}'; known envs are {', '.join(_KNOWN)} (see `sim2real envs list`)"
    )


def handle_list(args: argparse.Namespace) -> int:
    """``envs list``: the env ids, RandomMap presets and CrowdNav scenarios."""
    console = Console()
    table = Table(title="sim2real envs")
    table.add_column("id", no_wrap=True)
    for col in ("robot", "observation", "options"):
        table.add_column(col, overflow="fold")
    table.add_row(
        "sim2real/CrowdNav-v0",
        "turtlebot2",
        "Dict(lidar, depth 64x48, goal, velocity)",
        f"scenario: {', '.join(SCENARIOS)}; complexity in [0, 1]",
    )
    table.add_row(
        "sim2real/RandomMap-v0",
        "turtlebot3_burger",
        "Box(40): 36 ranges, goal d/bearing, v, w",
        f"preset: {', '.join(PRESETS)}",
    )
    table.add_row(
        "sim2real/CarCrossing-v0",
        "Ackermann car 26x18 cm",
        "Box(14): position, 5 distance sensors, steering, distances, lane, detections, heading",
        "Discrete(4) actions; scenario drawn from the seed",
    )
    table.add_row(
        "sim2real/Race-v0",
        "turtlebot3_burger",
        "Box(63): 36 ranges, odometry, v, w, goal d/bearing, 5 nearest movers",
        "track: open, curve, cross, circuit; opponents 0-5 (ORCA)",
    )
    console.print(table)
    presets = Table(title="RandomMap-v0 presets (Yang et al., Table I)")
    for col in ("preset", "d_target m", "r_wall", "n cylinders", "paper rho_obs"):
        presets.add_column(col)
    for name, cfg in PRESETS.items():
        lo, hi = PAPER_RHO_OBS[name]
        presets.add_row(
            name,
            f"{cfg.d_target_m:g}",
            f"{cfg.r_wall:g}",
            f"{cfg.n_min}-{cfg.n_max}",
            f"{100 * lo:.0f}-{100 * hi:.0f} %",
        )
    console.print(presets)
    return 0


def _make_env(args: argparse.Namespace) -> tuple[Any, dict[str, Any] | None]:
    """The env of ``envs eval`` / ``envs robustness`` and its reset options; a flag of
    another env is refused in one sentence. With ``--policy`` the env has the settings the
    policy was trained with (:func:`~sim2real.cli._policy.policy_settings`)."""
    env_id = _env_id(args.env)
    if args.episodes < 1:
        raise Sim2RealValueError(
            f"--episodes must be >= 1, got {args.episodes}; e.g. --episodes 10"
        )
    _refuse_other_flags(args, env_id)
    kwargs = policy_settings(args, env_id)
    kwargs["dynamics"] = args.dynamics
    if env_id.endswith("RandomMap-v0") and args.preset is not None:
        kwargs["preset"] = args.preset
    if env_id.endswith("Race-v0"):
        race = _race_flags(args)
        kwargs.setdefault("track", race["--track"] or "circuit")
        if race["--opponents"] is not None:
            kwargs["num_opponents"] = race["--opponents"]
    options = {
        k: getattr(args, k) for k in ("scenario", "complexity") if getattr(args, k) is not None
    }
    where = f"policy '{args.policy}'" if args.policy else "envs"
    return build_env(env_id, kwargs, where=where), options or None


#: Flags an env does not take, and the sentence refusing them: env suffix -> (flags, text).
_NOT_TAKEN = {
    "Race-v0": (
        ("preset", "scenario", "complexity"),
        "--preset, --scenario and --complexity do not apply to Race-v0; use --track, "
        "--opponents and --planner",
    ),
    "CarCrossing-v0": (
        ("preset", "scenario", "complexity"),
        "--preset, --scenario and --complexity do not apply to CarCrossing-v0 (its scenario is "
        "drawn from the seed); drop them",
    ),
    "RandomMap-v0": (
        ("scenario", "complexity"),
        "--scenario and --complexity apply to CrowdNav-v0 only; use --preset for RandomMap-v0",
    ),
    "CrowdNav-v0": (
        ("preset",),
        "--preset applies to RandomMap-v0 only; use --scenario and --complexity for CrowdNav-v0",
    ),
}


def _race_flags(args: argparse.Namespace) -> dict[str, Any]:
    """``--track``, ``--opponents``, ``--planner`` as given (``envs robustness`` has none)."""
    return {flag: getattr(args, flag[2:], None) for flag in ("--track", "--opponents", "--planner")}


def _refuse_other_flags(args: argparse.Namespace, env_id: str) -> None:
    """Refuse the flags of another env than ``env_id`` (one sentence)."""
    if not env_id.endswith("Race-v0"):
        _refuse_race_flags(args)
    for suffix, (flags, text) in _NOT_TAKEN.items():
        if env_id.endswith(suffix) and any(getattr(args, f) is not None for f in flags):
            raise Sim2RealValueError(text)


def _refuse_race_flags(args: argparse.Namespace) -> None:
    """Refuse Race-v0's flags on another env."""
    given = [flag for flag, value in _race_flags(args).items() if value is not None]
    if given:
        raise Sim2RealValueError(
            f"{', '.join(given)} {'applies' if len(given) == 1 else 'apply'} to Race-v0 only, "
            f"not {args.env}; drop {'it' if len(given) == 1 else 'them'}"
        )


def _plain(value: Any) -> Any:
    """JSON-safe copy: NaN becomes null, numpy scalars become Python numbers."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, bool | str | int) or value is None:
        return value
    f = float(value)
    return None if math.isnan(f) else f


def _fmt(value: float, digits: int = 3) -> str:
    return "n/a" if math.isnan(value) else f"{value:.{digits}f}"


def handle_eval(args: argparse.Namespace) -> int:
    """``envs eval ENV``: a controller for N seeded episodes; outcome rates and means."""
    if args.json:
        check_output_path(args.json, what="--json file")
    env, options = _make_env(args)
    try:
        env, ctrl, label = prepare(env, args)
        with progress_bar(f"{env.spec.id} episodes", args.episodes, stdout=True) as update:
            summary = evaluate(
                env,
                ctrl,
                episodes=args.episodes,
                seed=args.seed,
                options=options,
                on_episode=lambda i, row: update(i + 1),
            )
    finally:
        env.close()
    ci = outcome_intervals(summary)
    Console().print(_eval_table(args, env.spec.id, label, summary, ci))
    if args.json:
        doc = _eval_document(args, env.spec.id, label, options, summary, ci)
        with atomic_write(args.json, "w", what="--json file") as fh:
            json.dump(_plain(doc), fh, indent=2)
    return 0


def _eval_table(args: argparse.Namespace, env_id: str, label: str, summary: Any, ci: Any) -> Table:
    """``envs eval``'s table: outcome rates with their 95 % intervals, then the means."""
    what = (
        args.preset.upper()
        if args.preset
        else (args.scenario or getattr(args, "track", None) or "")
    )
    last = args.seed + summary.episodes - 1
    robot = "".join(  # which robot and randomisation the figures are for
        f", {flag} {Path(value).name}"
        for flag, value in (("params", args.params), ("randomized by", args.randomize))
        if value
    )
    table = Table(
        title=f"{label} on {env_id} {what} ({summary.episodes} episodes, "
        f"seeds {args.seed}..{last}, dynamics {args.dynamics}{robot})"
    )
    table.add_column("metric")
    table.add_column("value", justify="right")
    table.add_column("95 % CI", justify="right")
    table.add_row("success rate", f"{summary.success_rate:.2f}", ci_text(ci.success_ci95, 2))
    table.add_row("collision rate", f"{summary.collision_rate:.2f}", ci_text(ci.collision_ci95, 2))
    table.add_row("timeout rate", f"{summary.timeout_rate:.2f}")
    table.add_row("overshoot rate", f"{summary.overshoot_rate:.2f}")
    for key, name, env_kind in (
        ("off_road", "off-road rate", "CarCrossing-v0"),
        ("wall_collision", "wall collision rate", "Race-v0"),
    ):
        if env_id.endswith(env_kind):
            share = sum(bool(r.get(key)) for r in summary.per_episode) / summary.episodes
            table.add_row(name, f"{share:.2f}")
    m = summary.means
    table.add_row("path length m", _fmt(m["path_length_m"], 2))
    table.add_row(
        "time to goal s (successes)", _fmt(m["time_to_goal_s"], 2), ci_text(ci.time_to_goal_ci95, 2)
    )
    for name, key, digits in _MEANS:
        table.add_row(name, _fmt(m[key], digits))
    return table


#: ``envs eval``'s smoothness and return rows: (row name, key of the means, digits).
_MEANS = (
    ("mean |dv| per step m/s", "mean_abs_dv_mps", 4),
    ("mean |dw| per step rad/s", "mean_abs_dw_radps", 4),
    ("mean |jerk v| m/s^3", "mean_abs_jerk_v_mps3", 3),
    ("mean |jerk w| rad/s^3", "mean_abs_jerk_w_radps3", 3),
    ("mean return", "return", 2),
)


def _eval_document(
    args: argparse.Namespace,
    env_id: str,
    label: str,
    options: dict[str, Any] | None,
    summary: Any,
    ci: Any,
) -> dict[str, Any]:
    """``envs eval --json``'s document: the setting, the rates with intervals, each episode."""
    return {
        "env": env_id,
        "preset": args.preset,
        "options": options,
        "dynamics": args.dynamics,
        "controller": label,
        "policy": args.policy,
        "params": args.params,
        "randomize": args.randomize,
        "seed": args.seed,
        "success_rate": summary.success_rate,
        "success_ci95": list(ci.success_ci95),
        "collision_rate": summary.collision_rate,
        "collision_ci95": list(ci.collision_ci95),
        "timeout_rate": summary.timeout_rate,
        "overshoot_rate": summary.overshoot_rate,
        "time_to_goal_ci95": list(ci.time_to_goal_ci95),
        "means": summary.means,
        "episodes": list(summary.per_episode),
    }


def handle_robustness(args: argparse.Namespace) -> int:
    """``envs robustness ENV``: the env built as ``envs eval`` builds it."""
    return robustness(args, _make_env)
