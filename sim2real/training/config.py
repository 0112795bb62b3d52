"""The training config: one YAML file (``format: sim2real.train/1``) read into a :class:`TrainConfig`.

Relative paths are relative to the config file::

    format: sim2real.train/1
    env:
      id: sim2real/RandomMap-v0        # or RandomMap-v0, CrowdNav-v0
      kwargs: {preset: TRAIN, max_episode_steps: 400}   # gymnasium.make keyword arguments;
                                       # map_config: {...} (RandomMap MapConfig fields) and
                                       # params: RESULT.yaml (drive parameters) are understood
    randomizers: randommap_randomizers.yaml  # a randomizer config file, an inline one, or null
    algorithm: PPO                     # PPO, SAC, TD3, DQN (stable-baselines3) or rllib-ppo
    policy: auto                       # MlpPolicy for Box observations, MultiInputPolicy for Dict;
                                       # sarl: SARL*'s attention over neighbours (Race-v0, or
                                       # CrowdNav-v0 with kwargs neighbours: K);
                                       # sarl-lookahead: its value of each action's predicted
                                       # next observation (DQN on Race-v0); sensors: a
                                       # small encoder per lidar / depth entry of a Dict
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
    action_noise: {type: normal, sigma: 0.1}   # TD3/SAC exploration noise (see below)
    curriculum: {goal_speed_mps: 0.7, until: 0.5}   # an easier goal at first (see below)

``curriculum`` (SB3 algorithms, navigation envs): the goal criteria start at the values given
(``goal_speed_mps``, ``goal_tolerance_m``) and move geometrically, at every rollout, to the
env's own values (its ``goal_speed_mps`` and tolerance), which they reach after ``until`` of
the timesteps (a share in (0, 1], default 0.5) and keep. The saved policy's env, and every
evaluation, has the env's own values: e.g. a stop at the goal (``goal_speed_mps: 0.05``) first
counts any speed below 0.7 m/s inside the tolerance, so that the policy learns to reach the
goal before it has to stop in it. CrowdNav-v0's crowd can grow the same way::

    curriculum: {complexity: 0.0, scenario: static, hold: 0.2, until: 0.5}

``complexity`` (in [0, 1]) holds for the first ``hold`` of the timesteps (a share below
``until``, default 0), in the scenario family ``scenario`` if given (``static`` at complexity
0 is the empty room), then, in the env's own family, rises linearly to the env's own
complexity at ``until``. Each episode keeps the task it was reset with.

``action_noise``: Gaussian (``normal``) or Ornstein-Uhlenbeck (``ornstein-uhlenbeck``) noise
of standard deviation ``sigma`` added to every action TD3 or SAC takes while training (SB3's
``action_noise``; in the policy's action units, so [-1, 1] with ``normalize: {actions: true}``).
Without it SB3's TD3 explores only in its ``learning_starts`` random steps.

``algorithm: rllib-ppo`` trains with Ray RLlib's PPO (:mod:`sim2real.training._rllib`); its
``rllib`` key names the Ray cluster and the env runners::

    rllib:
      address: auto            # Ray cluster (see sim2real.cluster.connect); auto starts a local one
      num_env_runners: 2       # Ray actors sampling the env (one CPU each)
      num_envs_per_env_runner: 1

``normalize``: ``observations`` and ``actions`` rescale Box spaces to [-1, 1] from their bounds
(fixed, stateless wrappers outermost in the stack, recorded in ``model.zip`` so that
evaluation applies them too); ``rewards`` divides the training reward by a running estimate of
the discounted return's std (SB3 ``VecNormalize(norm_obs=False)``; training only). PPO's
Gaussian policy starts at mean 0 and std ~1 in the action space, so on RandomMap-v0 (v in
[0, 0.21] m/s) unscaled actions mostly clip; rescaled ones start at half speed.

Examples
--------
>>> cfg = load_config("examples/randommap_ppo.yaml", timesteps=500)
>>> cfg.algorithm, cfg.timesteps, cfg.env_id
('PPO', 500, 'sim2real/RandomMap-v0')
"""

from __future__ import annotations

import importlib.util
import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import yaml

import sim2real.envs
from sim2real.errors import Sim2RealFileNotFoundError, Sim2RealValueError

__all__ = [
    "ACTION_NOISES",
    "ALGORITHMS",
    "CONFIG_FORMAT",
    "CURRICULUM_KEYS",
    "POLICIES",
    "RLLIB_KEYS",
    "RLLIB_PPO",
    "SARL_LOOKAHEAD_POLICY",
    "SARL_POLICY",
    "SENSORS_POLICY",
    "TrainConfig",
    "config_from_dict",
    "config_summary",
    "load_config",
    "require_rllib",
    "require_train_extra",
    "resolve_env_id",
    "rllib_options",
]

#: ``format:`` key of a training config.
CONFIG_FORMAT = "sim2real.train/1"
#: Algorithms by their config name (stable-baselines3 class names).
ALGORITHMS = ("PPO", "SAC", "TD3", "DQN")
#: RLlib's PPO (``ray[rllib]``; see :mod:`sim2real.training._rllib`).
RLLIB_PPO = "rllib-ppo"
#: The crowd-aware policy (:mod:`sim2real.training._sarl`): SB3's policy on SARL*'s features.
SARL_POLICY = "sarl"
#: SARL's value network with a one-step look-ahead as DQN's Q (:mod:`sim2real.training._lookahead`).
SARL_LOOKAHEAD_POLICY = "sarl-lookahead"
#: SB3's policy over a small encoder per sensor of a Dict observation (:mod:`sim2real.training._sensors`).
SENSORS_POLICY = "sensors"
#: Values of the config's ``policy`` key (SB3 policy names, ``auto`` and the three above).
POLICIES = (
    "auto",
    "MlpPolicy",
    "MultiInputPolicy",
    "CnnPolicy",
    SARL_POLICY,
    SARL_LOOKAHEAD_POLICY,
    SENSORS_POLICY,
)
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
    "action_noise",
    "curriculum",
    "rllib",
)
_NORMALIZE = ("observations", "actions", "rewards")
#: Keys of ``curriculum``: the goal criteria and the crowd it starts from, the share of the
#: timesteps the crowd holds, and the share after which all are the env's own.
CURRICULUM_KEYS = ("goal_speed_mps", "goal_tolerance_m", "complexity", "scenario", "hold", "until")
#: Values of ``action_noise.type``.
ACTION_NOISES = ("normal", "ornstein-uhlenbeck")
#: Algorithms that take ``action_noise`` (SB3's off-policy continuous ones).
_NOISY = ("SAC", "TD3")
#: Keys of the config's ``rllib`` mapping and their defaults.
RLLIB_KEYS: dict[str, Any] = {
    "address": "auto",
    "num_env_runners": 1,
    "num_envs_per_env_runner": 1,
}


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
    action_noise : dict or None
        ``{type: normal | ornstein-uhlenbeck, sigma: float}`` for TD3/SAC, in action units.
    curriculum : dict or None
        ``{goal_speed_mps, goal_tolerance_m, complexity, scenario, hold, until}`` (start
        values and the shares of the timesteps at which they move and at which the env's own
        are reached; see the module docstring).
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
    action_noise: dict[str, Any] | None = None
    curriculum: dict[str, Any] | None = None
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
            "action_noise": None if self.action_noise is None else dict(self.action_noise),
            "curriculum": None if self.curriculum is None else dict(self.curriculum),
            **({"rllib": dict(self.rllib)} if self.algorithm == RLLIB_PPO else {}),
        }


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


def require_rllib() -> None:
    """Raise one sentence when ``ray[rllib]`` cannot be imported."""
    try:
        import ray.rllib  # noqa: F401
    except ImportError as exc:
        raise Sim2RealValueError(
            f"algorithm 'rllib-ppo' needs Ray RLlib, which cannot be imported here ({exc}); "
            "ray[rllib] 2.60 pins gymnasium==1.2.2, so install it in its own venv: "
            "`make rllib-extra` (or pip install 'ray[rllib]==2.60.0' torch==2.13.0 -e '.[train]'"
            " in a fresh venv)"
        ) from None


def _importable(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


# --------------------------------------------------------------------------- env ids


def resolve_env_id(name: str, *, where: str = "env id") -> str:
    """The registered sim2real env id for ``name`` (with or without the ``sim2real/`` prefix).

    Examples
    --------
    >>> resolve_env_id("randommap-v0")
    'sim2real/RandomMap-v0'
    """
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


def _policy(value: Any, where: str) -> str:
    for name in POLICIES:
        if str(value).lower() == name.lower():
            return name
    raise Sim2RealValueError(
        f"{where}: key 'policy' is {value!r}, which is not a known policy preset; use one of "
        f"{', '.join(POLICIES)}"
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


def _action_noise(value: Any, where: str) -> dict[str, Any] | None:
    """``{type, sigma}`` checked (None = SB3's default, no noise)."""
    if value is None:
        return None
    ok = isinstance(value, Mapping) and set(value) == {"type", "sigma"}
    sigma: Any = value.get("sigma") if ok else None
    ok = ok and value["type"] in ACTION_NOISES
    ok = ok and isinstance(sigma, int | float) and not isinstance(sigma, bool)
    if not (ok and math.isfinite(sigma) and sigma > 0):
        raise Sim2RealValueError(
            f"{where}: key 'action_noise' must be {{type: {' or '.join(ACTION_NOISES)}, "
            f"sigma: a number > 0}} (the noise's standard deviation in action units), got "
            f"{value!r}"
        )
    return {"type": str(value["type"]), "sigma": float(sigma)}


def _curriculum(value: Any, where: str) -> dict[str, Any] | None:
    """``{goal_speed_mps, goal_tolerance_m, complexity, scenario, hold, until}`` checked,
    ``until`` filled in."""
    if value is None:
        return None
    ok = isinstance(value, Mapping) and set(value) <= set(CURRICULUM_KEYS)
    ok = ok and bool(set(value) & {"goal_speed_mps", "goal_tolerance_m", "complexity"})
    doc = dict(value) if ok else {}
    scenario = doc.pop("scenario", None)
    for k, v in doc.items():
        ok = ok and isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
        ok = ok and (0 <= v <= 1 if k in ("complexity", "hold") else v > 0)
    until, hold = doc.get("until", 0.5), doc.get("hold", 0.0)
    ok = ok and until <= 1 and hold < until
    ok = ok and (scenario is None or (scenario in sim2real.envs.SCENARIOS and hold > 0))
    ok = ok and ("complexity" in doc or not {"scenario", "hold"} & set(value))
    if not ok:
        raise Sim2RealValueError(
            f"{where}: key 'curriculum' must map goal_speed_mps and/or goal_tolerance_m to the "
            f"start value (a number > 0) and/or complexity to one in [0, 1], optionally "
            f"until to a share of the timesteps in (0, 1], hold to a share below until and, "
            f"with hold, scenario to one of {', '.join(sim2real.envs.SCENARIOS)}; got "
            f"{value!r}; e.g. curriculum: {{goal_speed_mps: 0.7, until: 0.5}} or "
            f"{{complexity: 0.0, scenario: static, hold: 0.2, until: 0.5}}"
        )
    out: dict[str, Any] = {str(k): float(v) for k, v in doc.items()}
    if scenario is not None:
        out["scenario"] = str(scenario)
    return {**out, "until": float(until)}


def rllib_options(value: Any, where: str) -> dict[str, Any]:
    """The config's ``rllib`` mapping with defaults filled in, checked."""
    if value is None:
        return dict(RLLIB_KEYS)
    if not isinstance(value, Mapping) or not set(value) <= set(RLLIB_KEYS):
        raise Sim2RealValueError(
            f"{where}: key 'rllib' must be a mapping of {', '.join(RLLIB_KEYS)}, got {value!r}"
        )
    out = {**RLLIB_KEYS, **{str(k): v for k, v in value.items()}}
    for key, low in (("num_env_runners", 0), ("num_envs_per_env_runner", 1)):
        v = out[key]
        if isinstance(v, bool) or not isinstance(v, int) or v < low:
            raise Sim2RealValueError(
                f"{where}: key 'rllib.{key}' must be an integer >= {low}, got {v!r}"
            )
    if out["address"] is not None and not isinstance(out["address"], str):
        raise Sim2RealValueError(
            f"{where}: key 'rllib.address' must be 'auto', HOST:PORT or null, got "
            f"{out['address']!r}"
        )
    return out


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
    _check_keys(doc, where)
    env = _env_entry(doc.get("env"), where)
    env_id = resolve_env_id(env["id"], where=f"{where}: env id")
    evaluation = _mapping(doc.get("evaluation"), "evaluation", where)
    env_kwargs = _training_kwargs(env, folder, where)
    eval_kwargs = _with_params_path(
        _mapping(evaluation.get("kwargs"), "evaluation.kwargs", where), folder
    )
    cfg = TrainConfig(
        env_id=env_id,
        env_kwargs=env_kwargs,
        randomizers=_randomizers(doc.get("randomizers"), folder, where),
        algorithm=_algorithm(doc.get("algorithm", "PPO"), where),
        policy=_policy(doc.get("policy", "auto"), where),
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
        action_noise=_action_noise(doc.get("action_noise"), where),
        curriculum=_curriculum(doc.get("curriculum"), where),
        rllib=rllib_options(doc.get("rllib"), where),
        source=where,
    )
    if cfg.action_noise is not None and cfg.algorithm not in _NOISY:
        raise Sim2RealValueError(
            f"{where}: key 'action_noise' applies to {' and '.join(_NOISY)} only, not "
            f"{cfg.algorithm}; remove the key or use one of those algorithms"
        )
    if cfg.curriculum is not None and cfg.algorithm == RLLIB_PPO:
        raise Sim2RealValueError(
            f"{where}: key 'curriculum' applies to the stable-baselines3 algorithms "
            f"({', '.join(ALGORITHMS)}), not {RLLIB_PPO}; remove the key or use one of those"
        )
    if cfg.vec_env not in _VEC_ENVS:
        raise Sim2RealValueError(
            f"{where}: key 'vec_env' must be one of {', '.join(_VEC_ENVS)}, got {cfg.vec_env!r}"
        )
    return replace(cfg, **_overrides(timesteps, seed, out))


def _check_keys(doc: Mapping[str, Any], where: str) -> None:
    fmt = doc.get("format", CONFIG_FORMAT)  # first: another file (a sysid result) says so
    if fmt != CONFIG_FORMAT:
        raise Sim2RealValueError(f"{where}: key 'format' must be '{CONFIG_FORMAT}', got {fmt!r}")
    unknown = sorted(set(doc) - set(_KEYS))
    if unknown:
        raise Sim2RealValueError(
            f"{where}: unknown key(s) {unknown}; known keys are {', '.join(_KEYS)}"
        )


def _env_entry(env: Any, where: str) -> Mapping[str, Any]:
    """The ``env`` key as a mapping with ``id`` (a bare id is accepted)."""
    if isinstance(env, str):
        env = {"id": env}
    if not isinstance(env, Mapping) or "id" not in env:
        raise Sim2RealValueError(
            f"{where}: key 'env' must be a mapping with 'id' (e.g. sim2real/RandomMap-v0) and "
            f"optional 'kwargs', got {env!r}"
        )
    return env


def _training_kwargs(env: Mapping[str, Any], folder: Path, where: str) -> dict[str, Any]:
    """The training env's kwargs (a relative params file made absolute); never a plant."""
    env_kwargs = _with_params_path(_mapping(env.get("kwargs"), "env.kwargs", where), folder)
    if env_kwargs.get("dynamics") == "plant":
        raise Sim2RealValueError(
            f"{where}: env.kwargs dynamics 'plant' is a foreign base that stands in for the real "
            "robot and is never trained on; train with dynamics 'reduced' and evaluate on the "
            "plant (evaluation.kwargs dynamics: plant, or sim2real envs eval --dynamics plant)"
        )
    return env_kwargs


def _overrides(timesteps: int | None, seed: int | None, out: str | Path | None) -> dict[str, Any]:
    """The command line's ``--timesteps``, ``--seed`` and ``--out``, checked."""
    overrides: dict[str, Any] = {}
    if timesteps is not None:
        overrides["timesteps"] = _int(
            {"timesteps": timesteps}, "timesteps", 0, "--timesteps", low=1
        )
    if seed is not None:
        overrides["seed"] = _int({"seed": seed}, "seed", 0, "--seed", low=0)
    if out is not None:
        overrides["out"] = Path(out)
    return overrides


def config_summary(cfg: TrainConfig) -> dict[str, Any]:
    """Short description for logs and tests."""
    return {k: v for k, v in asdict(cfg).items() if k not in ("randomizers", "source")}
