"""Raise the randomisation scale when the agent succeeds often enough (the curriculum of
Liang et al. 2020)."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

from randomizers._base import check_scale, set_scale
from randomizers.errors import RandomizerTypeError, RandomizerValueError

__all__ = ["CurriculumUpdate", "SuccessRateCurriculum"]


@dataclass(frozen=True, kw_only=True)
class CurriculumUpdate:
    """What :meth:`SuccessRateCurriculum.record` did.

    Attributes
    ----------
    scale : float
        Scale in effect from the next reset on.
    success_rate : float or None
        Success rate over the full window, or None while the window is filling.
    raised : bool
        True when this episode raised the scale.
    """

    scale: float
    success_rate: float | None
    raised: bool


class SuccessRateCurriculum:
    r"""Raise the scale of every randomizer in a stack when the success rate crosses a threshold.

    Liang et al. (2020) start training in simple scenarios and raises a complexity factor c as the policy
    converges. Here c is the randomizers' ``scale``: it starts at ``initial_scale``; after each
    episode call :meth:`record` with whether it succeeded. Once ``window`` episodes have been
    recorded at the current scale and their success rate is ``>= threshold``, the scale rises by
    ``increment`` (capped at 1) and the window starts again. New scales apply from each
    randomizer's next reset.

    Parameters
    ----------
    env : gymnasium.Env or gymnasium.vector.VectorEnv
        The wrapped env (vector envs are reached through ``call``).
    threshold : float
        Success rate in [0, 1] that triggers a raise.
    window : int
        Number of episodes the rate is computed over (>= 1).
    increment : float
        Step added to the scale, in (0, 1].
    initial_scale : float
        Scale set on construction, in [0, 1].

    Examples
    --------
    >>> import gymnasium as gym
    >>> from randomizers import ObservationNoise, SuccessRateCurriculum
    >>> env = ObservationNoise(gym.make("CartPole-v1"), std=0.05)
    >>> cur = SuccessRateCurriculum(env, threshold=0.5, window=2, increment=0.25)
    >>> cur.record(True).scale, cur.record(True).scale
    (0.0, 0.25)
    """

    def __init__(
        self,
        env: Any,
        *,
        threshold: float = 0.8,
        window: int = 100,
        increment: float = 0.1,
        initial_scale: float = 0.0,
    ) -> None:
        self.threshold = check_scale(threshold, argument="threshold")
        if isinstance(window, bool) or not isinstance(window, int):
            raise RandomizerTypeError(f"argument 'window' must be an int, got {window!r}")
        if window < 1:
            raise RandomizerValueError(f"argument 'window' must be >= 1 episode, got {window!r}")
        self.increment = check_scale(increment, argument="increment")
        if self.increment == 0.0:
            raise RandomizerValueError("argument 'increment' must be > 0, got 0; pass e.g. 0.1")
        self.window = window
        self.env = env
        self._outcomes: deque[bool] = deque(maxlen=window)
        self.scale = check_scale(initial_scale, argument="initial_scale")
        if set_scale(env, self.scale) == 0:
            raise RandomizerValueError(
                "SuccessRateCurriculum: the env has no randomizer wrappers to drive; wrap it "
                "first (e.g. randomizers.from_config)"
            )

    @property
    def success_rate(self) -> float | None:
        """Success rate over the current window, or None until it is full."""
        if len(self._outcomes) < self.window:
            return None
        return sum(self._outcomes) / self.window

    def record(self, success: bool) -> CurriculumUpdate:
        """Add one finished episode; raise the scale when the window's rate is high enough."""
        self._outcomes.append(bool(success))
        rate = self.success_rate
        raised = rate is not None and rate >= self.threshold and self.scale < 1.0
        if raised:
            self.scale = min(1.0, self.scale + self.increment)
            set_scale(self.env, self.scale)
            self._outcomes.clear()
        return CurriculumUpdate(scale=self.scale, success_rate=rate, raised=raised)
