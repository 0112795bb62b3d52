r"""``sim2real/RandomMap-v0``: mapless navigation through random walls and cylinders (Yang et al.).

A TurtleBot 3 Burger starts at the origin with a random heading and must reach the goal
:math:`(d_{target}, 0)` (within 0.3 m) through a map drawn by :mod:`sim2real.envs.maps`.

Observation (40 float32 values, Yang et al. Sec. III-B)
    36 lidar ranges (m, LDS-01 limits 0.12-3.5 m; beams every 10 degrees counter-clockwise from
    straight ahead; readings outside the limits read 3.5), goal distance (m, clipped at
    ``goal_range_m``) and bearing (rad, counter-clockwise from the heading), measured v (m/s)
    and w (rad/s).
Action
    (v, w) with v in [0, 0.21] m/s and w in [-1, 1] rad/s (Yang et al. Sec. III-B);
    ``action_limits="robot"``: v in [0, max_v] and w in [-max_w, max_w] of the robot spec
    (0.7 m/s and 3.14 rad/s for the TurtleBot 2).
Reward (Yang et al. eqs. 2-5; the constants are ours, in :class:`RandomMapReward`)
    .. math::

        r = r_{goal} + r_{crash} + r_{free} + r_{step}

    - :math:`r_{goal} = r_{reach}` (100) on reaching the goal, else
      :math:`k_{goal}\,\Delta d_{goal}` (20 per metre of progress, potential-based shaping);
    - :math:`r_{crash} = -r_{crash,i}` for the clearance (gap between the robot's footprint
      disc and the nearest obstacle) in band *i*: contact (<= 0 m, 100, ends the episode),
      (0, 0.05] m (2), (0.05, 0.15] m (0.5);
    - :math:`r_{free} = -w_{free}\sum_i (1 - d_i / d_{max})^4` over the 36 ranges
      (:math:`w_{free}` = 0.1: the paper's weight is 1, which with 36 beams dominates the sum);
    - :math:`r_{step} = -T` per step (T = 0.05), so the accumulated penalty grows with time;
    - :math:`r_{stop} = -k_{stop}\,|v|\,\max(0, 1 - d_{goal}/R_{stop})` per step (:math:`k_{stop}`
      = 0 by default, :math:`R_{stop}` = 1 m): with ``goal_speed_mps`` set it pays for braking
      on the way into the goal, more the closer.
Outcome (``info["outcome"]`` at the end)
    ``"success"``, ``"crash"`` (contact), ``"trap"`` (``max_episode_steps`` reached) or, with a
    finite ``goal_speed_mps``, ``"overshoot"`` (the robot left the goal tolerance without
    stopping in it; the episode ends there, as in a crash, without its penalty). The
    generic metrics are in ``info["metrics"]``; ``info["rho_obs"]`` is the map's obstacle
    density.

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs
>>> env = gym.make("sim2real/RandomMap-v0", preset="TEST1")
>>> obs, info = env.reset(seed=0)
>>> obs.shape
(40,)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from robots.params import DriveParams
from robots.randomization import DriveDistribution
from sim2real.envs._nav import NavEnvBase, StepInfo
from sim2real.envs._reward import reward_constants
from sim2real.envs.geometry import FloatArray
from sim2real.envs.maps import MapConfig, MapLayout, generate_map, get_preset
from sim2real.errors import Sim2RealValueError
from sim2real.plants.closed_loop import PlantSessions
from sim2real.plants.diff_drive import PlantParams

__all__ = ["RandomMapEnv", "RandomMapReward"]

_N_BEAMS = 36
_GOAL_DIST_MAX_M = 30.0
#: Action limits: Yang et al.'s (Sec. III-B) or the robot spec's.
_ACTION_LIMITS = ("paper", "robot")


@dataclass(frozen=True, kw_only=True)
class RandomMapReward:
    """Constants of the RandomMap-v0 reward (see the module docstring)."""

    reach: float = 100.0
    progress_per_m: float = 20.0
    crash_bands_m: tuple[float, float, float] = (0.0, 0.05, 0.15)
    crash_penalties: tuple[float, float, float] = (100.0, 2.0, 0.5)
    free_weight: float = 0.1
    step_penalty: float = 0.05
    goal_speed_per_mps: float = 0.0
    goal_speed_radius_m: float = 1.0


class RandomMapEnv(NavEnvBase):
    """Mapless navigation of a TurtleBot 3 Burger through random maps (Yang et al.).

    Parameters
    ----------
    preset : str
        ``"TRAIN"``, ``"TEST1"`` ... ``"TEST4"`` (Table I of Yang et al.).
    map_config : MapConfig, optional
        A custom generator configuration (overrides ``preset``).
    dynamics : str
        ``"reduced"`` (drive model in numba, exact 2-D world), ``"pybullet"`` or ``"plant"``
        (a foreign base, to evaluate on).
    control_dt : float
        Control period, s.
    max_episode_steps : int
        Steps before the episode ends as a trap (default 1000 = 100 s: 2.6 times the straight
        8 m at 0.21 m/s).
    reward : RandomMapReward or mapping, optional
        Reward constants (a mapping sets some of :class:`RandomMapReward`'s fields).
    drive_params : DriveParams, optional
        Drive parameters (default: the robot spec's).
    drive_distribution : robots.randomization.DriveDistribution, optional
        Draw each episode's robot from it at reset, from the env's ``np_random`` (after the
        world; same seed, same robot), e.g.
        ``DriveDistribution.from_params_file("params.yaml", robot=...)``. The native vector
        env's sub-envs draw the same robots as single envs with the same seeds.
    drive_spread : float
        Multiplies every standard deviation of ``drive_distribution`` (1 = as given).
    plant_sessions : PlantSessions or PlantParams, optional
        ``dynamics="plant"`` only: where each episode's plant session comes from, drawn at
        reset from the env's ``np_random`` after the world (default: the robot's plant with
        the default payload, floor, battery and latency variation); a ``PlantParams`` is one
        fixed session.
    robot : str
        Robot spec name.
    action_limits : str
        ``"paper"`` (v <= 0.21 m/s and w within 1 rad/s, Yang et al.) or ``"robot"`` (the robot
        spec's top speed and yaw rate).
    goal_range_m : float
        The observed goal distance is clipped at this, m (default 30; its bound in the
        observation space, so a policy that rescales observations to [-1, 1] resolves
        distances near the goal finer with a range fitted to the course).
    goal_speed_mps : float
        Success needs the measured speed at or below this within the goal tolerance, m/s
        (default inf: passing through the goal counts; e.g. 0.05: stop inside it). With a
        finite value, leaving the tolerance disc after entering it ends the episode as an
        overshoot.

    Notes
    -----
    ``reset(options={"preset": "TEST3"})`` switches the preset for that episode onwards.
    """

    def __init__(
        self,
        *,
        preset: str = "TRAIN",
        map_config: MapConfig | None = None,
        dynamics: str = "reduced",
        control_dt: float = 0.1,
        max_episode_steps: int = 1000,
        reward: RandomMapReward | Mapping[str, Any] | None = None,
        drive_params: DriveParams | None = None,
        drive_distribution: DriveDistribution | None = None,
        drive_spread: float = 1.0,
        plant_sessions: PlantSessions | PlantParams | None = None,
        robot: str = "turtlebot3_burger",
        action_limits: str = "paper",
        goal_speed_mps: float = math.inf,
        goal_range_m: float = _GOAL_DIST_MAX_M,
    ) -> None:
        if action_limits not in _ACTION_LIMITS:
            raise Sim2RealValueError(
                f"action_limits must be one of {', '.join(_ACTION_LIMITS)}, got "
                f"{action_limits!r}; use 'paper' (v <= 0.21 m/s, |w| <= 1 rad/s, Yang et al.) "
                "or 'robot' (the robot spec's top speed and yaw rate)"
            )
        if isinstance(goal_range_m, bool) or not (
            isinstance(goal_range_m, int | float)
            and math.isfinite(goal_range_m)
            and goal_range_m > 0
        ):
            raise Sim2RealValueError(
                f"goal_range_m must be a finite number of m > 0 (where the observed goal "
                f"distance is clipped), got {goal_range_m!r}; e.g. 5.0 for a goal 3 m away"
            )
        #: The observed goal distance is clipped at this, m.
        self.goal_range_m = float(goal_range_m)
        self.map_config = map_config if map_config is not None else get_preset(preset)
        self.preset = str(preset).upper() if map_config is None else "custom"
        super().__init__(
            robot=robot,
            dynamics=dynamics,
            control_dt=control_dt,
            max_episode_steps=max_episode_steps,
            goal_tolerance_m=self.map_config.goal_tolerance_m,
            drive_params=drive_params,
            needs_world=False,
            drive_distribution=drive_distribution,
            drive_spread=drive_spread,
            plant_sessions=plant_sessions,
            goal_speed_mps=goal_speed_mps,
        )
        self.reward_config = reward_constants(RandomMapReward, reward, "goal_speed_per_mps")
        lid = self.robot_spec.lidar
        self.range_min_m, self.range_max_m = float(lid.range_min_m), float(lid.range_max_m)
        # 36 equidistant beams over the full circle, from the lidar's first angle
        self.beam_angles_rad = lid.angle_min_rad + 2.0 * math.pi * np.arange(_N_BEAMS) / _N_BEAMS
        vmax, wmax = float(self.robot_spec.max_v_mps), float(self.robot_spec.max_w_radps)
        low = np.concatenate(
            [np.full(_N_BEAMS, self.range_min_m), [0.0, -math.pi, -vmax, -wmax]]
        ).astype(np.float32)
        high = np.concatenate(
            [np.full(_N_BEAMS, self.range_max_m), [self.goal_range_m, math.pi, vmax, wmax]]
        ).astype(np.float32)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        v_cap, w_cap = (0.21, 1.0) if action_limits == "paper" else (vmax, wmax)
        self.action_space = spaces.Box(
            np.array([0.0, -w_cap], dtype=np.float32),
            np.array([v_cap, w_cap], dtype=np.float32),
            dtype=np.float32,
        )
        self.layout: MapLayout | None = None
        self._ranges = np.full(_N_BEAMS, self.range_max_m)

    def _build(self, options: dict[str, Any]) -> tuple[float, float, float]:
        unknown = sorted(set(options) - {"preset", "map_config"})
        if unknown:
            raise Sim2RealValueError(
                f"unknown reset option(s) {unknown} for RandomMap-v0; known: preset, map_config"
            )
        if "map_config" in options:
            self.map_config = options["map_config"]
            self.preset = "custom"
        elif "preset" in options:
            self.map_config = get_preset(str(options["preset"]))
            self.preset = str(options["preset"]).upper()
        layout = generate_map(self.map_config, self.np_random)
        self.layout = layout
        self._scene = layout.scene
        self._goal = layout.goal_xy.copy()
        if self._world is not None:
            self._world.set_static(
                cylinders=layout.cylinders,
                cylinder_height_m=0.5,
                boxes=layout.walls,
                box_height_m=0.5,
            )
        return float(layout.start_xy[0]), float(layout.start_xy[1]), layout.start_yaw_rad

    def _observation(self) -> FloatArray:
        self._ranges = self._lidar_ranges(self._scene, self.beam_angles_rad)
        d, bearing = self._goal_polar()
        v, w = self._backend.velocity
        obs = np.concatenate([self._ranges, [min(d, self.goal_range_m), bearing, v, w]])
        space = self.observation_space
        return np.clip(obs, space.low, space.high).astype(np.float32)  # type: ignore[attr-defined]

    def _reward(self, s: StepInfo) -> float:
        cfg = self.reward_config
        if s.outcome == "success":
            r_goal = cfg.reach
        else:
            r_goal = cfg.progress_per_m * (s.prev_goal_dist_m - s.goal_dist_m)
        r_crash = 0.0
        for edge, penalty in zip(cfg.crash_bands_m, cfg.crash_penalties, strict=True):
            if s.clearance_m <= edge:
                r_crash = -penalty
                break
        # the ranges of the observation just computed for this step
        r_free = -cfg.free_weight * float(np.sum((1.0 - self._ranges / self.range_max_m) ** 4))
        ramp = max(0.0, 1.0 - s.goal_dist_m / cfg.goal_speed_radius_m)
        r_stop = -cfg.goal_speed_per_mps * abs(s.v) * ramp
        return r_goal + r_crash + r_free + r_stop - cfg.step_penalty

    def _extra_info(self) -> dict[str, Any]:
        rho = math.nan if self.layout is None else self.layout.rho_obs
        return {"rho_obs": rho, "preset": self.preset}

    def _outcome_name(self, outcome: str) -> str:
        names = {"success": "success", "collision": "crash", "timeout": "trap"}
        return names.get(outcome, outcome)
