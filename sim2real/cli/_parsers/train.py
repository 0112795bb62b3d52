"""Arguments of `sim2real train CONFIG.yaml`: train a policy on a sim2real env with randomizers."""

from __future__ import annotations

import argparse

from sim2real.cli._common import add_command

__all__ = ["register"]

_EXAMPLES = """\
  sim2real train examples/randommap_ppo.yaml                     # as configured
  sim2real train examples/randommap_ppo.yaml --timesteps 2000    # a quick smoke run
  sim2real train examples/crowdnav_ppo.yaml --seed 3 --out runs/crowd_s3
  sim2real train examples/carcrossing_dqn.yaml
  .venv-rllib/bin/sim2real train examples/randommap_rllib_ppo.yaml   # RLlib env runners
  sim2real envs eval RandomMap-v0 --policy runs/randommap_ppo/model.zip --episodes 20
  tensorboard --logdir runs/randommap_ppo/tensorboard
"""


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register the ``train`` command."""
    p = add_command(
        sub,
        "train",
        help="train a policy (SB3 PPO/SAC/TD3/DQN, RLlib PPO) with a randomizer stack from YAML",
        description=(
            "Read a training config (format sim2real.train/1: env id and options, randomizer "
            "stack, algorithm, timesteps, parallel envs, seed, output folder; see "
            "sim2real.training.train), train with stable-baselines3 and write OUT/config.yaml (resolved), "
            "OUT/model.zip, OUT/checkpoints/, OUT/tensorboard/ and OUT/evaluation.yaml (a "
            "short seeded evaluation). Needs the [train] extra: pip install torch==2.13.0 && "
            "pip install -e '.[train]'. algorithm: rllib-ppo trains with Ray RLlib instead "
            "(env runners on a Ray cluster; the policy is OUT/model/; needs ray[rllib], which "
            "pins gymnasium 1.2.2: make rllib-extra)."
        ),
        examples=_EXAMPLES,
    )
    p.add_argument("config", metavar="CONFIG.yaml", help="training config")
    p.add_argument("--timesteps", type=int, help="override the config's timesteps")
    p.add_argument("--seed", type=int, help="override the config's seed")
    p.add_argument("--out", metavar="DIR", help="override the config's output folder")
    p.add_argument(
        "--no-progress", action="store_true", help="no progress bar (none off a terminal anyway)"
    )
    p.set_defaults(handler="train:handle_train")
