"""The foreign differential-drive plant driven command by command, as a world for a policy.

:func:`~sim2real.plants.diff_drive.run_plant` simulates a whole session from a command list
known in advance. A policy decides each command from what it sensed, so the envs drive the
same plant one control period at a time (:class:`PlantStepper`): each command is published at
the session clock, reaches the firmware after its own latency and is integrated by the same
kernel with the same physics; the base's odometry (quantised encoders, gyro or wheel w) is
what the robot reports. :class:`PlantSessions` says where a session's plant comes from: one
fixed :class:`~sim2real.plants.diff_drive.PlantParams`, or a base with a per-session draw of
payload, floor friction, battery charge and latency
(:class:`~sim2real.plants.diff_drive.SessionVariation`).

Examples
--------
>>> import numpy as np
>>> from sim2real.plants.closed_loop import PlantSessions, PlantStepper
>>> sessions = PlantSessions.of("turtlebot3_burger")
>>> stepper = PlantStepper(sessions.draw(np.random.default_rng(0)), np.random.default_rng(1))
>>> for _ in range(30):
...     t, v, w = stepper.step(0.2, 0.0, 0.1)
>>> round(float(v[-1]), 2), round(stepper.time_s, 6)
(0.2, 3.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sim2real.errors import Sim2RealValueError
from sim2real.plants.diff_drive import (
    FloatArray,
    PlantParams,
    SessionVariation,
    _fresh_state,
    _kernel,
    _pack,
    draw_session,
    plant_from_spec,
)

__all__ = ["PlantSessions", "PlantStepper", "as_plant_sessions"]


@dataclass(frozen=True, kw_only=True)
class PlantSessions:
    """Where each session's plant comes from.

    Attributes
    ----------
    base : PlantParams
        The base (a robot's plant, :func:`~sim2real.plants.diff_drive.plant_from_spec`).
    variation : SessionVariation or None
        Ranges of the per-session draw (:func:`~sim2real.plants.diff_drive.draw_session`);
        ``None``: every session is ``base`` itself.

    Examples
    --------
    >>> import numpy as np
    >>> s = PlantSessions.of("turtlebot2", variation=None)
    >>> s.robot, s.draw(np.random.default_rng(0)) == s.base
    ('turtlebot2', True)
    """

    base: PlantParams
    variation: SessionVariation | None = field(default_factory=SessionVariation)

    def __post_init__(self) -> None:
        if not isinstance(self.base, PlantParams):
            raise Sim2RealValueError(
                f"PlantSessions.base must be a PlantParams, got {type(self.base).__name__}; "
                "build one with sim2real.plants.diff_drive.plant_from_spec(robot)"
            )
        if self.variation is not None and not isinstance(self.variation, SessionVariation):
            raise Sim2RealValueError(
                "PlantSessions.variation must be a SessionVariation or None (a fixed session), "
                f"got {type(self.variation).__name__}"
            )

    @classmethod
    def of(
        cls,
        robot: str,
        *,
        variation: SessionVariation | None = SessionVariation(),  # noqa: B008
        **changes: Any,
    ) -> PlantSessions:
        """Sessions of ``robot``'s plant (``changes`` go to :func:`plant_from_spec`)."""
        return cls(base=plant_from_spec(robot, **changes), variation=variation)

    @property
    def robot(self) -> str:
        """Name of the robot spec the plant comes from."""
        return self.base.robot

    def draw(self, rng: np.random.Generator) -> PlantParams:
        """One session's plant, drawn from ``rng`` (no draw for a fixed session)."""
        if self.variation is None:
            return self.base
        return draw_session(self.base, rng, self.variation)


def as_plant_sessions(value: Any, robot: str) -> PlantSessions:
    """``value`` (``None``, a :class:`PlantParams` or :class:`PlantSessions`) for ``robot``.

    ``None`` is the robot's plant with the default session variation; a :class:`PlantParams`
    is one fixed session. A plant of another robot is refused in one sentence.
    """
    if value is None:
        return PlantSessions.of(robot)
    if isinstance(value, PlantParams):
        value = PlantSessions(base=value, variation=None)
    if not isinstance(value, PlantSessions):
        raise Sim2RealValueError(
            "plant_sessions must be a sim2real.plants.PlantSessions or PlantParams, got "
            f"{type(value).__name__}; build one with PlantSessions.of(robot)"
        )
    if value.robot != robot:
        raise Sim2RealValueError(
            f"plant_sessions are sessions of robot '{value.robot}' but the env drives "
            f"'{robot}'; build them with PlantSessions.of('{robot}')"
        )
    return value


class _Buffer:
    """A growing float array (the session's commands as they arrive)."""

    def __init__(self) -> None:
        self.data = np.zeros(64)
        self.n = 0

    def append(self, x: float) -> None:
        if self.n == self.data.size:
            self.data = np.concatenate([self.data, np.zeros(self.data.size)])
        self.data[self.n] = x
        self.n += 1

    @property
    def view(self) -> FloatArray:
        return self.data[: self.n]


class PlantStepper:
    """One plant session driven one command at a time (closed loop).

    Each :meth:`step` publishes a command at the session clock, draws its latency (mean plus
    jitter, at least 2 ms, arrival order kept: :func:`~sim2real.plants.diff_drive.run_plant`'s
    transport) and integrates the plant for the step. The odometry is read at the plant's
    own rate and phase: v from the quantised encoder counts over one period, w from the gyro
    (white noise and bias) or the encoders, as the plant's ``w_source`` says.

    Parameters
    ----------
    params : PlantParams
        The session's plant.
    rng : numpy.random.Generator
        Draws the odometry clock's phase (at construction and at each :meth:`reset`), then per
        step the command's latency and per odometry sample the gyro noise.
    substep_s : float
        Spacing of the true body velocities :meth:`step` returns, s.
    """

    def __init__(
        self, params: PlantParams, rng: np.random.Generator, *, substep_s: float = 0.01
    ) -> None:
        if not isinstance(params, PlantParams):
            raise Sim2RealValueError(
                f"PlantStepper needs a PlantParams, got {type(params).__name__}"
            )
        if not (math.isfinite(substep_s) and substep_s > 0):
            raise Sim2RealValueError(f"substep_s must be a finite number > 0, got {substep_s}")
        self.params = params
        self._rng = rng
        self._packed = _pack(params)
        self._substep_s = float(substep_s)
        self._period = 1.0 / params.odom_rate_hz
        self._tick_rad = 2.0 * math.pi / params.ticks_per_rev
        self.reset()

    def reset(self) -> None:
        """A new session at rest at t = 0, no command sent; the odometry clock's phase drawn."""
        self._state = _fresh_state()
        self._time = 0.0
        self._arr_t, self._arr_v, self._arr_w = _Buffer(), _Buffer(), _Buffer()
        self._next_tick = float(self._rng.uniform(0.0, self._period))
        self._counts = (0, 0)
        self._odom = (0.0, 0.0)
        self._true = (0.0, 0.0)

    @property
    def time_s(self) -> float:
        """Session clock, s."""
        return self._time

    @property
    def true_velocity(self) -> tuple[float, float]:
        """The base's body velocity (v [m/s], w [rad/s]) at the session clock."""
        return self._true

    @property
    def odometry(self) -> tuple[float, float]:
        """The latest odometry reading (v [m/s], w [rad/s]); zeros before the first."""
        return self._odom

    def step(
        self, cmd_v: float, cmd_w: float, duration_s: float
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Publish ``(cmd_v, cmd_w)`` now and run the plant for ``duration_s`` seconds.

        Returns
        -------
        t_s, v, w : ndarray
            The session clock and the true body velocity at the ends of equal sub-steps of at
            most ``substep_s`` (the last at the step's end).
        """
        if not (math.isfinite(cmd_v) and math.isfinite(cmd_w)):
            raise Sim2RealValueError(f"the command must be finite, got ({cmd_v}, {cmd_w})")
        if not (math.isfinite(duration_s) and duration_s > 0):
            raise Sim2RealValueError(f"duration_s must be a finite number > 0, got {duration_s}")
        p = self.params
        t0 = self._time
        latency = max(p.latency_s + p.latency_jitter_s * float(self._rng.standard_normal()), 0.002)
        last = self._arr_t.view[-1] if self._arr_t.n else -math.inf
        self._arr_t.append(max(t0 + latency, last))
        self._arr_v.append(float(cmd_v))
        self._arr_w.append(float(cmd_w))
        n_sub = max(1, math.ceil(duration_s / self._substep_s - 1e-9))
        t_sub = t0 + duration_s * np.arange(1, n_sub + 1) / n_sub
        t_end = float(t_sub[-1])
        n_tick = max(0, math.floor((t_end - self._next_tick) / self._period) + 1)
        t_tick = self._next_tick + self._period * np.arange(n_tick)
        out_t = np.concatenate([t_sub, t_tick])
        order = np.argsort(out_t, kind="stable")
        out = np.zeros((out_t.size, 4))
        _kernel(
            self._packed,
            self._arr_t.view,
            self._arr_v.view,
            self._arr_w.view,
            out_t[order],
            p.physics_dt_s,
            1.0 / p.control_rate_hz,
            out,
            self._state,
        )
        samples = np.empty_like(out)
        samples[order] = out
        self._read_odometry(samples[n_sub:])
        self._next_tick += self._period * n_tick
        self._time = t_end
        v, w = samples[:n_sub, 0], samples[:n_sub, 1]
        self._true = (float(v[-1]), float(w[-1]))
        return t_sub, v, w

    def _read_odometry(self, ticks: FloatArray) -> None:
        """The odometry messages at the plant's ticks (rows of v, w, angle L, angle R)."""
        p = self.params
        for _, w_true, ang_l, ang_r in ticks:
            counts = (math.floor(ang_l / self._tick_rad), math.floor(ang_r / self._tick_rad))
            d_l = (counts[0] - self._counts[0]) * self._tick_rad * p.wheel_radius_m
            d_r = (counts[1] - self._counts[1]) * self._tick_rad * p.wheel_radius_m
            self._counts = counts
            v = 0.5 * (d_l + d_r) / self._period
            if p.w_source == "imu":
                noise = p.gyro_noise_radps * float(self._rng.standard_normal())
                w = w_true + p.gyro_bias_radps + noise
            else:
                w = (d_r - d_l) / p.wheel_separation_m / self._period
            self._odom = (float(v), float(w))
