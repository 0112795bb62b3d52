"""The controller of `envs eval` and `envs robustness` (--policy or the baseline), --params
and --randomize applied to the env, and `envs robustness` (success with and without each
randomizer)."""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

import randomizers
from sim2real._io import atomic_write, check_output_path
from sim2real.envs.baselines import DWAController
from sim2real.envs.car_baseline import CarCrossingBaseline
from sim2real.envs.race_baseline import PLANNERS, RaceBaseline
from sim2real.errors import Sim2RealValueError
from sim2real.training.environment import set_params_file
from sim2real.training.evaluation import check_spaces, load_policy, read_policy_metadata
from sim2real.training.evaluation import robustness as robustness_rows

__all__ = ["ci_text", "policy_settings", "prepare", "robustness"]

#: Env kwargs an `envs` flag sets, as (flag, args attribute, kwarg).
_FLAG_KWARGS = (
    ("--dynamics", "dynamics", "dynamics"),
    ("--preset", "preset", "preset"),
    ("--scenario", "scenario", "scenario"),
    ("--complexity", "complexity", "complexity"),
    ("--track", "track", "track"),
    ("--opponents", "opponents", "num_opponents"),
)


def ci_text(ci: tuple[float, float], digits: int) -> str:
    """``[lo, hi]`` of an interval, ``n/a`` when undefined."""
    lo, hi = ci
    return "n/a" if math.isnan(lo) or math.isnan(hi) else f"[{lo:.{digits}f}, {hi:.{digits}f}]"


def policy_settings(args: argparse.Namespace, env_id: str) -> dict[str, Any]:
    """The env kwargs saved with ``--policy`` (empty without one) that the env is built with.

    A policy evaluates with the settings it was trained with (control period, episode length,
    robot, course, ...). A flag given on the command line replaces its saved setting, with a
    printed note; the saved settings applied are printed too. ``args.dynamics`` is resolved:
    the flag, else the policy's, else ``reduced``. A policy of another env, or a saved params
    file that does not exist, is refused in one sentence.
    """
    saved: dict[str, Any] = {}
    if args.policy is not None:
        meta = read_policy_metadata(args.policy)
        trained_on = meta.get("env_id")
        if trained_on is not None and trained_on != env_id:
            raise Sim2RealValueError(
                f"policy '{args.policy}' was trained on {trained_on}, not {env_id}; evaluate "
                f"it on {str(trained_on).removeprefix('sim2real/')}"
            )
        saved = dict(meta.get("env_kwargs") or {})
    if args.dynamics is None:
        args.dynamics = str(saved.get("dynamics", "reduced"))
    notes = []
    for flag, attr, key in _FLAG_KWARGS:
        given = getattr(args, attr, None)
        if given is None:
            continue
        trained = saved.pop(key, None)
        if key == "preset" and "map_config" in saved:
            trained = f"map_config {saved.pop('map_config')}"
        if trained is not None and str(given).lower() != str(trained).lower():
            notes.append(f"{flag} {given} replaces the policy's training setting {trained}")
    notes.extend(_params_notes(args, saved))
    applied = ", ".join(f"{k} {v}" for k, v in saved.items())
    for note in ([f"env settings of the policy: {applied}"] if applied else []) + notes:
        print(f"note: {note}")
    return saved


def _params_notes(args: argparse.Namespace, saved: dict[str, Any]) -> list[str]:
    """Notes on the policy's saved params file, dropped from ``saved`` when not applied."""
    params = saved.get("params")
    if params is None:
        return []
    if args.dynamics == "plant":
        del saved["params"]
        return [
            f"the policy's params file {params} is not applied: --dynamics plant has its own "
            "physics"
        ]
    if args.params is not None:
        del saved["params"]
        return [f"--params {args.params} replaces the policy's params file {params}"]
    if not Path(params).is_file():
        raise Sim2RealValueError(
            f"policy '{args.policy}' was trained with params file '{params}', which does not "
            "exist here; pass --params with that sysid result"
        )
    return []


def _controller(env: Any, args: argparse.Namespace) -> tuple[Any, Any, str]:
    """(controller, outermost wrap or None, label) for --policy or the DWA baseline."""
    if args.algorithm is not None and args.policy is None:
        raise Sim2RealValueError("--algorithm applies to --policy only; add --policy MODEL.zip")
    if args.policy is None:
        if env.spec is not None and env.spec.id.endswith("CarCrossing-v0"):
            return CarCrossingBaseline.for_env(env), None, "Rule-based baseline"
        if env.spec is not None and env.spec.id.endswith("Race-v0"):
            planner = getattr(args, "planner", None) or "astar"
            if planner not in PLANNERS:
                raise Sim2RealValueError(
                    f"--planner must be one of {', '.join(PLANNERS)}, got {planner!r}"
                )
            return RaceBaseline.for_env(env, method=planner), None, f"{planner} + DWA baseline"
        return DWAController.for_env(env), None, "DWA baseline"
    policy = load_policy(args.policy, algorithm=args.algorithm)
    check_spaces(policy, policy.wrap(env), env.spec.id if env.spec else "env")
    return policy.controller(), policy.wrap, f"{policy.algorithm} policy {Path(args.policy).name}"


def _apply_params(env: Any, args: argparse.Namespace) -> None:
    """--params: the sysid result's drive parameters (the drive model's; not the plant's)."""
    if args.params is None:
        return
    if args.dynamics == "plant":
        raise Sim2RealValueError(
            "--params sets the drive model's parameters, which --dynamics plant does not use "
            "(the plant's motion comes from its own physics); drop --params or use --dynamics "
            "reduced"
        )
    set_params_file(env, args.params)


def prepare(env: Any, args: argparse.Namespace) -> tuple[Any, Any, str]:
    """Apply --params and --randomize to ``env``; return (env, controller, label).

    The controller is the policy of --policy (its observation space checked against the env's)
    or the DWA baseline.
    """
    _apply_params(env, args)
    controller, wrap, label = _controller(env, args)
    if args.randomize is not None:
        env = randomizers.from_config(env, args.randomize)
    if wrap is not None:
        env = wrap(env)
    return env, controller, label


def robustness(
    args: argparse.Namespace, make_env: Callable[[argparse.Namespace], tuple[Any, Any]]
) -> int:
    """``envs robustness ENV``: one controller with no, each and all randomizers."""
    if args.json:
        check_output_path(args.json, what="--json file")
    env, options = make_env(args)
    try:
        _apply_params(env, args)
        controller, wrap, label = _controller(env, args)
        rows = robustness_rows(
            env,
            controller,
            args.randomize,
            episodes=args.episodes,
            seed=args.seed,
            options=options,
            wrap=wrap,
        )
    finally:
        env.close()
    table = _robustness_table(args, label, env.spec.id if env.spec else args.env, rows)
    probe = Console()  # wide off a terminal, so a piped table keeps one row per line
    (probe if probe.is_terminal else Console(width=160)).print(table)
    if args.json:
        with atomic_write(args.json, "w", what="--json file") as fh:
            json.dump(_robustness_document(args, label, rows), fh, indent=2)
    return 0


def _robustness_table(args: argparse.Namespace, label: str, env_id: str, rows: Any) -> Table:
    """One row per condition: success, collision and timeout rates, time to goal, intervals."""
    table = Table(
        title=f"robustness of the {label} on {env_id} "
        f"({args.episodes} episodes per condition, seeds {args.seed}..{args.seed + args.episodes - 1})"
    )
    columns = ("randomizer", "success", "95 % CI", "collision", "95 % CI ", "timeout", "overshoot")
    for col in (*columns, "time to goal s", "95 % CI  "):
        table.add_column(col, justify="left" if col == "randomizer" else "right")
    for r in rows:
        table.add_row(
            r.condition,
            f"{r.success_rate:.2f}",
            ci_text(r.success_ci95, 2),
            f"{r.collision_rate:.2f}",
            ci_text(r.collision_ci95, 2),
            f"{r.timeout_rate:.2f}",
            f"{r.overshoot_rate:.2f}",
            "n/a" if math.isnan(r.time_to_goal_s) else f"{r.time_to_goal_s:.2f}",
            ci_text(r.time_to_goal_ci95, 2),
        )
    return table


def _robustness_document(args: argparse.Namespace, label: str, rows: Any) -> dict[str, Any]:
    """``envs robustness --json``'s document: the setting and one entry per condition."""
    return {
        "env": args.env,
        "controller": label,
        "randomize": str(args.randomize),
        "episodes": args.episodes,
        "seed": args.seed,
        "rows": [
            {
                "condition": r.condition,
                "success_rate": r.success_rate,
                "success_ci95": list(r.success_ci95),
                "collision_rate": r.collision_rate,
                "collision_ci95": list(r.collision_ci95),
                "timeout_rate": r.timeout_rate,
                "overshoot_rate": r.overshoot_rate,
                "time_to_goal_s": r.time_to_goal_s,
                "time_to_goal_ci95": list(r.time_to_goal_ci95),
            }
            for r in rows
        ],
    }
