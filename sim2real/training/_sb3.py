"""stable-baselines3's side of ``sim2real train``: the vector env, the model, the callbacks.

Needs the ``[train]`` extra (torch, stable-baselines3): :func:`sim2real.training.train.train`
and :func:`sim2real.training.evaluation.load_policy` import this module once
:func:`sim2real.training.config.require_train_extra` has found it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from functools import partial
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import stable_baselines3 as sb3
import torch
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.noise import (
    ActionNoise,
    NormalActionNoise,
    OrnsteinUhlenbeckActionNoise,
)
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize

from sim2real.errors import Sim2RealValueError
from sim2real.training._lookahead import LookaheadDQNPolicy, lookahead_kwargs, race_lookahead
from sim2real.training._sarl import SarlExtractor
from sim2real.training._sensors import SensorEncoderExtractor
from sim2real.training.config import (
    SARL_LOOKAHEAD_POLICY,
    SARL_POLICY,
    SENSORS_POLICY,
    TrainConfig,
)
from sim2real.training.environment import build_env, neighbour_slots

__all__ = [
    "Curriculum",
    "EpisodeLog",
    "EpisodeRow",
    "RichProgress",
    "action_noise",
    "learn",
    "load_model",
]

#: One training episode: env step at its end, outcome, return, length.
EpisodeRow = tuple[int, str, float, int]


def learn(
    cfg: TrainConfig,
    probe: Any,
    *,
    progress: bool = False,
    on_episodes: Callable[[list[EpisodeRow]], Any] | None = None,
    every_s: float = 5.0,
) -> tuple[Any, list[EpisodeRow], float]:
    """Train ``cfg.algorithm`` on ``cfg.n_envs`` envs; returns (model, episode rows, train s).

    ``probe`` is one env as the policy sees it (action grid and scaling applied): it chooses the
    policy network. The episode rows are those of :func:`sim2real.training.train.write_episodes`;
    ``on_episodes`` receives all rows so far when training starts, then at most every
    ``every_s`` seconds of wall time after an episode ends, and when training ends.
    """
    torch.set_num_threads(1)  # small MLPs: more threads only add overhead on 2 cores
    vec = _vec_env(cfg)
    try:
        model = _model(cfg, vec, probe)
        episode_log = EpisodeLog(on_episodes, every_s=every_s)
        callbacks: list[Any] = [episode_log]
        if cfg.checkpoint_every > 0:
            callbacks.append(
                CheckpointCallback(
                    save_freq=max(cfg.checkpoint_every // cfg.n_envs, 1),
                    save_path=str(cfg.out / "checkpoints"),
                    name_prefix="model",
                )
            )
        if cfg.curriculum is not None:
            callbacks.append(Curriculum(cfg.curriculum, cfg.timesteps))
        if progress:
            callbacks.append(RichProgress(cfg.timesteps))
        t0 = time.perf_counter()
        model.learn(total_timesteps=cfg.timesteps, callback=callbacks, tb_log_name="run")
        train_time_s = time.perf_counter() - t0
    finally:
        vec.close()
    return model, episode_log.rows, train_time_s


def load_model(algorithm: str, path: Path) -> Any:
    """The SB3 model of class ``algorithm`` (``PPO``, ``SAC``, ...) saved at ``path``, on the CPU.

    An off-policy model saved with ``n_steps > 1`` stores the ``NStepReplayBuffer`` SB3 chose
    for it, and SB3 warns on reload that ``n_steps`` is ignored for a custom buffer class.
    Loading with the class unset lets SB3 choose it again from the saved ``n_steps``: the same
    buffer with the same kwargs, and no warning.
    """
    cls = getattr(sb3, algorithm)
    custom: dict[str, Any] = {}
    if issubclass(cls, OffPolicyAlgorithm):
        custom["replay_buffer_class"] = None
    return cls.load(str(path), device="cpu", custom_objects=custom)


def _env_factory(cfg: TrainConfig, *, rank: int) -> Callable[[], Any]:
    """A picklable thunk building env ``rank`` (with SB3's Monitor for episode statistics)."""
    return partial(
        _make_monitored,
        cfg.env_id,
        cfg.env_kwargs,
        cfg.randomizers,
        cfg.discrete_actions,
        cfg.normalize,
    )


def _make_monitored(
    env_id: str,
    kwargs: Mapping[str, Any],
    randomizers: Mapping[str, Any] | None,
    discrete: Mapping[str, list[float]] | None,
    normalize: Mapping[str, bool] | None = None,
) -> Any:
    env = build_env(
        env_id, kwargs, randomizers=randomizers, discrete_actions=discrete, normalize=normalize
    )
    return Monitor(env)


def _policy_name(cfg: TrainConfig, env: Any) -> Any:
    if cfg.policy == SARL_LOOKAHEAD_POLICY:
        return LookaheadDQNPolicy
    if cfg.policy not in ("auto", SARL_POLICY, SENSORS_POLICY):
        return cfg.policy
    return "MultiInputPolicy" if isinstance(env.observation_space, gym.spaces.Dict) else "MlpPolicy"


def _vec_env(cfg: TrainConfig) -> Any:
    thunks = [_env_factory(cfg, rank=i) for i in range(cfg.n_envs)]
    if cfg.vec_env == "subproc" and cfg.n_envs > 1:
        vec: Any = SubprocVecEnv(thunks, start_method="forkserver")
    else:
        vec = DummyVecEnv(thunks)
    vec.seed(cfg.seed)
    if cfg.normalize.get("rewards"):
        gamma = float(cfg.hyperparameters.get("gamma", 0.99))
        vec = VecNormalize(vec, norm_obs=False, norm_reward=True, gamma=gamma)
    return vec


def _model(cfg: TrainConfig, vec: Any, probe: Any) -> Any:
    cls = getattr(sb3, cfg.algorithm)
    hyper = dict(cfg.hyperparameters)
    if cfg.action_noise is not None:
        hyper["action_noise"] = action_noise(cfg.action_noise, probe.action_space)
    if cfg.policy in (SARL_POLICY, SARL_LOOKAHEAD_POLICY):
        k, f = neighbour_slots(probe, where=cfg.source)
        user = dict(hyper.get("policy_kwargs") or {})
        extractor = {
            **dict(user.get("features_extractor_kwargs") or {}),  # robot_dim, pair_dim
            "neighbours": k,
            "neighbour_features": f,
        }
        hyper["policy_kwargs"] = {
            **user,
            "features_extractor_class": SarlExtractor,
            "features_extractor_kwargs": extractor,
        }
    if cfg.policy == SARL_LOOKAHEAD_POLICY:
        grid = race_lookahead(
            probe,
            **dict(cfg.discrete_actions or {}),
            where=cfg.source,
            models=dict(hyper.get("policy_kwargs") or {}).get("lookahead"),
        )
        hyper["policy_kwargs"]["lookahead"] = lookahead_kwargs(grid)
    if cfg.policy == SENSORS_POLICY:
        hyper["policy_kwargs"] = {
            **dict(hyper.get("policy_kwargs") or {}),
            "features_extractor_class": SensorEncoderExtractor,
        }
    try:
        return cls(
            _policy_name(cfg, probe),
            vec,
            seed=cfg.seed,
            verbose=0,
            tensorboard_log=str(cfg.out / "tensorboard"),
            device="cpu",
            **hyper,
        )
    except TypeError as exc:
        raise Sim2RealValueError(
            f"{cfg.source}: key 'hyperparameters' {cfg.hyperparameters} is not accepted by "
            f"{cfg.algorithm} ({exc}); use that class's constructor keyword arguments"
        ) from None


def action_noise(spec: Mapping[str, Any], space: gym.spaces.Box) -> ActionNoise:
    """SB3's action noise for ``spec`` (``{type, sigma}``, see the config) on ``space``.

    Examples
    --------
    >>> space = gym.spaces.Box(-1.0, 1.0, shape=(2,))
    >>> action_noise({"type": "normal", "sigma": 0.1}, space)
    NormalActionNoise(mu=[0. 0.], sigma=[0.1 0.1])
    """
    n = int(np.prod(space.shape))
    mean, sigma = np.zeros(n), np.full(n, float(spec["sigma"]))
    if spec["type"] == "ornstein-uhlenbeck":
        return OrnsteinUhlenbeckActionNoise(mean=mean, sigma=sigma)
    return NormalActionNoise(mean=mean, sigma=sigma)


class RichProgress(BaseCallback):  # type: ignore[misc]
    """An SB3 callback drawing a rich progress bar of ``total`` env steps (TTY only)."""

    def __init__(self, total: int) -> None:
        super().__init__()
        self.total = total

    def _on_training_start(self) -> None:
        self._bar = Progress(
            "[progress.description]{task.description}",
            BarColumn(),
            MofNCompleteColumn(),
            TimeRemainingColumn(),
            console=Console(stderr=True),
            transient=True,
        )
        self._bar.start()
        self._task = self._bar.add_task("training", total=self.total)

    def _on_step(self) -> bool:
        self._bar.update(self._task, completed=min(self.num_timesteps, self.total))
        return True

    def _on_training_end(self) -> None:
        self._bar.stop()


class Curriculum(BaseCallback):  # type: ignore[misc]
    """An SB3 callback moving the envs' goal criteria and crowd from ``start`` to their own.

    ``start`` is the config's ``curriculum``. At every rollout start, after ``steps`` env
    steps, each goal criterion (``goal_speed_mps``, ``goal_tolerance_m``) is
    ``start * (own / start) ** p`` with ``p = min(1, steps / (until * timesteps))``; the
    ``complexity`` is ``start`` (in ``scenario``, if given) until ``hold * timesteps``, then
    rises linearly, in the env's own scenario, to its own at ``until * timesteps``.
    """

    _GOAL = ("goal_speed_mps", "goal_tolerance_m")

    def __init__(self, start: Mapping[str, Any], timesteps: int) -> None:
        super().__init__()
        self.start = {k: float(v) for k, v in start.items() if k in (*self._GOAL, "complexity")}
        self.scenario: str | None = start.get("scenario")
        self.until_steps = max(float(start.get("until", 0.5)) * timesteps, 1.0)
        self.hold_steps = float(start.get("hold", 0.0)) * timesteps
        self.own: dict[str, Any] = {}

    def _on_training_start(self) -> None:
        names = [*self.start, *(["scenario"] if self.scenario is not None else [])]
        self.own = {k: self.training_env.get_attr(k, [0])[0] for k in names}

    def values(self, steps: int) -> dict[str, Any]:
        """The criteria and crowd after ``steps`` env steps (``goal_speed_mps`` etc. -> value)."""
        p = min(1.0, steps / self.until_steps)
        now: dict[str, Any] = {
            k: s * (self.own[k] / s) ** p for k, s in self.start.items() if k in self._GOAL
        }
        if "complexity" in self.start:
            ramp = self.until_steps - self.hold_steps
            q = min(1.0, max(0.0, steps - self.hold_steps) / ramp)
            c0 = self.start["complexity"]
            now["complexity"] = c0 + (float(self.own["complexity"]) - c0) * q
        if self.scenario is not None:
            now["scenario"] = self.scenario if steps < self.hold_steps else self.own["scenario"]
        return now

    def _on_rollout_start(self) -> None:
        now = self.values(int(self.num_timesteps))
        if set(now) & set(self._GOAL):
            self.training_env.env_method(
                "set_goal_criteria",
                speed_mps=now.get("goal_speed_mps"),
                tolerance_m=now.get("goal_tolerance_m"),
            )
        if "complexity" in now:
            self.training_env.env_method(
                "set_task", scenario=now.get("scenario"), complexity=now["complexity"]
            )

    def _on_step(self) -> bool:
        return True


class EpisodeLog(BaseCallback):  # type: ignore[misc]
    """An SB3 callback keeping (env step, outcome, return, length) of every training episode.

    ``on_episodes`` (if given) receives all rows so far at the start, at most every ``every_s``
    seconds after an episode ends, and at the end of training: the learning curve on disk
    while training goes.
    """

    rows: list[EpisodeRow]

    def __init__(
        self, on_episodes: Callable[[list[EpisodeRow]], Any] | None = None, *, every_s: float = 5.0
    ) -> None:
        super().__init__()
        self.on_episodes = on_episodes
        self.every_s = every_s
        self._last_s = 0.0

    def _on_training_start(self) -> None:
        self.rows = []
        self._flush()

    def _on_training_end(self) -> None:
        self._flush()

    def _flush(self) -> None:
        if self.on_episodes is not None:
            self.on_episodes(list(self.rows))
        self._last_s = time.perf_counter()

    def _on_step(self) -> bool:
        for info, done in zip(self.locals["infos"], self.locals["dones"], strict=True):
            episode = info.get("episode")
            if done and episode is not None:
                outcome = str(info.get("outcome", ""))
                self.rows.append(
                    (int(self.num_timesteps), outcome, float(episode["r"]), int(episode["l"]))
                )
                if time.perf_counter() - self._last_s >= self.every_s:
                    self._flush()
        return True
