"""The controller of `envs eval` and `envs robustness` (--policy or the baseline), --params
and --randomize applied to the env, and `envs robustness` (success with and without each
randomizer)."""

from __future__ import annotations

import argparse
import json
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
from sim2real.training.evaluation import check_spaces, load_policy
from sim2real.training.evaluation import robustness as robustness_rows

__all__ = ["prepare", "robustness"]


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


def prepare(env: Any, args: argparse.Namespace) -> tuple[Any, Any, str]:
    """Apply --params and --randomize to ``env``; return (env, controller, label).

    The controller is the policy of --policy (its observation space checked against the env's)
    or the DWA baseline.
    """
    if args.params is not None:
        set_params_file(env, args.params)
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
        if args.params is not None:
            set_params_file(env, args.params)
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
    table = Table(
        title=f"robustness of the {label} on {env.spec.id if env.spec else args.env} "
        f"({args.episodes} episodes per condition, seeds {args.seed}..{args.seed + args.episodes - 1})"
    )
    for col in ("randomizer", "success", "95 % CI", "collision", "timeout"):
        table.add_column(col, justify="left" if col == "randomizer" else "right")
    for r in rows:
        lo, hi = r.success_ci95
        table.add_row(
            r.condition,
            f"{r.success_rate:.2f}",
            f"[{lo:.2f}, {hi:.2f}]",
            f"{r.collision_rate:.2f}",
            f"{r.timeout_rate:.2f}",
        )
    Console().print(table)
    if args.json:
        doc_out = {
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
                    "timeout_rate": r.timeout_rate,
                }
                for r in rows
            ],
        }
        with atomic_write(args.json, "w", what="--json file") as fh:
            json.dump(doc_out, fh, indent=2)
    return 0
