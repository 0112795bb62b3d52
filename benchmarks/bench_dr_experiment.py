"""Does randomisation from a sysid result help a policy survive a robot it never saw?

Run (needs the [train] extra; minutes to hours depending on the budget)::

    nice .venv/bin/python benchmarks/bench_dr_experiment.py --timesteps 60000 --seeds 0 1 2 \\
        --episodes 30 --out bench-dr

Protocol
--------
1. **Identify** the simulated robot: ``sim2real sysid fit`` on the bundled training log
   (``data/demo_train.mcap``, TurtleBot3 Burger) gives the sim robot's drive parameters, their
   uncertainty and its odometry noise (the result's ``randomization`` block).
2. **Train** the same algorithm (SB3 PPO, same hyperparameters, same seeds) twice per seed on
   RandomMap-v0 (reduced dynamics, a 2 m course with 3-10 cylinders so that a small budget
   learns something) with the identified parameters:

   - ``nominal``: no randomisation;
   - ``DR``: dynamics + sensor randomisation built from the sysid result --
     ``DynamicsRandomizer`` with each varying field ~ N(fitted value, s^2) where s is the
     result's marginal std times ``--spread`` with a floor (delay 0.05 s, added mass 0.3 kg,
     20 % of the value otherwise), odometry noise ``ObservationNoise`` with the result's
     odometry noise std times ``--noise-factor``, and ``OdometryDelay`` of 0-0.1 s.

3. **Evaluate** both on the identified sim robot and on a "real" robot the policies never saw:
   the identified parameters with a heavier payload (``--real-added-mass-kg`` more), a longer
   command delay (``--real-extra-delay-s`` more) and noisier odometry (``--real-noise-factor``
   times the identified noise std), on the same ``--episodes`` seeded maps per model.

Reported: success and collision rates per condition as mean over seeds with a 95 % Student-t
interval across seeds, and the pooled Wilson 95 % interval over all episodes. Training time per
run is printed. Everything (configs, models, per-episode results) stays in ``--out``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from scipy import stats

from robots.params import read_params_file
from robots.randomization import DriveDistribution
from robots.spec import load_spec
from sim2real.cli import main as cli_main
from sim2real.evaluation import PolicyController, evaluate_controller, load_policy, wilson_interval
from sim2real.train import build_env, config_from_dict, train

ROOT = Path(__file__).resolve().parents[1]
ROBOT = "turtlebot3_burger"
#: A course a small budget can learn: 2 m to the goal, 3-10 cylinders, half the walls.
MAP = {"d_target_m": 2.0, "n_min": 3, "n_max": 10, "area_m": 5.0, "r_wall": 0.5}
MAX_STEPS = 200
#: Cheap updates (few gradient steps per sample): the env, not the optimiser, takes the time.
PPO = {
    "learning_rate": 1e-3,
    "n_steps": 512,
    "batch_size": 256,
    "n_epochs": 4,
    "gamma": 0.99,
    # std 0.22 at the start: with std 1 most draws of v (range [0, 0.21]) are clipped, and the
    # deterministic policy (the mean) may stand still after a short budget
    "policy_kwargs": {"net_arch": [64, 64], "log_std_init": -1.5},
}
#: Drive-chain fields randomised (the speed caps stay: the action space is bounded anyway).
DR_FIELDS = (
    "delay_s",
    "added_mass_kg",
    "added_yaw_inertia_kgm2",
    "motor_gain_nms_per_rad",
    "accel_lim_v_mps2",
    "accel_lim_w_radps2",
    "coulomb_v_fwd_n",
    "coulomb_v_bwd_n",
    "coulomb_w_nm",
    "viscous_v_ns_per_m",
    "viscous_w_nms_per_rad",
)
#: Floors of the dynamics randomisation std (value units).
FLOORS = {"delay_s": 0.05, "added_mass_kg": 0.3}
REL_FLOOR = 0.2
ODOM = [38, 40]  # RandomMap-v0 observation: measured v (m/s), w (rad/s)


def fit(out: Path) -> Path:
    """The sim robot's sysid result (fitted once; reused when present)."""
    path = out / "sim_fit.yaml"
    if not path.is_file():
        argv = ["sysid", "fit", str(ROOT / "data" / "demo_train.mcap"), "--robot", ROBOT]
        if cli_main([*argv, "-o", str(path)]) != 0:
            raise SystemExit("sysid fit failed")
    return path


def marginals(path: Path, spread: float) -> tuple[dict[str, list[float]], dict[str, float]]:
    """Per-field N(mean, std) in value units of the result's distribution (widened), and noise."""
    dist = DriveDistribution.from_params_file(path, robot=ROBOT)
    draws = dist.sample(np.random.default_rng(0), 4000)
    values = read_params_file(path).values
    normal = {}
    for name in (n for n in dist.names if n in DR_FIELDS):
        x = np.array([getattr(d, name) for d in draws])
        if not np.all(np.isfinite(x)):
            continue
        centre = float(values.get(name, float(np.mean(x))))
        floor = FLOORS.get(name, REL_FLOOR * abs(centre))
        normal[name] = [centre, max(spread * float(np.std(x)), floor)]
    noise = {"v": dist.noise.std_v_mps, "w": dist.noise.std_w_radps}
    return normal, noise


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


def dr_stack(normal: dict[str, list[float]], noise: dict[str, float], k: float) -> dict[str, Any]:
    geo = load_spec(ROBOT).geometry
    # total mass and yaw inertia stay above 20 % of the bare robot's
    bounds = {
        "added_mass_kg": [-0.8 * geo.mass_kg, math.inf],
        "added_yaw_inertia_kgm2": [-0.8 * geo.yaw_inertia_kgm2, math.inf],
    }
    return {
        "format": "sim2real.randomizers/1",
        "randomizers": [
            {"type": "DynamicsRandomizer", "normal": normal, "bounds": bounds},
            {"type": "ObservationNoise", "index": ODOM, "std": [k * noise["v"], k * noise["w"]]},
            {"type": "OdometryDelay", "index": ODOM, "delay_s": [0.0, 0.1]},
        ],
    }


def evaluate_on(model_zip: Path, params: Path, noise_std: list[float] | None, n: int) -> Any:
    policy = load_policy(model_zip)
    rand = None
    if noise_std is not None:
        rand = {
            "format": "sim2real.randomizers/1",
            "randomizers": [{"type": "ObservationNoise", "index": ODOM, "std": noise_std}],
        }
    env = build_env(
        "sim2real/RandomMap-v0",
        {"map_config": MAP, "max_episode_steps": MAX_STEPS, "params": str(params)},
        randomizers=rand,
    )
    try:
        return evaluate_controller(env, PolicyController(policy.model), episodes=n, seed=900_000)
    finally:
        env.close()


def t_interval(x: list[float]) -> tuple[float, float, float]:
    """Mean and 95 % Student-t interval across seeds."""
    a = np.asarray(x, dtype=float)
    m = float(a.mean())
    if a.size < 2:
        return m, math.nan, math.nan
    half = float(stats.t.ppf(0.975, a.size - 1) * a.std(ddof=1) / math.sqrt(a.size))
    return m, max(0.0, m - half), min(1.0, m + half)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--timesteps", type=int, default=60_000, help="PPO env steps per run")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--episodes", type=int, default=40, help="evaluation episodes per model")
    ap.add_argument("--n-envs", type=int, default=2)
    ap.add_argument(
        "--vec-env", default="dummy", help="dummy (one process; best on a shared 2-core box)"
    )
    ap.add_argument("--spread", type=float, default=3.0, help="x the result's std (dynamics)")
    ap.add_argument("--noise-factor", type=float, default=10.0, help="x odometry noise std (DR)")
    ap.add_argument("--real-added-mass-kg", type=float, default=0.6)
    ap.add_argument("--real-extra-delay-s", type=float, default=0.12)
    ap.add_argument("--real-noise-factor", type=float, default=10.0)
    ap.add_argument("--out", type=Path, default=Path("bench-dr"))
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    sim = fit(args.out)
    normal, noise = marginals(sim, args.spread)
    real = real_robot(
        sim, args.out, extra_mass=args.real_added_mass_kg, extra_delay=args.real_extra_delay_s
    )
    real_noise = [args.real_noise_factor * noise["v"], args.real_noise_factor * noise["w"]]
    print(f"sim robot: {sim}; DR dynamics (value, std): {normal}; odometry noise std {noise}")
    print(
        f"real robot: {real} (+{args.real_added_mass_kg} kg, +{args.real_extra_delay_s} s, "
        f"odometry noise std {real_noise})"
    )
    conditions = {"nominal": None, "DR": dr_stack(normal, noise, args.noise_factor)}
    results: dict[str, dict[str, list[Any]]] = {}
    for seed in args.seeds:
        for name, stack in conditions.items():
            out = args.out / f"{name}_seed{seed}"
            if not (out / "model.zip").is_file():
                cfg = config_from_dict(
                    {
                        "env": {
                            "id": "sim2real/RandomMap-v0",
                            "kwargs": {
                                "map_config": MAP,
                                "max_episode_steps": MAX_STEPS,
                                "params": str(sim.resolve()),
                            },
                        },
                        "randomizers": stack,
                        "algorithm": "PPO",
                        "hyperparameters": PPO,
                        "timesteps": args.timesteps,
                        "n_envs": args.n_envs,
                        "vec_env": args.vec_env,
                        "seed": seed,
                        "out": str(out),
                        "evaluation": {"episodes": 0},
                    }
                )
                t0 = time.perf_counter()
                train(cfg)
                print(f"trained {name} seed {seed}: {time.perf_counter() - t0:.0f} s", flush=True)
            for where, params, nstd in (("sim", sim, None), ("real", real, real_noise)):
                s = evaluate_on(out / "model.zip", params, nstd, args.episodes)
                row = results.setdefault(
                    f"{name}@{where}", {"success": [], "collision": [], "n_success": [], "n": []}
                )
                row["success"].append(s.success_rate)
                row["collision"].append(s.collision_rate)
                row["n_success"].append(round(s.success_rate * s.episodes))
                row["n"].append(s.episodes)
                print(
                    f"  {name} seed {seed} on {where}: success {s.success_rate:.2f} "
                    f"collision {s.collision_rate:.2f}",
                    flush=True,
                )
    lines = [
        f"PPO, {args.timesteps} steps x seeds {args.seeds}, {args.episodes} eval episodes per "
        "model and robot",
        "",
        "| trained | evaluated on | success (mean, 95 % t-CI over seeds) | success pooled "
        "(Wilson 95 %) | collision (mean, 95 % t-CI) |",
        "|---|---|---|---|---|",
    ]
    for key, row in results.items():
        name, where = key.split("@")
        m, lo, hi = t_interval(row["success"])
        cm, clo, chi = t_interval(row["collision"])
        wl, wh = wilson_interval(sum(row["n_success"]), sum(row["n"]))
        lines.append(
            f"| {name} | {where} | {m:.2f} [{lo:.2f}, {hi:.2f}] | "
            f"{sum(row['n_success'])}/{sum(row['n'])} [{wl:.2f}, {wh:.2f}] | "
            f"{cm:.2f} [{clo:.2f}, {chi:.2f}] |"
        )
    table = "\n".join(lines)
    print(table)
    (args.out / "results.md").write_text(table + "\n")
    (args.out / "results.yaml").write_text(yaml.safe_dump(results, sort_keys=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
