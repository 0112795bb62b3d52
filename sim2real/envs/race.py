r"""``sim2real/Race-v0`` and a PettingZoo race: TurtleBot 3 Burgers against ORCA opponents (Pozo Ruiz 2024).

Pozo Ruiz (2024, "Desarrollo y evaluación de un entorno de simulación multi-robot para
carreras", USFQ 2024) races TurtleBot 3 Burgers on walled tracks against agents that move with
ORCA (its Table 1: 3-5 agents, unicycle robot, 0.25 s training step). Here:

- the tracks of :mod:`sim2real.envs.tracks` (``open``, ``curve``, ``cross``, ``circuit``);
- learning robots: TurtleBot 3 Burgers (``dynamics="reduced"``: the identified drive model;
  ``"pybullet"``: the rigid-body robot, walls and islands as pybullet bodies) with a 36-beam
  lidar and odometry;
- opponents (``num_opponents``, default 4, 0-5): ORCA discs
  (:mod:`sim2real.envs.orca`) scaled to the robot as the thesis' agents are to its robot (both
  0.3 m and 1 m/s there): radius = the Burger's footprint radius, top speed U(0.8, 1.0) x the
  Burger's 0.22 m/s. Each follows its own racing lane (the centre line shifted sideways) to the
  goal line and stops racing there; on ``cross`` half of them shuttle along the crossing
  corridor instead. They avoid each other reciprocally and the learning robots fully (the
  robots do not run ORCA);
- everyone starts on a grid of slots behind the start line (3 abreast, 0.5 m rows); the
  robots' slots are drawn from the seed.

Observation (63 float32 values per robot)
    36 lidar ranges (m, every 10 degrees from straight ahead, LDS-01 limits 0.12-3.5 m);
    odometry x, y (m, in the track frame) and yaw (rad); measured v (m/s) and w (rad/s);
    distance (m) and bearing (rad) to the centre of the goal line (with ``local_goal_m`` to
    SARL*'s dynamic local goal instead, Li et al. 2019: the farthest centre-line waypoint
    ahead within that radius, the goal line's centre once it is in reach); then for the 5 nearest
    other movers (opponents and other robots) their position and velocity relative to the
    robot, in its frame (x, y m; vx, vy m/s), nearest first, zero-padded.
Action
    (v, w), v in [0, 0.22] m/s, w in [-2.84, 2.84] rad/s (the Burger's limits).
Reward (the terms of the thesis' R1; the constants are ours, in :class:`RaceReward`)
    :math:`R = R_d + R_{pf} + R_g + R_c + R_{km} + R_{cw} + R_w + R_s + R_t + R_{turn}`:
    proximity to other movers :math:`-0.2\max(0, 1 - c/0.2\,\mathrm m)`; progress along the centre line
    :math:`+2\,\Delta s` per metre; goal +10; collision with a mover -10; keep moving
    :math:`+0.01\,v/v_{max}`; wall collision -10; near a wall :math:`-0.2\max(0, 1 -
    c_w/0.15\,\mathrm m)`; stopped (v < 0.02 m/s) -0.02; timeout -5; a time cost per step
    (0 by default); a turning cost per radian of heading turned,
    :math:`-k_{turn}\,|w|\,\Delta t` with the measured w (0 by default: a cost on the total
    turning, which a weave pays on every step and a clean line only where the track bends,
    :math:`\pi/2` rad on ``curve``). ``reward`` takes a
    :class:`RaceReward` or a mapping of some of its fields (a YAML config's ``env.kwargs``).
Outcome (``info["outcome"]``)
    ``"success"`` (crossed the goal line), ``"collision"`` (touched an opponent or another
    robot), ``"wall_collision"``, ``"timeout"``; ``info["metrics"]`` adds ``wall_collision``
    and ``completion_time_s`` to the episode metrics.

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs
>>> env = gym.make("sim2real/Race-v0", track="curve", num_opponents=3)
>>> obs, info = env.reset(seed=0)
>>> obs.shape
(63,)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from robots.params import DriveParams
from robots.spec import load_spec
from sim2real.envs._reward import reward_constants
from sim2real.envs._robot import (
    RobotBackend,
    check_env_arguments,
    checked_action,
    footprint_radius_m,
    make_backend,
)
from sim2real.envs._world import PybulletWorld
from sim2real.envs.geometry import (
    FloatArray,
    Scene2D,
    cast_rays,
    disc_clearance,
    distance_bearing,
    nearest_relative_states,
)
from sim2real.envs.metrics import MetricsTracker
from sim2real.envs.orca import OrcaConfig, orca_velocities
from sim2real.envs.tracks import TRACKS, Track, get_track
from sim2real.errors import Sim2RealValueError
from sim2real.plants.closed_loop import PlantSessions
from sim2real.plants.diff_drive import PlantParams

__all__ = [
    "RACE_OUTCOMES",
    "RaceCore",
    "RaceEnv",
    "RaceParallelEnv",
    "RaceReward",
    "race_parallel_env",
    "race_reward",
]

#: Episode outcomes of a racing robot.
RACE_OUTCOMES = ("success", "collision", "wall_collision", "timeout")

MAX_OPPONENTS = 5
N_BEAMS = 36
N_NEIGHBOURS = 5
OBS_SIZE = N_BEAMS + 7 + 4 * N_NEIGHBOURS
_LANES = (0.0, 0.4, -0.4)
_ROW_M = 0.5
_LOOKAHEAD = 3  # waypoints (~0.75 m) ahead of the nearest one


@dataclass(frozen=True, kw_only=True)
class RaceReward:
    """Constants of the race reward (see the module docstring)."""

    proximity: float = 0.2
    proximity_m: float = 0.2
    progress_per_m: float = 2.0
    goal: float = 10.0
    collision: float = 10.0
    keep_moving: float = 0.01
    wall_collision: float = 10.0
    near_wall: float = 0.2
    near_wall_m: float = 0.15
    stop: float = 0.02
    stop_below_mps: float = 0.02
    timeout: float = 5.0
    time: float = 0.0
    turn_per_rad: float = 0.0


def race_reward(value: RaceReward | Mapping[str, Any] | None) -> RaceReward:
    """``value`` as :class:`RaceReward`: as it is, the defaults for None, or a mapping's fields.

    Examples
    --------
    >>> race_reward({"stop": 0.1}).stop, race_reward(None).stop
    (0.1, 0.02)
    """
    return reward_constants(RaceReward, value, "stop")


def _check_options(track: Any, num_opponents: Any, n_robots: Any) -> tuple[str, int, int]:
    if track not in TRACKS:
        raise Sim2RealValueError(
            f"track (--track) must be one of {', '.join(TRACKS)}, got {track!r}; "
            "e.g. --track circuit"
        )
    if not (
        isinstance(num_opponents, int)
        and not isinstance(num_opponents, bool)
        and 0 <= num_opponents <= MAX_OPPONENTS
    ):
        raise Sim2RealValueError(
            f"num_opponents (--opponents) must be an integer in [0, {MAX_OPPONENTS}], got "
            f"{num_opponents!r}; the thesis races against 3-5"
        )
    if not (isinstance(n_robots, int) and not isinstance(n_robots, bool) and n_robots >= 1):
        raise Sim2RealValueError(f"n_robots must be an integer >= 1, got {n_robots!r}")
    if n_robots + num_opponents > 3 * 4:
        raise Sim2RealValueError(
            f"n_robots + num_opponents must be at most 12 (start grid slots), got "
            f"{n_robots + num_opponents}"
        )
    return str(track), int(num_opponents), int(n_robots)


class RaceCore:
    """State and rules of one race (shared by :class:`RaceEnv` and :class:`RaceParallelEnv`).

    Parameters
    ----------
    track : str
        Track name (:data:`sim2real.envs.tracks.TRACKS`).
    n_robots, num_opponents : int
        Learning robots and ORCA opponents.
    dynamics : str
        ``"reduced"``, ``"pybullet"`` or ``"plant"`` (foreign bases, to evaluate on).
    control_dt : float
        Control period, s.
    max_episode_steps : int
        Steps before a timeout.
    reward : RaceReward
        Reward constants.
    drive_params : DriveParams, optional
        The robots' drive parameters (default: the spec's).
    robot : str
        Robot spec name.
    plant_sessions : PlantSessions or PlantParams, optional
        ``dynamics="plant"`` only: where each robot's plant session comes from, drawn at each
        reset (see :class:`RaceEnv`).
    """

    def __init__(
        self,
        *,
        track: str,
        n_robots: int,
        num_opponents: int,
        dynamics: str,
        control_dt: float,
        max_episode_steps: int,
        reward: RaceReward,
        drive_params: DriveParams | None,
        robot: str,
        plant_sessions: PlantSessions | PlantParams | None = None,
    ) -> None:
        check_env_arguments(
            dynamics=dynamics,
            control_dt=control_dt,
            max_episode_steps=max_episode_steps,
            drive_params=drive_params,
        )
        self.track_name, self.num_opponents, self.n_robots = _check_options(
            track, num_opponents, n_robots
        )
        self.track: Track = get_track(self.track_name)
        self.spec = load_spec(robot)
        self.dynamics = dynamics
        self.control_dt = float(control_dt)
        self.max_episode_steps = max_episode_steps
        self.reward = reward
        self.radius_m = footprint_radius_m(self.spec)
        self.max_v = float(self.spec.max_v_mps)
        self.max_w = float(self.spec.max_w_radps)
        lid = self.spec.lidar
        self.lidar_xy = (float(lid.xyz_m[0]), float(lid.xyz_m[1]))
        self.range_min_m, self.range_max_m = float(lid.range_min_m), float(lid.range_max_m)
        self.beam_angles_rad = lid.angle_min_rad + 2.0 * math.pi * np.arange(N_BEAMS) / N_BEAMS
        self.world: Any = None
        if dynamics == "pybullet":
            self.world = PybulletWorld()
        params = drive_params if drive_params is not None else self.spec.drive
        client = None if self.world is None else self.world.client
        self.backends: list[RobotBackend] = [
            make_backend(dynamics, self.spec, params, client=client, plant_sessions=plant_sessions)
            for _ in range(n_robots)
        ]
        self.scene: Scene2D = self.track.scene()
        self.orca = OrcaConfig(time_horizon_s=2.0, obstacle_time_horizon_s=0.5, neighbor_dist_m=2.0)
        self.trackers = [MetricsTracker(control_dt_s=self.control_dt) for _ in range(n_robots)]
        self.active = np.ones(n_robots, dtype=bool)
        self.outcomes: list[str | None] = [None] * n_robots
        self.steps = 0
        self._init_opponents(np.random.default_rng(0))

    # ------------------------------------------------------------------ setup
    def _slots(self) -> FloatArray:
        t = self.track
        fwd = np.array([math.cos(t.start_yaw_rad), math.sin(t.start_yaw_rad)])
        left = np.array([-fwd[1], fwd[0]])
        return np.array(
            [
                t.start_xy - (0.25 + _ROW_M * row) * fwd + lane * left
                for row in range(4)
                for lane in _LANES
            ]
        )

    def _init_opponents(self, rng: np.random.Generator) -> None:
        n = self.num_opponents
        self.opp_xy = np.zeros((n, 2))
        self.opp_v = np.zeros((n, 2))
        self.opp_r = np.full(n, self.radius_m)
        self.opp_vmax = self.max_v * rng.uniform(0.8, 1.0, n)
        self.opp_path: list[FloatArray] = []
        self.opp_idx = np.zeros(n, dtype=int)
        self.opp_racing = np.ones(n, dtype=bool)
        self.opp_done = np.zeros(n, dtype=bool)

    def reset(self, rng: np.random.Generator) -> None:
        """Draw the start grid and opponents and place everyone (robots at rest)."""
        t = self.track
        slots = self._slots()
        n_cross = self.num_opponents // 2 if t.cross_path.shape[0] else 0
        n_grid = self.n_robots + self.num_opponents - n_cross
        order = rng.permutation(n_grid)
        robot_slots = order[: self.n_robots]
        opp_slots = order[self.n_robots :]
        self._init_opponents(rng)
        if self.world is not None:
            self.world.reset_simulation()
            self._build_pybullet_static()
        for k, backend in enumerate(self.backends):
            x, y = slots[robot_slots[k]]
            backend.new_session(rng)  # dynamics="plant": this race's plant of robot k
            backend.reset(float(x), float(y), t.start_yaw_rad + rng.uniform(-0.05, 0.05))
            self.trackers[k].reset(float(x), float(y))
        self.opp_path = []
        for j in range(self.num_opponents):
            if j < n_cross:
                a, b = t.cross_path
                f = rng.uniform(0.0, 1.0)
                self.opp_xy[j] = a + f * (b - a)
                path = np.linspace(a, b, 30) if rng.random() < 0.5 else np.linspace(b, a, 30)
                self.opp_path.append(path)
                self.opp_racing[j] = False
                self.opp_idx[j] = int(np.argmin(np.sum((path - self.opp_xy[j]) ** 2, axis=1)))
            else:
                slot = slots[opp_slots[j - n_cross]]
                self.opp_xy[j] = slot
                offset = float(
                    (slot - t.start_xy)
                    @ np.array([-math.sin(t.start_yaw_rad), math.cos(t.start_yaw_rad)])
                )
                self.opp_path.append(t.lane_path(offset))
                self.opp_idx[j] = 0
        self.active[:] = True
        self.outcomes = [None] * self.n_robots
        self.prev_progress = [t.progress_m(np.asarray(b.pose[:2])) for b in self.backends]
        self.steps = 0
        self._sync_pybullet_opponents()

    def _build_pybullet_static(self) -> None:
        t = self.track
        d = t.seg_b - t.seg_a
        length = np.linalg.norm(d, axis=1)
        centre = 0.5 * (t.seg_a + t.seg_b)
        yaw = np.arctan2(d[:, 1], d[:, 0])
        boxes = np.column_stack([centre, length, np.full(len(length), 0.05), yaw])
        self.world.set_static(
            cylinders=t.islands, cylinder_height_m=0.3, boxes=boxes, box_height_m=0.3
        )

    def _sync_pybullet_opponents(self) -> None:
        if self.world is not None and self.num_opponents:
            xy = np.where(self.opp_done[:, None], 1e3, self.opp_xy)
            self.world.set_pedestrians(xy, self.opp_r, np.full(self.num_opponents, 0.2))

    # ------------------------------------------------------------------ dynamics
    def _opponent_pref(self) -> FloatArray:
        pref = np.zeros((self.num_opponents, 2))
        for j, path in enumerate(self.opp_path):
            if self.opp_done[j]:
                continue
            lo = self.opp_idx[j]
            window = path[lo : lo + 8]
            k = lo + int(np.argmin(np.sum((window - self.opp_xy[j]) ** 2, axis=1)))
            self.opp_idx[j] = k
            if not self.opp_racing[j] and k >= len(path) - 2:
                self.opp_path[j] = path[::-1].copy()  # shuttle back
                self.opp_idx[j] = 0
                path = self.opp_path[j]
                k = 0
            target = path[min(k + _LOOKAHEAD, len(path) - 1)]
            if self.opp_racing[j] and k >= len(path) - 1:
                target = path[-1] + 2.0 * self.track.goal_dir
            d = target - self.opp_xy[j]
            dist = float(np.hypot(*d))
            if dist > 1e-9:
                pref[j] = d / dist * self.opp_vmax[j]
        return pref

    def _robot_states(self) -> tuple[FloatArray, FloatArray]:
        xy = np.array([b.pose[:2] for b in self.backends]).reshape(-1, 2)
        vel = np.array(
            [
                [b.velocity[0] * math.cos(b.pose[2]), b.velocity[0] * math.sin(b.pose[2])]
                for b in self.backends
            ]
        ).reshape(-1, 2)
        return xy, vel

    def _move_opponents(self) -> None:
        n = self.num_opponents
        if n == 0:
            return
        live = ~self.opp_done
        rxy, rvel = self._robot_states()
        keep = self.active
        pos = np.vstack([self.opp_xy, rxy[keep]])
        vel = np.vstack([self.opp_v, rvel[keep]])
        rad = np.concatenate([self.opp_r, np.full(int(keep.sum()), self.radius_m)])
        pref = np.vstack([self._opponent_pref(), rvel[keep]])
        vmax = np.concatenate([self.opp_vmax, np.zeros(int(keep.sum()))])
        act = np.concatenate([live, np.zeros(int(keep.sum()), dtype=bool)])
        pos[:n][~live] = 1e3  # finished opponents are out of the way
        new = orca_velocities(
            pos,
            vel,
            rad,
            pref,
            vmax,
            self.control_dt,
            config=self.orca,
            active=act,
            walls=(self.track.seg_a, self.track.seg_b),
        )
        self.opp_v = np.where(live[:, None], new[:n], 0.0)
        self.opp_xy = self.opp_xy + self.opp_v * self.control_dt
        for j in range(n):
            if live[j] and self.opp_racing[j] and self.track.crossed_goal(self.opp_xy[j]):
                self.opp_done[j] = True
                self.opp_v[j] = 0.0
        self._sync_pybullet_opponents()

    def step(self, actions: list[FloatArray | None]) -> list[tuple[float, str | None]]:
        """Apply one (v, w) per robot (None for finished robots); returns (reward, outcome)."""
        for k, a in enumerate(actions):
            if a is None or not self.active[k]:
                continue
            self.backends[k].step(float(a[0]), float(a[1]), self.control_dt)
        self._move_opponents()
        self.steps += 1
        out: list[tuple[float, str | None]] = []
        for k in range(self.n_robots):
            if not self.active[k]:
                out.append((0.0, self.outcomes[k]))
                continue
            out.append(self._judge(k))
        for k, (_, outcome) in enumerate(out):
            if outcome is not None and self.active[k]:
                self.active[k] = False
                self.outcomes[k] = outcome
        return out

    def _mover_gap(self, k: int) -> float:
        xy = np.asarray(self.backends[k].pose[:2])
        gaps = [np.inf]
        live = ~self.opp_done
        if live.any():
            d = np.hypot(*(self.opp_xy[live] - xy).T) - self.opp_r[live] - self.radius_m
            gaps.append(float(d.min()))
        for j, b in enumerate(self.backends):
            if j != k and self.active[j]:
                gaps.append(float(np.hypot(*(np.asarray(b.pose[:2]) - xy))) - 2 * self.radius_m)
        return min(gaps)

    def _judge(self, k: int) -> tuple[float, str | None]:
        b = self.backends[k]
        x, y, _ = b.pose
        v, w = b.velocity
        self.trackers[k].record(x=x, y=y, v=v, w=w)
        xy = np.array([x, y])
        wall_gap = disc_clearance(self.scene, xy, self.radius_m)
        mover_gap = self._mover_gap(k)
        outcome: str | None = None
        if mover_gap <= 0.0:
            outcome = "collision"
        elif wall_gap <= 0.0:
            outcome = "wall_collision"
        elif self.track.crossed_goal(xy):
            outcome = "success"
        elif self.steps >= self.max_episode_steps:
            outcome = "timeout"
        cfg = self.reward
        progress = self.track.progress_m(xy)
        r = cfg.progress_per_m * (progress - self.prev_progress[k])
        self.prev_progress[k] = progress
        r -= cfg.proximity * max(0.0, 1.0 - mover_gap / cfg.proximity_m)
        r -= cfg.near_wall * max(0.0, 1.0 - wall_gap / cfg.near_wall_m)
        r += cfg.keep_moving * max(v, 0.0) / self.max_v
        if abs(v) < cfg.stop_below_mps:
            r -= cfg.stop
        r -= cfg.time
        r -= cfg.turn_per_rad * abs(w) * self.control_dt
        r += {
            "success": cfg.goal,
            "collision": -cfg.collision,
            "wall_collision": -cfg.wall_collision,
            "timeout": -cfg.timeout,
            None: 0.0,
        }[outcome]
        return float(r), outcome

    # ------------------------------------------------------------------ observation
    def observation(self, k: int) -> FloatArray:
        """The 63-value observation of robot ``k`` (see the module docstring)."""
        b = self.backends[k]
        x, y, yaw = b.pose
        c, s = math.cos(yaw), math.sin(yaw)
        lx, ly = self.lidar_xy
        origin = np.array([x + c * lx - s * ly, y + s * lx + c * ly])
        movers_xy, movers_v, movers_r = self._others(k)
        scene = self.scene.with_circles(movers_xy, movers_r)
        ranges = cast_rays(scene, origin, self.beam_angles_rad + yaw, self.range_max_m)
        ranges = np.where(ranges < self.range_min_m, self.range_max_m, ranges)
        xy = np.array([x, y])
        goal_d, bearing = distance_bearing(xy, yaw, self._target(xy))
        v, w = b.velocity
        nb = nearest_relative_states(
            xy, yaw, np.array([v * c, v * s]), movers_xy, movers_v, N_NEIGHBOURS
        )
        return np.concatenate([ranges, [x, y, yaw, v, w, goal_d, bearing], nb.reshape(-1)]).astype(
            np.float32
        )

    #: SARL*'s local-goal radius, m (None: the goal line's centre is the target)
    local_goal_m: float | None = None

    def _target(self, xy: FloatArray) -> FloatArray:
        """Where the observation's goal distance and bearing point (see the module docstring)."""
        if self.local_goal_m is None:
            return self.track.goal_xy
        line = self.track.centreline
        k = int(np.argmin(np.sum((line - xy) ** 2, axis=1)))
        inside = np.flatnonzero(np.hypot(*(line[k:] - xy).T) <= self.local_goal_m)
        j = k + (int(inside[-1]) if inside.size else 1)
        return self.track.goal_xy if j >= len(line) - 1 else line[j]

    def _others(self, k: int) -> tuple[FloatArray, FloatArray, FloatArray]:
        live = ~self.opp_done
        xy = [self.opp_xy[live]]
        vel = [self.opp_v[live]]
        rad = [self.opp_r[live]]
        rxy, rvel = self._robot_states()
        others = [j for j in range(self.n_robots) if j != k and self.active[j]]
        if others:
            xy.append(rxy[others])
            vel.append(rvel[others])
            rad.append(np.full(len(others), self.radius_m))
        return np.vstack(xy), np.vstack(vel), np.concatenate(rad)

    def metrics(self, k: int) -> dict[str, Any]:
        """Episode metrics of robot ``k`` (after its episode ended)."""
        outcome = self.outcomes[k] or "timeout"
        base = self.trackers[k].finish("collision" if outcome == "wall_collision" else outcome)
        m: dict[str, Any] = dict(base.to_dict())
        m["outcome"] = outcome
        m["wall_collision"] = outcome == "wall_collision"
        m["collision"] = outcome == "collision"
        m["completion_time_s"] = m["time_to_goal_s"]
        return m

    def observation_space(self) -> spaces.Box:
        """The Box of one robot's observation."""
        t = self.track
        big = 1e3
        low = np.concatenate(
            [
                np.full(N_BEAMS, self.range_min_m),
                [
                    t.bounds[0] - 5,
                    t.bounds[2] - 5,
                    -math.pi,
                    -self.max_v,
                    -self.max_w,
                    0.0,
                    -math.pi,
                ],
                np.full(4 * N_NEIGHBOURS, -big),
            ]
        )
        high = np.concatenate(
            [
                np.full(N_BEAMS, self.range_max_m),
                [t.bounds[1] + 5, t.bounds[3] + 5, math.pi, self.max_v, self.max_w, big, math.pi],
                np.full(4 * N_NEIGHBOURS, big),
            ]
        )
        return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)

    def clip_obs(self, obs: FloatArray, space: spaces.Box) -> FloatArray:
        """``obs`` clipped into ``space`` (velocities can overshoot the limits slightly)."""
        return np.clip(obs, space.low, space.high).astype(np.float32)

    def action_space(self) -> spaces.Box:
        """The Box of one robot's (v, w) action."""
        return spaces.Box(
            np.array([0.0, -self.max_w], np.float32),
            np.array([self.max_v, self.max_w], np.float32),
            dtype=np.float32,
        )

    def close(self) -> None:
        """Release the pybullet client."""
        if self.world is not None:
            self.world.close()
            self.world = None


class RaceEnv(gym.Env):  # type: ignore[type-arg]
    """One TurtleBot 3 Burger racing ORCA opponents on a walled track (Pozo Ruiz 2024).

    Parameters
    ----------
    track : str
        ``"open"``, ``"curve"``, ``"cross"`` or ``"circuit"``.
    num_opponents : int
        ORCA opponents, 0-5 (the thesis: 3-5).
    dynamics : str
        ``"reduced"``, ``"pybullet"`` or ``"plant"`` (a foreign base, to evaluate on).
    control_dt : float
        Control period, s.
    max_episode_steps : int, optional
        Steps before a timeout (default: 3 x the track length at top speed).
    reward : RaceReward or mapping, optional
        Reward constants (a mapping sets some of :class:`RaceReward`'s fields).
    drive_params : DriveParams, optional
        Drive parameters (default: the spec's).
    robot : str
        Robot spec name.
    plant_sessions : PlantSessions or PlantParams, optional
        ``dynamics="plant"`` only: where each episode's plant session comes from, drawn at
        reset from the env's ``np_random`` after the start grid (default: the robot's plant
        with the default payload, floor, battery and latency variation); a ``PlantParams`` is
        one fixed session.
    local_goal_m : float, optional
        Observe SARL*'s dynamic local goal within this radius (m) instead of the goal line's
        centre (see the module docstring).

    Notes
    -----
    ``reset(options={"track": ..., "num_opponents": ...})`` is not supported: make a new env
    (tracks differ in geometry and in the observation bounds).
    """

    metadata: dict[str, Any] = {"render_modes": []}  # noqa: RUF012

    def __init__(
        self,
        *,
        track: str = "circuit",
        num_opponents: int = 4,
        dynamics: str = "reduced",
        control_dt: float = 0.1,
        max_episode_steps: int | None = None,
        reward: RaceReward | Mapping[str, Any] | None = None,
        drive_params: DriveParams | None = None,
        robot: str = "turtlebot3_burger",
        plant_sessions: PlantSessions | PlantParams | None = None,
        local_goal_m: float | None = None,
    ) -> None:
        super().__init__()
        _check_options(track, num_opponents, 1)
        if local_goal_m is not None and not (
            isinstance(local_goal_m, int | float)
            and not isinstance(local_goal_m, bool)
            and math.isfinite(local_goal_m)
            and local_goal_m > 0
        ):
            raise Sim2RealValueError(
                f"local_goal_m must be a distance in metres > 0 or None, got {local_goal_m!r}; "
                "e.g. 1.0"
            )
        max_episode_steps = _episode_steps(
            track, dynamics, control_dt, max_episode_steps, drive_params
        )
        self.core = RaceCore(
            track=track,
            n_robots=1,
            num_opponents=num_opponents,
            dynamics=dynamics,
            control_dt=control_dt,
            max_episode_steps=max_episode_steps,
            reward=race_reward(reward),
            drive_params=drive_params,
            robot=robot,
            plant_sessions=plant_sessions,
        )
        self.control_dt = self.core.control_dt
        self.robot_spec = self.core.spec
        self.robot_radius_m = self.core.radius_m
        self.beam_angles_rad = self.core.beam_angles_rad
        self._obs_box = self.core.observation_space()
        self._act_box = self.core.action_space()
        self.observation_space = self._obs_box
        self.action_space = self._act_box
        self.core.local_goal_m = None if local_goal_m is None else float(local_goal_m)
        #: (slots, values per slot) of the neighbours at the end of the observation
        self.neighbour_slots: tuple[int, int] | None = (N_NEIGHBOURS, 4)
        self._done = False

    @property
    def track(self) -> Track:
        """The track raced on."""
        return self.core.track

    def get_drive_params(self) -> DriveParams:
        """The robot's drive parameters now."""
        return self.core.backends[0].get_drive_params()

    def set_drive_params(self, params: DriveParams) -> None:
        """Use ``params`` from the next step on."""
        if not isinstance(params, DriveParams):
            raise Sim2RealValueError(
                f"set_drive_params needs a robots.DriveParams, got {type(params).__name__}"
            )
        self.core.backends[0].set_drive_params(params)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[FloatArray, dict[str, Any]]:
        super().reset(seed=seed)
        if options:
            raise Sim2RealValueError(
                f"Race-v0 takes no reset options, got {sorted(options)}; make a new env for "
                "another track or number of opponents"
            )
        self.core.reset(self.np_random)
        self._done = False
        obs = self.core.clip_obs(self.core.observation(0), self._obs_box)
        return obs, {"outcome": None, "track": self.core.track_name}

    def step(self, action: Any) -> tuple[FloatArray, float, bool, bool, dict[str, Any]]:
        if self._done:
            raise Sim2RealValueError("step() called after the episode ended; call reset() first")
        a = checked_action(action, self._act_box)
        ((reward, outcome),) = self.core.step([a])
        obs = self.core.clip_obs(self.core.observation(0), self._obs_box)
        info: dict[str, Any] = {"outcome": outcome, "track": self.core.track_name}
        if outcome is not None:
            self._done = True
            info["metrics"] = self.core.metrics(0)
        terminated = outcome in ("success", "collision", "wall_collision")
        return obs, reward, terminated, outcome == "timeout", info

    def close(self) -> None:
        self.core.close()
        super().close()


class RaceParallelEnv(ParallelEnv):  # type: ignore[misc]
    """The race with several learning robots, as a PettingZoo ``ParallelEnv``.

    Agents are ``"robot_0"`` ... ``"robot_{n-1}"``; each has the observation and action space
    of :class:`RaceEnv`; an agent leaves ``agents`` when it finishes, collides or times out.
    Build it with :func:`race_parallel_env`.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012
        "render_modes": [],
        "name": "sim2real_race_v0",
        "is_parallelizable": True,
    }

    def __init__(self, core: RaceCore) -> None:
        self.core = core
        self.possible_agents = [f"robot_{k}" for k in range(core.n_robots)]
        self.agents: list[str] = []
        self._obs_space = core.observation_space()
        self._act_space = core.action_space()
        self._rng = np.random.default_rng()
        self.render_mode = None

    def observation_space(self, agent: str) -> spaces.Box:
        """Observation space of ``agent`` (the same for all)."""
        return self._obs_space

    def action_space(self, agent: str) -> spaces.Box:
        """Action space of ``agent`` (the same for all)."""
        return self._act_space

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, FloatArray], dict[str, dict[str, Any]]]:
        """Start a race; ``seed`` seeds the start grid and the opponents (``options`` unused)."""
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        self.core.reset(self._rng)
        self.agents = list(self.possible_agents)
        obs = {a: self._obs(k) for k, a in enumerate(self.possible_agents)}
        return obs, {a: {"outcome": None} for a in self.agents}

    def _obs(self, k: int) -> FloatArray:
        return self.core.clip_obs(self.core.observation(k), self._obs_space)

    def step(
        self, actions: dict[str, Any]
    ) -> tuple[
        dict[str, FloatArray],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """One control step of every live agent (``actions`` maps each to its (v, w))."""
        unknown = sorted(set(actions) - set(self.agents))
        if unknown:
            raise Sim2RealValueError(
                f"actions for agents that are not racing: {unknown}; live agents: {self.agents}"
            )
        acts: list[FloatArray | None] = []
        for name in self.possible_agents:
            acts.append(checked_action(actions[name], self._act_space) if name in actions else None)
        results = self.core.step(acts)
        obs: dict[str, FloatArray] = {}
        rew: dict[str, float] = {}
        term: dict[str, bool] = {}
        trunc: dict[str, bool] = {}
        infos: dict[str, dict[str, Any]] = {}
        for k, name in enumerate(self.possible_agents):
            if name not in self.agents:
                continue
            reward, outcome = results[k]
            obs[name] = self._obs(k)
            rew[name] = reward
            term[name] = outcome in ("success", "collision", "wall_collision")
            trunc[name] = outcome == "timeout"
            info: dict[str, Any] = {"outcome": outcome}
            if outcome is not None:
                info["metrics"] = self.core.metrics(k)
            infos[name] = info
        self.agents = [a for a in self.agents if not (term[a] or trunc[a])]
        return obs, rew, term, trunc, infos

    def render(self) -> None:
        """No rendering."""

    def state(self) -> FloatArray:
        """Global state: every robot's pose and every opponent's position."""
        poses = np.array([b.pose for b in self.core.backends]).reshape(-1)
        return np.concatenate([poses, self.core.opp_xy.reshape(-1)]).astype(np.float32)

    def close(self) -> None:
        """Release the pybullet client."""
        self.core.close()


def _episode_steps(
    track: str,
    dynamics: str,
    control_dt: float,
    max_episode_steps: int | None,
    drive_params: DriveParams | None,
) -> int:
    """``max_episode_steps``, by default three times the track at the Burger's 0.22 m/s.

    The arguments are checked first, so a bad ``control_dt`` is one sentence, not a division error.
    """
    check_env_arguments(
        dynamics=dynamics,
        control_dt=control_dt,
        max_episode_steps=1 if max_episode_steps is None else max_episode_steps,
        drive_params=drive_params,
    )
    if max_episode_steps is not None:
        return max_episode_steps
    return math.ceil(3.0 * get_track(track).length_m / 0.22 / float(control_dt))


def race_parallel_env(
    *,
    n_robots: int = 2,
    track: str = "circuit",
    num_opponents: int = 3,
    dynamics: str = "reduced",
    control_dt: float = 0.1,
    max_episode_steps: int | None = None,
    reward: RaceReward | None = None,
    drive_params: DriveParams | None = None,
    plant_sessions: PlantSessions | PlantParams | None = None,
) -> RaceParallelEnv:
    """The race of :class:`RaceEnv` with ``n_robots`` learning robots (PettingZoo ParallelEnv).

    Examples
    --------
    >>> from sim2real.envs import race_parallel_env
    >>> env = race_parallel_env(n_robots=2, track="open", num_opponents=2)
    >>> obs, infos = env.reset(seed=0)
    >>> sorted(obs), obs["robot_0"].shape
    (['robot_0', 'robot_1'], (63,))
    """
    _check_options(track, num_opponents, n_robots)
    max_episode_steps = _episode_steps(track, dynamics, control_dt, max_episode_steps, drive_params)
    core = RaceCore(
        track=track,
        n_robots=n_robots,
        num_opponents=num_opponents,
        dynamics=dynamics,
        control_dt=control_dt,
        max_episode_steps=max_episode_steps,
        reward=race_reward(reward),
        drive_params=drive_params,
        robot="turtlebot3_burger",
        plant_sessions=plant_sessions,
    )
    return RaceParallelEnv(core)
