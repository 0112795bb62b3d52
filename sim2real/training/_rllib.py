"""``algorithm: rllib-ppo`` of ``sim2real train``: RLlib's PPO on the same env construction.

The training loop is RLlib's (new API stack: RLModule + Learner + EnvRunners); this module
registers :func:`sim2real.training.environment.build_env` (env id, kwargs, randomizer stack, space scaling)
as the RLlib env, so every env runner -- on this machine or anywhere on a Ray cluster --
builds exactly the env ``sim2real train`` builds for SB3. Outputs in ``OUT``::

    OUT/config.yaml           the resolved config
    OUT/checkpoints/step_N/   Algorithm checkpoints (``Algorithm.from_checkpoint``)
    OUT/model/                the final policy: the RLModule checkpoint plus ``sim2real.yaml``
                              (what ``sim2real envs eval --policy OUT/model`` needs)
    OUT/progress.csv          per training iteration: env steps, mean episode return
    OUT/evaluation.yaml       a short seeded evaluation of the final policy

The ``rllib`` key of the training config::

    rllib:
      address: auto            # Ray cluster (see sim2real.cluster.connect); auto starts a local one
      num_env_runners: 2       # Ray actors sampling the env (one CPU each)
      num_envs_per_env_runner: 1

``hyperparameters`` go to ``PPOConfig.training`` (``lr``, ``gamma``, ``lambda_``,
``train_batch_size_per_learner``, ``minibatch_size``, ``num_epochs``, ...); the key
``fcnet_hiddens`` (list of layer sizes) sets the MLP. Needs ``ray[rllib]``, which pins
gymnasium 1.2.2 (see README "Cluster": ``make rllib-extra`` builds its own venv).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.core.rl_module.rl_module import RLModule
from ray.rllib.utils.metrics import (
    ENV_RUNNER_RESULTS,
    EPISODE_RETURN_MEAN,
    NUM_ENV_STEPS_SAMPLED_LIFETIME,
)
from ray.tune.registry import register_env

from sim2real._io import atomic_write
from sim2real.cluster import connect
from sim2real.errors import Sim2RealValueError
from sim2real.training.environment import build_env

__all__ = [
    "ENV_NAME",
    "RLlibController",
    "load_rllib_policy",
    "train_rllib",
]

#: Name under which the env is registered with ``ray.tune.registry.register_env``.
ENV_NAME = "sim2real_train_env"


def _make_env(env_config: Mapping[str, Any]) -> Any:
    """The RLlib env creator: :func:`sim2real.training.environment.build_env` from the env_config."""
    return build_env(
        env_config["env_id"],
        env_config["env_kwargs"],
        randomizers=env_config["randomizers"],
        discrete_actions=env_config["discrete_actions"],
        normalize=env_config["normalize"],
    )


def _ppo_config(cfg: Any, options: Mapping[str, Any]) -> Any:
    hp = dict(cfg.hyperparameters)
    hidden = hp.pop("fcnet_hiddens", None)
    scaling = {k: bool(cfg.normalize.get(k)) for k in ("observations", "actions")}
    env_config = {
        "env_id": cfg.env_id,
        "env_kwargs": dict(cfg.env_kwargs),
        "randomizers": cfg.randomizers,
        "discrete_actions": cfg.discrete_actions,
        "normalize": scaling,
    }
    config = (
        PPOConfig()
        .environment(ENV_NAME, env_config=env_config, normalize_actions=False, clip_actions=True)
        .framework("torch")
        .env_runners(
            num_env_runners=int(options["num_env_runners"]),
            num_envs_per_env_runner=int(options["num_envs_per_env_runner"]),
            num_cpus_per_env_runner=1,
        )
        .learners(num_learners=0)
        .debugging(seed=cfg.seed, log_level="ERROR")
    )
    if hidden is not None:
        config = config.rl_module(model_config={"fcnet_hiddens": list(hidden)})
    try:
        return config.training(**hp)
    except (TypeError, AttributeError, ValueError) as exc:
        raise Sim2RealValueError(
            f"{cfg.source}: key 'hyperparameters' {cfg.hyperparameters} is not accepted by "
            f"RLlib's PPOConfig.training ({exc}); use its keyword arguments (lr, gamma, "
            "train_batch_size_per_learner, minibatch_size, num_epochs, ...) or fcnet_hiddens"
        ) from None


def _sampled(result: Mapping[str, Any]) -> int:
    runners = result.get(ENV_RUNNER_RESULTS, {})
    value = runners.get(NUM_ENV_STEPS_SAMPLED_LIFETIME, result.get(NUM_ENV_STEPS_SAMPLED_LIFETIME))
    return int(value or 0)


def _mean_return(result: Mapping[str, Any]) -> float:
    value = result.get(ENV_RUNNER_RESULTS, {}).get(EPISODE_RETURN_MEAN)
    return float(value) if value is not None else math.nan


def train_rllib(cfg: Any, options: Mapping[str, Any]) -> tuple[Path, int, float, Any]:
    """Train RLlib PPO per ``cfg``; returns (policy dir, env steps, train seconds, module)."""
    address = options["address"]
    connect("auto" if address is None else str(address))
    register_env(ENV_NAME, _make_env)
    algo = _ppo_config(cfg, options).build_algo()
    try:
        steps = 0
        rows: list[tuple[int, int, float]] = []
        next_checkpoint = cfg.checkpoint_every
        t0 = time.perf_counter()
        while steps < cfg.timesteps:
            result = algo.train()
            steps = _sampled(result)
            rows.append((len(rows) + 1, steps, _mean_return(result)))
            if cfg.checkpoint_every and steps >= next_checkpoint:
                algo.save_to_path(str((cfg.out / "checkpoints" / f"step_{steps}").resolve()))
                while next_checkpoint <= steps:
                    next_checkpoint += cfg.checkpoint_every
        train_s = time.perf_counter() - t0
        module = algo.get_module()
        policy_dir = (cfg.out / "model").resolve()
        module.save_to_path(str(policy_dir))
    finally:
        algo.stop()
    with atomic_write(cfg.out / "progress.csv", "w", what="progress file") as fh:
        fh.write("iteration,env_steps,episode_return_mean\n")
        for it, n, ret in rows:
            fh.write(f"{it},{n},{ret:.6g}\n")
    meta = {
        "format": "sim2real.policy/1",
        "algorithm": "rllib-ppo",
        "env_id": cfg.env_id,
        "env_kwargs": dict(cfg.env_kwargs),
        "discrete_actions": cfg.discrete_actions,
        "normalize": {k: bool(cfg.normalize.get(k)) for k in ("observations", "actions")},
        "timesteps": steps,
        "seed": cfg.seed,
    }
    with atomic_write(policy_dir / "sim2real.yaml", "w", what="policy metadata") as fh:
        yaml.safe_dump(meta, fh, sort_keys=False)
    return policy_dir, steps, train_s, module


class RLlibController:
    """Deterministic actions of an RLlib RLModule, with the DWA controller's ``reset``/``act``."""

    def __init__(self, module: Any) -> None:
        self.module = module
        self._dist = module.get_inference_action_dist_cls()

    def reset(self) -> None:
        """Nothing to forget (feed-forward module)."""

    def act(self, obs: Any) -> Any:
        """The module's greedy (deterministic) action for one observation."""
        batch = {"obs": torch.as_tensor(np.asarray(obs, dtype=np.float32)[None])}
        with torch.no_grad():
            out = self.module.forward_inference(batch)
        logits = out["action_dist_inputs"]
        action = self._dist.from_logits(logits).to_deterministic().sample()
        value = action.numpy()[0]
        space = self.module.action_space
        if hasattr(space, "low"):
            value = np.clip(value, space.low, space.high).astype(np.float32)
        return value


def load_rllib_policy(path: Path) -> Any:
    """The RLModule saved in ``OUT/model`` by :func:`train_rllib`."""
    return RLModule.from_checkpoint(str(path.resolve()))
