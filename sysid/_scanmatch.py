"""Point-to-line matching of two 2-D lidar scans (private).

:func:`match_scans` aligns the points of one scan onto those of another (Censi 2008,
point-to-line ICP): each source point pairs with its nearest target point, the residual is the
distance along the target's local normal (from its neighbours in beam order), and a
Gauss-Newton step on ``(dx, dy, dtheta)`` with trimmed pairs is repeated until it stalls.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from robots.arrays import FloatArray

__all__ = ["compose", "invert", "match_scans", "scan_points", "translation_conditioning"]

Pose = tuple[float, float, float]

_MIN_POINTS = 30


def scan_points(
    ranges_m: FloatArray, angles_rad: FloatArray, valid: NDArray[np.bool_]
) -> FloatArray:
    """The valid returns of one scan as points in the lidar frame, shape (N, 2), m."""
    r = ranges_m[valid]
    a = angles_rad[valid]
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def compose(a: Pose, b: Pose) -> Pose:
    """The pose ``a ∘ b`` (b expressed in a's frame), ``(x, y, theta)``."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def invert(a: Pose) -> Pose:
    """The inverse pose of ``a``."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2])


def _normals(q: FloatArray, max_gap_m: float) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Unit normals of target points from their neighbours in beam order, and which exist."""
    tangent = np.zeros_like(q)
    ok = np.zeros(q.shape[0], dtype=bool)
    if q.shape[0] >= 3:
        d = q[2:] - q[:-2]
        gap = np.hypot(d[:, 0], d[:, 1])
        good = (gap > 1e-6) & (gap < 2.0 * max_gap_m)
        tangent[1:-1][good] = d[good] / gap[good, None]
        ok[1:-1] = good
    return np.column_stack([-tangent[:, 1], tangent[:, 0]]), ok


def match_scans(
    source: FloatArray,
    target: FloatArray,
    guess: Pose,
    *,
    max_pair_m: float = 0.3,
    iterations: int = 30,
) -> Pose | None:
    """The pose of the source scan's frame in the target scan's frame, ``(x, y, theta)``.

    Parameters
    ----------
    source, target : ndarray, shape (N, 2)
        Points of the two scans in their own lidar frames, m, in beam order.
    guess : tuple
        Initial pose (e.g. from odometry), m and rad.
    max_pair_m : float
        Pairs further apart than this are ignored in the first step; the gate then shrinks
        to four times the median residual (at least 5 cm).
    iterations : int
        Most Gauss-Newton steps.

    Returns
    -------
    tuple or None
        The pose, or None when fewer than 30 points pair up (no overlap).

    Examples
    --------
    >>> import numpy as np
    >>> a = np.linspace(-1.0, 1.0, 200)
    >>> target = np.column_stack([np.full(200, 2.0), a])
    >>> target = np.vstack([target, np.column_stack([a + 1.0, np.full(200, 1.5)])])
    >>> source = target - [0.05, 0.02]
    >>> pose = match_scans(source, target, (0.0, 0.0, 0.0))
    >>> [round(v, 3) + 0.0 for v in pose]
    [0.05, 0.02, 0.0]
    """
    if source.shape[0] < _MIN_POINTS or target.shape[0] < _MIN_POINTS:
        return None
    normals, has_normal = _normals(target, max_pair_m)
    tree = cKDTree(target)
    x, y, th = guess
    gate = max_pair_m
    for _ in range(iterations):
        c, s = math.cos(th), math.sin(th)
        moved = source @ np.array([[c, s], [-s, c]]) + np.array([x, y])
        dist, idx = tree.query(moved, distance_upper_bound=gate)
        use = np.isfinite(dist)
        use[use] &= has_normal[idx[use]]
        if int(use.sum()) < _MIN_POINTS:
            return None
        p, n, q = moved[use], normals[idx[use]], target[idx[use]]
        resid = np.einsum("ij,ij->i", n, p - q)
        jac = np.column_stack([n[:, 0], n[:, 1], n[:, 1] * p[:, 0] - n[:, 0] * p[:, 1]])
        step = np.linalg.lstsq(jac, -resid, rcond=None)[0]
        dx, dy, dth = (float(v) for v in step)
        cd, sd = math.cos(dth), math.sin(dth)
        x, y = cd * x - sd * y + dx, sd * x + cd * y + dy
        th += dth
        gate = max(0.05, min(gate, 4.0 * float(np.median(np.abs(resid)))))
        if abs(dth) < 1e-6 and math.hypot(dx, dy) < 1e-6:
            break
    return (x, y, th)


def translation_conditioning(source: FloatArray, target: FloatArray, pose: Pose) -> float:
    """How well a match pins the translation: the smaller over the larger eigenvalue of the
    point-to-line information about ``(dx, dy)`` (0: a corridor, one direction free; 1: all
    directions alike)."""
    normals, has_normal = _normals(target, 0.3)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    moved = source @ np.array([[c, s], [-s, c]]) + np.array([pose[0], pose[1]])
    dist, idx = cKDTree(target).query(moved, distance_upper_bound=0.1)
    use = np.isfinite(dist)
    use[use] &= has_normal[idx[use]]
    n = normals[idx[use]]
    if n.shape[0] < _MIN_POINTS:
        return 0.0
    eig = np.linalg.eigvalsh(n.T @ n)
    return float(eig[0] / max(eig[1], 1e-12))
