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
                            (the learning curve)

Config file (``format: sim2real.train/1``; relative paths are relative to the config file)::

    format: sim2real.train/1
    env:
      id: sim2real/RandomMap-v0        # or RandomMap-v0, CrowdNav-v0
      kwargs: {preset: TRAIN, max_episode_steps: 400}   # gymnasium.make keyword arguments;
                                       # map_config: {...} (RandomMap MapConfig fields) and
                                       # params: RESULT.yaml (drive parameters) are understood
    randomizers: randommap_randomizers.yaml  # a randomizer config file, an inline one, or null
    algorithm: PPO                     # PPO, SAC, TD3, DQN (stable-baselines3) or rllib-ppo
    policy: auto                       # MlpPolicy for Box observations, MultiInputPolicy for Dict
    hyperparameters: {n_steps: 256, batch_size: 64}   # SB3 constructor keyword arguments
    timesteps: 20000
    n_envs: 2
    vec_env: subproc                   # subproc (one process per env) or dummy (in-process)
    seed: 0
    out: runs/randommap_ppo            # relative to the working directory
    checkpoint_every: 10000            # env steps between checkpoints; 0 = none
    evaluation: {episodes: 10, seed: 10000, kwargs: {preset: TEST1}, randomize: false}
    discrete_actions: {v_mps: [0.0, 0.1, 0.21], w_radps: [-1.0, 0.0, 1.0]}  # for DQN
    normalize: {observations: true, actions: true, rewards: true}   # all false by default

``algorithm: rllib-ppo`` trains with Ray RLlib's PPO instead (:mod:`sim2real.training._rllib`: the
``rllib`` key names the Ray cluster and the env runners; the final policy is ``OUT/model/``).

``normalize``: ``observations`` and ``actions`` rescale Box spaces to [-1, 1] from their bounds
(fixed, stateless wrappers outermost in the stack, recorded in ``model.zip`` so that
evaluation applies them too); ``rewards`` divides the training reward by a running estimate of
the discounted return's std (SB3 ``VecNormalize(norm_obs=False)``; training only). PPO's
Gaussian policy starts at mean 0 and std ~1 in the action space, so on RandomMap-v0 (v in
[0, 0.21] m/s) unscaled actions mostly clip; rescaled ones start at half speed.

Needs the ``[train]`` extra (``pip install torch==2.13.0 && pip install -e '.[train]'``).

Example
-------
>>> from sim2real.training.train import load_config
>>> cfg = load_config("examples/randommap_ppo.yaml", timesteps=2000, seed=3)  # doctest: +SKIP
>>> result = train(cfg)  # doctest: +SKIP
>>> result.model_path  # doctest: +SKIP
PosixPath('runs/randommap_ppo/model.zip')
"""

from __future__ import annotations

import dataclasses
import io
import math
import time
import zipfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml

from sim2real.errors import Sim2RealFileNotFoundError, Sim2RealValueError

__all__ = [
    "ALGORITHMS",
    "CONFIG_FORMAT",
    "METADATA_ENTRY",
    "RLLIB_PPO",
    "DiscreteActions",
    "TrainConfig",
    "TrainResult",
    "build_env",
    "config_from_dict",
    "describe_space",
    "load_config",
    "normalize_spaces",
    "require_train_extra",
    "resolve_env_id",
    "set_params_file",
    "train",
    "write_episodes",
]

#: ``format:`` key of a training config.
CONFIG_FORMAT = "sim2real.train/1"
#: Algorithms by their config name (stable-baselines3 class names).
ALGORITHMS = ("PPO", "SAC", "TD3", "DQN")
#: RLlib's PPO (``ray[rllib]``; see :mod:`sim2real.training._rllib`).
RLLIB_PPO = "rllib-ppo"
#: Name of the metadata entry added to ``model.zip``.
METADATA_ENTRY = "sim2real.yaml"
_CONTINUOUS_ONLY = ("SAC", "TD3")
_VEC_ENVS = ("subproc", "dummy")
_KEYS = (
    "format",
    "env",
    "randomizers",
    "algorithm",
    "policy",
    "hyperparameters",
    "timesteps",
    "n_envs",
    "vec_env",
    "seed",
    "out",
    "checkpoint_every",
    "evaluation",
    "discrete_actions",
    "normalize",
    "rllib",
)
_NORMALIZE = ("observations", "actions", "rewards")


@dataclass(frozen=True, kw_only=True)
class TrainConfig:
    """A resolved training config (see the module docstring for the YAML form).

    Attributes
    ----------
    env_id : str
        Registered env id, e.g. ``sim2real/RandomMap-v0``.
    env_kwargs : dict
        ``gymnasium.make`` keyword arguments of the training env.
    randomizers : dict or None
        Randomizer config (``randomizers.from_config`` format) with absolute ``sysid`` paths.
    algorithm : str
        One of :data:`ALGORITHMS`.
    policy : str
        SB3 policy name or ``auto``.
    hyperparameters : dict
        Algorithm constructor keyword arguments.
    timesteps : int
        Env steps to train for.
    n_envs : int
        Parallel envs.
    vec_env : str
        ``subproc`` or ``dummy``.
    seed : int
        Seed of the model and of env i (``seed + i``).
    out : Path
        Output folder.
    checkpoint_every : int
        Env steps between checkpoints (0 = none).
    eval_episodes, eval_seed : int
        Final evaluation: episodes and the seed of the first one.
    eval_kwargs : dict
        ``gymnasium.make`` keyword arguments that replace the training ones for the evaluation.
    eval_randomize : bool
        Evaluate under the randomizer stack too.
    discrete_actions : dict or None
        ``{v_mps: [...], w_radps: [...]}`` grid for DQN on a Box action space.
    normalize : dict
        ``{observations: bool, actions: bool, rewards: bool}`` (see the module docstring).
    rllib : dict
        ``{address, num_env_runners, num_envs_per_env_runner}`` for ``algorithm: rllib-ppo``.
    source : str
        Where the config came from (for messages).
    """

    env_id: str
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    randomizers: dict[str, Any] | None = None
    algorithm: str = "PPO"
    policy: str = "auto"
    hyperparameters: dict[str, Any] = field(default_factory=dict)
    timesteps: int = 100_000
    n_envs: int = 1
    vec_env: str = "subproc"
    seed: int = 0
    out: Path = Path("runs/train")
    checkpoint_every: int = 0
    eval_episodes: int = 10
    eval_seed: int = 10_000
    eval_kwargs: dict[str, Any] = field(default_factory=dict)
    eval_randomize: bool = False
    discrete_actions: dict[str, list[float]] | None = None
    normalize: dict[str, bool] = field(default_factory=lambda: dict.fromkeys(_NORMALIZE, False))
    rllib: dict[str, Any] = field(default_factory=dict)
    source: str = "config"

    def to_dict(self) -> dict[str, Any]:
        """The config as YAML-ready plain data (the ``OUT/config.yaml`` layout)."""
        return {
            "format": CONFIG_FORMAT,
            "env": {"id": self.env_id, "kwargs": dict(self.env_kwargs)},
            "randomizers": self.randomizers,
            "algorithm": self.algorithm,
            "policy": self.policy,
            "hyperparameters": dict(self.hyperparameters),
            "timesteps": self.timesteps,
            "n_envs": self.n_envs,
            "vec_env": self.vec_env,
            "seed": self.seed,
            "out": str(self.out),
            "checkpoint_every": self.checkpoint_every,
            "evaluation": {
                "episodes": self.eval_episodes,
                "seed": self.eval_seed,
                "kwargs": dict(self.eval_kwargs),
                "randomize": self.eval_randomize,
            },
            "discrete_actions": self.discrete_actions,
            "normalize": dict(self.normalize),
            **({"rllib": dict(self.rllib)} if self.algorithm == RLLIB_PPO else {}),
        }


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


# --------------------------------------------------------------------------- extras


def require_train_extra(what: str = "sim2real train") -> None:
    """Raise a one-sentence error when stable-baselines3/torch are not installed."""
    missing = [m for m in ("torch", "stable_baselines3") if not _importable(m)]
    if missing:
        raise Sim2RealValueError(
            f"{what} needs {' and '.join(missing)}, which "
            f"{'is' if len(missing) == 1 else 'are'} not installed; install the "
            "training extra with `pip install torch==2.13.0 && pip install -e '.[train]'` "
            "(in a checkout: `make train-extra`)"
        )


def _importable(module: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(module) is not None


# --------------------------------------------------------------------------- env ids


def resolve_env_id(name: str, *, where: str = "env id") -> str:
    """The registered sim2real env id for ``name`` (with or without the ``sim2real/`` prefix).

    Examples
    --------
    >>> resolve_env_id("randommap-v0")
    'sim2real/RandomMap-v0'
    """
    import sim2real.envs

    known: Sequence[str] = sim2real.envs.ENV_IDS
    key = str(name).lower().removeprefix("sim2real/")
    for env_id in known:
        if env_id.lower().removeprefix("sim2real/") == key:
            return env_id
    raise Sim2RealValueError(
        f"{where} {name!r} is not a sim2real env; known envs are {', '.join(known)} "
        "(see `sim2real envs list`)"
    )


# --------------------------------------------------------------------------- config parsing


def _yaml_file(path: Path, what: str) -> Mapping[str, Any]:
    if not path.is_file():
        raise Sim2RealFileNotFoundError(
            f"{what} '{path}' does not exist; give the path of a YAML file"
        )
    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}" if mark is not None else ""
        raise Sim2RealValueError(
            f"{what} '{path}' is not valid YAML{at}; fix the syntax there"
        ) from None
    if not isinstance(doc, Mapping):
        raise Sim2RealValueError(
            f"{what} '{path}' must be a mapping of keys (format, env, algorithm, ...), got "
            f"{type(doc).__name__}"
        )
    return doc


def _int(doc: Mapping[str, Any], key: str, default: int, where: str, *, low: int) -> int:
    value = doc.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise Sim2RealValueError(f"{where}: key '{key}' must be an integer >= {low}, got {value!r}")
    return int(value)


def _mapping(value: Any, key: str, where: str) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise Sim2RealValueError(
            f"{where}: key '{key}' must be a mapping of keyword arguments, got {value!r}"
        )
    return {str(k): v for k, v in value.items()}


def _algorithm(value: Any, where: str) -> str:
    for name in (*ALGORITHMS, RLLIB_PPO):
        if str(value).lower() == name.lower():
            return name
    raise Sim2RealValueError(
        f"{where}: key 'algorithm' is {value!r}, which is not supported; use one of "
        f"{', '.join(ALGORITHMS)} (stable-baselines3) or {RLLIB_PPO} (Ray RLlib)"
    )


def _randomizers(value: Any, folder: Path, where: str) -> dict[str, Any] | None:
    """The randomizer config as a mapping with absolute ``sysid`` paths (None = no stack)."""
    if value is None:
        return None
    if isinstance(value, str):
        path = Path(value) if Path(value).is_absolute() else folder / value
        doc = dict(_yaml_file(path, f"{where}: key 'randomizers' names a file;"))
        return _absolute_sysid(doc, path.parent)
    if isinstance(value, list):
        return _absolute_sysid({"format": "sim2real.randomizers/1", "randomizers": value}, folder)
    if isinstance(value, Mapping):
        return _absolute_sysid(dict(value), folder)
    raise Sim2RealValueError(
        f"{where}: key 'randomizers' must be a randomizer config file, a list of "
        f"{{type: ..., <arguments>}} or null, got {value!r}"
    )


def _absolute_sysid(doc: dict[str, Any], folder: Path) -> dict[str, Any]:
    entries = doc.get("randomizers")
    if isinstance(entries, list):
        fixed = []
        for entry in entries:
            if isinstance(entry, Mapping) and isinstance(entry.get("sysid"), str):
                p = Path(entry["sysid"])
                entry = {**entry, "sysid": str(p if p.is_absolute() else (folder / p).resolve())}
            fixed.append(entry)
        doc = {**doc, "randomizers": fixed}
    return doc


def _with_params_path(kwargs: dict[str, Any], folder: Path) -> dict[str, Any]:
    """``kwargs`` with a relative ``params`` file made absolute (relative to the config)."""
    params = kwargs.get("params")
    if isinstance(params, str) and not Path(params).is_absolute():
        kwargs = {**kwargs, "params": str((folder / params).resolve())}
    return kwargs


def _discrete(value: Any, where: str) -> dict[str, list[float]] | None:
    if value is None:
        return None
    ok = isinstance(value, Mapping) and set(value) == {"v_mps", "w_radps"}
    grids: dict[str, list[float]] = {}
    if ok:
        for key in ("v_mps", "w_radps"):
            grid = value[key]
            if not (
                isinstance(grid, list)
                and grid
                and all(isinstance(g, int | float) and math.isfinite(g) for g in grid)
            ):
                ok = False
                break
            grids[key] = [float(g) for g in grid]
    if not ok:
        raise Sim2RealValueError(
            f"{where}: key 'discrete_actions' must be {{v_mps: [numbers], w_radps: [numbers]}}, "
            f"got {value!r}"
        )
    return grids


def _normalize(value: Any, where: str) -> dict[str, bool]:
    out = dict.fromkeys(_NORMALIZE, False)
    if value is None or value is False:
        return out
    if value is True:
        return dict.fromkeys(_NORMALIZE, True)
    ok = isinstance(value, Mapping) and set(value) <= set(_NORMALIZE)
    ok = ok and all(isinstance(v, bool) for v in value.values())
    if not ok:
        raise Sim2RealValueError(
            f"{where}: key 'normalize' must be true, false or a mapping of "
            f"{', '.join(_NORMALIZE)} to true/false, got {value!r}"
        )
    return {**out, **{str(k): bool(v) for k, v in value.items()}}


def _rllib_options(value: Any, where: str) -> dict[str, Any]:
    from sim2real.training._rllib import rllib_options

    return rllib_options(value, where)


def load_config(
    path: str | Path,
    *,
    timesteps: int | None = None,
    seed: int | None = None,
    out: str | Path | None = None,
) -> TrainConfig:
    """Read a training config YAML; ``timesteps``, ``seed`` and ``out`` override its keys.

    Raises :class:`~sim2real.errors.Sim2RealValueError` naming the file and key on bad input
    (unknown algorithm, unknown env id, wrong types).

    Examples
    --------
    >>> cfg = load_config("examples/randommap_ppo.yaml", timesteps=500)  # doctest: +SKIP
    >>> cfg.algorithm, cfg.timesteps  # doctest: +SKIP
    ('PPO', 500)
    """
    p = Path(path)
    where = f"training config '{p}'"
    doc = _yaml_file(p, "training config")
    return config_from_dict(
        doc, folder=p.parent, where=where, timesteps=timesteps, seed=seed, out=out
    )


def config_from_dict(
    doc: Mapping[str, Any],
    *,
    folder: Path = Path("."),
    where: str = "training config",
    timesteps: int | None = None,
    seed: int | None = None,
    out: str | Path | None = None,
) -> TrainConfig:
    """Like :func:`load_config` for an already-parsed mapping (paths relative to ``folder``)."""
    fmt = doc.get("format", CONFIG_FORMAT)  # first: another file (a sysid result) says so
    if fmt != CONFIG_FORMAT:
        raise Sim2RealValueError(f"{where}: key 'format' must be '{CONFIG_FORMAT}', got {fmt!r}")
    unknown = sorted(set(doc) - set(_KEYS))
    if unknown:
        raise Sim2RealValueError(
            f"{where}: unknown key(s) {unknown}; known keys are {', '.join(_KEYS)}"
        )
    env = doc.get("env")
    if isinstance(env, str):
        env = {"id": env}
    if not isinstance(env, Mapping) or "id" not in env:
        raise Sim2RealValueError(
            f"{where}: key 'env' must be a mapping with 'id' (e.g. sim2real/RandomMap-v0) and "
            f"optional 'kwargs', got {env!r}"
        )
    env_id = resolve_env_id(env["id"], where=f"{where}: env id")
    evaluation = _mapping(doc.get("evaluation"), "evaluation", where)
    env_kwargs = _with_params_path(_mapping(env.get("kwargs"), "env.kwargs", where), folder)
    eval_kwargs = _with_params_path(
        _mapping(evaluation.get("kwargs"), "evaluation.kwargs", where), folder
    )
    cfg = TrainConfig(
        env_id=env_id,
        env_kwargs=env_kwargs,
        randomizers=_randomizers(doc.get("randomizers"), folder, where),
        algorithm=_algorithm(doc.get("algorithm", "PPO"), where),
        policy=str(doc.get("policy", "auto")),
        hyperparameters=_mapping(doc.get("hyperparameters"), "hyperparameters", where),
        timesteps=_int(doc, "timesteps", 100_000, where, low=1),
        n_envs=_int(doc, "n_envs", 1, where, low=1),
        vec_env=str(doc.get("vec_env", "subproc")),
        seed=_int(doc, "seed", 0, where, low=0),
        out=Path(str(doc.get("out", "runs/train"))),
        checkpoint_every=_int(doc, "checkpoint_every", 0, where, low=0),
        eval_episodes=_int(evaluation, "episodes", 10, f"{where}: evaluation", low=0),
        eval_seed=_int(evaluation, "seed", 10_000, f"{where}: evaluation", low=0),
        eval_kwargs=eval_kwargs,
        eval_randomize=bool(evaluation.get("randomize", False)),
        discrete_actions=_discrete(doc.get("discrete_actions"), where),
        normalize=_normalize(doc.get("normalize"), where),
        rllib=_rllib_options(doc.get("rllib"), where),
        source=where,
    )
    if cfg.vec_env not in _VEC_ENVS:
        raise Sim2RealValueError(
            f"{where}: key 'vec_env' must be one of {', '.join(_VEC_ENVS)}, got {cfg.vec_env!r}"
        )
    overrides: dict[str, Any] = {}
    if timesteps is not None:
        overrides["timesteps"] = _int(
            {"timesteps": timesteps}, "timesteps", 0, "--timesteps", low=1
        )
    if seed is not None:
        overrides["seed"] = _int({"seed": seed}, "seed", 0, "--seed", low=0)
    if out is not None:
        overrides["out"] = Path(out)
    return replace(cfg, **overrides)


# --------------------------------------------------------------------------- env construction


class DiscreteActions(gym.ActionWrapper):  # type: ignore[type-arg]
    """A ``Discrete`` action space over a grid of (v, w) commands, for DQN.

    Action ``k`` is ``(v_mps[k // len(w_radps)], w_radps[k % len(w_radps)])``.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import sim2real.envs
    >>> env = DiscreteActions(gym.make("sim2real/RandomMap-v0"), v_mps=[0.0, 0.25],
    ...                       w_radps=[-1.0, 0.0, 1.0])
    >>> int(env.action_space.n), env.action(4).tolist()
    (6, [0.25, 0.0])
    """

    def __init__(self, env: gym.Env[Any, Any], *, v_mps: list[float], w_radps: list[float]):
        super().__init__(env)
        self.grid = np.array([(v, w) for v in v_mps for w in w_radps], dtype=np.float32)
        self.action_space = gym.spaces.Discrete(len(self.grid))

    def action(self, action: Any) -> np.ndarray:
        """The (v, w) command of grid index ``action``."""
        return self.grid[int(np.asarray(action).reshape(-1)[0])]


def default_action_grid(env: gym.Env[Any, Any]) -> dict[str, list[float]]:
    """3 forward speeds x 5 turn rates spanning the env's Box action space."""
    space = env.action_space
    low = np.asarray(space.low, dtype=np.float64)  # type: ignore[attr-defined]
    high = np.asarray(space.high, dtype=np.float64)  # type: ignore[attr-defined]
    return {
        "v_mps": [float(x) for x in np.linspace(max(low[0], 0.0), high[0], 3)],
        "w_radps": [float(x) for x in np.linspace(low[1], high[1], 5)],
    }


def build_env(
    env_id: str,
    env_kwargs: Mapping[str, Any],
    *,
    randomizers: Mapping[str, Any] | None = None,
    discrete_actions: Mapping[str, list[float]] | None = None,
    normalize: Mapping[str, bool] | None = None,
    where: str = "env",
) -> Any:
    """``gymnasium.make(env_id, **env_kwargs)`` wrapped in the randomizer stack (innermost first),
    for a discrete-action algorithm :class:`DiscreteActions`, and the ``observations`` /
    ``actions`` entries of ``normalize`` (:func:`normalize_spaces`, outermost).

    Examples
    --------
    >>> env = build_env("sim2real/RandomMap-v0", {"preset": "TEST1"})
    >>> env.observation_space.shape
    (40,)
    """
    import randomizers as dr
    import sim2real.envs  # noqa: F401  (registers the ids)

    kwargs = dict(env_kwargs)
    params = kwargs.pop("params", None)
    if isinstance(kwargs.get("map_config"), Mapping):
        from sim2real.envs.maps import MapConfig

        try:
            kwargs["map_config"] = MapConfig(**kwargs["map_config"])
        except TypeError as exc:
            raise Sim2RealValueError(
                f"{where}: env kwargs 'map_config' {kwargs['map_config']} is not a MapConfig "
                f"({exc}); use its fields d_target_m, r_wall, n_min, n_max, area_m, ..."
            ) from None
    # through the spec, so that max_episode_steps reaches the env (the envs end episodes
    # themselves); gym.make(id, max_episode_steps=...) would add a TimeLimit wrapper instead
    spec = gym.spec(env_id)
    try:
        env: Any = gym.make(dataclasses.replace(spec, kwargs={**spec.kwargs, **kwargs}))
    except TypeError as exc:
        raise Sim2RealValueError(
            f"{where}: env kwargs {dict(env_kwargs)} are not accepted by {env_id} ({exc}); "
            "see `sim2real envs list` for its options"
        ) from None
    if params is not None:
        set_params_file(env, params)
    if randomizers is not None:
        env = dr.from_config(env, randomizers)
    if discrete_actions is not None:
        env = DiscreteActions(env, **discrete_actions)
    if normalize is not None:
        env = normalize_spaces(env, normalize, where=where)
    return env


def normalize_spaces(env: Any, normalize: Mapping[str, bool], *, where: str = "env") -> Any:
    """``env`` with its Box observation / action space rescaled to [-1, 1] from their bounds.

    ``normalize["observations"]`` adds ``gymnasium.wrappers.RescaleObservation``,
    ``normalize["actions"]`` ``gymnasium.wrappers.RescaleAction`` (a Box action space only; a
    discrete one is left alone). Both are fixed affine maps, so a saved policy evaluates with
    exactly its training scaling.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import sim2real.envs
    >>> env = normalize_spaces(gym.make("sim2real/RandomMap-v0"),
    ...                        {"observations": True, "actions": True})
    >>> float(env.observation_space.low.min()), env.action_space.high.tolist()
    (-1.0, [1.0, 1.0])
    """
    if normalize.get("observations"):
        space = env.observation_space
        box = isinstance(space, gym.spaces.Box)
        if not (box and np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))):
            raise Sim2RealValueError(
                f"{where}: normalize 'observations' needs a Box observation space with finite "
                f"bounds, got {describe_space(space)}; set normalize.observations: false"
            )
        env = gym.wrappers.RescaleObservation(env, np.float32(-1.0), np.float32(1.0))
    if normalize.get("actions") and isinstance(env.action_space, gym.spaces.Box):
        env = gym.wrappers.RescaleAction(env, np.float32(-1.0), np.float32(1.0))
    return env


def set_params_file(env: Any, path: str | Path) -> None:
    """Give ``env`` the drive parameters of a sysid result (refused for another robot)."""
    from robots.params import load_drive_params

    base = env.unwrapped
    spec = getattr(base, "robot_spec", None)
    if spec is None or not hasattr(base, "set_drive_params"):
        raise Sim2RealValueError(
            f"params file '{path}' cannot be applied: {type(base).__name__} has no robot drive "
            "model (params apply to CrowdNav-v0 and RandomMap-v0)"
        )
    base.set_drive_params(load_drive_params(path, robot=spec.name, base=base.get_drive_params()))


def _env_factory(cfg: TrainConfig, *, rank: int) -> Callable[[], Any]:
    """A picklable thunk building env ``rank`` (with SB3's Monitor for episode statistics)."""
    from functools import partial

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
    from stable_baselines3.common.monitor import Monitor

    env = build_env(
        env_id, kwargs, randomizers=randomizers, discrete_actions=discrete, normalize=normalize
    )
    return Monitor(env)


# --------------------------------------------------------------------------- training


def _sb3_class(algorithm: str) -> Any:
    import stable_baselines3 as sb3

    return getattr(sb3, algorithm)


def _policy_name(cfg: TrainConfig, env: Any) -> str:
    if cfg.policy != "auto":
        return cfg.policy
    return "MultiInputPolicy" if isinstance(env.observation_space, gym.spaces.Dict) else "MlpPolicy"


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


def _progress_callback(base: type, total: int) -> Any:
    """An SB3 callback drawing a rich progress bar of the env steps (TTY only)."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    class RichProgress(base):  # type: ignore[misc, valid-type]
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
            self._task = self._bar.add_task("training", total=total)

        def _on_step(self) -> bool:
            self._bar.update(self._task, completed=min(self.num_timesteps, total))
            return True

        def _on_training_end(self) -> None:
            self._bar.stop()

    return RichProgress()


def _episode_log_callback(base: type) -> Any:
    """An SB3 callback keeping (env step, outcome, return, length) of every training episode."""

    class EpisodeLog(base):  # type: ignore[misc, valid-type]
        rows: list[tuple[int, str, float, int]]

        def _on_training_start(self) -> None:
            self.rows = []

        def _on_step(self) -> bool:
            for info, done in zip(self.locals["infos"], self.locals["dones"], strict=True):
                episode = info.get("episode")
                if done and episode is not None:
                    outcome = str(info.get("outcome", ""))
                    self.rows.append(
                        (int(self.num_timesteps), outcome, float(episode["r"]), int(episode["l"]))
                    )
            return True

    return EpisodeLog()


def write_episodes(path: Path, rows: Sequence[tuple[int, str, float, int]]) -> Path:
    """``OUT/episodes.csv``: one line per training episode (see the module docstring)."""
    from sim2real._io import atomic_write

    with atomic_write(path, "w", what="episodes file") as fh:
        fh.write("step,outcome,return,length\n")
        for step, outcome, ret, length in rows:
            fh.write(f"{step},{outcome},{ret:.6g},{length}\n")
    return path


def _vec_env(cfg: TrainConfig) -> Any:
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    thunks = [_env_factory(cfg, rank=i) for i in range(cfg.n_envs)]
    if cfg.vec_env == "subproc" and cfg.n_envs > 1:
        vec: Any = SubprocVecEnv(thunks, start_method="forkserver")
    else:
        vec = DummyVecEnv(thunks)
    vec.seed(cfg.seed)
    if cfg.normalize.get("rewards"):
        from stable_baselines3.common.vec_env import VecNormalize

        gamma = float(cfg.hyperparameters.get("gamma", 0.99))
        vec = VecNormalize(vec, norm_obs=False, norm_reward=True, gamma=gamma)
    return vec


def _model(cfg: TrainConfig, vec: Any, probe: Any) -> Any:
    cls = _sb3_class(cfg.algorithm)
    try:
        return cls(
            _policy_name(cfg, probe),
            vec,
            seed=cfg.seed,
            verbose=0,
            tensorboard_log=str(cfg.out / "tensorboard"),
            device="cpu",
            **cfg.hyperparameters,
        )
    except TypeError as exc:
        raise Sim2RealValueError(
            f"{cfg.source}: key 'hyperparameters' {cfg.hyperparameters} is not accepted by "
            f"{cfg.algorithm} ({exc}); use that class's constructor keyword arguments"
        ) from None


def _write_yaml(path: Path, doc: Any, what: str) -> None:
    from sim2real._io import atomic_write

    with atomic_write(path, "w", what=what) as fh:
        yaml.safe_dump(_plain(doc), fh, sort_keys=False)


def _plain(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, np.generic):
        return value.item()
    return value


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


def describe_space(space: Any) -> str:
    """Short text of a space: ``Box(40,)``, ``Dict(lidar: Box(36,), ...)``, ``Discrete(15)``."""
    if isinstance(space, gym.spaces.Box):
        return f"Box{space.shape}"
    if isinstance(space, gym.spaces.Dict):
        inner = ", ".join(f"{k}: {describe_space(v)}" for k, v in space.spaces.items())
        return f"Dict({inner})"
    return str(space)


def save_model(model: Any, path: Path, metadata: Mapping[str, Any]) -> Path:
    """Save an SB3 model to ``path`` with a ``sim2real.yaml`` entry, atomically."""
    from sim2real._io import atomic_write

    buf = io.BytesIO()
    model.save(buf)
    with zipfile.ZipFile(buf, "a") as zf:
        zf.writestr(METADATA_ENTRY, yaml.safe_dump(_plain(metadata), sort_keys=False))
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
    import torch
    from stable_baselines3.common.callbacks import CheckpointCallback

    probe = build_env(cfg.env_id, cfg.env_kwargs, randomizers=cfg.randomizers, where=cfg.source)
    cfg = _check_action_space(cfg, probe)
    if cfg.algorithm in _CONTINUOUS_ONLY and not isinstance(probe.action_space, gym.spaces.Box):
        raise Sim2RealValueError(
            f"{cfg.source}: {cfg.algorithm} needs a continuous (Box) action space but "
            f"{cfg.env_id} has {probe.action_space}; use PPO or DQN"
        )
    if cfg.discrete_actions is not None:
        probe = DiscreteActions(probe, **cfg.discrete_actions)
    probe = normalize_spaces(probe, cfg.normalize, where=cfg.source)
    cfg.out.mkdir(parents=True, exist_ok=True)
    resolved = cfg.to_dict()
    if cfg.randomizers is not None:
        import randomizers as dr

        resolved["randomizers"] = dr.to_config(probe)
    _write_yaml(cfg.out / "config.yaml", resolved, "resolved config")
    torch.set_num_threads(1)  # small MLPs: more threads only add overhead on 2 cores
    vec = _vec_env(cfg)
    try:
        model = _model(cfg, vec, probe)
        from stable_baselines3.common.callbacks import BaseCallback

        episode_log = _episode_log_callback(BaseCallback)
        callbacks: list[Any] = [episode_log]
        if cfg.checkpoint_every > 0:
            callbacks.append(
                CheckpointCallback(
                    save_freq=max(cfg.checkpoint_every // cfg.n_envs, 1),
                    save_path=str(cfg.out / "checkpoints"),
                    name_prefix="model",
                )
            )
        if progress:
            callbacks.append(_progress_callback(BaseCallback, cfg.timesteps))
        t0 = time.perf_counter()
        model.learn(total_timesteps=cfg.timesteps, callback=callbacks, tb_log_name="run")
        train_time_s = time.perf_counter() - t0
    finally:
        vec.close()
    model_path = save_model(model, cfg.out / "model.zip", model_metadata(cfg, probe))
    write_episodes(cfg.out / "episodes.csv", episode_log.rows)
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


def _train_rllib(cfg: TrainConfig) -> TrainResult:
    """``algorithm: rllib-ppo``: RLlib's PPO on the same env construction (sim2real.training._rllib)."""
    from sim2real.training._rllib import RLlibController, require_rllib, train_rllib

    require_rllib()
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
        import randomizers as dr

        resolved["randomizers"] = dr.to_config(probe)
    probe.close()
    _write_yaml(cfg.out / "config.yaml", resolved, "resolved config")
    policy_dir, steps, train_s, module = train_rllib(cfg, cfg.rllib)
    evaluation = final_evaluation(cfg, None, controller=RLlibController(module))
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
    from sim2real.training.evaluation import PolicyController, evaluate_controller

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
        **(
            {"off_road_rate": sum(bool(r.get("off_road")) for r in rows) / len(rows)}
            if rows and "off_road" in rows[0]
            else {}
        ),
        "means": {k: (None if math.isnan(v) else v) for k, v in summary.means.items()},
    }


def config_summary(cfg: TrainConfig) -> dict[str, Any]:
    """Short description for logs and tests."""
    return {k: v for k, v in asdict(cfg).items() if k not in ("randomizers", "source")}
