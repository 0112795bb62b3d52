"""Evaluate the seed papers' experiments (``examples/*.yaml`` trained with ``sim2real train``).

Needs the ``[train]`` extra. One sub-command per experiment (docs/experiments.md)::

    python benchmarks/seed_experiments.py randommap runs/randommap_td3*/model.zip --episodes 50
    python benchmarks/seed_experiments.py crowdnav runs/crowdnav_card/model.zip \\
        runs/crowdnav_nominal/model.zip --episodes 50
    python benchmarks/seed_experiments.py race runs/race_sarl/model.zip --races 50
    python benchmarks/seed_experiments.py curve runs/carcrossing_*_s0/episodes.csv --block 20000

- ``randommap``: every model on TEST1-TEST4 (Yang et al.'s Table II metrics: success, crash
  and trap = timeout rates), pooled over the models (seeds) with Wilson 95 % intervals and the
  per-seed min/median/max, beside the paper's TD3 and SAC success rates;
- ``crowdnav``: every model with and without the card's randomiser stack
  (``examples/crowdnav_card_randomizers.yaml``): success, collisions, time to goal and
  oscillation, the sign changes of the commanded w per metre driven (Liang et al.'s complaint
  about jerky real-robot motion);
- ``race``: the SARL* policy against the global-plan + DWA racer and an ORCA racer (the same
  plan, ORCA velocities among the observed movers, turned into (v, w)) over the same seeded
  races against ORCA opponents: navigation time, collisions, path length and jerk (Pozo Ruiz
  2024);
- ``curve``: the learning curve of training runs from their ``episodes.csv``: per block of
  env steps the training episodes' outcome rates and mean return.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import statistics
from collections.abc import Callable, Sequence
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import itertools

import gymnasium as gym
import numpy as np
import yaml

import randomizers as dr
import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs.baselines import DWAController
from sim2real.envs.orca import orca_velocities
from sim2real.envs.race import N_BEAMS, N_NEIGHBOURS
from sim2real.envs.race_baseline import RaceBaseline
from sim2real.training.environment import DiscreteActions, build_env
from sim2real.training.evaluation import evaluate_controller, load_policy, wilson_interval

#: Yang et al., Table II: success rates on TEST1-TEST4.
PAPER_TABLE_II = {"TD3": (0.986, 0.920, 0.796, 0.656), "SAC": (0.786, 0.918, 0.850, 0.782)}
PRESETS = ("TEST1", "TEST2", "TEST3", "TEST4")
EVAL_SEED = 10_000


def _rate(rows: Sequence[dict[str, Any]], key: str) -> str:
    k, n = sum(bool(r[key]) for r in rows), len(rows)
    lo, hi = wilson_interval(k, n)
    return f"{k}/{n} = {k / n:.2f} [{lo:.2f}, {hi:.2f}]"


def _spread(values: Sequence[float]) -> str:
    vals = [v for v in values if not math.isnan(v)]
    if not vals:
        return "-"
    return f"{min(vals):.2f} / {statistics.median(vals):.2f} / {max(vals):.2f}"


def _mean(rows: Sequence[dict[str, Any]], key: str) -> float:
    vals = [float(r[key]) for r in rows if not math.isnan(float(r[key]))]
    return float(np.mean(vals)) if vals else math.nan


class _Commands:
    """Wraps a controller and keeps the commanded w of every step (for the oscillation)."""

    def __init__(self, controller: Any, to_w: Callable[[Any], float]) -> None:
        self.controller, self.to_w = controller, to_w
        self.w: list[float] = []

    def reset(self) -> None:
        self.w = []
        self.controller.reset()

    def act(self, obs: Any) -> Any:
        action = self.controller.act(obs)
        self.w.append(self.to_w(action))
        return action


def _w_of(env: Any) -> Callable[[Any], float]:
    """The commanded w (its sign: a [-1, 1] rescaling keeps it) of an action of ``env``."""
    while isinstance(env, gym.Wrapper):
        if isinstance(env, DiscreteActions):
            grid = env.grid
            return lambda a: float(grid[int(np.asarray(a).reshape(-1)[0]), 1])
        env = env.env
    return lambda a: float(np.asarray(a, dtype=np.float64).reshape(-1)[1])


def sign_changes_per_m(
    w: Sequence[float], path_length_m: float, *, dead_radps: float = 0.05
) -> float:
    """Sign changes of w (ignoring |w| below ``dead_radps``) per metre driven."""
    signs = [math.copysign(1.0, x) for x in w if abs(x) > dead_radps]
    flips = sum(a != b for a, b in itertools.pairwise(signs))
    return flips / path_length_m if path_length_m > 0.1 else math.nan


def _episodes(env: Any, controller: Any, episodes: int) -> list[dict[str, Any]]:
    probe = _Commands(controller, _w_of(env))
    rows: list[dict[str, Any]] = []

    def keep(_: int, row: dict[str, Any]) -> None:
        rows.append({**row, "oscillation_per_m": sign_changes_per_m(probe.w, row["path_length_m"])})

    evaluate_controller(env, probe, episodes=episodes, seed=EVAL_SEED, on_episode=keep)
    return rows


def _policy_env(path: str, **override: Any) -> tuple[Any, Any, dict[str, Any]]:
    policy = load_policy(path)
    meta = policy.metadata
    kwargs = {**meta.get("env_kwargs", {}), **override}
    return policy, policy.wrap(build_env(meta["env_id"], kwargs)), kwargs


def random_map(models: Sequence[str], episodes: int) -> None:
    """Every model on TEST1-TEST4 (success, crash, trap)."""
    per_preset: dict[str, list[dict[str, Any]]] = {p: [] for p in PRESETS}
    per_seed: dict[str, list[float]] = {p: [] for p in PRESETS}
    algorithm = ""
    for path in models:
        for preset in PRESETS:
            policy, env, _ = _policy_env(path, preset=preset)
            algorithm = policy.algorithm
            rows = _episodes(env, policy.controller(), episodes)
            per_preset[preset] += rows
            per_seed[preset].append(sum(r["success"] for r in rows) / len(rows))
            print(f"{path} {preset}: {_rate(rows, 'success')}", flush=True)
    paper = PAPER_TABLE_II.get(algorithm, (math.nan,) * 4)
    print(
        f"\n| {algorithm} | success (Wilson 95 %) | per seed min/median/max | crash | trap | paper |"
    )
    print("|---|---|---|---|---|---|")
    for preset, ref in zip(PRESETS, paper, strict=True):
        rows = per_preset[preset]
        print(
            f"| {preset} | {_rate(rows, 'success')} | {_spread(per_seed[preset])} | "
            f"{_rate(rows, 'collision')} | {_rate(rows, 'timeout')} | {ref:.3f} |"
        )


def _crowd_row(name: str, condition: str, rows: Sequence[dict[str, Any]]) -> None:
    print(
        f"| {name} | {condition} | {_rate(rows, 'success')} | {_rate(rows, 'collision')} "
        f"| {_mean(rows, 'time_to_goal_s'):.1f} | {_mean(rows, 'oscillation_per_m'):.2f} |",
        flush=True,
    )


def crowd_baselines(kwargs: dict[str, Any], episodes: int) -> None:
    """DWA on the lidar and ORCA with the pedestrians' true states on the same seeded episodes."""
    env = build_env("sim2real/CrowdNav-v0", {**kwargs, "neighbours": 5})
    for name, ctrl in (
        ("DWA (lidar)", DWAController.for_env(env)),
        ("ORCA (true pedestrian states)", OrcaWalker(env)),
    ):
        _crowd_row(name, "none", _episodes(env, ctrl, episodes))


def crowd_nav(models: Sequence[str], episodes: int, stack: str, *, baselines: bool) -> None:
    """Every model with and without the randomiser stack, then pooled over the models (seeds)
    with the per-model success min / median / max (and the baselines on its env)."""
    doc = yaml.safe_load(open(stack, encoding="utf-8"))  # noqa: SIM115
    print("| policy | evaluated | success | collision | time to goal s | oscillation /m |")
    print("|---|---|---|---|---|---|")
    kwargs: dict[str, Any] = {}
    pooled: dict[str, list[dict[str, Any]]] = {"none": [], "card stack": []}
    per_model: dict[str, list[float]] = {"none": [], "card stack": []}
    for path in models:
        for condition in ("none", "card stack"):
            policy, env, kwargs = _policy_env(path)
            if condition != "none":
                env = policy.wrap(dr.from_config(env.unwrapped, doc))
            rows = _episodes(env, policy.controller(), episodes)
            _crowd_row(path, condition, rows)
            pooled[condition] += rows
            per_model[condition].append(sum(r["success"] for r in rows) / len(rows))
    if len(models) > 1:
        for condition, rows in pooled.items():
            _crowd_row(f"{len(models)} models pooled", condition, rows)
            print(f"  success per model min / median / max: {_spread(per_model[condition])}")
    if baselines:
        crowd_baselines(kwargs, episodes)


def orca_unicycle(
    xy: np.ndarray,
    vel: np.ndarray,
    radius: np.ndarray,
    pref_mps: np.ndarray,
    *,
    yaw_rad: float,
    max_v_mps: float,
    max_w_radps: float,
    dt_s: float,
    reciprocal: bool,
) -> tuple[float, float] | None:
    """Agent 0's ORCA velocity among the others, driven as a unicycle: (v, w), None if ~0.

    v = |u| cos(e), w = 2 e / s clipped, e the heading error of u; ``reciprocal``: the others
    run ORCA too (half the avoidance each), else agent 0 takes all of it.
    """
    n = len(xy)
    active = np.zeros(n, dtype=bool)
    active[0] = True
    u = orca_velocities(
        xy,
        vel,
        radius,
        pref_mps,
        np.full(n, max_v_mps),
        dt_s,
        active=active,
        reciprocal=np.full(n, reciprocal),
    )[0]
    if float(np.hypot(*u)) < 1e-6:
        return None
    err = math.atan2(u[1], u[0]) - yaw_rad
    err = math.atan2(math.sin(err), math.cos(err))
    speed = max(0.0, float(np.hypot(*u)) * math.cos(err))
    return min(speed, max_v_mps), float(np.clip(2.0 * err, -max_w_radps, max_w_radps))


class OrcaRacer:
    """The race baseline's plan and carrot, with ORCA (van den Berg et al. 2011) among the movers.

    The robot takes the ORCA velocity towards the carrot at top speed against the observed
    movers (half the avoidance each; the opponents run ORCA too) and drives it as a unicycle
    (:func:`orca_unicycle`). Every radius carries ``margin_m`` more, since the unicycle lags
    the holonomic ORCA velocity.
    """

    def __init__(self, env: Any, *, margin_m: float = 0.05) -> None:
        self.margin_m = margin_m
        self.plan = RaceBaseline.for_env(env)
        self.base = env.unwrapped
        self.high = np.asarray(env.action_space.high, dtype=np.float64)

    def reset(self) -> None:
        self.plan.reset()

    def act(self, obs: Any) -> Any:
        o = np.asarray(obs, dtype=np.float64)
        x, y, yaw, v, _ = o[N_BEAMS : N_BEAMS + 5]
        dwa_action = self.plan.act(obs)  # advances the carrot along the plan
        path = self.plan.path
        assert path is not None
        ahead = path[min(self.plan._idx + 3, len(path) - 1)]
        to = ahead - np.array([x, y])
        c, s = math.cos(yaw), math.sin(yaw)
        rows = o[N_BEAMS + 7 :].reshape(N_NEIGHBOURS, 4)
        rows = rows[np.abs(rows).sum(axis=1) > 0]
        own = np.array([v * c, v * s])
        rot = np.array([[c, -s], [s, c]])  # robot frame -> track frame
        xy = np.vstack([np.zeros(2), rows[:, :2] @ rot.T])
        vel = np.vstack([own, rows[:, 2:] @ rot.T + own])
        vmax = float(self.high[0])
        pref = vel.copy()
        pref[0] = to / max(float(np.hypot(*to)), 1e-9) * vmax
        radius = np.full(len(xy), self.base.robot_radius_m + self.margin_m)
        vw = orca_unicycle(
            xy,
            vel,
            radius,
            pref,
            yaw_rad=yaw,
            max_v_mps=vmax,
            max_w_radps=float(self.high[1]),
            dt_s=self.base.control_dt,
            reciprocal=True,
        )
        if vw is None:
            return np.array([0.0, float(dwa_action[1])], dtype=np.float32)
        return np.array(vw, dtype=np.float32)


class OrcaWalker:
    """CrowdNav-v0's reference with the pedestrians' true states: ORCA towards the goal.

    Reads the observation's ``"neighbours"`` (relative positions and velocities, robot frame;
    the env needs ``neighbours`` > 0) and takes all the avoidance (the pedestrians of eq. (1)
    do not run ORCA); radii are the robot's plus ``margin_m`` and the largest pedestrian's.
    It sees neither the static obstacles nor the walls: a feasibility reference, not a policy.
    """

    def __init__(self, env: Any, *, margin_m: float = 0.05, pedestrian_m: float = 0.24) -> None:
        self.base = env.unwrapped
        self.margin_m, self.pedestrian_m = margin_m, pedestrian_m
        self.high = np.asarray(self.base.action_space.high, dtype=np.float64)

    def reset(self) -> None:
        pass

    def act(self, obs: Any) -> Any:
        d, bearing = (float(x) for x in obs["goal"])
        v = float(obs["velocity"][0])
        rows = np.asarray(obs["neighbours"], dtype=np.float64).reshape(-1, 4)
        rows = rows[np.abs(rows).sum(axis=1) > 0]
        own = np.array([v, 0.0])
        xy = np.vstack([np.zeros(2), rows[:, :2]])
        vel = np.vstack([own, rows[:, 2:] + own])
        pref = vel.copy()
        pref[0] = np.array([math.cos(bearing), math.sin(bearing)]) * min(float(self.high[0]), d)
        radius = np.full(len(xy), self.pedestrian_m)
        radius[0] = self.base.robot_radius_m + self.margin_m
        vw = orca_unicycle(
            xy,
            vel,
            radius,
            pref,
            yaw_rad=0.0,
            max_v_mps=float(self.high[0]),
            max_w_radps=float(self.high[1]),
            dt_s=self.base.control_dt,
            reciprocal=False,
        )
        return np.array((0.0, 0.0) if vw is None else vw, dtype=np.float32)


def race(model: str, races: int, racers: Sequence[str] = ("sarl", "dwa", "orca")) -> None:
    """SARL* vs DWA vs ORCA racers on the same seeded races."""
    policy, env, kwargs = _policy_env(model)
    raw = gym.make("sim2real/Race-v0", **kwargs)
    print(f"Race-v0 {kwargs}, {races} races each, seeds {EVAL_SEED}..{EVAL_SEED + races - 1}")
    print(
        "| racer | success | collision (mover) | wall collision | navigation time s "
        "| min / median / max s | path length m | jerk v m/s^3 | jerk w rad/s^3 |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    entries = {
        "sarl": ("SARL* (DQN)", env, policy.controller()),
        "dwa": ("A* + DWA", raw, RaceBaseline.for_env(raw)),
        "orca": ("A* + ORCA", raw, OrcaRacer(raw)),
    }
    for name, e, ctrl in (entries[r] for r in racers):
        rows = _episodes(e, ctrl, races)
        print(
            f"| {name} | {_rate(rows, 'success')} | {_rate(rows, 'collision')} | "
            f"{_rate(rows, 'wall_collision')} | {_mean(rows, 'time_to_goal_s'):.1f} | "
            f"{_spread([float(r['time_to_goal_s']) for r in rows])} | "
            f"{_mean(rows, 'path_length_m'):.2f} | {_mean(rows, 'mean_abs_jerk_v_mps3'):.3f} | "
            f"{_mean(rows, 'mean_abs_jerk_w_radps3'):.2f} |",
            flush=True,
        )


# episodes.csv outcomes by kind: RandomMap-v0 says "crash" and "trap" (Yang et al.'s words)
_OUTCOMES = {
    "success": ("success",),
    "collision": ("collision", "crash"),
    "timeout": ("timeout", "trap"),
    "overshoot": ("overshoot",),
}


def curve(files: Sequence[str], block: int) -> None:
    """Per block of ``block`` env steps: success, collision, timeout, overshoot rates, return."""
    print("| run | steps | episodes | success | collision | timeout | overshoot | mean return |")
    print("|---|---|---|---|---|---|---|---|")
    for path in files:
        with open(path, encoding="utf-8", newline="") as f:
            rows = list(csv.DictReader(f))
        blocks: dict[int, list[dict[str, str]]] = {}
        for row in rows:
            blocks.setdefault((int(row["step"]) - 1) // block, []).append(row)
        for b, part in sorted(blocks.items()):
            n = len(part)
            share = {
                kind: sum(r["outcome"] in names for r in part) / n
                for kind, names in _OUTCOMES.items()
            }
            ret = statistics.fmean(float(r["return"]) for r in part)
            print(
                f"| {path} | {b * block}-{(b + 1) * block} | {n} | {share['success']:.2f} | "
                f"{share['collision']:.2f} | {share['timeout']:.2f} | "
                f"{share['overshoot']:.2f} | {ret:.2f} |"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="experiment", required=True)
    p = sub.add_parser("randommap")
    p.add_argument("models", nargs="+")
    p.add_argument("--episodes", type=int, default=50)
    p = sub.add_parser("crowdnav")
    p.add_argument("models", nargs="+")
    p.add_argument("--episodes", type=int, default=50)
    p.add_argument("--stack", default="examples/crowdnav_card_randomizers.yaml")
    p.add_argument(
        "--baselines", action="store_true", help="also DWA and ORCA on the first model's env"
    )
    p = sub.add_parser("race")
    p.add_argument("model")
    p.add_argument("--races", type=int, default=50)
    p.add_argument("--racers", default="sarl,dwa,orca", help="comma-separated: sarl, dwa, orca")
    p = sub.add_parser("curve")
    p.add_argument("files", nargs="+")
    p.add_argument("--block", type=int, default=20_000)
    args = parser.parse_args()
    if args.experiment == "randommap":
        random_map(args.models, args.episodes)
    elif args.experiment == "crowdnav":
        crowd_nav(args.models, args.episodes, args.stack, baselines=args.baselines)
    elif args.experiment == "curve":
        curve(args.files, args.block)
    else:
        race(args.model, args.races, args.racers.split(","))


if __name__ == "__main__":
    main()
