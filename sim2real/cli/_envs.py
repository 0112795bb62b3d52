"""`sim2real envs` commands: list the reference envs, evaluate the DWA baseline on one."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from sim2real.cli._common import add_command
from sim2real.cli._policy import add_policy_arguments, prepare, register_robustness
from sim2real.errors import Sim2RealValueError

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
"""

_KNOWN = (
    "sim2real/CrowdNav-v0",
    "sim2real/RandomMap-v0",
    "sim2real/CarCrossing-v0",
    "sim2real/Race-v0",
)


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register the ``envs`` command group (``envs list``, ``envs eval``)."""
    group = add_command(
        sub,
        "envs",
        help="reference training envs: list them, evaluate the baseline controller",
        description=(
            "The gymnasium envs of sim2real.envs (registered on import): CrowdNav-v0 (dense "
            "crowds, Liang et al. (2020)), RandomMap-v0 (random walls and cylinders, Yang et al.) and "
            "CarCrossing-v0 (a car passes an obstacle and an occluded pedestrian, Trararak et al.) "
            "and Race-v0 (TurtleBot 3 Burgers race ORCA opponents on walled tracks, Pozo Ruiz (2024))."
        ),
        examples=_GROUP_EXAMPLES,
    )
    group_sub = group.add_subparsers(dest="envs_command", metavar="SUBCOMMAND")
    group_sub.required = True
    lst = add_command(
        group_sub,
        "list",
        help="the env ids, RandomMap presets and CrowdNav scenarios",
        description="List the registered env ids with their presets or scenario families.",
        examples=_LIST_EXAMPLES,
    )
    lst.set_defaults(handler=_list)
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
            "number per preset. --policy evaluates a trained policy instead (sim2real train), "
            "--params uses a sysid result's drive parameters, --randomize adds a randomizer "
            "stack."
        ),
        examples=_EVAL_EXAMPLES,
    )
    ev.add_argument("env", metavar="ENV", help="env id, e.g. RandomMap-v0 or sim2real/CrowdNav-v0")
    ev.add_argument("--episodes", type=int, default=10, help="number of episodes")
    ev.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    ev.add_argument("--preset", help="RandomMap-v0 map preset (TRAIN, TEST1..TEST4)")
    ev.add_argument("--scenario", help="CrowdNav-v0 scenario (static, dynamic, occluded)")
    ev.add_argument("--complexity", type=float, help="CrowdNav-v0 complexity factor in [0, 1]")
    ev.add_argument("--track", help="Race-v0 track (open, curve, cross, circuit)")
    ev.add_argument("--opponents", type=int, help="Race-v0 number of ORCA opponents (0-5)")
    ev.add_argument("--planner", help="Race-v0 global planner: astar (default) or dijkstra")
    ev.add_argument(
        "--dynamics", default="reduced", help="robot back-end: reduced (fast) or pybullet"
    )
    add_policy_arguments(ev)
    ev.add_argument("--json", metavar="FILE", help="also write the summary and episodes as JSON")
    ev.set_defaults(handler=_eval)
    register_robustness(group_sub, _make_env)


def _env_id(name: str) -> str:
    key = name.lower().removeprefix("sim2real/")
    for env_id in _KNOWN:
        if env_id.lower().removeprefix("sim2real/") == key:
            return env_id
    raise Sim2RealValueError(
        f"unknown env '{name}'; known envs are {', '.join(_KNOWN)} (see `sim2real envs list`)"
    )


def _list(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.table import Table

    from sim2real.envs import PAPER_RHO_OBS, PRESETS, SCENARIOS

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
    import gymnasium as gym

    import sim2real.envs  # noqa: F401  (registers the ids)

    env_id = _env_id(args.env)
    if args.episodes < 1:
        raise Sim2RealValueError(
            f"--episodes must be >= 1, got {args.episodes}; e.g. --episodes 10"
        )
    track = getattr(args, "track", None)  # `envs robustness` has no race flags
    opponents = getattr(args, "opponents", None)
    race_only = {
        "--track": track,
        "--opponents": opponents,
        "--planner": getattr(args, "planner", None),
    }
    given = [flag for flag, value in race_only.items() if value is not None]
    if env_id.endswith("Race-v0"):
        if args.preset is not None or args.scenario is not None or args.complexity is not None:
            raise Sim2RealValueError(
                "--preset, --scenario and --complexity do not apply to Race-v0; use --track, "
                "--opponents and --planner"
            )
        kw: dict[str, Any] = {"track": track or "circuit"}
        if opponents is not None:
            kw["num_opponents"] = opponents
        return gym.make(env_id, dynamics=args.dynamics, **kw), None
    if given:
        raise Sim2RealValueError(
            f"{', '.join(given)} {'applies' if len(given) == 1 else 'apply'} to Race-v0 only, "
            f"not {args.env}; drop {'it' if len(given) == 1 else 'them'}"
        )
    if env_id.endswith("CarCrossing-v0"):
        if args.preset is not None or args.scenario is not None or args.complexity is not None:
            raise Sim2RealValueError(
                "--preset, --scenario and --complexity do not apply to CarCrossing-v0 (its "
                "scenario is drawn from the seed); drop them"
            )
        return gym.make(env_id, dynamics=args.dynamics), None
    if env_id.endswith("RandomMap-v0"):
        if args.scenario is not None or args.complexity is not None:
            raise Sim2RealValueError(
                "--scenario and --complexity apply to CrowdNav-v0 only; use --preset for "
                "RandomMap-v0"
            )
        return gym.make(env_id, dynamics=args.dynamics, preset=args.preset or "TRAIN"), None
    if args.preset is not None:
        raise Sim2RealValueError(
            "--preset applies to RandomMap-v0 only; use --scenario and --complexity for CrowdNav-v0"
        )
    options: dict[str, Any] = {}
    if args.scenario is not None:
        options["scenario"] = args.scenario
    if args.complexity is not None:
        options["complexity"] = args.complexity
    return gym.make(env_id, dynamics=args.dynamics), options or None


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


def _eval(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.progress import Progress
    from rich.table import Table

    from sim2real._io import atomic_write, check_output_path
    from sim2real.envs.baselines import evaluate

    if args.json:
        check_output_path(args.json, what="--json file")
    env, options = _make_env(args)
    console = Console()
    try:
        is_car = env.spec.id.endswith("CarCrossing-v0")
        is_race = env.spec.id.endswith("Race-v0")
        env, ctrl, label = prepare(env, args)
        # disabled off a terminal: rich would print an empty line to a pipe
        with Progress(console=console, transient=True, disable=not console.is_terminal) as progress:
            task = progress.add_task(f"{env.spec.id} episodes", total=args.episodes)
            summary = evaluate(
                env,
                ctrl,
                episodes=args.episodes,
                seed=args.seed,
                options=options,
                on_episode=lambda i, row: progress.advance(task),
            )
    finally:
        env.close()
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
        title=f"{label} on {env.spec.id} {what} ({summary.episodes} episodes, "
        f"seeds {args.seed}..{last}, dynamics {args.dynamics}{robot})"
    )
    table.add_column("metric")
    table.add_column("value", justify="right")
    table.add_row("success rate", f"{summary.success_rate:.2f}")
    table.add_row("collision rate", f"{summary.collision_rate:.2f}")
    table.add_row("timeout rate", f"{summary.timeout_rate:.2f}")
    if is_car:
        off = sum(bool(r.get("off_road")) for r in summary.per_episode) / summary.episodes
        table.add_row("off-road rate", f"{off:.2f}")
    if is_race:
        wall = sum(bool(r.get("wall_collision")) for r in summary.per_episode) / summary.episodes
        table.add_row("wall collision rate", f"{wall:.2f}")
    m = summary.means
    table.add_row("path length m", _fmt(m["path_length_m"], 2))
    table.add_row("time to goal s (successes)", _fmt(m["time_to_goal_s"], 2))
    table.add_row("mean |dv| per step m/s", _fmt(m["mean_abs_dv_mps"], 4))
    table.add_row("mean |dw| per step rad/s", _fmt(m["mean_abs_dw_radps"], 4))
    table.add_row("mean |jerk v| m/s^3", _fmt(m["mean_abs_jerk_v_mps3"], 3))
    table.add_row("mean |jerk w| rad/s^3", _fmt(m["mean_abs_jerk_w_radps3"], 3))
    table.add_row("mean return", _fmt(m["return"], 2))
    console.print(table)
    if args.json:
        doc = {
            "env": env.spec.id,
            "preset": args.preset,
            "options": options,
            "dynamics": args.dynamics,
            "controller": label,
            "policy": args.policy,
            "params": args.params,
            "randomize": args.randomize,
            "seed": args.seed,
            "success_rate": summary.success_rate,
            "collision_rate": summary.collision_rate,
            "timeout_rate": summary.timeout_rate,
            "means": summary.means,
            "episodes": list(summary.per_episode),
        }
        with atomic_write(args.json, "w", what="--json file") as fh:
            json.dump(_plain(doc), fh, indent=2)
    return 0
