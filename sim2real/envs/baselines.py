r"""A non-learned reference controller: the dynamic-window approach (DWA) on the lidar scan.

Fox, Burgard and Thrun, "The dynamic window approach to collision avoidance", IEEE Robotics &
Automation Magazine 4(1), 1997. Each control step the controller samples (v, w) pairs in the
window reachable within one step from the measured velocity, rolls each out as a circular arc
over ``horizon_s``, drops the arcs that bring the robot's footprint within ``margin_m`` of a
lidar point, and picks the arc with the best score

.. math::

    G(v, w) = a\,\mathrm{heading} + b\,\min(\mathrm{clearance}, c_{cap}) / c_{cap}
              + c\,v / v_{max} + d\,\mathrm{progress}

(heading: 1 - |goal bearing at the arc's end| / pi; progress: goal-distance decrease over the
arc divided by :math:`v_{max}` times the horizon). When no arc is admissible it turns in
place towards the side with more free range. It only sees what the lidar sees (CrowdNav's
TurtleBot 2 lidar covers +-30 degrees) and treats pedestrians as static, which is what makes
it a baseline.

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs
>>> from sim2real.envs.baselines import DWAController
>>> env = gym.make("sim2real/RandomMap-v0", preset="TEST1")
>>> ctrl = DWAController.for_env(env)
>>> obs, _ = env.reset(seed=0)
>>> action = ctrl.act(obs)
>>> env.action_space.contains(action)
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from sim2real.envs.geometry import FloatArray

__all__ = ["Controller", "DWAConfig", "DWAController", "EvalSummary", "evaluate"]

_MAX_POINTS = 80


@dataclass(frozen=True, kw_only=True)
class DWAConfig:
    """Tuning of :class:`DWAController` (units in the names).

    Attributes
    ----------
    v_samples, w_samples : int
        Grid of (v, w) samples in the dynamic window.
    horizon_s : float
        Roll-out time of each arc, s.
    accel_v_mps2, accel_w_radps2 : float
        Accelerations that bound the dynamic window (capped by the robot's limits).
    margin_m : float
        Minimum admissible clearance between footprint and lidar points, m.
    clearance_cap_m : float
        Clearance above which more is not better, m.
    heading, clearance, velocity, progress : float
        Score weights a, b, c, d.
    """

    v_samples: int = 7
    w_samples: int = 15
    horizon_s: float = 2.0
    accel_v_mps2: float = 1.0
    accel_w_radps2: float = 4.0
    margin_m: float = 0.05
    clearance_cap_m: float = 0.6
    heading: float = 0.6
    clearance: float = 0.8
    velocity: float = 0.3
    progress: float = 1.0


class DWAController:
    """Dynamic-window controller for :class:`RandomMapEnv` and :class:`CrowdNavEnv`.

    Parameters
    ----------
    beam_angles_rad : ndarray
        Lidar beam angles in the lidar frame (parallel to the base), rad.
    lidar_xy_m : tuple
        Lidar position in the base frame, m.
    range_max_m : float
        Readings at or beyond this are free space.
    robot_radius_m : float
        Footprint disc radius, m.
    action_low, action_high : ndarray
        Bounds of (v, w).
    control_dt : float
        Control period, s.
    config : DWAConfig, optional
        Tuning.
    """

    def __init__(
        self,
        *,
        beam_angles_rad: FloatArray,
        lidar_xy_m: tuple[float, float],
        range_max_m: float,
        robot_radius_m: float,
        action_low: FloatArray,
        action_high: FloatArray,
        control_dt: float,
        config: DWAConfig | None = None,
    ) -> None:
        self.config = config if config is not None else DWAConfig()
        self.beam_angles_rad = np.asarray(beam_angles_rad, dtype=np.float64)
        self.lidar_xy_m = np.asarray(lidar_xy_m, dtype=np.float64)
        self.range_max_m = float(range_max_m)
        self.robot_radius_m = float(robot_radius_m)
        self.low = np.asarray(action_low, dtype=np.float64)
        self.high = np.asarray(action_high, dtype=np.float64)
        self.control_dt = float(control_dt)
        self._last = np.zeros(2)
        self._turn = 0.0

    @classmethod
    def for_env(cls, env: Any, config: DWAConfig | None = None) -> DWAController:
        """A controller matched to ``env`` (a registered sim2real env, wrapped or not)."""
        base = env.unwrapped
        lid = base.robot_spec.lidar
        angles = getattr(base, "beam_angles_rad", None)
        if angles is None:
            angles = base.lidar_angles_rad
        return cls(
            beam_angles_rad=np.asarray(angles),
            lidar_xy_m=(lid.xyz_m[0], lid.xyz_m[1]),
            range_max_m=lid.range_max_m,
            robot_radius_m=base.robot_radius_m,
            action_low=base.action_space.low,
            action_high=base.action_space.high,
            control_dt=base.control_dt,
            config=config,
        )

    def reset(self) -> None:
        """Forget the previous command (call at episode start)."""
        self._last = np.zeros(2)
        self._turn = 0.0

    def act(self, obs: Any) -> FloatArray:
        """The (v, w) action for an observation of either env (float32, within the bounds)."""
        if isinstance(obs, dict):
            ranges = np.asarray(obs["lidar"], dtype=np.float64)
            goal_d, goal_b = (float(x) for x in obs["goal"])
            v, w = (float(x) for x in obs["velocity"])
        else:
            o = np.asarray(obs, dtype=np.float64)
            n = self.beam_angles_rad.shape[0]
            ranges = o[:n]
            goal_d, goal_b, v, w = (float(x) for x in o[n : n + 4])
        return self._plan(ranges, goal_d, goal_b, v, w).astype(np.float32)

    def _points(self, ranges: FloatArray) -> FloatArray:
        step = max(1, ranges.shape[0] // _MAX_POINTS)  # dense scans: every k-th beam
        ranges = np.where(np.arange(ranges.shape[0]) % step == 0, ranges, self.range_max_m)
        hit = ranges < self.range_max_m - 1e-6
        a, r = self.beam_angles_rad[hit], ranges[hit]
        return np.column_stack([r * np.cos(a), r * np.sin(a)]) + self.lidar_xy_m

    def _plan(
        self, ranges: FloatArray, goal_d: float, goal_b: float, v: float, w: float
    ) -> FloatArray:
        cfg = self.config
        dt = self.control_dt
        v_lo = max(self.low[0], v - cfg.accel_v_mps2 * dt)
        v_hi = min(self.high[0], v + cfg.accel_v_mps2 * dt)
        w_lo = max(self.low[1], w - cfg.accel_w_radps2 * dt)
        w_hi = min(self.high[1], w + cfg.accel_w_radps2 * dt)
        vs = np.linspace(v_lo, max(v_lo, v_hi), cfg.v_samples)
        ws = np.linspace(w_lo, max(w_lo, w_hi), cfg.w_samples)
        vv, ww = (a.reshape(-1) for a in np.meshgrid(vs, ws, indexing="ij"))
        t = np.linspace(dt, cfg.horizon_s, max(2, round(cfg.horizon_s / dt)))
        th = ww[:, None] * t[None, :]
        small = np.abs(ww) < 1e-6
        safe_w = np.where(small, 1.0, ww)
        x = np.where(small[:, None], vv[:, None] * t, vv[:, None] / safe_w[:, None] * np.sin(th))
        y = np.where(small[:, None], 0.0, vv[:, None] / safe_w[:, None] * (1.0 - np.cos(th)))
        pts = self._points(ranges)
        # a scan point farther from the robot than every trajectory reaches (an arc's chord is
        # at most |v| t) plus the clearance that scores or blocks is farther than that
        # clearance from every trajectory: min(clear, cap) and clear > margin are the same
        # without it, so it is left out of the distances (the nearest point of a trajectory
        # within that clearance is kept)
        reach_m = float(np.max(np.abs(vs))) * float(t[-1]) + self.robot_radius_m
        reach_m += max(cfg.clearance_cap_m, cfg.margin_m) + 1e-6
        pts = pts[pts[:, 0] ** 2 + pts[:, 1] ** 2 <= reach_m**2]
        if pts.shape[0]:
            d = np.hypot(x[..., None] - pts[:, 0], y[..., None] - pts[:, 1])
            clear = d.min(axis=(1, 2)) - self.robot_radius_m
        else:
            clear = np.full(vv.shape, np.inf)
        gx, gy = goal_d * math.cos(goal_b), goal_d * math.sin(goal_b)
        ex, ey, eth = x[:, -1], y[:, -1], th[:, -1]
        bearing = np.arctan2(gy - ey, gx - ex) - eth
        bearing = np.abs(np.arctan2(np.sin(bearing), np.cos(bearing)))
        progress = (goal_d - np.hypot(gx - ex, gy - ey)) / max(self.high[0] * cfg.horizon_s, 1e-9)
        score = (
            cfg.heading * (1.0 - bearing / math.pi)
            + cfg.clearance * np.minimum(clear, cfg.clearance_cap_m) / cfg.clearance_cap_m
            + cfg.velocity * vv / max(self.high[0], 1e-9)
            + cfg.progress * progress
        )
        moving = vv > 1e-6
        ok = moving & (clear > cfg.margin_m)
        if not ok.any():
            # stuck: turn in place, keeping one direction (towards the side with more free
            # range when the stall began) so that it does not dither left and right
            if self._turn == 0.0:
                side = np.sin(self.beam_angles_rad)
                left = float(ranges[side > 0].mean()) if (side > 0).any() else 0.0
                right = float(ranges[side < 0].mean()) if (side < 0).any() else 0.0
                self._turn = 1.0 if left >= right else -1.0
            turn = self.high[1] if self._turn > 0 else self.low[1]
            action = np.array([self.low[0], turn])
        else:
            self._turn = 0.0
            best = int(np.argmax(np.where(ok, score, -np.inf)))
            action = np.array([vv[best], ww[best]])
        self._last = np.clip(action, self.low, self.high)
        return self._last


@dataclass(frozen=True, kw_only=True)
class EvalSummary:
    """Aggregate of :func:`evaluate` over episodes.

    Attributes
    ----------
    episodes : int
        Episodes run.
    success_rate, collision_rate, timeout_rate : float
        Fractions of episodes per outcome.
    means : dict
        Mean of every numeric metric of :class:`~sim2real.envs.EpisodeMetrics` (time to goal
        over successful episodes only; NaN when there were none).
    per_episode : tuple of dict
        The metrics of each episode (plus ``"seed"`` and ``"return"``).
    overshoot_rate : float
        Fraction of episodes that left the goal without stopping in it (a task with a goal
        speed; see :data:`~sim2real.envs.metrics.OUTCOMES`).
    """

    episodes: int
    success_rate: float
    collision_rate: float
    timeout_rate: float
    means: dict[str, float]
    per_episode: tuple[dict[str, Any], ...]
    overshoot_rate: float = 0.0


_MEAN_KEYS = (
    "path_length_m",
    "time_to_goal_s",
    "episode_time_s",
    "mean_abs_dv_mps",
    "mean_abs_dw_radps",
    "mean_abs_jerk_v_mps3",
    "mean_abs_jerk_w_radps3",
    "return",
)


class Controller(Protocol):
    """What :func:`evaluate` drives: :class:`DWAController`, a trained policy's controller."""

    def reset(self) -> None:
        """Start an episode."""

    def act(self, obs: Any) -> Any:
        """The action for observation ``obs``."""


def evaluate(
    env: Any,
    controller: Controller,
    *,
    episodes: int,
    seed: int = 0,
    options: dict[str, Any] | None = None,
    on_episode: Any = None,
) -> EvalSummary:
    """Run ``controller`` for ``episodes`` episodes (seeds ``seed``, ``seed + 1``, ...).

    ``on_episode(i, metrics)`` is called after each episode (e.g. to advance a progress bar).
    """
    rows: list[dict[str, Any]] = []
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i, options=options)
        controller.reset()
        total = 0.0
        while True:
            obs, reward, terminated, truncated, info = env.step(controller.act(obs))
            total += float(reward)
            if terminated or truncated:
                break
        row = dict(info["metrics"], seed=seed + i, **{"return": total})
        rows.append(row)
        if on_episode is not None:
            on_episode(i, row)
    n = max(len(rows), 1)

    def mean(key: str) -> float:
        vals = [float(r[key]) for r in rows if not math.isnan(float(r[key]))]
        return float(np.mean(vals)) if vals else math.nan

    return EvalSummary(
        episodes=len(rows),
        success_rate=sum(r["success"] for r in rows) / n,
        collision_rate=sum(r["collision"] for r in rows) / n,
        timeout_rate=sum(r["timeout"] for r in rows) / n,
        means={k: mean(k) for k in _MEAN_KEYS},
        per_episode=tuple(rows),
        overshoot_rate=sum(bool(r.get("overshoot")) for r in rows) / n,
    )
