"""Observation and action delays, fixed or drawn per episode, in seconds or control steps.

A delay of ``k`` steps means the value the agent sees (``OdometryDelay``) or the env applies
(``ActionDelay``) at step ``t`` is the one of step ``t - k`` (the reset observation is step 0).

Seconds are converted with the control period ``dt`` (``env.unwrapped.control_dt``, or the
``dt_s`` argument) by rounding to the nearest step, halves rounded up:
``k = floor(c * delay_s / dt + 0.5)`` (a 1e-9 guard absorbs float error, so 0.3 s at 0.1 s is
3 steps). The curriculum scale c multiplies the delay before rounding. A ``[low, high]`` delay
is drawn per episode: uniform in seconds, or uniform over the integers ``low..high`` in steps.
"""

from __future__ import annotations

import functools
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium.wrappers.utils import create_zero_array

from randomizers._base import Randomizer, check_choice, check_name, check_number, check_scale
from randomizers._lidar_sysid import scan_latency_s
from randomizers._observation import ObservationRandomizer
from randomizers._select import select
from randomizers.errors import MissingProtocolError, RandomizerTypeError, RandomizerValueError

__all__ = ["ActionDelay", "OdometryDelay", "steps_from_seconds"]

_FILL = ("first", "zeros")
#: Longest delay a wrapper accepts, in control steps: longer than any episode that can run
#: (its buffer would hold a million observations before the first real one shows).
MAX_DELAY_STEPS = 1_000_000


def steps_from_seconds(delay_s: float, dt_s: float) -> int:
    """Round a delay in seconds to whole control steps (nearest, halves up).

    Examples
    --------
    >>> steps_from_seconds(0.3, 0.1), steps_from_seconds(0.25, 0.1), steps_from_seconds(0.049, 0.1)
    (3, 3, 0)
    """
    return math.floor(delay_s / dt_s + 0.5 + 1e-9)


@dataclass(frozen=True, kw_only=True)
class _DelaySpec:
    """Validated delay arguments: bounds in seconds or steps, and the control period."""

    low: float
    high: float
    in_seconds: bool
    dt_s: float | None

    def draw(self, rng: np.random.Generator, scale: float) -> int:
        """The episode's delay in steps (a draw only when low < high)."""
        if self.in_seconds:
            assert self.dt_s is not None
            value = self.low if self.low == self.high else float(rng.uniform(self.low, self.high))
            return steps_from_seconds(scale * value, self.dt_s)
        low, high = int(self.low), int(self.high)
        steps = low if low == high else int(rng.integers(low, high + 1))
        return math.floor(scale * steps + 0.5 + 1e-9)


def _bounds(value: Any, argument: str, *, integer: bool) -> tuple[float, float]:
    if isinstance(value, Sequence) and not isinstance(value, str):
        if len(value) != 2:
            raise RandomizerValueError(
                f"argument '{argument}' must be a number or [low, high], got {value!r}"
            )
        low, high = (_one(v, argument, integer=integer) for v in value)
    else:
        low = high = _one(value, argument, integer=integer)
    if low > high:
        raise RandomizerValueError(
            f"argument '{argument}' must have low <= high, got {value!r}; swap the bounds"
        )
    return low, high


def _one(value: Any, argument: str, *, integer: bool) -> float:
    if integer and not (isinstance(value, int | np.integer) and not isinstance(value, bool)):
        raise RandomizerTypeError(
            f"argument '{argument}' must be a whole number of steps, got {value!r}; pass an "
            "int (or use delay_s for seconds)"
        )
    number = check_number(value, argument=argument)
    if number < 0:
        raise RandomizerValueError(
            f"argument '{argument}' must be >= 0, got {value!r}; a delay cannot be negative"
        )
    return number


def _delay_spec(
    env: gym.Env[Any, Any], delay_s: Any, delay_steps: Any, dt_s: Any, wrapper: str
) -> _DelaySpec:
    if (delay_s is None) == (delay_steps is None):
        raise RandomizerValueError(
            f"{wrapper}: give exactly one of 'delay_s' (seconds) and 'delay_steps' (control "
            f"steps), got delay_s={delay_s!r}, delay_steps={delay_steps!r}"
        )
    if delay_steps is not None:
        low, high = _bounds(delay_steps, "delay_steps", integer=True)
        known = dt_s if dt_s is not None else getattr(env.unwrapped, "control_dt", None)
        period = _period(known) if known is not None else None  # only to report seconds
        _check_length(high, delay_steps, "delay_steps", wrapper, "")
        return _DelaySpec(low=low, high=high, in_seconds=False, dt_s=period)
    low, high = _bounds(delay_s, "delay_s", integer=False)
    if dt_s is None:
        dt_s = getattr(env.unwrapped, "control_dt", None)
        if dt_s is None:
            raise MissingProtocolError(
                f"{wrapper}: delay_s needs the control period, but "
                f"{type(env.unwrapped).__name__} has no 'control_dt' attribute; pass dt_s=... "
                "(seconds per step) or give the delay in steps with delay_steps"
            )
    period = _period(dt_s)
    steps = high / period
    _check_length(steps, delay_s, "delay_s", wrapper, f" ({steps:.3g} steps of {period:g} s)")
    return _DelaySpec(low=low, high=high, in_seconds=True, dt_s=period)


def _check_length(steps: float, value: Any, argument: str, wrapper: str, detail: str) -> None:
    """Refuse a delay longer than :data:`MAX_DELAY_STEPS`, before any buffer is allocated."""
    if steps > MAX_DELAY_STEPS:
        raise RandomizerValueError(
            f"{wrapper}: argument '{argument}' = {value!r}{detail} exceeds {MAX_DELAY_STEPS} "
            "control steps, longer than any episode can run; give the delay of the real "
            "system (e.g. delay_s=0.1)"
        )


def _period(dt_s: Any) -> float:
    dt = check_number(dt_s, argument="dt_s")
    if dt <= 0:
        raise RandomizerValueError(f"argument 'dt_s' must be > 0 s, got {dt_s!r}")
    return dt


def _delay_kwargs(spec: _DelaySpec, delay_s: Any, delay_steps: Any) -> dict[str, Any]:
    """The delay arguments as YAML-friendly values (lists for ranges)."""

    def norm(value: Any, cast: type) -> Any:
        if value is None:
            return None
        if isinstance(value, Sequence) and not isinstance(value, str):
            return [cast(v) for v in value]
        return cast(value)

    return {"delay_s": norm(delay_s, float), "delay_steps": norm(delay_steps, int)}


class OdometryDelay(ObservationRandomizer):
    """Delay the velocity (odometry) observation by a fixed or per-episode random delay.

    Liang et al. (2020) increase the delay with which the policy subscribes to the robot's current
    velocity. At step ``t`` the selected entry shows its value of step ``t - k``. Before ``k``
    steps have passed it holds the episode's first value (``fill="first"``, default) or shows
    zeros (``fill="zeros"``); the rest of the observation is not delayed. See the module
    docstring for seconds-to-steps rounding.

    Parameters
    ----------
    env : gymnasium.Env
        Env with a Box entry (any dtype) to delay.
    delay_s : float or [low, high], optional
        Delay in seconds (a range: uniform per episode). Needs ``dt_s`` or
        ``env.unwrapped.control_dt``.
    delay_steps : int or [low, high], optional
        Delay in control steps (a range: uniform integer per episode).
    key : str, optional
        Dict key of the velocity entry (required for Dict spaces).
    index : int, slice or [start, stop], optional
        Range of the last axis to delay (e.g. CartPole's velocities ``[1, 2]``).
    fill : {"first", "zeros"}
        What to show before the buffer fills.
    dt_s : float, optional
        Control period in seconds (default: ``env.unwrapped.control_dt``).
    scale : float
        Curriculum scale c in [0, 1] multiplying the delay.
    name : str, optional
        Unique name in the stack; default ``OdometryDelay[<key>]``.

    Examples
    --------
    >>> import gymnasium as gym
    >>> from randomizers import OdometryDelay
    >>> env = OdometryDelay(gym.make("CartPole-v1"), delay_steps=2, index=[1, 2])
    >>> obs0, info = env.reset(seed=0)
    >>> info["randomization"]["OdometryDelay[1:2]"]["delay_steps"]
    2
    >>> obs1 = env.step(0)[0]
    >>> bool(obs1[1] == obs0[1])
    True
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        *,
        delay_s: float | Sequence[float] | None = None,
        delay_steps: int | Sequence[int] | None = None,
        key: str | None = None,
        index: Any = None,
        fill: str = "first",
        dt_s: float | None = None,
        scale: float = 1.0,
        name: str | None = None,
    ) -> None:
        sel = select(
            env.observation_space, key=key, index=index, wrapper="OdometryDelay", float_only=False
        )
        spec = _delay_spec(env, delay_s, delay_steps, dt_s, "OdometryDelay")
        fill = check_choice(fill, argument="fill", choices=_FILL)
        self._wrap_selection(
            env,
            sel,
            scale=scale,
            name=name,
            **_delay_kwargs(spec, delay_s, delay_steps),
            options={"fill": fill, "dt_s": None if dt_s is None else float(dt_s)},
            dtype=np.float64,
        )
        self._spec = spec
        self.fill = fill
        self.delay_steps = 0
        self._queue: deque[np.ndarray] = deque()

    @classmethod
    def from_sysid(
        cls, path: str | Path, *, env: gym.Env[Any, Any] | None = None, **kwargs: Any
    ) -> Any:
        """Delay an entry (e.g. the scan, ``key="scan"``) by the latency a ``sim2real sysid
        sensors`` result identified: ``delay_s`` uniform over its interval per episode.

        Other keyword arguments (``key``, ``index``, ``fill``, ``dt_s``, ``scale``, ``name``)
        pass through. Without ``env`` it returns a picklable ``env -> wrapper`` callable.

        Examples
        --------
        >>> make = OdometryDelay.from_sysid("sensors.yaml", key="scan")  # doctest: +SKIP
        """
        low, high = scan_latency_s(path)
        factory: Any = functools.partial(cls, delay_s=[low, high], **kwargs)
        return factory if env is None else factory(env)

    def sample_episode(self) -> None:
        """Draw the episode's delay in steps."""
        self.delay_steps = self._spec.draw(self.rng, self.scale)

    def start_episode(self, observation: Any) -> None:
        """Fill the buffer with the first value (or zeros)."""
        first = np.array(self._sel.get(observation), copy=True)
        pad = first if self.fill == "first" else np.zeros_like(first)
        # one copy per slot: the observations handed out must never share an array
        self._queue = deque(pad.copy() for _ in range(self.delay_steps))

    def observation(self, observation: Any) -> Any:
        """Return ``observation`` with the selected entry ``delay_steps`` steps old."""
        if self.delay_steps == 0:
            return observation
        self._queue.append(np.array(self._sel.get(observation), copy=True))
        return self._sel.put(observation, self._queue.popleft())

    def episode_record(self) -> dict[str, Any]:
        """The episode's delay in steps (and seconds when the control period is known)."""
        record: dict[str, Any] = {"delay_steps": self.delay_steps, "scale": self.scale}
        if self._spec.dt_s is not None:
            record["delay_s"] = self.delay_steps * self._spec.dt_s
        return record


class ActionDelay(gym.ActionWrapper[Any, Any, Any], Randomizer, gym.utils.RecordConstructorArgs):
    """Apply each action ``k`` control steps after the agent chose it (actuation latency).

    Before ``k`` actions have been queued in an episode the env receives the episode's first
    action (``fill="first"``, default) or the zero action of the action space
    (``fill="zeros"``; for ``Discrete`` that is ``space.start``). See the module docstring for
    seconds-to-steps rounding and per-episode ranges.

    Parameters
    ----------
    env : gymnasium.Env
        Any env.
    delay_s, delay_steps, dt_s, scale, name
        As for :class:`OdometryDelay`.
    fill : {"first", "zeros"}
        What the env receives before the queue fills.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> from randomizers import ActionDelay
    >>> env = ActionDelay(gym.make("Pendulum-v1"), delay_steps=1, fill="zeros")
    >>> _ = env.reset(seed=0)
    >>> env.action(np.array([1.5], np.float32)), env.action(np.array([-1.0], np.float32))
    (array([0.], dtype=float32), array([1.5], dtype=float32))
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        *,
        delay_s: float | Sequence[float] | None = None,
        delay_steps: int | Sequence[int] | None = None,
        fill: str = "first",
        dt_s: float | None = None,
        scale: float = 1.0,
        name: str | None = None,
    ) -> None:
        spec = _delay_spec(env, delay_s, delay_steps, dt_s, "ActionDelay")
        fill = check_choice(fill, argument="fill", choices=_FILL)
        scale = check_scale(scale)
        name = check_name(name, env, "ActionDelay")
        self._wrap(
            env,
            **_delay_kwargs(spec, delay_s, delay_steps),
            fill=fill,
            dt_s=None if dt_s is None else float(dt_s),
            scale=scale,
            name=name,
        )
        self._spec = spec
        self.fill = fill
        self.delay_steps = 0
        self._queue: deque[Any] = deque()
        self._filled = False

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the env, empty the action queue and draw the episode's delay."""
        self._begin_episode(seed)
        self.delay_steps = self._spec.draw(self.rng, self.scale)
        self._queue = deque()
        self._filled = False
        obs, info = self.env.reset(seed=seed, options=options)
        record: dict[str, Any] = {"delay_steps": self.delay_steps, "scale": self.scale}
        if self._spec.dt_s is not None:
            record["delay_s"] = self.delay_steps * self._spec.dt_s
        return obs, self._record(info, record)

    def action(self, action: Any) -> Any:
        """Queue ``action`` and return the one chosen ``delay_steps`` steps ago."""
        if self.delay_steps == 0:
            return action
        action = _copy(action)
        if not self._filled:
            pad = action if self.fill == "first" else create_zero_array(self.action_space)
            self._queue.extend(_copy(pad) for _ in range(self.delay_steps))
            self._filled = True
        self._queue.append(action)
        return self._queue.popleft()

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the env with the delayed action."""
        return self.env.step(self.action(action))


def _copy(action: Any) -> Any:
    if isinstance(action, np.ndarray):
        return action.copy()
    return action
