"""Train a navigation policy with stable-baselines3 on a sim2real env wrapped in a randomizer stack.

The training loops are SB3's (PPO, SAC, TD3, DQN); this module reads one YAML file, builds the
env and its randomizers (:func:`randomizers.from_config`, including a sysid result for the
dynamics), runs the parallel envs (SB3 ``SubprocVecEnv`` or ``DummyVecEnv``), and writes the
outputs into one folder::

    OUT/config.yaml         the resolved config (defaults filled in, randomizer stack expanded)
    OUT/model.zip           the final policy (SB3 zip plus a ``sim2real.yaml`` entry that names
                            the algorithm, env and action grid, for ``sim2real envs eval``)
    OUT/checkpoints/        model_<steps>_steps.zip every ``checkpoint_every`` steps
    OUT/tensorboard/        TensorBoard event files (``tensorboard --logdir OUT/tensorboard``)
    OUT/evaluation.yaml     a short seeded evaluation of the final policy
    OUT/episodes.csv        every training episode: env step at its end, outcome, return, length
                            (the learning curve; rewritten every few seconds while training)

The config file and its keys: :mod:`sim2real.training.config`; the env construction:
:mod:`sim2real.training.environment`. ``algorithm: rllib-ppo`` trains with Ray RLlib's PPO
instead (:mod:`sim2real.training._rllib`; the final policy is ``OUT/model/``).

Needs the ``[train]`` extra (``pip install torch==2.13.0 && pip install -e '.[train]'``).

Examples
--------
>>> from sim2real.training.config import load_config
>>> cfg = load_config("examples/randommap_ppo.yaml", timesteps=2000, seed=3)
>>> result = train(cfg)  # doctest: +SKIP
>>> result.model_path  # doctest: +SKIP
PosixPath('runs/randommap_ppo/model.zip')
"""

from __future__ import annotations

import io
import math
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import gymnasium as gym
import yaml

import randomizers as dr
from robots.files import plain_data
from sim2real._io import atomic_write
from sim2real.errors import Sim2RealValueError
from sim2real.training.config import (
    RLLIB_PPO,
    SARL_LOOKAHEAD_POLICY,
    SARL_POLICY,
    SENSORS_POLICY,
    TrainConfig,
    require_rllib,
    require_train_extra,
)
from sim2real.training.environment import (
    DiscreteActions,
    build_env,
    default_action_grid,
    describe_space,
    neighbour_slots,
    normalize_spaces,
)
from sim2real.training.evaluation import PolicyController, evaluate_controller

__all__ = [
    "METADATA_ENTRY",
    "TrainResult",
    "final_evaluation",
    "model_metadata",
    "save_model",
    "train",
    "write_episodes",
]

#: Name of the metadata entry added to ``model.zip``.
METADATA_ENTRY = "sim2real.yaml"
_CONTINUOUS_ONLY = ("SAC", "TD3")


@dataclass(frozen=True, kw_only=True)
class TrainResult:
    """What :func:`train` produced.

    Attributes
    ----------
    out : Path
        Output folder.
    model_path : Path
        ``OUT/model.zip``.
    timesteps : int
        Env steps actually trained (SB3 finishes its last rollout).
    train_time_s : float
        Wall time of the training loop, s.
    evaluation : dict
        The ``OUT/evaluation.yaml`` content (success/collision/timeout rates, means).
    """

    out: Path
    model_path: Path
    timesteps: int
    train_time_s: float
    evaluation: dict[str, Any]


# --------------------------------------------------------------------------- training


def _check_action_space(cfg: TrainConfig, env: Any) -> TrainConfig:
    """Fill in DQN's action grid; refuse SAC/TD3 on a discrete action space."""
    box = isinstance(env.action_space, gym.spaces.Box)
    if cfg.algorithm == "DQN" and box and cfg.discrete_actions is None:
        return replace(cfg, discrete_actions=default_action_grid(env))
    if (
        cfg.algorithm != "DQN"
        and cfg.discrete_actions is not None
        and cfg.algorithm in _CONTINUOUS_ONLY
    ):
        raise Sim2RealValueError(
            f"{cfg.source}: key 'discrete_actions' is set but {cfg.algorithm} needs continuous "
            "actions; remove the key or use DQN/PPO"
        )
    return cfg


def write_episodes(path: Path, rows: Sequence[tuple[int, str, float, int]]) -> Path:
    """``OUT/episodes.csv``: one line per training episode (see the module docstring)."""
    with atomic_write(path, "w", what="episodes file") as fh:
        fh.write("step,outcome,return,length\n")
        for step, outcome, ret, length in rows:
            fh.write(f"{step},{outcome},{ret:.6g},{length}\n")
    return path


def _write_yaml(path: Path, doc: Any, what: str) -> None:
    with atomic_write(path, "w", what=what) as fh:
        yaml.safe_dump(plain_data(doc), fh, sort_keys=False)


def model_metadata(cfg: TrainConfig, env: Any) -> dict[str, Any]:
    """The ``sim2real.yaml`` entry of ``model.zip``: what :func:`load_policy` needs."""
    return {
        "format": "sim2real.policy/1",
        "algorithm": cfg.algorithm,
        "env_id": cfg.env_id,
        "env_kwargs": dict(cfg.env_kwargs),
        "discrete_actions": cfg.discrete_actions,
        "normalize": {k: bool(cfg.normalize.get(k)) for k in ("observations", "actions")},
        "observation_space": describe_space(env.observation_space),
        "timesteps": cfg.timesteps,
        "seed": cfg.seed,
    }


def _check_curriculum(cfg: TrainConfig, curriculum: Mapping[str, Any], env: Any) -> None:
    """Refuse a curriculum the env cannot follow (no goal criteria, no finite goal speed, no
    crowd)."""
    goal = {"goal_speed_mps", "goal_tolerance_m"} & set(curriculum)
    if goal and not hasattr(env, "set_goal_criteria"):
        raise Sim2RealValueError(
            f"{cfg.source}: key 'curriculum' anneals a navigation env's goal, which "
            f"{cfg.env_id} does not have; remove the key or use RandomMap-v0 or CrowdNav-v0"
        )
    if "goal_speed_mps" in curriculum and not math.isfinite(env.goal_speed_mps):
        raise Sim2RealValueError(
            f"{cfg.source}: key 'curriculum' starts goal_speed_mps at "
            f"{curriculum['goal_speed_mps']:g} but the env's own goal_speed_mps is inf "
            "(passing through the goal counts); set env.kwargs goal_speed_mps to the speed "
            "the curriculum ends at, e.g. 0.05"
        )
    if "complexity" in curriculum and not hasattr(env, "set_task"):
        raise Sim2RealValueError(
            f"{cfg.source}: key 'curriculum' grows a crowd's complexity, which {cfg.env_id} "
            "does not have; remove complexity, scenario and hold or use CrowdNav-v0"
        )


def save_model(model: Any, path: Path, metadata: Mapping[str, Any]) -> Path:
    """Save an SB3 model to ``path`` with a ``sim2real.yaml`` entry, atomically."""
    buf = io.BytesIO()
    model.save(buf)
    with zipfile.ZipFile(buf, "a") as zf:
        zf.writestr(METADATA_ENTRY, yaml.safe_dump(plain_data(metadata), sort_keys=False))
    with atomic_write(path, "wb", what="model file") as fh:
        fh.write(buf.getvalue())
    return path


def train(cfg: TrainConfig, *, progress: bool = False) -> TrainResult:
    """Train ``cfg.algorithm`` on the config's env and write the outputs into ``cfg.out``.

    Examples
    --------
    >>> result = train(load_config("examples/randommap_ppo.yaml", timesteps=2000))  # doctest: +SKIP
    >>> result.evaluation["success_rate"]  # doctest: +SKIP
    0.0
    """
    if cfg.algorithm == RLLIB_PPO:
        return _train_rllib(cfg)
    require_train_extra()
    from sim2real.training import _lookahead, _sb3  # the [train] extra, checked above

    probe = build_env(cfg.env_id, cfg.env_kwargs, randomizers=cfg.randomizers, where=cfg.source)
    cfg = _check_action_space(cfg, probe)
    if cfg.algorithm in _CONTINUOUS_ONLY and not isinstance(probe.action_space, gym.spaces.Box):
        raise Sim2RealValueError(
            f"{cfg.source}: {cfg.algorithm} needs a continuous (Box) action space but "
            f"{cfg.env_id} has {probe.action_space}; use PPO or DQN"
        )
    if cfg.policy == SARL_LOOKAHEAD_POLICY:
        if cfg.algorithm != "DQN":
            raise Sim2RealValueError(
                f"{cfg.source}: policy 'sarl-lookahead' values each command of a discrete "
                f"(v, w) grid, which {cfg.algorithm} does not act on; use algorithm DQN"
            )
        _lookahead.race_lookahead(
            probe,
            **dict(cfg.discrete_actions or {}),
            where=cfg.source,
            models=dict(cfg.hyperparameters.get("policy_kwargs") or {}).get("lookahead"),
        )
    if cfg.policy in (SARL_POLICY, SARL_LOOKAHEAD_POLICY):
        _check_sarl(cfg, probe)
    if cfg.policy == SENSORS_POLICY and not isinstance(probe.observation_space, gym.spaces.Dict):
        raise Sim2RealValueError(
            f"{cfg.source}: policy 'sensors' encodes the entries of a Dict observation, but "
            f"{cfg.env_id} observes {describe_space(probe.observation_space)}; use policy auto"
        )
    if cfg.curriculum is not None:
        _check_curriculum(cfg, cfg.curriculum, probe.unwrapped)
    if cfg.discrete_actions is not None:
        probe = DiscreteActions(probe, **cfg.discrete_actions)
    probe = normalize_spaces(probe, cfg.normalize, where=cfg.source)
    cfg.out.mkdir(parents=True, exist_ok=True)
    resolved = cfg.to_dict()
    if cfg.randomizers is not None:
        resolved["randomizers"] = dr.to_config(probe)
    _write_yaml(cfg.out / "config.yaml", resolved, "resolved config")
    episodes_csv = partial(write_episodes, cfg.out / "episodes.csv")
    model, episodes, train_time_s = _sb3.learn(
        cfg, probe, progress=progress, on_episodes=episodes_csv
    )
    model_path = save_model(model, cfg.out / "model.zip", model_metadata(cfg, probe))
    episodes_csv(episodes)
    probe.close()
    evaluation = final_evaluation(cfg, model)
    _write_yaml(cfg.out / "evaluation.yaml", evaluation, "evaluation file")
    return TrainResult(
        out=cfg.out,
        model_path=model_path,
        timesteps=int(model.num_timesteps),
        train_time_s=train_time_s,
        evaluation=evaluation,
    )


def _check_sarl(cfg: TrainConfig, env: Any) -> None:
    """``policy: sarl`` needs neighbour slots, unscaled (the zero rows mark empty slots)."""
    neighbour_slots(env, where=cfg.source)
    if cfg.normalize.get("observations"):
        raise Sim2RealValueError(
            f"{cfg.source}: policy '{cfg.policy}' reads empty neighbour slots as zero rows, which "
            "normalize 'observations' shifts; set normalize.observations: false"
        )


def _train_rllib(cfg: TrainConfig) -> TrainResult:
    """``algorithm: rllib-ppo``: RLlib's PPO on the same env construction (sim2real.training._rllib)."""
    if cfg.policy in (SARL_POLICY, SARL_LOOKAHEAD_POLICY, SENSORS_POLICY):
        raise Sim2RealValueError(
            f"{cfg.source}: policy '{cfg.policy}' is a stable-baselines3 features extractor; use "
            f"algorithm DQN or PPO with it, not {RLLIB_PPO}"
        )
    require_rllib()
    from sim2real.training import _rllib  # Ray RLlib, checked above

    if cfg.normalize.get("rewards"):
        raise Sim2RealValueError(
            f"{cfg.source}: normalize 'rewards' is SB3's VecNormalize and does not apply to "
            f"{RLLIB_PPO}; set normalize.rewards: false"
        )
    probe = build_env(cfg.env_id, cfg.env_kwargs, randomizers=cfg.randomizers, where=cfg.source)
    cfg = _check_action_space(replace(cfg, algorithm="PPO"), probe)
    cfg = replace(cfg, algorithm=RLLIB_PPO)
    cfg.out.mkdir(parents=True, exist_ok=True)
    resolved = cfg.to_dict()
    if cfg.randomizers is not None:
        resolved["randomizers"] = dr.to_config(probe)
    probe.close()
    _write_yaml(cfg.out / "config.yaml", resolved, "resolved config")
    policy_dir, steps, train_s, module = _rllib.train_rllib(cfg, cfg.rllib)
    evaluation = final_evaluation(cfg, None, controller=_rllib.RLlibController(module))
    _write_yaml(cfg.out / "evaluation.yaml", evaluation, "evaluation file")
    return TrainResult(
        out=cfg.out,
        model_path=policy_dir,
        timesteps=steps,
        train_time_s=train_s,
        evaluation=evaluation,
    )


def final_evaluation(cfg: TrainConfig, model: Any, *, controller: Any = None) -> dict[str, Any]:
    """Seeded episodes of the trained policy (``evaluation`` keys of the config)."""
    if cfg.eval_episodes == 0:
        return {"episodes": 0}
    kwargs = {**cfg.env_kwargs, **cfg.eval_kwargs}
    env = build_env(
        cfg.env_id,
        kwargs,
        randomizers=cfg.randomizers if cfg.eval_randomize else None,
        discrete_actions=cfg.discrete_actions,
        normalize=cfg.normalize,
        where=cfg.source,
    )
    try:
        summary = evaluate_controller(
            env,
            PolicyController(model) if controller is None else controller,
            episodes=cfg.eval_episodes,
            seed=cfg.eval_seed,
        )
    finally:
        env.close()
    rows = summary.per_episode
    return {
        "env_id": cfg.env_id,
        "env_kwargs": kwargs,
        "randomized": cfg.eval_randomize,
        "episodes": summary.episodes,
        "seeds": [cfg.eval_seed, cfg.eval_seed + summary.episodes - 1],
        "success_rate": summary.success_rate,
        "collision_rate": summary.collision_rate,
        "timeout_rate": summary.timeout_rate,
        "overshoot_rate": summary.overshoot_rate,
        **(
            {"off_road_rate": sum(bool(r.get("off_road")) for r in rows) / len(rows)}
            if rows and "off_road" in rows[0]
            else {}
        ),
        "means": {k: (None if math.isnan(v) else v) for k, v in summary.means.items()},
    }
