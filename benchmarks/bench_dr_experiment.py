"""Does randomisation from a sysid result help a policy survive a robot it never saw?

Run (needs the [train] extra; the defaults took 50 min on 2 shared cores)::

    nice -n 10 .venv/bin/python benchmarks/bench_dr_experiment.py --out bench-dr
    .venv/bin/python benchmarks/bench_dr_experiment.py --timesteps 3000 --seeds 0 --episodes 4 \\
        --out /tmp/dr-smoke                                  # a minute: does it run

Protocol
--------
1. **Identify** the simulated robot: ``sim2real sysid fit`` on the bundled training log
   (``data/demo_train.mcap``, TurtleBot3 Burger) gives the sim robot's drive parameters, their
   uncertainty and its odometry noise (the result's ``randomization`` block).
2. **Train** the same algorithm (SB3, same hyperparameters, same seeds) twice per seed on
   RandomMap-v0 (reduced dynamics) with the identified parameters, on a course this budget can
   learn (``--course``: 2 m to the goal through 0-4 cylinders, no walls, 200 steps), with
   observations and actions scaled to [-1, 1] (``normalize`` of the training config):

   - ``nominal``: no randomisation;
   - ``DR``: dynamics + sensor randomisation from the sysid result --
     ``DynamicsRandomizer(sysid=..., spread=--spread)`` (the one sampler,
     :meth:`robots.randomization.DriveDistribution.sample`, every identified standard deviation
     times the spread), odometry noise ``ObservationNoise`` with the result's odometry noise
     std times ``--noise-factor``, and ``OdometryDelay`` of 0-0.1 s.

   Each run's training curve (success rate of its training episodes per tenth of the budget)
   is printed: the nominal policy must learn on its own robot for the comparison to mean
   anything.
3. **Evaluate** both on the identified sim robot and on a "real" robot the policies never saw:
   the identified parameters with a heavier payload (``--real-added-mass-kg`` more), a longer
   command delay (``--real-extra-delay-s`` more) and noisier odometry (``--real-noise-factor``
   times the identified noise std), on the same ``--episodes`` seeded maps per model.

Reported: success and collision rates per condition, per seed and pooled over the seeds with
the Wilson 95 % interval over all episodes, the budget and the wall time. Everything
(configs, models, curves, per-episode results) stays in ``--out``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse
import itertools
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from robots.randomization import DriveDistribution
from sim2real.cli import main as cli_main
from sim2real.training.config import config_from_dict
from sim2real.training.environment import build_env
from sim2real.training.evaluation import evaluate_controller, load_policy, wilson_interval
from sim2real.training.train import train

ROOT = Path(__file__).resolve().parents[1]
ROBOT = "turtlebot3_burger"
#: Courses (RandomMap MapConfig fields): 2 m to the goal, a few cylinders, no walls.
COURSES = {
    "sparse": {"d_target_m": 2.0, "n_min": 0, "n_max": 4, "area_m": 5.0, "r_wall": 0.0},
    "open": {"d_target_m": 2.0, "n_min": 0, "n_max": 0, "area_m": 5.0, "r_wall": 0.0},
}
MAX_STEPS = 200
#: Many small updates (8 envs x 64 steps per rollout) and a short horizon: the env, not the
#: optimiser, takes the time; initial action std 0.37 of the [-1, 1] range.
HYPERPARAMETERS = {
    "PPO": {
        "learning_rate": 1e-3,
        "n_steps": 64,
        "batch_size": 128,
        "n_epochs": 10,
        "gamma": 0.98,
        "gae_lambda": 0.95,
        "policy_kwargs": {"net_arch": [64, 64], "log_std_init": -1.0},
    },
    "SAC": {
        "learning_rate": 1e-3,
        "buffer_size": 100_000,
        "batch_size": 256,
        "gamma": 0.98,
        "learning_starts": 1000,
        "policy_kwargs": {"net_arch": [64, 64]},
    },
}
ODOM = [38, 40]  # RandomMap-v0 observation: measured v (m/s), w (rad/s)


def fit(out: Path) -> Path:
    """The sim robot's sysid result (fitted once; reused when present)."""
    path = out / "sim_fit.yaml"
    if not path.is_file():
        argv = ["sysid", "fit", str(ROOT / "data" / "demo_train.mcap"), "--robot", ROBOT]
        if cli_main([*argv, "-o", str(path)]) != 0:
            raise SystemExit("sysid fit failed")
    return path


def real_robot(path: Path, out: Path, *, extra_mass: float, extra_delay: float) -> Path:
    """A sysid-format params file: the identified robot, heavier and slower to respond."""
    doc = yaml.safe_load(path.read_text())
    params = {k: v["value"] for k, v in doc["parameters"].items()}
    params["added_mass_kg"] = float(params["added_mass_kg"]) + extra_mass
    params["delay_s"] = float(params["delay_s"]) + extra_delay
    real = {
        "format": "sim2real.sysid/1",
        "robot": ROBOT,
        "parameters": {k: {"value": v, "status": "fixed"} for k, v in params.items()},
    }
    target = out / "real_robot.yaml"
    target.write_text(yaml.safe_dump(real, sort_keys=False))
    return target


def dr_stack(sim: Path, noise_std: list[float], spread: float) -> dict[str, Any]:
    return {
        "format": "sim2real.randomizers/1",
        "randomizers": [
            {"type": "DynamicsRandomizer", "sysid": str(sim.resolve()), "spread": spread},
            {"type": "ObservationNoise", "index": ODOM, "std": noise_std},
            {"type": "OdometryDelay", "index": ODOM, "delay_s": [0.0, 0.1]},
        ],
    }


def learning_curve(episodes_csv: Path, total: int, parts: int = 10) -> list[float]:
    """Success rate of the training episodes ending in each tenth of the budget (NaN: none)."""
    rows = [line.split(",") for line in episodes_csv.read_text().splitlines()[1:]]
    steps = np.array([int(r[0]) for r in rows])
    success = np.array([r[1] == "success" for r in rows])
    edges = np.linspace(0, total, parts + 1)
    out = []
    for lo, hi in itertools.pairwise(edges):
        pick = (steps > lo) & (steps <= hi)
        out.append(float(success[pick].mean()) if pick.any() else float("nan"))
    return out


def evaluate_on(
    model_zip: Path, env_kwargs: dict[str, Any], noise_std: list[float] | None, n: int
) -> Any:
    policy = load_policy(model_zip)
    rand = None
    if noise_std is not None:
        rand = {
            "format": "sim2real.randomizers/1",
            "randomizers": [{"type": "ObservationNoise", "index": ODOM, "std": noise_std}],
        }
    env = policy.wrap(build_env("sim2real/RandomMap-v0", env_kwargs, randomizers=rand))
    try:
        return evaluate_controller(env, policy.controller(), episodes=n, seed=900_000)
    finally:
        env.close()


def train_run(
    args: argparse.Namespace, out: Path, env_kwargs: dict[str, Any], stack: Any, seed: int
) -> float:
    """Train one model into ``out`` (skipped when its model exists); wall seconds."""
    if (out / "model.zip").is_file():
        return float(yaml.safe_load((out / "run.yaml").read_text())["wall_s"])
    cfg = config_from_dict(
        {
            "env": {"id": "sim2real/RandomMap-v0", "kwargs": env_kwargs},
            "randomizers": stack,
            "algorithm": args.algorithm,
            "hyperparameters": HYPERPARAMETERS[args.algorithm],
            "timesteps": args.timesteps,
            "n_envs": args.n_envs,
            "vec_env": "dummy",
            "seed": seed,
            "out": str(out),
            "evaluation": {"episodes": 0},
            # rewards stay raw: normalising them (VecNormalize) drowned the progress reward in
            # the crash penalty's variance here (no learning at 50k steps, 39 % success without)
            "normalize": {"observations": True, "actions": True, "rewards": False},
        }
    )
    t0 = time.perf_counter()
    result = train(cfg)
    wall = time.perf_counter() - t0
    curve = learning_curve(out / "episodes.csv", result.timesteps)
    (out / "run.yaml").write_text(
        yaml.safe_dump({"wall_s": wall, "timesteps": result.timesteps, "curve": curve})
    )
    return wall


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--algorithm", choices=sorted(HYPERPARAMETERS), default="PPO")
    ap.add_argument("--timesteps", type=int, default=120_000, help="env steps per run")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--episodes", type=int, default=50, help="evaluation episodes per model")
    ap.add_argument("--n-envs", type=int, default=8, help="envs in one process (DummyVecEnv)")
    ap.add_argument("--course", choices=sorted(COURSES), default="sparse")
    ap.add_argument("--spread", type=float, default=3.0, help="x the identified std (dynamics)")
    ap.add_argument("--noise-factor", type=float, default=10.0, help="x odometry noise std (DR)")
    ap.add_argument("--real-added-mass-kg", type=float, default=0.6)
    ap.add_argument("--real-extra-delay-s", type=float, default=0.12)
    ap.add_argument("--real-noise-factor", type=float, default=10.0)
    ap.add_argument("--out", type=Path, default=Path("bench-dr"))
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    sim = fit(args.out)
    noise = DriveDistribution.from_params_file(sim, robot=ROBOT).noise
    real = real_robot(
        sim, args.out, extra_mass=args.real_added_mass_kg, extra_delay=args.real_extra_delay_s
    )
    dr_noise = [args.noise_factor * noise.std_v_mps, args.noise_factor * noise.std_w_radps]
    real_noise = [
        args.real_noise_factor * noise.std_v_mps,
        args.real_noise_factor * noise.std_w_radps,
    ]
    course = COURSES[args.course]
    base = {"map_config": course, "max_episode_steps": MAX_STEPS}
    print(
        f"sim robot: {sim}; odometry noise std v {noise.std_v_mps:.4g} m/s, w {noise.std_w_radps:.4g} rad/s"
    )
    print(
        f"real robot: {real} (+{args.real_added_mass_kg} kg, +{args.real_extra_delay_s} s, "
        f"odometry noise std {real_noise})"
    )
    conditions = {"nominal": None, "DR": dr_stack(sim, dr_noise, args.spread)}
    rows: dict[str, dict[str, list[int]]] = {}
    walls: list[float] = []
    for seed in args.seeds:
        for name, stack in conditions.items():
            out = args.out / f"{name}_seed{seed}"
            wall = train_run(args, out, {**base, "params": str(sim.resolve())}, stack, seed)
            walls.append(wall)
            curve = yaml.safe_load((out / "run.yaml").read_text())["curve"]
            print(
                f"trained {name} seed {seed}: {wall:.0f} s; training success per tenth: "
                + " ".join("-" if c != c else f"{c:.2f}" for c in curve),
                flush=True,
            )
            for where, params, nstd in (("sim", sim, None), ("real", real, real_noise)):
                kwargs = {**base, "params": str(params.resolve())}
                s = evaluate_on(out / "model.zip", kwargs, nstd, args.episodes)
                add_outcomes(rows.setdefault(f"{name}@{where}", {}), s)
                print(
                    f"  {name} seed {seed} on {where}: success {s.success_rate:.2f} "
                    f"collision {s.collision_rate:.2f}",
                    flush=True,
                )
    total_s = time.perf_counter() - t_start
    lines = [
        f"{args.algorithm}, {args.timesteps} env steps per run, seeds {args.seeds}, course "
        f"'{args.course}' {course}, {MAX_STEPS} steps per episode, {args.episodes} evaluation "
        f"episodes per model and robot (seeds 900000-{900000 + args.episodes - 1}); training "
        f"wall time per run {min(walls):.0f}-{max(walls):.0f} s, whole experiment "
        f"{total_s / 60:.0f} min",
        "",
        f"| trained | evaluated on | {POOLED_HEADER} |",
        "|---|---|---|---|---|",
    ]
    for key, row in rows.items():
        name, where = key.split("@")
        lines.append(f"| {name} | {where} | {pooled_cells(row)} |")
    table = "\n".join(lines)
    print(table)
    (args.out / "results.md").write_text(table + "\n")
    (args.out / "results.yaml").write_text(yaml.safe_dump(rows, sort_keys=False))
    return 0


def add_outcomes(row: dict[str, list[Any]], summary: Any) -> None:
    """Append one evaluation's successes, collisions and episodes (an ``EvalSummary``) to the
    runs of ``row`` that :func:`pooled_cells` pools."""
    for key, value in (
        ("success", round(summary.success_rate * summary.episodes)),
        ("collision", round(summary.collision_rate * summary.episodes)),
        ("n", summary.episodes),
    ):
        row.setdefault(key, []).append(value)


#: The header of :func:`pooled_cells`' three cells.
POOLED_HEADER = "success per seed | success pooled (Wilson 95 %) | collision pooled (Wilson 95 %)"


def pooled_cells(row: dict[str, list[Any]]) -> str:
    """Three table cells of one row of runs: the successes per seed, then the pooled success
    and collision rates with their Wilson 95 % intervals."""
    n, ks, kc = sum(row["n"]), sum(row["success"]), sum(row["collision"])
    (sl, sh), (cl, ch) = wilson_interval(ks, n), wilson_interval(kc, n)
    per_seed = ", ".join(f"{k}/{m}" for k, m in zip(row["success"], row["n"], strict=True))
    return (
        f"{per_seed} | {ks}/{n} = {ks / n:.2f} [{sl:.2f}, {sh:.2f}] | "
        f"{kc}/{n} = {kc / n:.2f} [{cl:.2f}, {ch:.2f}]"
    )


if __name__ == "__main__":
    sys.exit(main())
