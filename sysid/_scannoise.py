"""Range residuals of a matched scan pair: the noise seen while the sensor moves (private).

:func:`pair_residuals` moves the returns of one scan into the frame of another with the matched
pose (refined here by weighted least squares on these residuals) and compares each moved
return's range with the other scan's range at the same bearing, linearly interpolated between
the two beams on either side (weight ``w``). With independent range noise of standard
deviation :math:`\\sigma(r)` on every return the residual's variance is
:math:`\\sigma(\\rho)^2 (1 + (1 - w)^2 + w^2)`. Returns are compared only where both scans see
one surface around them (no range jump or invalid return within a beam either side), which
leaves out the grazing returns at an object's silhouette.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robots.arrays import BoolArray, FloatArray
from sysid.steady import robust_sd

__all__ = ["PairResiduals", "pair_residuals"]

PairResiduals = tuple[FloatArray, FloatArray, FloatArray]
Pose = tuple[float, float, float]

_JUMP_M = 0.15
_JUMP_PER_M = 0.05
_MIN_RETURNS = 30
_REFINE_STEPS = 3
_STEP = (1e-4, 1e-4, 1e-5)


def _one_surface(ranges_m: FloatArray, ok: BoolArray, full: bool) -> BoolArray:
    """Per beam: it and the next beam are valid without a range jump between them."""
    nxt = np.roll(ranges_m, -1)
    with np.errstate(invalid="ignore"):
        jump = np.abs(ranges_m - nxt) > _JUMP_M + _JUMP_PER_M * np.minimum(ranges_m, nxt)
    edge = ok & np.roll(ok, -1) & ~jump
    if not full:
        edge[-1] = False
    return edge


@dataclass(frozen=True)
class _Compare:
    """Source returns (range, beam angle) against a target scan with the same beam angles."""

    target_m: FloatArray
    target_edge: BoolArray
    angles_rad: FloatArray
    full: bool
    r: FloatArray
    a: FloatArray

    def moved(self, pose: Pose) -> tuple[FloatArray, FloatArray]:
        """The returns in the target frame, m."""
        return pose[0] + self.r * np.cos(self.a + pose[2]), pose[1] + self.r * np.sin(
            self.a + pose[2]
        )

    def segments(self, pose: Pose) -> tuple[_Compare, NDArray[np.intp]]:
        """The returns that fall between two target beams on one surface (whose neighbours
        are on it too), with the first of those beams as ``k``."""
        beams = self.angles_rad.size
        inc = float(self.angles_rad[1] - self.angles_rad[0])
        px, py = self.moved(pose)
        u = (np.arctan2(py, px) - self.angles_rad[0]) / inc
        if self.full:
            u = np.mod(u, beams)
        k = np.floor(u).astype(np.intp)
        inside = np.flatnonzero((k >= 0) & (k < (beams if self.full else beams - 1)))
        k = k[inside]
        e = self.target_edge
        same = e[k] & e[(k - 1) % beams] & e[(k + 1) % beams]
        keep = inside[same]
        return dataclasses.replace(self, r=self.r[keep], a=self.a[keep]), k[same]

    def residuals(
        self, k: NDArray[np.intp], pose: Pose
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Range in the target frame, that range minus the target's range interpolated at
        the same bearing between beams ``k`` and ``k + 1``, and the variance factor."""
        px, py = self.moved(pose)
        rho = np.hypot(px, py)
        inc = float(self.angles_rad[1] - self.angles_rad[0])
        w = np.mod(np.arctan2(py, px) - self.angles_rad[k], 2.0 * math.pi) / inc
        w = np.where(w > 1.5, w - 2.0 * math.pi / inc, w)
        t = self.target_m
        resid = rho - ((1.0 - w) * t[k] + w * t[(k + 1) % t.size])
        return rho, resid, 1.0 + (1.0 - w) ** 2 + w**2

    def refine(self, k: NDArray[np.intp], pose: Pose) -> Pose:
        """Gauss-Newton steps on the pose minimising the squared residuals over their
        factors (residuals beyond three robust standard deviations left out of each step)."""
        p = np.array(pose, dtype=np.float64)
        for _ in range(_REFINE_STEPS):
            _, d, f = self.residuals(k, (p[0], p[1], p[2]))
            z = d / np.sqrt(f)
            w = np.where(np.abs(z) <= 3.0 * robust_sd(z, about=0.0), 1.0 / f, 0.0)
            jac = np.empty((d.size, 3))
            for c in range(3):
                q = p.copy()
                q[c] += _STEP[c]
                jac[:, c] = (self.residuals(k, (q[0], q[1], q[2]))[1] - d) / _STEP[c]
            sw = np.sqrt(w)
            p -= np.linalg.lstsq(jac * sw[:, None], d * sw, rcond=None)[0]
        return (float(p[0]), float(p[1]), float(p[2]))


def pair_residuals(
    target_m: FloatArray,
    target_ok: BoolArray,
    source_m: FloatArray,
    source_ok: BoolArray,
    angles_rad: FloatArray,
    pose: Pose,
) -> PairResiduals:
    """Residuals of the source scan's returns against the target scan.

    Parameters
    ----------
    target_m, source_m : ndarray, shape (beams,)
        Ranges of the two scans, m.
    target_ok, source_ok : ndarray of bool
        Which returns are valid.
    angles_rad : ndarray, shape (beams,)
        Beam angles (evenly spaced, increasing), rad.
    pose : tuple
        The source scan's frame in the target scan's frame ``(x, y, theta)``, m and rad (a
        scan match: the residuals are scaled by :math:`\\sqrt{n / (n - 3)}` for its three
        fitted parameters).

    Returns
    -------
    range_m, residual_m, factor : ndarray
        Per compared return: its range in the target frame, the range minus the target's
        interpolated range (m), and the residual's variance over :math:`\\sigma^2`.

    Examples
    --------
    >>> import numpy as np
    >>> ang = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    >>> r = np.full(360, 2.0)  # inside a circle of 2 m radius
    >>> ok = np.ones(360, bool)
    >>> rho, d, f = pair_residuals(r, ok, r, ok, ang, (0.0, 0.0, 0.01))
    >>> bool(np.all(np.abs(d) < 1e-4) and np.all((f >= 1.5) & (f <= 2.0)))
    True
    """
    inc = float(angles_rad[1] - angles_rad[0])
    full = abs(angles_rad.size * inc - 2.0 * math.pi) < 1.5 * abs(inc)
    edge = _one_surface(source_m, source_ok, full)
    inner = edge & np.roll(edge, 1) & np.roll(edge, 2) & np.roll(edge, -1)
    every = _Compare(
        target_m=target_m,
        target_edge=_one_surface(target_m, target_ok, full),
        angles_rad=angles_rad,
        full=full,
        r=source_m[inner],
        a=angles_rad[inner],
    )
    some, k = every.segments(pose)
    if k.size > _MIN_RETURNS:
        pose = some.refine(k, pose)
        some, k = every.segments(pose)
    rho, d, f = some.residuals(k, pose)
    if d.size <= _MIN_RETURNS:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    return rho, d * math.sqrt(d.size / (d.size - 3.0)), f
