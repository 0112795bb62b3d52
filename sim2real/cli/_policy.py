"""Options shared by `envs eval` and `envs robustness`: --policy, --params, --randomize.

Also registers `sim2real envs robustness` (success with and without each randomizer).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from sim2real.cli._common import add_command
from sim2real.errors import Sim2RealValueError

__all__ = ["add_policy_arguments", "prepare", "register_robustness"]

_ROBUST_EXAMPLES = """\
  sim2real envs robustness RandomMap-v0 --randomize examples/randommap_randomizers.yaml
  sim2real envs robustness RandomMap-v0 --policy runs/randommap_ppo/model.zip \\
      --randomize examples/randommap_randomizers.yaml --episodes 50 --preset TEST1
  sim2real envs robustness RandomMap-v0 --params params.yaml --randomize dr.yaml --json r.json
"""


def add_policy_arguments(p: argparse.ArgumentParser, *, randomize_required: bool = False) -> None:
    """Add --policy, --algorithm, --params and --randomize to an `envs` subcommand."""
    p.add_argument(
        "--policy",
        metavar="MODEL.zip",
        help="evaluate this trained policy (`sim2real train` output) instead of the DWA baseline",
    )
    p.add_argument(
        "--algorithm",
        help="algorithm of a --policy zip not written by `sim2real train` (PPO, SAC, TD3, DQN)",
    )
    p.add_argument(
        "--params",
        metavar="RESULT.yaml",
        help="drive parameters of a sysid result (`sim2real sysid fit -o`) for the robot",
    )
    p.add_argument(
        "--randomize",
        metavar="CONFIG.yaml",
        required=randomize_required,
        help="randomizer stack (format sim2real.randomizers/1) to evaluate under",
    )


def _controller(env: Any, args: argparse.Namespace) -> tuple[Any, Any, str]:
    """(controller, outermost wrap or None, label) for --policy or the DWA baseline."""
    if args.algorithm is not None and args.policy is None:
        raise Sim2RealValueError("--algorithm applies to --policy only; add --policy MODEL.zip")
    if args.policy is None:
        from sim2real.envs.baselines import DWAController

        if env.spec is not None and env.spec.id.endswith("CarCrossing-v0"):
            from sim2real.envs.car_baseline import CarCrossingBaseline

            return CarCrossingBaseline.for_env(env), None, "Rule-based baseline"
        if env.spec is not None and env.spec.id.endswith("Race-v0"):
            from sim2real.envs.race_baseline import PLANNERS, RaceBaseline

            planner = getattr(args, "planner", None) or "astar"
            if planner not in PLANNERS:
                raise Sim2RealValueError(
                    f"--planner must be one of {', '.join(PLANNERS)}, got {planner!r}"
                )
            return RaceBaseline.for_env(env, method=planner), None, f"{planner} + DWA baseline"
        return DWAController.for_env(env), None, "DWA baseline"
    from sim2real.training.evaluation import check_spaces, load_policy

    policy = load_policy(args.policy, algorithm=args.algorithm)
    check_spaces(policy, policy.wrap(env), env.spec.id if env.spec else "env")
    return policy.controller(), policy.wrap, f"{policy.algorithm} policy {Path(args.policy).name}"


def prepare(env: Any, args: argparse.Namespace) -> tuple[Any, Any, str]:
    """Apply --params and --randomize to ``env``; return (env, controller, label).

    The controller is the policy of --policy (its observation space checked against the env's)
    or the DWA baseline.
    """
    if args.params is not None:
        from sim2real.training.environment import set_params_file

        set_params_file(env, args.params)
    controller, wrap, label = _controller(env, args)
    if args.randomize is not None:
        import randomizers as dr

        env = dr.from_config(env, args.randomize)
    if wrap is not None:
        env = wrap(env)
    return env, controller, label


def register_robustness(group_sub: argparse._SubParsersAction, make_env: Any) -> None:  # type: ignore[type-arg]
    """Register ``envs robustness``; ``make_env(args)`` builds the env (as `envs eval` does)."""
    p = add_command(
        group_sub,
        "robustness",
        help="success with no randomizer, with each randomizer of a stack alone, and with all",
        description=(
            "Evaluate one controller (a --policy or the DWA baseline) on the same seeded episodes "
            "under: no randomisation, each randomizer of --randomize alone, and the whole stack. "
            "Prints success / collision / timeout rates with the Wilson 95 % interval of the "
            "success rate per condition."
        ),
        examples=_ROBUST_EXAMPLES,
    )
    p.add_argument("env", metavar="ENV", help="env id, e.g. RandomMap-v0")
    p.add_argument("--episodes", type=int, default=10, help="episodes per condition")
    p.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    p.add_argument("--preset", help="RandomMap-v0 map preset (TRAIN, TEST1..TEST4)")
    p.add_argument("--scenario", help="CrowdNav-v0 scenario (static, dynamic, occluded)")
    p.add_argument("--complexity", type=float, help="CrowdNav-v0 complexity factor in [0, 1]")
    p.add_argument("--dynamics", default="reduced", help="robot back-end: reduced or pybullet")
    add_policy_arguments(p, randomize_required=True)
    p.add_argument("--json", metavar="FILE", help="also write the table as JSON")
    p.set_defaults(handler=lambda args: _robustness(args, make_env))


def _robustness(args: argparse.Namespace, make_env: Any) -> int:
    from rich.console import Console
    from rich.table import Table

    from sim2real._io import atomic_write, check_output_path
    from sim2real.training.evaluation import robustness

    if args.json:
        check_output_path(args.json, what="--json file")
    env, options = make_env(args)
    try:
        if args.params is not None:
            from sim2real.training.environment import set_params_file

            set_params_file(env, args.params)
        controller, wrap, label = _controller(env, args)
        rows = robustness(
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
