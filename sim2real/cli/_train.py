"""`sim2real train CONFIG.yaml`: train a policy (SB3) on a sim2real env with randomizers."""

from __future__ import annotations

import argparse
import math
import sys

from sim2real.training.config import RLLIB_PPO, load_config, require_rllib, require_train_extra
from sim2real.training.train import train

__all__ = ["handle_train"]


def _fmt(value: object) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    return f"{value:.2f}" if isinstance(value, float) else str(value)


def handle_train(args: argparse.Namespace) -> int:
    """``train CONFIG.yaml``: train, then print the steps, the rate and the evaluation."""
    cfg = load_config(args.config, timesteps=args.timesteps, seed=args.seed, out=args.out)
    if cfg.algorithm == RLLIB_PPO:
        require_rllib()
    else:
        require_train_extra()
    progress = sys.stderr.isatty() and not args.no_progress
    print(
        f"training {cfg.algorithm} on {cfg.env_id} for {cfg.timesteps} steps "
        f"({cfg.n_envs} env(s), seed {cfg.seed}) -> {cfg.out}"
    )
    result = train(cfg, progress=progress)
    ev = result.evaluation
    rate = result.timesteps / result.train_time_s if result.train_time_s > 0 else math.nan
    print(
        f"trained {result.timesteps} steps in {result.train_time_s:.1f} s ({rate:.0f} steps/s); "
        f"wrote {result.model_path}"
    )
    if ev.get("episodes"):
        print(
            f"evaluation ({ev['episodes']} episodes, seeds {ev['seeds'][0]}..{ev['seeds'][1]}): "
            f"success {_fmt(ev['success_rate'])}, collision {_fmt(ev['collision_rate'])}, "
            f"timeout {_fmt(ev['timeout_rate'])} -> {result.out / 'evaluation.yaml'}"
        )
    return 0
