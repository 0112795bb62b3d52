r"""The thesis' traditional racer for ``Race-v0``: a global planner on the map plus DWA.

Pozo Ruiz (2024) races robots driven by the ROS navigation stack (move_base): a global planner (A* or
Dijkstra) on the costmap of the known track map and the dynamic-window approach (DWA) as the
local planner, with a 0.25 m inflation radius and 0.2 m goal tolerance. Here:

- the global planner searches the 8-connected 5 cm grid of :func:`sim2real.envs.tracks.occupancy_grid`:
  cells closer to a wall than the robot's footprint radius + 2 cm are lethal, and within the
  0.25 m inflation radius the step cost grows linearly up to 1 + ``inflation_weight``
  (move_base's inflation layer, linearised). ``method="astar"`` uses the Euclidean distance to
  the goal as heuristic; ``"dijkstra"`` none (uniform-cost search). The plan is made once per
  episode from the start pose to a point 0.3 m beyond the goal line's centre;
- the local planner is :class:`sim2real.envs.baselines.DWAController` on the 36-beam lidar,
  steering towards a carrot on the plan 0.8 m ahead of the path point nearest to the
  odometry pose (opponents are just lidar points to it, as in move_base).

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs
>>> from sim2real.envs.race_baseline import RaceBaseline
>>> env = gym.make("sim2real/Race-v0", track="open", num_opponents=0)
>>> ctrl = RaceBaseline.for_env(env)
>>> obs, _ = env.reset(seed=0)
>>> ctrl.reset()
>>> env.action_space.contains(ctrl.act(obs))
True
"""

from __future__ import annotations

import heapq
import math
from typing import Any

import numpy as np

from sim2real.envs.baselines import DWAConfig, DWAController
from sim2real.envs.geometry import FloatArray, distance_bearing
from sim2real.envs.race import N_BEAMS
from sim2real.envs.tracks import OccupancyGrid, Track, occupancy_grid
from sim2real.errors import Sim2RealValueError

__all__ = ["PLANNERS", "RaceBaseline", "plan_path"]

#: Global planners.
PLANNERS = ("astar", "dijkstra")

_MOVES = [(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if (di, dj) != (0, 0)]


def _step_cost(
    grid: OccupancyGrid, robot_radius_m: float, inflation_m: float, weight: float
) -> FloatArray:
    free = grid.clearance_m - robot_radius_m
    cost = 1.0 + weight * np.clip(1.0 - free / inflation_m, 0.0, 1.0)
    return np.asarray(np.where(free > 0.02, cost, np.inf))


def plan_path(
    track: Track,
    start_xy: FloatArray,
    goal_xy: FloatArray,
    *,
    robot_radius_m: float,
    method: str = "astar",
    inflation_m: float = 0.25,
    inflation_weight: float = 3.0,
) -> FloatArray:
    """Grid path from ``start_xy`` to ``goal_xy`` on ``track``, shape (M, 2), m.

    Raises when the goal cannot be reached (a closed track is always passable).
    """
    if method not in PLANNERS:
        raise Sim2RealValueError(
            f"planner method must be one of {', '.join(PLANNERS)}, got {method!r}"
        )
    grid = occupancy_grid(track.name)
    cost = _step_cost(grid, robot_radius_m, inflation_m, inflation_weight)
    nx, ny = cost.shape
    start, goal = grid.cell(start_xy), grid.cell(goal_xy)
    if not math.isfinite(
        cost[start]
    ):  # starting against a wall: leave through the nearest free cell
        cost[start] = 1.0
    astar = method == "astar"

    def h(c: tuple[int, int]) -> float:
        return math.hypot(c[0] - goal[0], c[1] - goal[1]) if astar else 0.0

    best = {start: 0.0}
    parent: dict[tuple[int, int], tuple[int, int]] = {}
    heap = [(h(start), 0.0, start)]
    while heap:
        _, g, cell = heapq.heappop(heap)
        if cell == goal:
            break
        if g > best.get(cell, math.inf):
            continue
        for di, dj in _MOVES:
            n = (cell[0] + di, cell[1] + dj)
            if not (0 <= n[0] < nx and 0 <= n[1] < ny):
                continue
            c = cost[n]
            if not math.isfinite(c):
                continue
            g2 = g + c * (1.4142135623730951 if di and dj else 1.0)
            if g2 < best.get(n, math.inf):
                best[n] = g2
                parent[n] = cell
                heapq.heappush(heap, (g2 + h(n), g2, n))
    if goal not in best:
        raise Sim2RealValueError(
            f"no path from {tuple(np.round(start_xy, 2))} to {tuple(np.round(goal_xy, 2))} on "
            f"track {track.name!r}"
        )
    cells = [goal]
    while cells[-1] != start:
        cells.append(parent[cells[-1]])
    return np.array([grid.centre(i, j) for i, j in reversed(cells)])


class RaceBaseline:
    """Global planner + DWA for :class:`~sim2real.envs.RaceEnv` (see the module docstring).

    Parameters
    ----------
    track : Track
        The (known) track map.
    dwa : DWAController
        Local planner matched to the robot.
    method : str
        ``"astar"`` or ``"dijkstra"``.
    lookahead_m : float
        Carrot distance along the plan, m.
    """

    def __init__(
        self,
        track: Track,
        dwa: DWAController,
        *,
        method: str = "astar",
        lookahead_m: float = 0.8,
    ) -> None:
        if method not in PLANNERS:
            raise Sim2RealValueError(
                f"planner method must be one of {', '.join(PLANNERS)}, got {method!r}"
            )
        self.track = track
        self.dwa = dwa
        self.method = method
        self.lookahead_m = lookahead_m
        self.path: FloatArray | None = None
        self._idx = 0
        self._cache: dict[tuple[int, int], FloatArray] = {}

    @classmethod
    def for_env(cls, env: Any, *, method: str = "astar") -> RaceBaseline:
        """A racer matched to ``env`` (Race-v0, wrapped or not)."""
        base = env.unwrapped
        dwa = DWAController.for_env(
            env, DWAConfig(horizon_s=1.5, clearance_cap_m=0.4, margin_m=0.06, velocity=0.5)
        )
        return cls(base.track, dwa, method=method)

    def reset(self) -> None:
        """Forget the plan (a new one is made from the first observation)."""
        self.path = None
        self._idx = 0
        self.dwa.reset()

    def _plan(self, xy: FloatArray) -> FloatArray:
        grid = occupancy_grid(self.track.name)
        key = grid.cell(xy)
        if key not in self._cache:
            goal = self.track.goal_xy + 0.3 * self.track.goal_dir
            self._cache[key] = plan_path(
                self.track, xy, goal, robot_radius_m=self.dwa.robot_radius_m, method=self.method
            )
        return self._cache[key]

    def act(self, obs: Any) -> FloatArray:
        """The (v, w) action for a Race-v0 observation."""
        o = np.asarray(obs, dtype=np.float64)
        ranges = o[:N_BEAMS]
        x, y, yaw, v, w = o[N_BEAMS : N_BEAMS + 5]
        xy = np.array([x, y])
        if self.path is None:
            self.path = self._plan(xy)
            self._idx = 0
        path = self.path
        window = path[self._idx : self._idx + 40]
        self._idx += int(np.argmin(np.sum((window - xy) ** 2, axis=1)))
        seg = np.linalg.norm(np.diff(path[self._idx :], axis=0), axis=1)
        ahead = int(np.searchsorted(np.cumsum(seg), self.lookahead_m))
        carrot = path[min(self._idx + ahead, len(path) - 1)]
        dist, bearing = distance_bearing(xy, yaw, carrot)
        return self.dwa.act(np.concatenate([ranges, [dist, bearing, v, w]]))
