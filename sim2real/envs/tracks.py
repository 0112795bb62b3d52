r"""Race tracks of Pozo Ruiz (2024): walls, islands, start and goal lines, grid maps.

The thesis trains on three scenarios (its Fig. 3: a curve path, a cross path and a no-wall
field) and races on a Gazebo circuit "with straight paths, acute turns and roundabouts" (its
Fig. 4). Dimensions are not printed; ours are scaled to TurtleBot 3 Burgers (footprint radius
~0.1 m): corridors 1.4 m wide (room for three robots abreast), sharp turns of 1 m centre-line
radius, a roundabout plaza of 2 m radius around a 0.6 m island.

- ``"open"``: no walls; start line at x = 0, goal line 8 m ahead (the thesis' no-wall field).
- ``"curve"``: 4 m straight, a 90 degree left turn of 1.5 m radius, 3 m straight.
- ``"cross"``: an 8 m straight corridor crossed at x = 4 m by a 7 m corridor along y
  (an intersection; crossing traffic uses it).
- ``"circuit"``: 5 m straight, a sharp left turn, a roundabout (enter from the south, go round
  the island counter-clockwise, leave to the north), a sharp right turn and 3 m to the goal.

Corridors are built from pieces (straights and arcs) by offsetting the centre line by half the
width on both sides; walls are closed behind the start and beyond the goal, so the free space
of a track is bounded. :func:`occupancy_grid` rasterises a track for a global planner.

Examples
--------
>>> from sim2real.envs.tracks import TRACKS, get_track
>>> track = get_track("curve")
>>> sorted(TRACKS)
['circuit', 'cross', 'curve', 'open']
>>> round(track.length_m, 2)
9.35
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cache, lru_cache

import numpy as np
from numpy.typing import NDArray

from sim2real.envs.geometry import FloatArray, Scene2D, point_segment_distance, wrap_angle
from sim2real.errors import Sim2RealValueError

__all__ = ["TRACKS", "OccupancyGrid", "Track", "get_track", "occupancy_grid"]

#: Track names.
TRACKS = ("open", "curve", "cross", "circuit")


@dataclass(frozen=True, kw_only=True)
class Track:
    """One race track (SI units).

    Attributes
    ----------
    name : str
        Track name.
    seg_a, seg_b : ndarray, shape (S, 2)
        Wall segments.
    islands : ndarray, shape (K, 3)
        Round obstacles ``(x, y, r)`` (the roundabout's island).
    centreline : ndarray, shape (N, 2)
        Waypoints every ~0.25 m from the start line to the goal line.
    normals : ndarray, shape (N, 2)
        Unit normals (to the left) of the centre line at the waypoints.
    width_m : float
        Corridor width.
    start_xy, goal_xy : ndarray, shape (2,)
        Centres of the start and goal lines.
    start_yaw_rad : float
        Racing direction at the start.
    goal_dir : ndarray, shape (2,)
        Unit direction in which the goal line is crossed.
    bounds : tuple
        (xmin, xmax, ymin, ymax) of the area a planner searches.
    cross_path : ndarray, shape (2, 2)
        End points of the crossing corridor's centre line (``cross`` only; else empty).
    """

    name: str
    seg_a: FloatArray
    seg_b: FloatArray
    islands: FloatArray
    centreline: FloatArray
    normals: FloatArray
    width_m: float
    start_xy: FloatArray
    start_yaw_rad: float
    goal_xy: FloatArray
    goal_dir: FloatArray
    bounds: tuple[float, float, float, float]
    cross_path: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))

    @property
    def length_m(self) -> float:
        """Length of the centre line from start to goal, m."""
        return float(np.sum(np.linalg.norm(np.diff(self.centreline, axis=0), axis=1)))

    @property
    def arc_length_m(self) -> FloatArray:
        """Cumulative arc length at each waypoint, m."""
        steps = np.linalg.norm(np.diff(self.centreline, axis=0), axis=1)
        return np.concatenate([[0.0], np.cumsum(steps)])

    def scene(self) -> Scene2D:
        """Walls and islands for ray casting and clearances."""
        return Scene2D(
            circles_xy=self.islands[:, :2].copy(),
            circles_r=self.islands[:, 2].copy(),
            seg_a=self.seg_a,
            seg_b=self.seg_b,
        )

    def crossed_goal(self, xy: FloatArray) -> bool:
        """Whether ``xy`` is past the goal line (within the corridor's width of its centre)."""
        d = np.asarray(xy, dtype=float) - self.goal_xy
        along = float(d @ self.goal_dir)
        across = abs(float(d[0] * -self.goal_dir[1] + d[1] * self.goal_dir[0]))
        return along >= 0.0 and across <= 0.5 * self.width_m + 0.5

    def progress_m(self, xy: FloatArray) -> float:
        """Arc length of the centre-line point nearest to ``xy``, m."""
        k = int(np.argmin(np.sum((self.centreline - np.asarray(xy)) ** 2, axis=1)))
        return float(self.arc_length_m[k])

    def lane_path(self, offset_m: float) -> FloatArray:
        """The centre line shifted ``offset_m`` to the left (a racing lane), shape (N, 2)."""
        return np.asarray(self.centreline + offset_m * self.normals)


# ------------------------------------------------------------------------ building the tracks

#: Corridor width, m.
WIDTH_M = 1.4
_START_LEAD_M = 2.2  # corridor behind the start line (the start grid stands there)
_END_LEAD_M = 0.6  # corridor beyond the goal line
_ARC_STEP_RAD = math.radians(10.0)
_WAYPOINT_STEP_M = 0.25


class _Builder:
    """Centre line from straights and arcs, with its left and right offset walls."""

    def __init__(self, x: float, y: float, heading: float, width: float) -> None:
        self.pts = [(x, y)]
        self.heads = [heading]
        self.heading = heading
        self.half = 0.5 * width

    def straight(self, length: float) -> _Builder:
        x, y = self.pts[-1]
        n = max(1, math.ceil(length / _WAYPOINT_STEP_M))
        for k in range(1, n + 1):
            t = length * k / n
            self.pts.append((x + t * math.cos(self.heading), y + t * math.sin(self.heading)))
            self.heads.append(self.heading)
        return self

    def arc(self, radius: float, angle_deg: float) -> _Builder:
        x, y = self.pts[-1]
        angle = math.radians(angle_deg)
        side = 1.0 if angle > 0 else -1.0
        cx = x - side * radius * math.sin(self.heading)
        cy = y + side * radius * math.cos(self.heading)
        n = max(2, math.ceil(abs(angle) * radius / _WAYPOINT_STEP_M))
        start = self.heading - side * 0.5 * math.pi
        for k in range(1, n + 1):
            a = start + angle * k / n
            self.pts.append((cx + radius * math.cos(a), cy + radius * math.sin(a)))
            self.heads.append(self.heading + angle * k / n)
        self.heading += angle
        return self

    def walls(self, *, close_start: bool, close_end: bool) -> FloatArray:
        p = np.asarray(self.pts)
        h = np.asarray(self.heads)
        n = np.column_stack([-np.sin(h), np.cos(h)])
        left, right = p + self.half * n, p - self.half * n
        segs = [np.hstack([side[:-1], side[1:]]) for side in (left, right)]
        if close_start:
            segs.append(np.array([[*left[0], *right[0]]]))
        if close_end:
            segs.append(np.array([[*left[-1], *right[-1]]]))
        return np.vstack(segs)

    def centre(self) -> tuple[FloatArray, FloatArray]:
        h = np.asarray(self.heads)
        return np.asarray(self.pts), np.column_stack([-np.sin(h), np.cos(h)])


def _trim(
    points: FloatArray, normals: FloatArray, s0: float, s1: float
) -> tuple[FloatArray, FloatArray]:
    """The polyline resampled every ~0.25 m from arc length s0 to s1 (start to goal line)."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    q = np.linspace(s0, s1, max(2, math.ceil((s1 - s0) / _WAYPOINT_STEP_M) + 1))
    pts = np.column_stack([np.interp(q, s, points[:, 0]), np.interp(q, s, points[:, 1])])
    nrm = np.column_stack([np.interp(q, s, normals[:, 0]), np.interp(q, s, normals[:, 1])])
    return pts, nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


def _finish(
    name: str,
    walls: FloatArray,
    islands: FloatArray,
    pts: FloatArray,
    normals: FloatArray,
    *,
    cross_path: FloatArray | None = None,
    margin: float = 1.0,
) -> Track:
    total = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    centre, nrm = _trim(pts, normals, _START_LEAD_M, total - _END_LEAD_M)
    d0 = centre[1] - centre[0]
    d1 = centre[-1] - centre[-2]
    allpts = np.vstack([pts, walls[:, :2], walls[:, 2:]]) if len(walls) else pts
    lo, hi = allpts.min(axis=0) - margin, allpts.max(axis=0) + margin
    return Track(
        name=name,
        seg_a=np.ascontiguousarray(walls[:, :2]),
        seg_b=np.ascontiguousarray(walls[:, 2:]),
        islands=np.asarray(islands, dtype=float).reshape(-1, 3),
        centreline=centre,
        normals=nrm,
        width_m=WIDTH_M,
        start_xy=centre[0].copy(),
        start_yaw_rad=math.atan2(d0[1], d0[0]),
        goal_xy=centre[-1].copy(),
        goal_dir=d1 / np.linalg.norm(d1),
        bounds=(float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])),
        cross_path=np.zeros((0, 2)) if cross_path is None else cross_path,
    )


def _open() -> Track:
    b = _Builder(-_START_LEAD_M, 0.0, 0.0, WIDTH_M).straight(8.0 + _START_LEAD_M + _END_LEAD_M)
    pts, nrm = b.centre()
    return _finish("open", np.zeros((0, 4)), np.zeros((0, 3)), pts, nrm, margin=1.5)


def _curve() -> Track:
    b = _Builder(-_START_LEAD_M, 0.0, 0.0, WIDTH_M).straight(4.0 + _START_LEAD_M).arc(1.5, 90.0)
    b.straight(3.0 + _END_LEAD_M)
    pts, nrm = b.centre()
    return _finish("curve", b.walls(close_start=True, close_end=True), np.zeros((0, 3)), pts, nrm)


def _cross() -> Track:
    b = _Builder(-_START_LEAD_M, 0.0, 0.0, WIDTH_M).straight(8.0 + _START_LEAD_M + _END_LEAD_M)
    pts, nrm = b.centre()
    h, x0, x1, ylen = 0.5 * WIDTH_M, 4.0 - 0.5 * WIDTH_M, 4.0 + 0.5 * WIDTH_M, 3.5
    xs, xe = -_START_LEAD_M, 8.0 + _END_LEAD_M
    walls = np.array(
        [
            [xs, h, x0, h],
            [x1, h, xe, h],
            [xs, -h, x0, -h],
            [x1, -h, xe, -h],
            [xs, h, xs, -h],
            [xe, h, xe, -h],
            [x0, h, x0, ylen],
            [x1, h, x1, ylen],
            [x0, -h, x0, -ylen],
            [x1, -h, x1, -ylen],
            [x0, ylen, x1, ylen],
            [x0, -ylen, x1, -ylen],
        ]
    )
    cross = np.array([[4.0, -ylen + 0.4], [4.0, ylen - 0.4]])
    return _finish("cross", walls, np.zeros((0, 3)), pts, nrm, cross_path=cross)


def _circuit() -> Track:
    r_out, r_in = 2.0, 0.6
    inset = r_out - math.sqrt(r_out**2 - (0.5 * WIDTH_M) ** 2) + 0.02
    a = _Builder(-_START_LEAD_M, 0.0, 0.0, WIDTH_M).straight(5.0 + _START_LEAD_M).arc(1.0, 90.0)
    a.straight(1.5 + inset)
    ex, ey = a.pts[-1]
    cx, cy = ex, ey - inset + r_out  # plaza centre: the entry road meets it from the south
    b = _Builder(cx, cy + r_out - inset, 0.5 * math.pi, WIDTH_M).straight(1.5 + inset)
    b.arc(1.0, -90.0).straight(3.0 + _END_LEAD_M)
    # plaza wall: the outer circle without the two road openings
    gap = math.asin(0.5 * WIDTH_M / r_out) + 0.01
    angles = np.arange(0.0, 2.0 * math.pi + 1e-9, _ARC_STEP_RAD)
    arc_pts = np.column_stack([cx + r_out * np.cos(angles), cy + r_out * np.sin(angles)])
    plaza = []
    for k in range(len(angles) - 1):
        mid = 0.5 * (angles[k] + angles[k + 1])
        off_s = abs(wrap_angle(mid + 0.5 * math.pi))
        off_n = abs(wrap_angle(mid - 0.5 * math.pi))
        if min(off_s, off_n) > gap + 0.5 * _ARC_STEP_RAD:
            plaza.append([*arc_pts[k], *arc_pts[k + 1]])
    walls = np.vstack(
        [
            a.walls(close_start=True, close_end=False),
            b.walls(close_start=False, close_end=True),
            plaza,
        ]
    )
    r_ring = 0.5 * (r_out + r_in)
    ring_a = np.linspace(-0.5 * math.pi, 0.5 * math.pi, 13)
    ring = np.column_stack([cx + r_ring * np.cos(ring_a), cy + r_ring * np.sin(ring_a)])
    ring_n = np.column_stack([np.cos(ring_a), np.sin(ring_a)]) * -1.0  # left = towards island
    pa, na = a.centre()
    pb, nb = b.centre()
    pts = np.vstack([pa, ring, pb])
    nrm = np.vstack([na, ring_n, nb])
    return _finish("circuit", walls, np.array([[cx, cy, r_in]]), pts, nrm)


@cache
def get_track(name: str) -> Track:
    """The track called ``name`` (one of :data:`TRACKS`)."""
    builders = {"open": _open, "curve": _curve, "cross": _cross, "circuit": _circuit}
    if name not in builders:
        raise Sim2RealValueError(
            f"track (--track) must be one of {', '.join(TRACKS)}, got {name!r}; "
            "e.g. --track circuit"
        )
    return builders[name]()


@dataclass(frozen=True, kw_only=True)
class OccupancyGrid:
    """A track rasterised for a planner.

    Attributes
    ----------
    origin_xy : ndarray, shape (2,)
        World position of cell (0, 0)'s centre, m.
    resolution_m : float
        Cell size, m.
    clearance_m : ndarray, shape (nx, ny)
        Distance from each cell centre to the nearest wall or island, m (inf on open tracks).
    """

    origin_xy: FloatArray
    resolution_m: float
    clearance_m: FloatArray

    def cell(self, xy: FloatArray) -> tuple[int, int]:
        """Index of the cell containing ``xy`` (clipped to the grid)."""
        ij = np.round((np.asarray(xy) - self.origin_xy) / self.resolution_m).astype(int)
        nx, ny = self.clearance_m.shape
        return int(np.clip(ij[0], 0, nx - 1)), int(np.clip(ij[1], 0, ny - 1))

    def centre(self, i: int, j: int) -> FloatArray:
        """World position of cell (i, j)'s centre, m."""
        return np.asarray(self.origin_xy + self.resolution_m * np.array([i, j], dtype=float))


@lru_cache(maxsize=16)
def occupancy_grid(name: str, resolution_m: float = 0.05) -> OccupancyGrid:
    """Clearance map of track ``name`` on a grid of ``resolution_m`` cells (cached)."""
    track = get_track(name)
    x0, x1, y0, y1 = track.bounds
    xs = np.arange(x0, x1 + 1e-9, resolution_m)
    ys = np.arange(y0, y1 + 1e-9, resolution_m)
    pts = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    clear = np.full(len(pts), np.inf)
    for k in range(0, len(pts), 20000):  # bounded memory
        chunk = pts[k : k + 20000]
        if track.seg_a.shape[0]:
            d = point_segment_distance(chunk, track.seg_a, track.seg_b).min(axis=1)
            clear[k : k + 20000] = np.minimum(clear[k : k + 20000], d)
        for cx, cy, r in track.islands:
            d = np.hypot(chunk[:, 0] - cx, chunk[:, 1] - cy) - r
            clear[k : k + 20000] = np.minimum(clear[k : k + 20000], d)
    grid: NDArray[np.float64] = clear.reshape(len(xs), len(ys))
    return OccupancyGrid(origin_xy=np.array([x0, y0]), resolution_m=resolution_m, clearance_m=grid)
