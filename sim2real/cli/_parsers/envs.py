"""Arguments of `sim2real envs`: list the reference envs, evaluate a controller, robustness."""

from __future__ import annotations

import argparse

from sim2real.cli._common import add_command, add_group

__all__ = ["register"]

_GROUP_EXAMPLES = """\
  sim2real envs list                                   # env ids, presets, scenarios
  sim2real envs eval RandomMap-v0 --episodes 20 --preset TEST3
  sim2real envs eval CrowdNav-v0 --episodes 10 --scenario occluded --complexity 0.8
"""
_LIST_EXAMPLES = """\
  sim2real envs list
"""
_EVAL_EXAMPLES = """\
  sim2real envs eval RandomMap-v0 --episodes 20                     # TRAIN preset, seeds 0..19
  sim2real envs eval RandomMap-v0 --episodes 50 --preset TEST4 --seed 100
  sim2real envs eval sim2real/RandomMap-v0 --episodes 5 --dynamics pybullet
  sim2real envs eval CrowdNav-v0 --episodes 10 --scenario dynamic --complexity 1.0
  sim2real envs eval CrowdNav-v0 --episodes 10 --json crowd.json    # also write the numbers
  sim2real envs eval CarCrossing-v0 --episodes 50                   # rule-based car baseline
  sim2real envs eval RandomMap-v0 --policy runs/randommap_ppo/model.zip --preset TEST1
  sim2real envs eval RandomMap-v0 --policy model.zip --params real.yaml --randomize dr.yaml
  sim2real envs eval Race-v0 --track circuit --opponents 4 --planner dijkstra
  sim2real envs eval RandomMap-v0 --policy model.zip --dynamics plant --episodes 100 --seed 1000
"""


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register the ``envs`` command group (``envs list``, ``envs eval``)."""
    group_sub = add_group(
        sub,
        "envs",
        help="reference training envs: list them, evaluate the baseline controller",
        description=(
            "The gymnasium envs of sim2real.envs (registered on import): CrowdNav-v0 (dense "
            "crowds, Liang et al. (2020)), RandomMap-v0 (random walls and cylinders, Yang et "
            "al.) and CarCrossing-v0 (a car passes an obstacle and an occluded pedestrian, "
            "Trararak et al.) and Race-v0 (TurtleBot 3 Burgers race ORCA opponents on walled "
            "tracks, Pozo Ruiz (2024))."
        ),
        examples=_GROUP_EXAMPLES,
    )
    lst = add_command(
        group_sub,
        "list",
        help="the env ids, RandomMap presets and CrowdNav scenarios",
        description="List the registered env ids with their presets or scenario families.",
        examples=_LIST_EXAMPLES,
    )
    lst.set_defaults(handler="envs:handle_list")
    _register_eval(group_sub)
    _register_robustness(group_sub)


def _register_eval(group_sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``envs eval``."""
    ev = add_command(
        group_sub,
        "eval",
        help="run the baseline controller or a trained --policy for N episodes; outcome rates",
        description=(
            "Run the env's non-learned baseline (the dynamic-window controller of "
            "sim2real.envs.baselines; for CarCrossing-v0 the rule-based "
            "sim2real.envs.car_baseline; for Race-v0 an A* or Dijkstra global plan on the track "
            "map followed with DWA, sim2real.envs.race_baseline) for N seeded episodes and print success / collision / "
            "timeout rates and the mean path length, time to goal and smoothness: a reference "
            "number per preset, with the Wilson 95 %% intervals of the success and collision "
            "rates and the 95 %% interval of the mean time to goal. --policy evaluates a trained "
            "policy instead (sim2real train), --params uses a sysid result's drive parameters, "
            "--randomize adds a randomizer stack, --dynamics plant drives a foreign base (one "
            "plant session per episode, drawn from the episode's seed) that no training saw."
        ),
        examples=_EVAL_EXAMPLES,
    )
    _add_env_arguments(ev, episodes_help="number of episodes")
    ev.add_argument("--track", help="Race-v0 track (open, curve, cross, circuit)")
    ev.add_argument("--opponents", type=int, help="Race-v0 number of ORCA opponents (0-5)")
    ev.add_argument("--planner", help="Race-v0 global planner: astar (default) or dijkstra")
    _add_policy_arguments(ev)
    ev.add_argument("--json", metavar="FILE", help="also write the summary and episodes as JSON")
    ev.set_defaults(handler="envs:handle_eval")


_ROBUST_EXAMPLES = """\
  sim2real envs robustness RandomMap-v0 --randomize examples/randommap_randomizers.yaml
  sim2real envs robustness RandomMap-v0 --policy runs/randommap_ppo/model.zip \\
      --randomize examples/randommap_randomizers.yaml --episodes 50 --preset TEST1
  sim2real envs robustness RandomMap-v0 --params params.yaml --randomize dr.yaml --json r.json
"""


def _add_env_arguments(p: argparse.ArgumentParser, *, episodes_help: str) -> None:
    """Add ENV, --episodes, --seed, --preset, --scenario, --complexity and --dynamics."""
    p.add_argument("env", metavar="ENV", help="env id, e.g. RandomMap-v0 or sim2real/CrowdNav-v0")
    p.add_argument("--episodes", type=int, default=10, help=episodes_help)
    p.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    p.add_argument("--preset", help="RandomMap-v0 map preset (TRAIN, TEST1..TEST4)")
    p.add_argument("--scenario", help="CrowdNav-v0 scenario (static, dynamic, occluded)")
    p.add_argument("--complexity", type=float, help="CrowdNav-v0 complexity factor in [0, 1]")
    p.add_argument(
        "--dynamics",
        help=(
            "robot back-end: reduced (fast; the default), pybullet, or plant (a foreign base to "
            "evaluate on: one plant session per episode, payload, floor, battery and latency "
            "drawn from the episode's seed; RandomMap-v0, CrowdNav-v0, Race-v0); a --policy's "
            "own by default"
        ),
    )


def _add_policy_arguments(p: argparse.ArgumentParser, *, randomize_required: bool = False) -> None:
    """Add --policy, --algorithm, --params and --randomize to an `envs` subcommand."""
    p.add_argument(
        "--policy",
        metavar="MODEL.zip",
        help="evaluate this trained policy (`sim2real train` output) instead of the DWA "
        "baseline, on the env settings it was trained with (a flag given replaces its setting, "
        "with a note)",
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


def _register_robustness(group_sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``envs robustness`` (its env is built as `envs eval` builds it)."""
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
    _add_env_arguments(p, episodes_help="episodes per condition")
    _add_policy_arguments(p, randomize_required=True)
    p.add_argument("--json", metavar="FILE", help="also write the table as JSON")
    p.set_defaults(handler="envs:handle_robustness")
