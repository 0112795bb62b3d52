"""Does PPO learn to aim in CrowdNav-v0's empty room, from which observation entries?

Run (needs the ``[train]`` extra; one training, 6-10 min on a shared 2-core machine)::

    .venv/bin/python benchmarks/crowdnav_aim.py --keys goal,velocity --timesteps 30720
    .venv/bin/python benchmarks/crowdnav_aim.py --keys goal,velocity,lidar,depth
    .venv/bin/python benchmarks/crowdnav_aim.py --keys goal,velocity,lidar,depth --encoders

The empty room (static scenario, complexity 0, 8 x 6 depth image, 400-step episodes) with
observations and actions scaled to [-1, 1] as the configs train, keeping only ``--keys`` of the
Dict observation. SB3 PPO (``MultiInputPolicy``, lr 3e-4, 512 steps per update, batch 64, gamma
0.99; ``--encoders``: a small encoder per sensor entry, as the config's ``policy: sensors``)
prints its mean training return and episode length every 5,120 steps, then the deterministic
policy's success on ``--episodes`` seeded episodes (seeds from 10,000) with its
Wilson 95 % interval.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # small networks: one thread is fastest

import argparse
import time
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.monitor import Monitor

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.training._sensors import SensorEncoderExtractor
from sim2real.training.environment import build_env
from sim2real.training.evaluation import wilson_interval

EMPTY_ROOM = {"scenario": "static", "complexity": 0.0, "depth_width": 8, "depth_height": 6}
_CHUNK = 5120


def _env(keys: list[str]) -> Any:
    env = build_env(
        "sim2real/CrowdNav-v0",
        {**EMPTY_ROOM, "max_episode_steps": 400},
        normalize={"observations": True, "actions": True},
    )
    return Monitor(gym.wrappers.FilterObservation(env, keys))


def main() -> None:
    """Train, print the learning curve, evaluate."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--keys", default="goal,velocity", help="observation entries kept")
    ap.add_argument("--timesteps", type=int, default=30720)
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--encoders", action="store_true", help="a small encoder per sensor")
    args = ap.parse_args()
    keys = args.keys.split(",")
    model = PPO(
        "MultiInputPolicy",
        _env(keys),
        learning_rate=3e-4,
        n_steps=512,
        batch_size=64,
        gamma=0.99,
        seed=args.seed,
        policy_kwargs={"features_extractor_class": SensorEncoderExtractor}
        if args.encoders
        else None,
    )
    start = time.perf_counter()
    while model.num_timesteps < args.timesteps:
        model.learn(_CHUNK, reset_num_timesteps=False)
        eps = model.ep_info_buffer
        print(
            f"{model.num_timesteps} steps, {time.perf_counter() - start:.0f} s: return "
            f"{np.mean([e['r'] for e in eps]):.2f}, length {np.mean([e['l'] for e in eps]):.0f}",
            flush=True,
        )
    env, wins = _env(keys), 0
    for k in range(args.episodes):
        obs, _ = env.reset(seed=10000 + k)
        done = False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        wins += info["outcome"] == "success"
    lo, hi = wilson_interval(wins, args.episodes)
    print(f"observes {keys}: success {wins}/{args.episodes} [{lo:.2f}, {hi:.2f}]")


if __name__ == "__main__":
    main()
