"""Build a randomizer stack from YAML and write the stack in use back, so it ships with a policy.

File format (``format: sim2real.randomizers/1``); the list is innermost first, i.e. the first
entry wraps the env directly::

    format: sim2real.randomizers/1
    randomizers:
      - {type: DepthNoise, key: depth, std_m: 0.2, near_m: 0.05, far_m: 8.0}
      - {type: OdometryDelay, key: velocity, delay_s: [0.05, 0.15]}
      - {type: DynamicsRandomizer, uniform: {coulomb_v_fwd_n: [0.5, 1.5]}, scale: 0.5}
      - {type: DynamicsRandomizer, sysid: params.yaml, scale: 1.0, name: fitted}

Each entry's other keys are the wrapper's keyword arguments. A ``DynamicsRandomizer`` entry with
a ``sysid`` key (the path of a ``sim2real sysid fit`` result, relative to the config file) is
built with :meth:`DynamicsRandomizer.from_sysid` (its ``scale``, ``fields``, ``robot`` and
``name`` keys pass through); a ``LidarNoise`` entry with a ``sysid`` key (a ``sim2real sysid
sensors`` result) likewise with :meth:`LidarNoise.from_sysid` (a ``DepthNoise`` entry with
:meth:`DepthNoise.from_sysid`, from the result's ``depth`` section), and an ``OdometryDelay``
entry with one with :meth:`OdometryDelay.from_sysid` (the scan's identified latency). :func:`to_config` writes every
argument (including the current ``scale`` and ``name``), so ``from_config(env, to_config(w))``
rebuilds the same stack with the same random streams.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import yaml

from randomizers._base import iter_randomizers
from randomizers._camera import CameraPoseJitter
from randomizers._delay import ActionDelay, OdometryDelay
from randomizers._dynamics import DynamicsRandomizer
from randomizers._goal import GoalNoise
from randomizers._noise import DepthNoise, LidarNoise, ObservationNoise
from randomizers._odometry_noise import VelocityObservationNoise
from randomizers.errors import RandomizerConfigError, RandomizerError
from robots.files import output_problem, plain_data, write_text_atomic

__all__ = ["CONFIG_FORMAT", "RANDOMIZERS", "from_config", "save_config", "to_config"]

#: ``format:`` key of a randomizer config file.
CONFIG_FORMAT = "sim2real.randomizers/1"

#: Wrapper classes a config may name, by ``type``.
RANDOMIZERS: dict[str, type[gym.Wrapper[Any, Any, Any, Any]]] = {
    cls.__name__: cls
    for cls in (
        ActionDelay,
        CameraPoseJitter,
        DepthNoise,
        DynamicsRandomizer,
        GoalNoise,
        LidarNoise,
        ObservationNoise,
        OdometryDelay,
        VelocityObservationNoise,
    )
}


def _yaml_problem(exc: Exception) -> str:
    """Where and what a YAML/decoding error is, on one line (e.g. `` at line 2, column 3 (...)``)."""
    mark = getattr(exc, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
    what = getattr(exc, "problem", None) or str(exc)
    return f"{where} ({' '.join(str(what).split())})"


def _load(config: str | Path | Mapping[str, Any]) -> tuple[str, Mapping[str, Any], Path | None]:
    if isinstance(config, Mapping):
        return "config", config, None
    path = Path(config)
    if not path.is_file():
        raise RandomizerConfigError(
            f"randomizer config '{path}' does not exist; give the path of a YAML file written "
            "by randomizers.save_config or by hand (see randomizers.from_config)"
        )
    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise RandomizerConfigError(
            f"randomizer config '{path}' is not valid YAML{_yaml_problem(exc)}; fix the syntax "
            "there, or write the file again with randomizers.save_config"
        ) from None
    if not isinstance(doc, Mapping):
        raise RandomizerConfigError(
            f"randomizer config '{path}' must be a mapping with 'format' and 'randomizers', got "
            f"{type(doc).__name__}"
        )
    return f"randomizer config '{path}'", doc, path.parent


def from_config(
    env: gym.Env[Any, Any],
    config: str | Path | Mapping[str, Any],
    *,
    base_dir: str | Path | None = None,
) -> Any:
    """Wrap ``env`` in the randomizers a YAML file (or an equivalent dict) lists.

    Relative ``sysid`` paths are taken relative to the config file's folder, or to ``base_dir``
    (default: the working directory) when ``config`` is a dict.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import randomizers
    >>> cfg = {"format": "sim2real.randomizers/1", "randomizers": [
    ...     {"type": "ObservationNoise", "std": 0.01},
    ...     {"type": "ActionDelay", "delay_steps": 1}]}
    >>> env = randomizers.from_config(gym.make("CartPole-v1"), cfg)
    >>> [r.name for r in randomizers.iter_randomizers(env)]
    ['ActionDelay', 'ObservationNoise']
    """
    where, doc, folder = _load(config)
    if folder is None and base_dir is not None:
        folder = Path(base_dir)
    fmt = doc.get("format", CONFIG_FORMAT)
    if fmt != CONFIG_FORMAT:
        raise RandomizerConfigError(f"{where}: key 'format' must be '{CONFIG_FORMAT}', got {fmt!r}")
    entries = doc.get("randomizers")
    if not isinstance(entries, list):
        raise RandomizerConfigError(
            f"{where}: key 'randomizers' must be a list of {{type: ..., <arguments>}}, got "
            f"{entries!r}"
        )
    wrapped: Any = env
    for i, entry in enumerate(entries):
        if not isinstance(entry, Mapping) or "type" not in entry:
            raise RandomizerConfigError(
                f"{where}: randomizers[{i}] must be a mapping with a 'type' key, got {entry!r}"
            )
        kind = entry["type"]
        cls = RANDOMIZERS.get(kind)
        if cls is None:
            raise RandomizerConfigError(
                f"{where}: randomizers[{i}] has unknown type {kind!r}; known types are "
                f"{sorted(RANDOMIZERS)}"
            )
        kwargs = {k: v for k, v in entry.items() if k != "type"}
        try:
            from_file = cls is DynamicsRandomizer or kwargs.get("sysid") is not None
            from_sysid = (DynamicsRandomizer, LidarNoise, DepthNoise, OdometryDelay)
            if "sysid" in kwargs and cls in from_sysid and from_file:
                wrapped = _from_sysid(cls, wrapped, kwargs, folder)
            else:
                wrapped = cls(wrapped, **kwargs)
        except RandomizerError as exc:
            raise type(exc)(f"{where}: randomizers[{i}] ({kind}): {exc}") from None
        except TypeError as exc:  # unknown or missing keyword
            raise RandomizerConfigError(f"{where}: randomizers[{i}] ({kind}): {exc}") from None
    return wrapped


def _from_sysid(cls: Any, env: Any, kwargs: dict[str, Any], folder: Path | None) -> Any:
    """A randomizer built from the sysid result named by ``kwargs['sysid']``."""
    rest = dict(kwargs)
    sysid = rest.pop("sysid")
    if not isinstance(sysid, str | Path):
        raise RandomizerConfigError(
            f"key 'sysid' must be the path of a sysid result file, got {sysid!r}"
        )
    path = Path(sysid)
    if not path.is_absolute() and folder is not None:
        path = folder / path
    if not path.is_file():
        raise RandomizerConfigError(
            f"key 'sysid' names '{path}', which does not exist; give the path of a "
            "'sim2real sysid fit' (or, for LidarNoise, 'sysid sensors') result, relative to "
            "the config file"
        )
    return cls.from_sysid(path, env=env, **rest)


def to_config(env: Any) -> dict[str, Any]:
    """Describe the randomizers of a stack (innermost first) as a YAML-ready dict.

    Examples
    --------
    >>> import gymnasium as gym
    >>> from randomizers import ActionDelay
    >>> to_config(ActionDelay(gym.make("CartPole-v1"), delay_steps=2))["randomizers"][0]["type"]
    'ActionDelay'
    """
    entries = []
    for randomizer in reversed(list(iter_randomizers(env))):
        entries.append({"type": type(randomizer).__name__, **plain_data(randomizer._saved_kwargs)})
    return {"format": CONFIG_FORMAT, "randomizers": entries}


def save_config(env: Any, path: str | Path) -> Path:
    """Write :func:`to_config` of ``env`` to ``path`` atomically (:mod:`robots.files`)."""
    problem = output_problem(path, what="randomizer config")
    if problem is not None:
        raise RandomizerConfigError(problem)
    return write_text_atomic(path, yaml.safe_dump(to_config(env), sort_keys=False))
