r"""Randomised maps of walls and cylinders (Yang et al., Sec. III-E, Table I).

The generator is the paper's :math:`Env(d_{target}, r_{wall}, n_{min}, n_{max})`: four walls,
each spawned with probability :math:`r_{wall}` and moved and rotated at random so that they
form corridors of varying width and inclination, plus :math:`n \sim U[n_{min}, n_{max}]`
cylinders placed uniformly at random (they may overlap and form larger shapes). Cylinders and
walls keep out of a safe disc around the start and the goal.

Facts taken from the paper (001) and its code: a 20 m x 20 m area, start at the origin with a
random yaw, goal at :math:`(d_{target}, 0)` reached within 0.3 m, walls 10 m x 0.15 m.

Cylinder radius (our choice): 0.34 m, so that the presets reach Table I's obstacle densities.
Table I defines :math:`\rho_{obs}` as "the percentage of obstacle area in total area"; its
rows give about 0.1 % of the area per cylinder (TRAIN: 70-100 cylinders, 6-10 %; TEST4:
150-200, 15-20 %). The code's 0.15 m cylinders cover only 0.018 % of 400 m^2 each (3-4 times
less than Table I); with 0.34 m (0.091 % each, minus overlaps, plus ~1.2 % of walls) the mean
measured density of every preset lies inside its Table I range (``docs/envs.md``; tested). Table I lists ``n_max`` before ``n_min`` and its numbers are in
that order swapped (TRAIN "n_max 70, n_min 100"); we read each row as the range
:math:`[\min, \max]` of the two numbers.

Wall placement (our choice; the paper only says "move and rotate randomly within a certain
range"): the four wall slots are two near walls, one on each side of the start-goal line at a
lateral offset :math:`U[1.0, 2.5]` m, and two far walls at :math:`U[3.0, 5.0]` m; each is
shifted along the line by :math:`U[-1.5, 1.5]` m and rotated by :math:`U[-20, 20]` degrees.
Walls that would cut a safe disc or cross the straight start-goal line (the walls form
corridors, they do not block them) are resampled (up to 20 times, then dropped).

The obstacle density :math:`\rho_{obs}` is the fraction of the 20 m x 20 m area covered by the
union of all obstacles (rasterised on a 2.5 cm grid, so overlapping cylinders count once).

Examples
--------
>>> import numpy as np
>>> from sim2real.envs.maps import PRESETS, generate_map
>>> layout = generate_map(PRESETS["TEST1"], np.random.default_rng(0))
>>> layout.goal_xy.tolist()
[8.0, 0.0]
>>> 0.0 <= layout.rho_obs < 0.1
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from sim2real.envs.geometry import FloatArray, Scene2D, point_segment_distance, rectangle_segments
from sim2real.errors import Sim2RealValueError

__all__ = [
    "PAPER_RHO_OBS",
    "PRESETS",
    "MapConfig",
    "MapLayout",
    "generate_map",
    "get_preset",
    "obstacle_density",
]

_RASTER_M = 0.025


@dataclass(frozen=True, kw_only=True)
class MapConfig:
    """Parameters of the map generator :math:`Env(d_{target}, r_{wall}, n_{min}, n_{max})`.

    Parameters
    ----------
    d_target_m : float
        Distance from the start (origin) to the goal on the +x axis, m.
    r_wall : float
        Probability that each of the four walls is spawned, in [0, 1].
    n_min, n_max : int
        Range of the uniformly drawn number of cylinders (inclusive).
    area_m : float
        Side of the square area (centred on the start-goal midpoint) where cylinders go, m.
    cylinder_radius_m : float
        Radius of every cylinder, m.
    wall_length_m, wall_thickness_m : float
        Wall size, m.
    goal_tolerance_m : float
        The goal counts as reached within this distance, m.
    safe_radius_m : float
        No obstacle reaches into this disc around the start and the goal, m.
    """

    d_target_m: float = 8.0
    r_wall: float = 0.8
    n_min: int = 70
    n_max: int = 100
    area_m: float = 20.0
    cylinder_radius_m: float = 0.34
    wall_length_m: float = 10.0
    wall_thickness_m: float = 0.15
    goal_tolerance_m: float = 0.3
    safe_radius_m: float = 0.6

    def __post_init__(self) -> None:
        if not 0.0 <= self.r_wall <= 1.0:
            raise Sim2RealValueError(
                f"map r_wall must be in [0, 1], got {self.r_wall!r}; give a probability"
            )
        if not (0 <= self.n_min <= self.n_max):
            raise Sim2RealValueError(
                f"map cylinder counts must satisfy 0 <= n_min <= n_max, got n_min={self.n_min}, "
                f"n_max={self.n_max}; swap or fix them"
            )
        for name in ("d_target_m", "area_m", "cylinder_radius_m", "goal_tolerance_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise Sim2RealValueError(f"map {name} must be a finite number > 0, got {value!r}")


#: Table I of Yang et al. (d_target 8 m, r_wall 0.8; the n ranges as [min, max]).
PRESETS: dict[str, MapConfig] = {
    "TRAIN": MapConfig(n_min=70, n_max=100),
    "TEST1": MapConfig(n_min=5, n_max=50),
    "TEST2": MapConfig(n_min=50, n_max=100),
    "TEST3": MapConfig(n_min=100, n_max=150),
    "TEST4": MapConfig(n_min=150, n_max=200),
}

#: The rho_obs column of Table I (fractions), for comparison with :attr:`MapLayout.rho_obs`.
PAPER_RHO_OBS: dict[str, tuple[float, float]] = {
    "TRAIN": (0.06, 0.10),
    "TEST1": (0.01, 0.05),
    "TEST2": (0.05, 0.10),
    "TEST3": (0.10, 0.15),
    "TEST4": (0.15, 0.20),
}


def get_preset(name: str) -> MapConfig:
    """The preset called ``name`` (case-insensitive); unknown names raise with the known ones."""
    key = str(name).upper()
    if key not in PRESETS:
        raise Sim2RealValueError(
            f"unknown map preset '{name}'; known presets are {', '.join(PRESETS)}"
        )
    return PRESETS[key]


@dataclass(frozen=True, kw_only=True)
class MapLayout:
    """One generated map.

    Attributes
    ----------
    start_xy, goal_xy : ndarray, shape (2,)
        Start and goal positions, m.
    start_yaw_rad : float
        Initial heading of the robot, rad.
    cylinders : ndarray, shape (N, 3)
        ``(x, y, r)`` of each cylinder, m.
    walls : ndarray, shape (K, 5)
        ``(cx, cy, length, thickness, yaw)`` of each spawned wall (m, rad).
    scene : Scene2D
        The obstacles for ray casting and collision checks.
    rho_obs : float
        Fraction of the area covered by obstacles (union), in [0, 1].
    """

    start_xy: FloatArray
    goal_xy: FloatArray
    start_yaw_rad: float
    cylinders: FloatArray
    walls: FloatArray
    scene: Scene2D
    rho_obs: float


def _wall_segments(walls: FloatArray) -> FloatArray:
    if walls.shape[0] == 0:
        return np.zeros((0, 4))
    return np.vstack([rectangle_segments(*w) for w in walls])


def _crosses_path(seg: FloatArray, ends: FloatArray) -> bool:
    """Whether any of the segments crosses the straight start-goal line."""
    (ax, ay), (bx, by) = ends
    for x1, y1, x2, y2 in seg:
        d1 = (bx - ax) * (y1 - ay) - (by - ay) * (x1 - ax)
        d2 = (bx - ax) * (y2 - ay) - (by - ay) * (x2 - ax)
        d3 = (x2 - x1) * (ay - y1) - (y2 - y1) * (ax - x1)
        d4 = (x2 - x1) * (by - y1) - (y2 - y1) * (bx - x1)
        if d1 * d2 < 0 and d3 * d4 < 0:
            return True
    return False


def _sample_walls(config: MapConfig, rng: np.random.Generator, keep_out: FloatArray) -> FloatArray:
    mid_x = 0.5 * config.d_target_m
    slots = ((1.0, 2.5, 1.0), (1.0, 2.5, -1.0), (3.0, 5.0, 1.0), (3.0, 5.0, -1.0))
    walls = []
    for lo, hi, side in slots:
        if rng.random() >= config.r_wall:
            continue
        for _ in range(20):
            wall = np.array(
                [
                    mid_x + rng.uniform(-1.5, 1.5),
                    side * rng.uniform(lo, hi),
                    config.wall_length_m,
                    config.wall_thickness_m,
                    math.radians(rng.uniform(-20.0, 20.0)),
                ]
            )
            seg = rectangle_segments(*wall)
            # the wall's gap to each keep-out disc (disc_clearance for all of them at once)
            gaps = point_segment_distance(keep_out, seg[:, :2], seg[:, 2:]).min(axis=1)
            clear = bool(np.all(gaps - config.safe_radius_m > 0))
            if clear and not _crosses_path(seg, keep_out):
                walls.append(wall)
                break
    return np.array(walls, dtype=np.float64).reshape(-1, 5)


def _sample_cylinders(
    config: MapConfig, rng: np.random.Generator, keep_out: FloatArray
) -> FloatArray:
    n = int(rng.integers(config.n_min, config.n_max + 1))
    half = 0.5 * config.area_m
    centre = np.array([0.5 * config.d_target_m, 0.0])
    r = config.cylinder_radius_m
    out = np.empty((0, 2))
    while out.shape[0] < n:
        need = n - out.shape[0]
        xy = centre + rng.uniform(-half + r, half - r, size=(2 * need + 8, 2))
        d = np.min(np.linalg.norm(xy[:, None, :] - keep_out[None, :, :], axis=2), axis=1)
        out = np.vstack([out, xy[d > config.safe_radius_m + r]])
    return np.hstack([out[:n], np.full((n, 1), r)])


def obstacle_density(
    cylinders: FloatArray, walls: FloatArray, *, centre_xy: FloatArray, area_m: float
) -> float:
    """Fraction of the square area covered by the union of cylinders and walls.

    Rasterised on a 2.5 cm grid (cell centres), so the error is well under 1 % of the value for
    the presets. Each obstacle paints the cells of its bounding box whose centres lie inside it
    (a compiled loop: map generation runs at every reset, also of the vector envs).
    """
    n = round(area_m / _RASTER_M)
    origin = np.asarray(centre_xy, dtype=np.float64) - 0.5 * area_m
    cyl = np.ascontiguousarray(cylinders, dtype=np.float64).reshape(-1, 3)
    wall = np.ascontiguousarray(walls, dtype=np.float64).reshape(-1, 5)
    covered = _paint_obstacles(n, float(origin[0]), float(origin[1]), _RASTER_M, cyl, wall)
    return float(covered / (n * n))


@numba.njit(cache=True, inline="always")
def _cell_range(lo: float, hi: float, origin: float, cell: float, n: int) -> tuple[int, int]:
    """Index range [i0, i1) of the cells of a bounding box [lo, hi] on one axis."""
    i0 = max(0, int((lo - origin) / cell))
    i1 = min(n, int((hi - origin) / cell) + 1)
    return i0, i1


@numba.njit(cache=True, inline="always")
def _cell_box(
    x: float, y: float, ex: float, ey: float, ox: float, oy: float, cell: float, n: int
) -> tuple[int, int, int, int]:
    """Index ranges [i0, i1) x [j0, j1) of the cells of the bounding box centred at (x, y)
    with half-extents ``ex``, ``ey`` on a grid of ``n`` x ``n`` cells from (ox, oy)."""
    i0, i1 = _cell_range(x - ex, x + ex, ox, cell, n)
    j0, j1 = _cell_range(y - ey, y + ey, oy, cell, n)
    return i0, i1, j0, j1


@numba.njit(cache=True)
def _paint_obstacles(
    n: int,
    ox: float,
    oy: float,
    cell: float,
    cylinders: FloatArray,
    walls: FloatArray,
) -> int:  # pragma: no cover - compiled
    """Number of grid cells whose centre lies in a cylinder or a wall (each cell counted once)."""
    grid = np.zeros((n, n), dtype=np.bool_)
    for k in range(cylinders.shape[0]):
        x, y, r = cylinders[k, 0], cylinders[k, 1], cylinders[k, 2]
        i0, i1, j0, j1 = _cell_box(x, y, r, r, ox, oy, cell, n)
        for i in range(i0, i1):
            px = ox + (i + 0.5) * cell
            for j in range(j0, j1):
                py = oy + (j + 0.5) * cell
                if (px - x) ** 2 + (py - y) ** 2 <= r * r:
                    grid[i, j] = True
    for k in range(walls.shape[0]):
        cx, cy, length, width, yaw = walls[k, 0], walls[k, 1], walls[k, 2], walls[k, 3], walls[k, 4]
        c, s = math.cos(yaw), math.sin(yaw)
        ex = 0.5 * (abs(length * c) + abs(width * s))
        ey = 0.5 * (abs(length * s) + abs(width * c))
        hl, hw = 0.5 * length, 0.5 * width
        i0, i1, j0, j1 = _cell_box(cx, cy, ex, ey, ox, oy, cell, n)
        for i in range(i0, i1):
            px = ox + (i + 0.5) * cell
            for j in range(j0, j1):
                py = oy + (j + 0.5) * cell
                u = (px - cx) * c + (py - cy) * s
                v = -(px - cx) * s + (py - cy) * c
                if abs(u) <= hl and abs(v) <= hw:
                    grid[i, j] = True
    return int(grid.sum())


def generate_map(config: MapConfig, rng: np.random.Generator) -> MapLayout:
    """Draw one map from ``config`` with the generator ``rng`` (same seed, same map).

    Examples
    --------
    >>> import numpy as np
    >>> a = generate_map(PRESETS["TRAIN"], np.random.default_rng(3))
    >>> b = generate_map(PRESETS["TRAIN"], np.random.default_rng(3))
    >>> bool(np.array_equal(a.cylinders, b.cylinders))
    True
    """
    start = np.zeros(2)
    goal = np.array([config.d_target_m, 0.0])
    keep_out = np.stack([start, goal])
    yaw = float(rng.uniform(-math.pi, math.pi))
    walls = _sample_walls(config, rng, keep_out)
    cylinders = _sample_cylinders(config, rng, keep_out)
    seg = _wall_segments(walls)
    scene = Scene2D(
        circles_xy=cylinders[:, :2].copy(),
        circles_r=cylinders[:, 2].copy(),
        seg_a=seg[:, :2].copy(),
        seg_b=seg[:, 2:].copy(),
    )
    rho = obstacle_density(
        cylinders, walls, centre_xy=np.array([0.5 * config.d_target_m, 0.0]), area_m=config.area_m
    )
    return MapLayout(
        start_xy=start,
        goal_xy=goal,
        start_yaw_rad=yaw,
        cylinders=cylinders,
        walls=walls,
        scene=scene,
        rho_obs=rho,
    )
