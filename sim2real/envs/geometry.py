r"""Exact 2-D geometry of the env worlds: ray casting and distances against discs and segments.

The worlds of :mod:`sim2real.envs` are vertical extrusions (cylinders, walls, pedestrian discs)
on a flat floor, so a horizontal 2-D lidar sees exactly the 2-D cross-section: casting rays
against circles and line segments in the plane is exact, and vectorised numpy does it about
two orders of magnitude faster than pybullet's ``rayTestBatch`` (see
``benchmarks/bench_envs.py``).

A ray :math:`p + t\,d` (:math:`|d| = 1`) meets the circle :math:`|x - c| = r` at the smaller
root :math:`t = -b - \sqrt{b^2 - q}` with :math:`b = (p - c)\cdot d`,
:math:`q = |p - c|^2 - r^2`, and the segment :math:`a + s\,e` (:math:`s \in [0, 1]`) at
:math:`t = ((a - p)\times e)/(d \times e)`, :math:`s = ((a - p)\times d)/(d \times e)`.

Examples
--------
>>> import numpy as np
>>> from sim2real.envs.geometry import Scene2D, cast_rays
>>> scene = Scene2D.build(circles=[(2.0, 0.0, 0.5)])
>>> cast_rays(scene, np.zeros(2), np.array([0.0, np.pi]), max_range_m=5.0).round(3)
array([1.5, 5. ])
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "FloatArray",
    "Scene2D",
    "cast_beams",
    "cast_rays",
    "cast_rays_multi",
    "cast_rays_numpy",
    "disc_clearance",
    "distance_bearing",
    "nearest_relative_states",
    "point_segment_distance",
    "ray_distance",
    "rectangle_corners",
    "rectangle_segments",
    "segment_distance",
    "wrap_angle",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True, kw_only=True)
class Scene2D:
    """Obstacles of a 2-D world: circles and line segments (walls are 4 segments each).

    Attributes
    ----------
    circles_xy : ndarray, shape (C, 2)
        Circle centres, m.
    circles_r : ndarray, shape (C,)
        Circle radii, m.
    seg_a, seg_b : ndarray, shape (S, 2)
        Segment end points, m.
    """

    circles_xy: FloatArray
    circles_r: FloatArray
    seg_a: FloatArray
    seg_b: FloatArray

    @classmethod
    def build(
        cls,
        *,
        circles: Sequence[tuple[float, float, float]] = (),
        segments: Sequence[tuple[float, float, float, float]] = (),
    ) -> Scene2D:
        """Scene from ``(x, y, r)`` circles and ``(ax, ay, bx, by)`` segments."""
        c = np.asarray(circles, dtype=np.float64).reshape(-1, 3)
        s = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
        return cls(
            circles_xy=c[:, :2].copy(), circles_r=c[:, 2].copy(), seg_a=s[:, :2], seg_b=s[:, 2:]
        )

    def kernel_arrays(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """``(circles_xy, circles_r, seg_a, seg_b)`` as the compiled kernels take them:
        contiguous float64, shapes (C, 2), (C,), (S, 2), (S, 2) (empty scenes included)."""
        return (
            np.ascontiguousarray(self.circles_xy, dtype=np.float64).reshape(-1, 2),
            np.ascontiguousarray(self.circles_r, dtype=np.float64),
            np.ascontiguousarray(self.seg_a, dtype=np.float64).reshape(-1, 2),
            np.ascontiguousarray(self.seg_b, dtype=np.float64).reshape(-1, 2),
        )

    def with_circles(self, xy: FloatArray, r: FloatArray) -> Scene2D:
        """The same segments plus extra circles (e.g. pedestrians at the current step)."""
        return Scene2D(
            circles_xy=np.concatenate([self.circles_xy, np.asarray(xy).reshape(-1, 2)]),
            circles_r=np.concatenate([self.circles_r, np.asarray(r).reshape(-1)]),
            seg_a=self.seg_a,
            seg_b=self.seg_b,
        )


def wrap_angle(a: float) -> float:
    """Angle wrapped to (-pi, pi], rad."""
    return math.atan2(math.sin(a), math.cos(a))


def distance_bearing(xy: FloatArray, yaw: float, target: FloatArray) -> tuple[float, float]:
    """Distance (m) and bearing (rad, from the heading, counter-clockwise, in (-pi, pi]) of
    ``target`` seen from a base at ``xy`` heading ``yaw``.

    Examples
    --------
    >>> d, b = distance_bearing(np.array([0.0, 0.0]), 0.0, np.array([0.0, 2.0]))
    >>> round(d, 3), round(b, 4)
    (2.0, 1.5708)
    """
    d = target - xy
    return float(np.hypot(*d)), wrap_angle(math.atan2(d[1], d[0]) - yaw)


def rectangle_corners(
    cx: float, cy: float, length_m: float, width_m: float, yaw_rad: float
) -> FloatArray:
    """The corners of a rectangle centred at (cx, cy), ``length_m`` along its heading
    ``yaw_rad``, shape (4, 2), m: front left, rear left, rear right, front right.

    Examples
    --------
    >>> rectangle_corners(1.0, 0.0, 2.0, 1.0, 0.0).tolist()
    [[2.0, 0.5], [0.0, 0.5], [0.0, -0.5], [2.0, -0.5]]
    """
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    hl, hw = 0.5 * length_m, 0.5 * width_m
    local = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
    return np.asarray(local @ np.array([[c, s], [-s, c]]) + np.array([cx, cy]))


def rectangle_segments(
    cx: float, cy: float, length_m: float, width_m: float, yaw_rad: float
) -> FloatArray:
    """The four sides ``(ax, ay, bx, by)`` of a rectangle centred at (cx, cy), shape (4, 4)."""
    corners = rectangle_corners(cx, cy, length_m, width_m, yaw_rad)
    return np.hstack([corners, corners[[1, 2, 3, 0]]])


def cast_rays_multi(
    scene: Scene2D, origins: FloatArray, directions: FloatArray, max_range_m: float
) -> FloatArray:
    """Distance along each ray ``origins[i] + t * directions[i]`` to the first obstacle.

    Parameters
    ----------
    scene : Scene2D
        The obstacles.
    origins, directions : ndarray, shape (R, 2)
        Ray origins (m) and unit directions.
    max_range_m : float
        Returned where a ray hits nothing closer.

    Returns
    -------
    ndarray, shape (R,)
        Hit distances in m, ``0`` for an origin inside a circle.
    """
    best = np.full(origins.shape[0], float(max_range_m))
    if scene.circles_r.size:
        f = origins[:, None, :] - scene.circles_xy[None, :, :]  # (R, C, 2)
        b = np.einsum("rck,rk->rc", f, directions)
        q = np.einsum("rck,rck->rc", f, f) - scene.circles_r[None, :] ** 2
        disc = b * b - q
        with np.errstate(invalid="ignore"):
            t = -b - np.sqrt(disc)
        t = np.where(q <= 0.0, 0.0, t)  # origin inside the circle
        ok = (disc >= 0.0) & (t >= 0.0)
        best = np.minimum(best, np.where(ok, t, np.inf).min(axis=1))
    if scene.seg_a.shape[0]:
        e = scene.seg_b - scene.seg_a  # (S, 2)
        ap = scene.seg_a[None, :, :] - origins[:, None, :]  # (R, S, 2)
        denom = directions[:, None, 0] * e[None, :, 1] - directions[:, None, 1] * e[None, :, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (ap[..., 0] * e[None, :, 1] - ap[..., 1] * e[None, :, 0]) / denom
            s = (ap[..., 0] * directions[:, None, 1] - ap[..., 1] * directions[:, None, 0]) / denom
        ok = (denom != 0.0) & (t >= 0.0) & (s >= 0.0) & (s <= 1.0)
        best = np.minimum(best, np.where(ok, t, np.inf).min(axis=1))
    return best


@numba.njit(cache=True, inline="always")
def ray_distance(
    ox: float,
    oy: float,
    dx: float,
    dy: float,
    cxy: FloatArray,
    cr: FloatArray,
    sa: FloatArray,
    sb: FloatArray,
    max_range: float,
) -> float:  # pragma: no cover - compiled
    """Distance from (ox, oy) along the unit direction (dx, dy) to the nearest circle or segment.

    Circles are ``cxy`` (C, 2) with radii ``cr``; segments run from ``sa`` to ``sb`` (S, 2).
    Returns 0 when the origin is inside a circle and ``max_range`` when nothing is hit.
    A compiled helper for numba kernels (the lidar here, the pedestrians' free space).
    """
    best = max_range
    for c in range(cr.shape[0]):
        fx, fy = ox - cxy[c, 0], oy - cxy[c, 1]
        q = fx * fx + fy * fy - cr[c] * cr[c]
        if q <= 0.0:
            return 0.0
        b = dx * fx + dy * fy
        if b >= 0.0:
            continue
        disc = b * b - q
        if disc >= 0.0:
            best = min(best, -b - np.sqrt(disc))
    for k in range(sa.shape[0]):
        ex, ey = sb[k, 0] - sa[k, 0], sb[k, 1] - sa[k, 1]
        denom = dx * ey - dy * ex
        if denom == 0.0:
            continue
        apx, apy = sa[k, 0] - ox, sa[k, 1] - oy
        t_num, u_num = apx * ey - apy * ex, apx * dy - apy * dx
        if segment_missed(t_num, u_num, denom):
            continue
        t = t_num / denom
        u = u_num / denom
        if 0.0 <= t < best and 0.0 <= u <= 1.0:
            best = t
    return best


#: Numerators below this size are left to the division (a quotient could round to -0.0).
_TINY = 1e-200


@numba.njit(cache=True, inline="always")
def segment_missed(t_num: float, u_num: float, denom: float) -> bool:  # pragma: no cover
    """Whether a ray misses a segment for sure, before dividing: ``t = t_num / denom < 0``,
    ``u = u_num / denom < 0`` or ``|u| > 1`` by a margin no rounding of the quotients can
    cross (then ``0 <= t`` and ``0 <= u <= 1`` fail too; otherwise the caller divides)."""
    if denom > 0.0:
        if t_num < -_TINY or u_num < -_TINY:
            return True
    elif t_num > _TINY or u_num > _TINY:
        return True
    return abs(u_num) > abs(denom) * 1.000001


@numba.njit(cache=True)
def segment_distance(
    x: float, y: float, ax: float, ay: float, bx: float, by: float
) -> float:  # pragma: no cover - compiled
    """Distance from (x, y) to the segment a-b (point_segment_distance's arithmetic)."""
    ex, ey = bx - ax, by - ay
    ee = max(ex * ex + ey * ey, 1e-300)
    apx, apy = x - ax, y - ay
    s = min(max((apx * ex + apy * ey) / ee, 0.0), 1.0)
    dx, dy = apx - s * ex, apy - s * ey
    return float(np.sqrt(dx * dx + dy * dy))


#: Margin (m) within which a segment counts as passing through a ray's origin.
_ON_SEGMENT_M = 1e-6
#: Margin (rad) around the directions under which an obstacle is seen: beams outside cannot
#: hit it (rounding moves a hit test by ~1e-15 rad).
_CULL_MARGIN_RAD = 1e-6


@numba.njit(cache=True)
def _beam_spans(
    beams: FloatArray, lo: float, hi: float, spans: IntArray
) -> int:  # pragma: no cover - compiled
    """Index ranges of the sorted body-frame ``beams`` within [lo, hi] (rad, taken modulo
    2 pi): writes (start, stop) rows into ``spans``, returns their count."""
    count = 0
    two_pi = 2.0 * math.pi
    for shift in range(-2, 3):
        k0 = np.searchsorted(beams, lo + shift * two_pi, side="left")
        k1 = np.searchsorted(beams, hi + shift * two_pi, side="right")
        if k0 < k1:
            spans[count, 0], spans[count, 1] = k0, k1
            count += 1
    return count


@numba.njit(cache=True)
def _wrap(a: float) -> float:  # pragma: no cover - compiled
    return math.atan2(math.sin(a), math.cos(a))


@numba.njit(cache=True)
def cast_beams(
    ox: float,
    oy: float,
    yaw: float,
    beams: FloatArray,
    sorted_beams: bool,
    dx: FloatArray,
    dy: FloatArray,
    cxy: FloatArray,
    cr: FloatArray,
    sa: FloatArray,
    sb: FloatArray,
    best: FloatArray,
) -> bool:  # pragma: no cover - compiled
    """:func:`ray_distance` from one origin along every beam (unit directions ``dx``, ``dy``), obstacle by
    obstacle over the beams under which the obstacle is seen (all beams if ``beams`` are not
    sorted): the same per-beam arithmetic, and the nearest hit does not depend on the order.
    ``best`` starts at the range; returns True (and leaves ``best``) if the origin lies inside
    a circle (every beam then reads 0)."""
    nb = beams.shape[0]
    spans = np.empty((5, 2), dtype=np.int64)
    for c in range(cr.shape[0]):
        fx, fy = ox - cxy[c, 0], oy - cxy[c, 1]
        q = fx * fx + fy * fy - cr[c] * cr[c]
        if q <= 0.0:
            return True
    for c in range(cr.shape[0]):
        fx, fy = ox - cxy[c, 0], oy - cxy[c, 1]
        q = fx * fx + fy * fy - cr[c] * cr[c]
        n_spans = 1
        spans[0, 0], spans[0, 1] = 0, nb
        if sorted_beams:
            mid = _wrap(math.atan2(-fy, -fx) - yaw)
            half = math.asin(min(cr[c] / math.sqrt(fx * fx + fy * fy), 1.0)) + _CULL_MARGIN_RAD
            n_spans = _beam_spans(beams, mid - half, mid + half, spans)
        for m in range(n_spans):
            for k in range(spans[m, 0], spans[m, 1]):
                b = dx[k] * fx + dy[k] * fy
                if b >= 0.0:
                    continue
                disc = b * b - q
                if disc >= 0.0:
                    best[k] = min(best[k], -b - np.sqrt(disc))
    for g in range(sa.shape[0]):
        ex, ey = sb[g, 0] - sa[g, 0], sb[g, 1] - sa[g, 1]
        apx, apy = sa[g, 0] - ox, sa[g, 1] - oy
        t_num = apx * ey - apy * ex
        n_spans = 1
        spans[0, 0], spans[0, 1] = 0, nb
        if sorted_beams:
            a_dir = _wrap(math.atan2(apy, apx) - yaw)
            span = _wrap(math.atan2(sb[g, 1] - oy, sb[g, 0] - ox) - math.atan2(apy, apx))
            near = segment_distance(ox, oy, sa[g, 0], sa[g, 1], sb[g, 0], sb[g, 1])
            if near > _ON_SEGMENT_M and abs(span) < math.pi - 1e-3:
                lo = a_dir + min(span, 0.0) - _CULL_MARGIN_RAD
                hi = a_dir + max(span, 0.0) + _CULL_MARGIN_RAD
                n_spans = _beam_spans(beams, lo, hi, spans)
        for m in range(n_spans):
            for k in range(spans[m, 0], spans[m, 1]):
                denom = dx[k] * ey - dy[k] * ex
                if denom == 0.0:
                    continue
                u_num = apx * dy[k] - apy * dx[k]
                if segment_missed(t_num, u_num, denom):
                    continue
                t = t_num / denom
                u = u_num / denom
                if 0.0 <= t < best[k] and 0.0 <= u <= 1.0:
                    best[k] = t
    return False


@numba.njit(cache=True)
def _cast_kernel(
    ox: float,
    oy: float,
    angles: FloatArray,
    cxy: FloatArray,
    cr: FloatArray,
    sa: FloatArray,
    sb: FloatArray,
    max_range: float,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    for i in range(angles.shape[0]):
        out[i] = ray_distance(
            ox, oy, np.cos(angles[i]), np.sin(angles[i]), cxy, cr, sa, sb, max_range
        )


def cast_rays(
    scene: Scene2D, origin: FloatArray, angles_rad: FloatArray, max_range_m: float
) -> FloatArray:
    """Distances from one ``origin`` along world-frame ``angles_rad`` (a lidar scan), m.

    A compiled loop with early rejection (numba); :func:`cast_rays_numpy` is the same
    computation vectorised in numpy, and the tests check that they agree.
    """
    o = np.asarray(origin, dtype=np.float64).reshape(2)
    ang = np.ascontiguousarray(angles_rad, dtype=np.float64)
    out = np.empty(ang.shape[0])
    _cast_kernel(
        float(o[0]),
        float(o[1]),
        ang,
        *scene.kernel_arrays(),
        float(max_range_m),
        out,
    )
    return out


def cast_rays_numpy(
    scene: Scene2D, origin: FloatArray, angles_rad: FloatArray, max_range_m: float
) -> FloatArray:
    """:func:`cast_rays` vectorised in numpy (outer products over rays x obstacles)."""
    dx, dy = np.cos(angles_rad), np.sin(angles_rad)
    o = np.asarray(origin, dtype=np.float64).reshape(2)
    best = np.full(dx.shape[0], float(max_range_m))
    if scene.circles_r.size:
        fx, fy = o[0] - scene.circles_xy[:, 0], o[1] - scene.circles_xy[:, 1]
        q = fx * fx + fy * fy - scene.circles_r**2
        # cull circles whose nearest point |c - o| - r lies beyond the range (the tangent
        # length sqrt(|c - o|^2 - r^2) is longer and culled circles a ray still reaches)
        near = np.sqrt(fx * fx + fy * fy) - scene.circles_r < max_range_m
        fx, fy, q = fx[near], fy[near], q[near]
        b = np.outer(dx, fx) + np.outer(dy, fy)
        disc = b * b - q
        with np.errstate(invalid="ignore"):
            t = np.where(q <= 0.0, 0.0, -b - np.sqrt(disc))
        t = np.where((disc >= 0.0) & (t >= 0.0), t, np.inf)
        if t.shape[1]:
            best = np.minimum(best, t.min(axis=1))
    if scene.seg_a.shape[0]:
        ex, ey = (scene.seg_b - scene.seg_a).T
        apx, apy = (scene.seg_a - o).T
        denom = np.outer(dx, ey) - np.outer(dy, ex)
        num_t = apx * ey - apy * ex
        num_s = np.outer(dy, apx) - np.outer(dx, apy)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = num_t / denom
            s = num_s / denom
        ok = (denom != 0.0) & (t >= 0.0) & (s >= 0.0) & (s <= 1.0)
        best = np.minimum(best, np.where(ok, t, np.inf).min(axis=1))
    return best


def point_segment_distance(p: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Distance from points ``p`` (P, 2) to segments ``a``-``b`` (S, 2); shape (P, S), m."""
    e = b - a
    ee = np.maximum(np.einsum("sk,sk->s", e, e), 1e-300)
    ap = p[:, None, :] - a[None, :, :]
    s = np.clip(np.einsum("psk,sk->ps", ap, e) / ee, 0.0, 1.0)
    d = ap - s[..., None] * e[None, :, :]
    result: FloatArray = np.sqrt(np.einsum("psk,psk->ps", d, d))
    return result


def disc_clearance(scene: Scene2D, xy: FloatArray, radius_m: float) -> float:
    """Gap between a disc (centre ``xy``, ``radius_m``) and the nearest obstacle, m.

    Negative when they overlap; ``inf`` for an empty scene.
    """
    p = np.asarray(xy, dtype=np.float64).reshape(1, 2)
    gap = np.inf
    if scene.circles_r.size:
        d = np.hypot(*(scene.circles_xy - p).T) - scene.circles_r
        gap = min(gap, float(d.min()))
    if scene.seg_a.shape[0]:
        gap = min(gap, float(point_segment_distance(p, scene.seg_a, scene.seg_b).min()))
    return gap - radius_m


def nearest_relative_states(
    xy: FloatArray,
    yaw_rad: float,
    velocity_xy_mps: FloatArray,
    others_xy: FloatArray,
    others_velocity_mps: FloatArray,
    slots: int,
) -> FloatArray:
    """The ``slots`` nearest movers relative to a robot, in its frame, shape (slots, 4).

    Each row is (x, y [m], vx, vy [m/s]): a mover's position and its velocity minus the
    robot's, rotated into the robot's frame; nearest first, zero rows where there are fewer
    movers (a real mover never sits exactly at the robot's centre).

    Examples
    --------
    >>> rows = nearest_relative_states(np.zeros(2), math.pi / 2, np.zeros(2),
    ...                                np.array([[0.0, 2.0], [1.0, 0.0]]), np.zeros((2, 2)), 3)
    >>> rows.round(6).tolist()
    [[0.0, -1.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]]
    """
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    rel = np.asarray(others_xy, dtype=np.float64).reshape(-1, 2) - np.asarray(xy)
    vel = np.asarray(others_velocity_mps, dtype=np.float64).reshape(-1, 2) - velocity_xy_mps
    order = np.argsort(np.hypot(rel[:, 0], rel[:, 1]), kind="stable")[:slots]
    rot = np.array([[c, s], [-s, c]])
    out = np.zeros((slots, 4))
    out[: len(order), :2] = rel[order] @ rot.T
    out[: len(order), 2:] = vel[order] @ rot.T
    return out
