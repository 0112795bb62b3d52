"""Evaluate trained policies on the reference envs: seeded episodes, robustness, intervals.

- :class:`PolicyController` drives an env with an SB3 model (deterministic actions), with the
  same ``reset()`` / ``act(obs)`` interface as the DWA baseline, so
  :func:`sim2real.envs.evaluate` runs either.
- :func:`load_policy` reads ``model.zip`` written by ``sim2real train`` (its ``sim2real.yaml``
  entry names the algorithm and action grid) and refuses a policy whose observation space
  differs from the env's.
- :func:`robustness` evaluates one controller without randomisation, under each randomizer of a
  stack alone, and under the whole stack.
- :func:`wilson_interval` is the 95 % score interval of a success rate;
  :func:`outcome_intervals` gives an evaluation's success and collision rates with theirs and
  the mean time to goal with its 95 % interval.

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs
>>> from sim2real.envs import DWAController
>>> env = gym.make("sim2real/RandomMap-v0", preset="TEST1")
>>> rows = robustness(env, DWAController.for_env(env), {"format": "sim2real.randomizers/1",
...     "randomizers": [{"type": "ActionDelay", "delay_steps": 2}]}, episodes=1)
>>> [r.condition for r in rows]
['none', 'ActionDelay', 'all']
"""

from __future__ import annotations

import math
import zipfile
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml

import randomizers as dr
from sim2real.envs.baselines import evaluate
from sim2real.errors import Sim2RealFileNotFoundError, Sim2RealValueError
from sim2real.training.config import ALGORITHMS, RLLIB_PPO, require_rllib, require_train_extra
from sim2real.training.environment import DiscreteActions, describe_space, normalize_spaces

__all__ = [
    "LoadedPolicy",
    "OutcomeIntervals",
    "PolicyController",
    "RobustnessRow",
    "evaluate_controller",
    "load_policy",
    "outcome_intervals",
    "read_policy_metadata",
    "robustness",
    "wilson_interval",
]


def wilson_interval(successes: int, n: int, *, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (95 % by default).

    Wilson, "Probable inference, the law of succession, and statistical inference", JASA 22
    (1927). Unlike the normal approximation it stays inside [0, 1] and is sensible at 0 and n.

    Examples
    --------
    >>> lo, hi = wilson_interval(0, 20)
    >>> lo, round(hi, 3)
    (0.0, 0.161)
    """
    if n <= 0:
        return (math.nan, math.nan)
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    # at 0 and n one bound is exactly 0 or 1 (centre -+ half cancel); rounding must not move it
    lo = 0.0 if successes <= 0 else max(0.0, centre - half)
    hi = 1.0 if successes >= n else min(1.0, centre + half)
    return (lo, hi)


@dataclass(frozen=True, kw_only=True)
class OutcomeIntervals:
    """An evaluation's outcome figures with their 95 % intervals.

    Attributes
    ----------
    episodes : int
        Episodes run.
    success_rate, collision_rate : float
        Fractions of the episodes.
    success_ci95, collision_ci95 : tuple of float
        Their Wilson 95 % intervals (:func:`wilson_interval`).
    time_to_goal_s : float
        Mean time to goal over the successful episodes, s (NaN without one).
    time_to_goal_ci95 : tuple of float
        Its 95 % interval, mean +- 1.96 standard errors, s (NaN with fewer than 2 successes).
    """

    episodes: int
    success_rate: float
    collision_rate: float
    success_ci95: tuple[float, float]
    collision_ci95: tuple[float, float]
    time_to_goal_s: float
    time_to_goal_ci95: tuple[float, float]


def outcome_intervals(summary: Any) -> OutcomeIntervals:
    """The outcome figures of an :class:`~sim2real.envs.EvalSummary` with 95 % intervals.

    Examples
    --------
    >>> from sim2real.envs import EvalSummary
    >>> rows = ({"outcome": "success", "time_to_goal_s": 10.0},
    ...         {"outcome": "success", "time_to_goal_s": 12.0},
    ...         {"outcome": "collision", "time_to_goal_s": float("nan")})
    >>> s = EvalSummary(episodes=3, success_rate=2 / 3, collision_rate=1 / 3, timeout_rate=0.0,
    ...                 means={}, per_episode=rows)
    >>> r = outcome_intervals(s)
    >>> [round(x, 3) for x in (*r.success_ci95, r.time_to_goal_s, *r.time_to_goal_ci95)]
    [0.208, 0.939, 11.0, 9.04, 12.96]
    """
    n = int(summary.episodes)
    times = np.array(
        [float(r.get("time_to_goal_s", math.nan)) for r in summary.per_episode], dtype=float
    )
    times = times[np.isfinite(times)]
    mean = float(times.mean()) if times.size else math.nan
    half = (
        1.959964 * float(times.std(ddof=1)) / math.sqrt(times.size) if times.size > 1 else math.nan
    )
    return OutcomeIntervals(
        episodes=n,
        success_rate=float(summary.success_rate),
        collision_rate=float(summary.collision_rate),
        success_ci95=wilson_interval(round(summary.success_rate * n), n),
        collision_ci95=wilson_interval(round(summary.collision_rate * n), n),
        time_to_goal_s=mean,
        time_to_goal_ci95=(mean - half, mean + half),
    )


class PolicyController:
    """Deterministic actions of an SB3 model, with the DWA controller's ``reset``/``act``.

    Parameters
    ----------
    model : stable_baselines3 BaseAlgorithm
        A trained model.
    deterministic : bool
        Use the mean/greedy action (default) rather than sampling.
    """

    def __init__(self, model: Any, *, deterministic: bool = True) -> None:
        self.model = model
        self.deterministic = deterministic
        self._state: Any = None

    def reset(self) -> None:
        """Forget any recurrent state (start of an episode)."""
        self._state = None

    def act(self, obs: Any) -> Any:
        """The model's action for one observation."""
        action, self._state = self.model.predict(
            obs, state=self._state, deterministic=self.deterministic
        )
        return action


@dataclass(frozen=True, kw_only=True)
class LoadedPolicy:
    """A policy read by :func:`load_policy`.

    Attributes
    ----------
    model : Any
        The SB3 model.
    algorithm : str
        ``PPO``, ``SAC``, ``TD3`` or ``DQN``.
    metadata : dict
        The ``sim2real.yaml`` entry of the zip (env id and kwargs, action grid, ...).
    path : Path
        The zip file.
    """

    model: Any
    algorithm: str
    metadata: dict[str, Any]
    path: Path

    @property
    def discrete_actions(self) -> dict[str, list[float]] | None:
        """The (v, w) grid of a discrete-action policy, or None."""
        grid = self.metadata.get("discrete_actions")
        return dict(grid) if isinstance(grid, Mapping) else None

    def controller(self) -> Any:
        """A :class:`PolicyController` of the model (an RLlib one for ``rllib-ppo``)."""
        if self.algorithm == RLLIB_PPO:
            from sim2real.training import _rllib  # Ray RLlib: only an RLlib policy gets here

            return _rllib.RLlibController(self.model)
        return PolicyController(self.model)

    def wrap(self, env: Any) -> Any:
        """``env`` with the policy's discrete action grid and space scaling applied."""
        grid = self.discrete_actions
        env = env if grid is None else DiscreteActions(env, **grid)
        scaling = self.metadata.get("normalize")
        if isinstance(scaling, Mapping):
            env = normalize_spaces(env, {k: bool(v) for k, v in scaling.items()}, where="policy")
        return env


def _read_metadata(path: Path) -> dict[str, Any]:
    try:
        with zipfile.ZipFile(path) as zf:
            names = zf.namelist()
            if "data" not in names:
                raise Sim2RealValueError(
                    f"policy '{path}' is a zip file but not a stable-baselines3 model (no 'data' "
                    "entry); give the model.zip that `sim2real train` wrote"
                )
            if "sim2real.yaml" not in names:
                return {}
            doc = yaml.safe_load(zf.read("sim2real.yaml").decode("utf-8"))
    except zipfile.BadZipFile:
        raise Sim2RealValueError(
            f"policy '{path}' is not a zip file; give the model.zip that `sim2real train` wrote"
        ) from None
    return dict(doc) if isinstance(doc, Mapping) else {}


def read_policy_metadata(path: str | Path) -> dict[str, Any]:
    """The ``sim2real.yaml`` entry of a policy (env id and kwargs, algorithm, ...), without
    loading the model; empty for an SB3 zip not written by ``sim2real train``.

    Examples
    --------
    >>> read_policy_metadata("runs/randommap_ppo/model.zip")["env_kwargs"]  # doctest: +SKIP
    {'preset': 'TRAIN', 'control_dt': 0.25}
    """
    p = Path(path)
    if p.is_dir() and (p / "sim2real.yaml").is_file():  # an rllib-ppo policy folder
        return dict(yaml.safe_load((p / "sim2real.yaml").read_text(encoding="utf-8")) or {})
    if not p.is_file():
        raise Sim2RealFileNotFoundError(
            f"policy '{p}' does not exist; give the model.zip that `sim2real train` wrote"
        )
    return _read_metadata(p)


def load_policy(path: str | Path, *, algorithm: str | None = None) -> LoadedPolicy:
    """Load ``model.zip`` written by ``sim2real train`` (or any SB3 zip with ``algorithm``).

    Examples
    --------
    >>> policy = load_policy("runs/randommap_ppo/model.zip")  # doctest: +SKIP
    >>> policy.algorithm  # doctest: +SKIP
    'PPO'
    """
    p = Path(path)
    meta = read_policy_metadata(p)
    if p.is_dir():  # an rllib-ppo policy folder
        if meta.get("algorithm") != RLLIB_PPO:
            raise Sim2RealValueError(
                f"policy folder '{p}' names algorithm {meta.get('algorithm')!r}; a folder policy "
                f"must be {RLLIB_PPO}'s OUT/model (SB3 policies are model.zip files)"
            )
        require_rllib()
        from sim2real.training import _rllib  # Ray RLlib, checked above

        model = _rllib.load_rllib_policy(p)
        return LoadedPolicy(model=model, algorithm=RLLIB_PPO, metadata=meta, path=p)
    require_train_extra("evaluating a policy (--policy)")
    algo = algorithm or meta.get("algorithm")
    sb3_algos = list(ALGORITHMS)
    match = [a for a in sb3_algos if str(algo).upper() == a]
    if not match:
        raise Sim2RealValueError(
            f"policy '{p}' does not say which algorithm trained it (got {algo!r}); pass "
            f"--algorithm with one of {', '.join(sb3_algos)}"
        )
    from sim2real.training import _sb3  # the [train] extra, checked above

    model = _sb3.load_model(match[0], p)
    return LoadedPolicy(model=model, algorithm=match[0], metadata=meta, path=p)


def check_spaces(policy: LoadedPolicy, env: Any, env_name: str) -> None:
    """Refuse an env whose observation or action space is not the policy's (one sentence)."""
    want, got = policy.model.observation_space, env.observation_space
    if not _same_space(want, got):
        raise Sim2RealValueError(
            f"policy '{policy.path}' expects observations {describe_space(want)} but env "
            f"{env_name} gives {describe_space(got)}; evaluate it on the env it was trained on "
            f"({policy.metadata.get('env_id', 'see its config.yaml')})"
        )
    want_a, got_a = policy.model.action_space, env.action_space
    if not _same_space(want_a, got_a):
        raise Sim2RealValueError(
            f"policy '{policy.path}' acts in {describe_space(want_a)} but env {env_name} takes "
            f"{describe_space(got_a)}; evaluate it on the env it was trained on"
        )


def _same_space(a: Any, b: Any) -> bool:
    if type(a) is not type(b):
        return False
    if isinstance(a, gym.spaces.Dict):
        return set(a.spaces) == set(b.spaces) and all(
            _same_space(a.spaces[k], b.spaces[k]) for k in a.spaces
        )
    if isinstance(a, gym.spaces.Box):
        return bool(
            a.shape == b.shape
            and np.allclose(a.low, b.low, equal_nan=True)
            and np.allclose(a.high, b.high, equal_nan=True)
        )
    return bool(a == b)


#: :func:`sim2real.envs.evaluate`, which drives any object with ``reset()`` and ``act(obs)``.
evaluate_controller = evaluate


@dataclass(frozen=True, kw_only=True)
class RobustnessRow:
    """One condition of :func:`robustness`.

    Attributes
    ----------
    condition : str
        ``none``, a randomizer's type (or ``name``), or ``all``.
    episodes : int
        Episodes run.
    success_rate, collision_rate, timeout_rate : float
        Outcome rates.
    success_ci95 : tuple of float
        Wilson 95 % interval of the success rate.
    collision_ci95 : tuple of float
        Wilson 95 % interval of the collision rate.
    time_to_goal_s : float
        Mean time to goal over the successes, s (NaN without one).
    time_to_goal_ci95 : tuple of float
        Its 95 % interval (:class:`OutcomeIntervals`), s.
    overshoot_rate : float
        Share of episodes that left the goal without stopping in it.

    The figures but ``condition``, ``timeout_rate`` and ``overshoot_rate`` are the
    :class:`OutcomeIntervals` of the condition's evaluation.
    """

    condition: str
    episodes: int
    success_rate: float
    collision_rate: float
    timeout_rate: float
    success_ci95: tuple[float, float]
    collision_ci95: tuple[float, float] = (math.nan, math.nan)
    time_to_goal_s: float = math.nan
    time_to_goal_ci95: tuple[float, float] = (math.nan, math.nan)
    overshoot_rate: float = 0.0


def robustness(
    env: Any,
    controller: Any,
    config: str | Path | Mapping[str, Any],
    *,
    episodes: int,
    seed: int = 0,
    options: dict[str, Any] | None = None,
    wrap: Any = None,
) -> list[RobustnessRow]:
    """Success with no randomizer, with each randomizer of ``config`` alone, and with all.

    Every condition runs the same seeds (``seed`` .. ``seed + episodes - 1``), so the maps and
    starts are the same and only the randomisation differs. ``wrap(env)`` is applied outermost
    (e.g. a policy's discrete action grid).
    """
    base_dir: Path | None = None
    if not isinstance(config, Mapping):
        dr.from_config(env, config)  # validates the file (one-sentence errors)
        base_dir = Path(config).parent
        doc = yaml.safe_load(Path(config).read_text(encoding="utf-8"))
        config = doc if isinstance(doc, Mapping) else {}
    entries = list(config.get("randomizers") or [])
    fmt = config.get("format", dr.CONFIG_FORMAT)
    conditions: list[tuple[str, list[Any]]] = [("none", [])]
    for entry in entries:
        label = str(entry.get("name") or entry.get("type")) if isinstance(entry, Mapping) else "?"
        conditions.append((label, [entry]))
    conditions.append(("all", entries))
    base = env.unwrapped
    # the plant has no drive parameters to restore (its sessions come from the seeds)
    has_drive = hasattr(base, "get_drive_params") and getattr(base, "dynamics", "") != "plant"
    nominal = base.get_drive_params() if has_drive else None
    rows = []
    for label, subset in conditions:
        if nominal is not None:  # a DynamicsRandomizer's last draw must not leak into the next
            base.set_drive_params(nominal)
        wrapped = (
            dr.from_config(env, {"format": fmt, "randomizers": subset}, base_dir=base_dir)
            if subset
            else env
        )
        if wrap is not None:
            wrapped = wrap(wrapped)
        s = evaluate_controller(wrapped, controller, episodes=episodes, seed=seed, options=options)
        figures = asdict(outcome_intervals(s))
        rows.append(
            RobustnessRow(
                condition=label,
                timeout_rate=s.timeout_rate,
                overshoot_rate=s.overshoot_rate,
                **figures,
            )
        )
    return rows
