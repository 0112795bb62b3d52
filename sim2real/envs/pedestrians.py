r"""Pedestrians as discs walking at the density-dependent speed of Liang et al. (2020), eq. (1).

Each pedestrian is a disc with state :math:`[r, \vec p, \vec v^{curr}, \vec v^{pref}] \in
\mathbb{R}^7` (radius, position, current and preferred velocity; Liang et al. (2020), Sec. I-A-2). Its
natural walking speed is

.. math::

    V = \min\left(\|\vec v^{pref}\|, \left(\frac{S\,\alpha}{H\,(1 + \beta)}\right)^2\right)
    \qquad (1)

with :math:`S` the free space in front of it, :math:`H` = height / 1.72 m, and the stride
constants :math:`\alpha, \beta`.

Choice of S, alpha and beta
---------------------------
We take :math:`S` = the distance the pedestrian's centre can travel along its walking
direction before its disc touches another body, plus its own diameter; for two equal discs
head-on this is their centre spacing. The constants only enter through
:math:`k = \alpha / (1 + \beta)`. On a square lattice of density :math:`\rho` the spacing is
:math:`\rho^{-1/2}`, and with :math:`k = 1.037` eq. (1) gives 1.08, 0.54 and 0.36 m/s at 1, 2
and 3 pedestrians/m^2 for a 1.72 m pedestrian — within 0.07 m/s of Weidmann's fundamental
diagram :math:`v = 1.34\,[1 - e^{-1.913(1/\rho - 1/5.4)}]` (U. Weidmann, *Transporttechnik
der Fussgänger*, ETH Zürich IVT report 90, 1993: 1.06, 0.61, 0.33 m/s), the empirical
speed-density relation that Liang et al. (2020) cite as "the fundamental diagram [12]". We split
:math:`k` as :math:`\alpha = 1.4, \beta = 0.35`: :math:`\beta` is the personal-space buffer
(Narang et al., "Generating pedestrian trajectories consistent with the fundamental diagram
based on physiological and psychological factors", PLoS ONE 10(4), 2015 — the source of
eq. (1)), a 35 % margin over the stride length. "Higher than average constants" (scenario b of
Liang et al. (2020)) scale :math:`\alpha` up.

Steering (our choice; the paper does not specify it): each step every walking pedestrian
tries seven headings within 60 degrees of the direction to its goal, evaluates eq. (1) along
each, and takes the one with the best progress :math:`V\cos(\Delta\theta)` — the velocity
sampling along an arc of Narang et al. No one moves further than the free gap along its
heading; residual overlaps (simultaneous moves, grazing contacts with walls) are pushed apart.

Examples
--------
>>> from sim2real.envs.pedestrians import walking_speed
>>> round(float(walking_speed(1.34, 1.0, 1.72)), 3)
1.075
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np
from numpy.typing import NDArray

from robots import _jit
from sim2real.envs import geometry as _geometry
from sim2real.envs.geometry import FloatArray, Scene2D, cast_beams, point_segment_distance
from sim2real.errors import Sim2RealValueError

__all__ = [
    "ALPHA",
    "BETA",
    "Crowd",
    "CrowdState",
    "spawn_positions",
    "walking_speed",
    "weidmann_speed",
]

#: Stride constant alpha of eq. (1) (see the module docstring for the derivation).
ALPHA = 1.4
#: Personal-space buffer beta of eq. (1).
BETA = 0.35
_HEADING_OFFSETS = np.radians([0.0, -20.0, 20.0, -40.0, 40.0, -60.0, 60.0])
_GOAL_REACHED_M = 0.3


def walking_speed(
    v_pref_mps: FloatArray | float,
    free_space_m: FloatArray | float,
    height_m: FloatArray | float,
    *,
    alpha: FloatArray | float = ALPHA,
    beta: float = BETA,
) -> FloatArray:
    """Eq. (1) of Liang et al. (2020): natural walking speed, m/s.

    Parameters
    ----------
    v_pref_mps : float or ndarray
        Preferred speed :math:`\\|\\vec v^{pref}\\|`, m/s.
    free_space_m : float or ndarray
        Free space :math:`S` in front of the pedestrian, m.
    height_m : float or ndarray
        Body height, m (normalised by 1.72 m).
    alpha, beta : float
        Stride constants.
    """
    h = np.asarray(height_m, dtype=np.float64) / 1.72
    s = np.maximum(np.asarray(free_space_m, dtype=np.float64), 0.0)
    return np.asarray(np.minimum(v_pref_mps, (s * alpha / (h * (1.0 + beta))) ** 2))


def weidmann_speed(density_per_m2: FloatArray | float) -> FloatArray:
    """Weidmann's (1993) fundamental diagram, m/s: the reference eq. (1) is calibrated to."""
    rho = np.asarray(density_per_m2, dtype=np.float64)
    return np.asarray(1.34 * (1.0 - np.exp(-1.913 * (1.0 / rho - 1.0 / 5.4))))


@dataclass(frozen=True, kw_only=True)
class CrowdState:
    """Snapshot of the crowd (arrays of length N).

    Attributes
    ----------
    radius_m : ndarray, shape (N,)
    position_m : ndarray, shape (N, 2)
    velocity_mps : ndarray, shape (N, 2)
        Current velocity.
    preferred_velocity_mps : ndarray, shape (N, 2)
        Preferred velocity (towards the goal at the preferred speed).
    """

    radius_m: FloatArray
    position_m: FloatArray
    velocity_mps: FloatArray
    preferred_velocity_mps: FloatArray

    def as_array(self) -> FloatArray:
        """The paper's per-pedestrian state ``[r, px, py, vx, vy, vpx, vpy]``, shape (N, 7)."""
        return np.hstack(
            [
                self.radius_m[:, None],
                self.position_m,
                self.velocity_mps,
                self.preferred_velocity_mps,
            ]
        )


def spawn_positions(
    rng: np.random.Generator,
    n: int,
    *,
    bounds: tuple[float, float, float, float],
    radius_m: float,
    scene: Scene2D,
    keep_out: FloatArray,
    keep_out_radius_m: float,
) -> FloatArray:
    """``n`` non-overlapping disc centres in ``bounds`` (xmin, xmax, ymin, ymax).

    A jittered grid of cell size >= ``2 * radius_m`` guarantees no overlap even at 3
    pedestrians/m^2; cells that touch the scene or a keep-out disc are dropped.
    """
    if n == 0:
        return np.zeros((0, 2))
    xmin, xmax, ymin, ymax = bounds
    area = (xmax - xmin) * (ymax - ymin)
    cell = max(2.0 * radius_m + 0.02, min(1.0, math.sqrt(area / (2.0 * n))))
    gx = np.arange(xmin + 0.5 * cell, xmax - 0.5 * cell + 1e-9, cell)
    gy = np.arange(ymin + 0.5 * cell, ymax - 0.5 * cell + 1e-9, cell)
    pts = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1).reshape(-1, 2)
    jitter = 0.5 * (cell - 2.0 * radius_m - 0.01)
    pts = pts + rng.uniform(-jitter, jitter, size=pts.shape)
    ok = np.ones(len(pts), dtype=bool)
    if keep_out.size:
        d = np.linalg.norm(pts[:, None, :] - keep_out[None, :, :], axis=2)
        ok &= d.min(axis=1) > keep_out_radius_m + radius_m
    if scene.circles_r.size:
        d = np.linalg.norm(pts[:, None, :] - scene.circles_xy[None, :, :], axis=2)
        ok &= (d - scene.circles_r[None, :]).min(axis=1) > radius_m + 0.05
    if scene.seg_a.shape[0]:
        ok &= point_segment_distance(pts, scene.seg_a, scene.seg_b).min(axis=1) > radius_m + 0.05
    pts = pts[ok]
    if len(pts) < n:
        raise Sim2RealValueError(
            f"cannot place {n} pedestrians of radius {radius_m} m in the free part of "
            f"{bounds} (room for {len(pts)}); lower the number or density of pedestrians"
        )
    return np.asarray(pts[rng.permutation(len(pts))[:n]])


class Crowd:
    """A crowd of disc pedestrians walking to random goals at the speed of eq. (1).

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws goals (use the env's ``np_random``).
    position_m : ndarray, shape (N, 2)
        Initial positions.
    radius_m, height_m, pref_speed_mps : ndarray, shape (N,)
        Disc radius, body height and preferred speed (0 = standing pedestrian).
    bounds : tuple
        (xmin, xmax, ymin, ymax) where goals are drawn, m.
    alpha : float or ndarray
        Stride constant(s) of eq. (1); ``beta`` is :data:`BETA`.
    start_time_s : ndarray, optional
        Pedestrians stand still until this time (pedestrians that appear "at random
        intervals" in the occluded scenario).
    goals : ndarray, optional
        First goals; random points in ``bounds`` by default.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> crowd = Crowd(rng, position_m=np.array([[0.0, 0.0]]), radius_m=np.array([0.2]),
    ...               height_m=np.array([1.72]), pref_speed_mps=np.array([1.3]),
    ...               bounds=(-5.0, 5.0, -5.0, 5.0))
    >>> crowd.step(0.1, Scene2D.build(), robot_xy=np.array([9.0, 9.0]), robot_radius_m=0.2)
    >>> round(float(np.linalg.norm(crowd.velocity_mps[0])), 2)
    1.3
    """

    def __init__(
        self,
        rng: np.random.Generator,
        *,
        position_m: FloatArray,
        radius_m: FloatArray,
        height_m: FloatArray,
        pref_speed_mps: FloatArray,
        bounds: tuple[float, float, float, float],
        alpha: FloatArray | float = ALPHA,
        start_time_s: FloatArray | None = None,
        goals: FloatArray | None = None,
    ) -> None:
        n = len(position_m)
        self._rng = rng
        self.bounds = bounds
        self.position_m = np.array(position_m, dtype=np.float64).reshape(n, 2)
        self.radius_m = np.asarray(radius_m, dtype=np.float64)
        self.height_m = np.asarray(height_m, dtype=np.float64)
        self.pref_speed_mps = np.asarray(pref_speed_mps, dtype=np.float64)
        self.alpha = np.broadcast_to(np.asarray(alpha, dtype=np.float64), (n,)).copy()
        self.start_time_s = np.zeros(n) if start_time_s is None else np.asarray(start_time_s)
        self.velocity_mps = np.zeros((n, 2))
        self.goals = self._random_goals(n) if goals is None else np.array(goals, dtype=float)
        self.time_s = 0.0

    def __len__(self) -> int:
        return int(self.position_m.shape[0])

    def _random_goals(self, n: int) -> FloatArray:
        xmin, xmax, ymin, ymax = self.bounds
        return np.column_stack([self._rng.uniform(xmin, xmax, n), self._rng.uniform(ymin, ymax, n)])

    @property
    def preferred_velocity_mps(self) -> FloatArray:
        """Preferred velocity: towards the goal at the preferred speed (0 before start)."""
        to_goal = self.goals - self.position_m
        dist = np.maximum(np.linalg.norm(to_goal, axis=1), 1e-9)
        speed = np.where(self.time_s >= self.start_time_s, self.pref_speed_mps, 0.0)
        return np.asarray(to_goal * (speed / dist)[:, None])

    def state(self) -> CrowdState:
        """Copy of the current state."""
        return CrowdState(
            radius_m=self.radius_m.copy(),
            position_m=self.position_m.copy(),
            velocity_mps=self.velocity_mps.copy(),
            preferred_velocity_mps=self.preferred_velocity_mps.copy(),
        )

    def free_space(
        self, headings_rad: FloatArray, scene: Scene2D, robot_xy: FloatArray, robot_radius_m: float
    ) -> FloatArray:
        """Gap (m) each pedestrian's centre can travel along each heading, shape (N, K).

        Other pedestrians and the robot are discs inflated by the walker's radius (exact);
        static obstacles use the centre ray's hit distance minus the own radius (exact
        head-on, slightly optimistic for grazing rays; :meth:`step` pushes out the rest).
        """
        others_xy = np.vstack([self.position_m, np.asarray(robot_xy, dtype=float).reshape(1, 2)])
        others_r = np.concatenate([self.radius_m, [float(robot_radius_m)]])
        out = np.empty(headings_rad.shape)
        _gaps_kernel(
            np.ascontiguousarray(self.position_m),
            np.ascontiguousarray(self.radius_m),
            np.ascontiguousarray(headings_rad, dtype=np.float64),
            others_xy,
            others_r,
            *scene.kernel_arrays(),
            out,
        )
        return out

    def step(
        self,
        dt_s: float,
        scene: Scene2D,
        *,
        robot_xy: FloatArray,
        robot_radius_m: float,
        robot_velocity_mps: FloatArray | None = None,
    ) -> None:
        """Advance every pedestrian by ``dt_s`` around the static ``scene`` and the robot.

        ``robot_velocity_mps`` is unused here (eq. (1) looks at free space only); the ORCA
        crowd (:class:`sim2real.envs.orca.OrcaCrowd`) needs it.
        """
        self.time_s += dt_s
        if len(self) == 0:
            return
        reached = np.linalg.norm(self.goals - self.position_m, axis=1) < _GOAL_REACHED_M
        if reached.any():
            self.goals[reached] = self._random_goals(int(reached.sum()))
        walking = (self.time_s >= self.start_time_s) & (self.pref_speed_mps > 0)
        robot = (np.asarray(robot_xy), float(robot_radius_m), robot_velocity_mps)
        self._walk(dt_s, scene, walking, robot)

    def _walk(
        self,
        dt_s: float,
        scene: Scene2D,
        walking: NDArray[np.bool_],
        robot: tuple[FloatArray, float, FloatArray | None],
    ) -> None:
        """Move the ``walking`` pedestrians by ``dt_s`` (eq. (1)); ``robot`` is its position,
        radius and velocity (of :meth:`step`)."""
        to_goal = self.goals - self.position_m
        goal_dir = np.arctan2(to_goal[:, 1], to_goal[:, 0])
        position = self.position_m.copy()
        velocity = np.empty((len(self), 2))
        robot_xy, robot_radius_m, _ = robot
        walk(
            position,
            velocity,
            self.radius_m,
            self.height_m,
            self.pref_speed_mps,
            self.alpha,
            walking,
            goal_dir,
            *scene.kernel_arrays(),
            float(robot_xy[0]),
            float(robot_xy[1]),
            robot_radius_m,
            float(dt_s),
        )
        self.velocity_mps = velocity
        self.position_m = position


@numba.njit(cache=True)
def _gaps_kernel(
    pos: FloatArray,
    rad: FloatArray,
    headings: FloatArray,
    oxy: FloatArray,
    orad: FloatArray,
    cxy: FloatArray,
    cr: FloatArray,
    sa: FloatArray,
    sb: FloatArray,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    """Free space of every pedestrian along each of its headings (see :meth:`Crowd.free_space`),
    body by body over the headings (the nearest hit does not depend on the order)."""
    n, k = headings.shape
    dx, dy = np.empty(k), np.empty(k)
    best, stat = np.empty(k), np.empty(k)
    for i in range(n):
        px, py, ri = pos[i, 0], pos[i, 1], rad[i]
        for j in range(k):
            dx[j], dy[j] = np.cos(headings[i, j]), np.sin(headings[i, j])
            best[j], stat[j] = 50.0, 50.0
        for o in range(oxy.shape[0]):  # pedestrians and the robot, inflated by ri
            if o == i:
                continue
            fx, fy = px - oxy[o, 0], py - oxy[o, 1]
            rr = orad[o] + ri
            q = fx * fx + fy * fy - rr * rr
            for j in range(k):
                b = dx[j] * fx + dy[j] * fy
                if q <= 0.0:
                    if b < 0.0:  # already touching and heading into it
                        best[j] = 0.0
                    continue
                if b >= 0.0:
                    continue
                disc = b * b - q
                if disc >= 0.0:
                    best[j] = min(best[j], -b - np.sqrt(disc))
        # static obstacles: ray_distance along each heading
        if cast_beams(px, py, 0.0, headings[i], False, dx, dy, cxy, cr, sa, sb, stat):
            stat[:] = 0.0
        for j in range(k):
            out[i, j] = min(best[j], max(stat[j] - ri, 0.0))


#: cos of the heading offsets and the tie-break penalty of the steering score (numpy's values)
_COS_OFFSETS = np.cos(_HEADING_OFFSETS)
_OFFSET_PENALTY = 1e-3 * np.abs(_HEADING_OFFSETS)


@numba.njit(cache=True)
def _walk_kernel(
    pos: FloatArray,
    vel: FloatArray,
    rad: FloatArray,
    height: FloatArray,
    pref: FloatArray,
    alpha: FloatArray,
    walking: NDArray[np.bool_],
    goal_dir: FloatArray,
    cxy: FloatArray,
    cr: FloatArray,
    sa: FloatArray,
    sb: FloatArray,
    robot_x: float,
    robot_y: float,
    robot_r: float,
    dt: float,
    offsets: FloatArray,
    cos_off: FloatArray,
    pen_off: FloatArray,
) -> None:  # pragma: no cover - compiled
    """One step of eq. (1) steering, separation and push-out for one crowd, in place.

    ``pos`` (N, 2) moves; ``vel`` (N, 2) gets the chosen velocities. The arithmetic is numpy's
    of the array formulation (sums in index order, as einsum adds), term by term.
    """
    n, k = pos.shape[0], offsets.shape[0]
    headings = np.empty((n, k))
    for i in range(n):
        for j in range(k):
            headings[i, j] = goal_dir[i] + offsets[j]
    oxy = np.empty((n + 1, 2))
    orad = np.empty(n + 1)
    for i in range(n):
        oxy[i, 0], oxy[i, 1], orad[i] = pos[i, 0], pos[i, 1], rad[i]
    oxy[n, 0], oxy[n, 1], orad[n] = robot_x, robot_y, robot_r
    gap = np.empty((n, k))
    _gaps_kernel(pos, rad, headings, oxy, orad, cxy, cr, sa, sb, gap)
    for i in range(n):
        h = height[i] / 1.72
        best, best_score, best_speed = 0, -np.inf, 0.0
        for j in range(k):
            g = gap[i, j]
            s = max(g + 2.0 * rad[i], 0.0)
            t = s * alpha[i] / (h * (1.0 + BETA))
            speed = min(min(pref[i], t * t), g / dt)
            score = speed * cos_off[j] - pen_off[j]
            if j == 0 or score > best_score:
                best, best_score, best_speed = j, score, speed
        v = best_speed if walking[i] else 0.0
        vel[i, 0] = v * np.cos(headings[i, best])
        vel[i, 1] = v * np.sin(headings[i, best])
    for i in range(n):
        pos[i, 0] = pos[i, 0] + vel[i, 0] * dt
        pos[i, 1] = pos[i, 1] + vel[i, 1] * dt
    _separate(pos, rad)
    _push_out(pos, rad, cxy, cr, sa, sb)


@numba.njit(cache=True)
def _separate(pos: FloatArray, rad: FloatArray) -> None:  # pragma: no cover - compiled
    """Push overlapping pedestrian pairs apart (half each), all from the same positions."""
    n = pos.shape[0]
    push = np.zeros((n, 2))
    hit = False
    for i in range(n):
        for j in range(n):
            if j == i:
                continue
            dx, dy = pos[i, 0] - pos[j, 0], pos[i, 1] - pos[j, 1]
            dist = np.sqrt(dx * dx + dy * dy)
            overlap = rad[i] + rad[j] - dist
            if overlap > 0.0:
                w = 0.5 * overlap / max(dist, 1e-9)
                push[i, 0] += w * dx
                push[i, 1] += w * dy
                hit = True
    if hit:
        for i in range(n):
            pos[i, 0] = pos[i, 0] + push[i, 0]
            pos[i, 1] = pos[i, 1] + push[i, 1]


@numba.njit(cache=True)
def _push_out(
    pos: FloatArray,
    rad: FloatArray,
    cxy: FloatArray,
    cr: FloatArray,
    sa: FloatArray,
    sb: FloatArray,
) -> None:  # pragma: no cover - compiled
    """Move pedestrians that touch a static circle, then a segment, out along its normal."""
    n = pos.shape[0]
    if cr.shape[0]:
        for i in range(n):
            ax, ay = 0.0, 0.0
            for c in range(cr.shape[0]):
                dx, dy = pos[i, 0] - cxy[c, 0], pos[i, 1] - cxy[c, 1]
                dist = max(np.sqrt(dx * dx + dy * dy), 1e-9)
                w = max(rad[i] + cr[c] - dist, 0.0) / dist
                ax += w * dx
                ay += w * dy
            pos[i, 0] = pos[i, 0] + ax
            pos[i, 1] = pos[i, 1] + ay
    if sa.shape[0]:
        for i in range(n):
            ax, ay = 0.0, 0.0
            for q in range(sa.shape[0]):
                ex, ey = sb[q, 0] - sa[q, 0], sb[q, 1] - sa[q, 1]
                px, py = pos[i, 0] - sa[q, 0], pos[i, 1] - sa[q, 1]
                s = (px * ex + py * ey) / max(ex * ex + ey * ey, 1e-12)
                s = min(max(s, 0.0), 1.0)
                dx, dy = px - s * ex, py - s * ey
                dist = max(np.sqrt(dx * dx + dy * dy), 1e-9)
                w = max(rad[i] - dist, 0.0) / dist
                ax += w * dx
                ay += w * dy
            pos[i, 0] = pos[i, 0] + ax
            pos[i, 1] = pos[i, 1] + ay


def walk(
    position_m: FloatArray,
    velocity_mps: FloatArray,
    radius_m: FloatArray,
    height_m: FloatArray,
    pref_speed_mps: FloatArray,
    alpha: FloatArray,
    walking: NDArray[np.bool_],
    goal_dir_rad: FloatArray,
    circles_xy: FloatArray,
    circles_r: FloatArray,
    seg_a: FloatArray,
    seg_b: FloatArray,
    robot_x_m: float,
    robot_y_m: float,
    robot_radius_m: float,
    dt_s: float,
) -> None:
    """One :meth:`Crowd.step` after the goals: steer, move, separate and push out, in place.

    ``position_m`` (N, 2) moves and ``velocity_mps`` (N, 2) gets the velocities;
    ``goal_dir_rad`` is each pedestrian's direction to its goal (numpy's ``arctan2``).
    """
    _walk_kernel(
        position_m,
        velocity_mps,
        radius_m,
        height_m,
        pref_speed_mps,
        alpha,
        walking,
        goal_dir_rad,
        circles_xy,
        circles_r,
        seg_a,
        seg_b,
        robot_x_m,
        robot_y_m,
        robot_radius_m,
        dt_s,
        _HEADING_OFFSETS,
        _COS_OFFSETS,
        _OFFSET_PENALTY,
    )


# _gaps_kernel inlines geometry.ray_distance: key the numba cache on both files
_jit.key_cache(_walk_kernel, {Path(__file__), Path(str(_geometry.__file__))})
