r"""Exact depth images of a 2.5-D world (upright cylinders and boxes on a flat floor) in numpy.

Every body of the env worlds is a vertical extrusion of a disc or a rectangle, so a pixel's
ray :math:`e + t\,d` first meets a body either through its side (the 2-D ray/circle or
ray/rectangle entry, if the height there is in :math:`[0, h]`) or, when the camera is above
the body, through its top face (the plane :math:`z = h` between the 2-D entry and exit), or
else the floor :math:`z = 0`. The camera ray of pixel (row i, column j) is
:math:`d = R\,[1,\; -u_j \tan(\mathrm{hfov}/2),\; -v_i \tan(\mathrm{vfov}/2)]^T` with
:math:`u_j = 2j/W - 1`, :math:`v_i = 2(i+1)/H - 1` (pybullet's TinyRenderer sampling), so :math:`t` is directly the depth
along the optical axis (what a depth camera reports). It matches pybullet's rasteriser
(``getCameraImage``) to within the rasteriser's cylinder tessellation; see the tests and
``benchmarks/bench_envs.py`` for the agreement and the speed-up.

Examples
--------
>>> import numpy as np
>>> from sim2real.envs.depth import DepthScene, render_depth
>>> scene = DepthScene.build(cylinders=[(2.0, 0.0, 0.5, 1.0)])
>>> img = render_depth(scene, eye=np.array([0.0, 0.0, 0.3]), rotation=np.eye(3),
...                    width=8, height=6, hfov_deg=60.0, near_m=0.05, far_m=8.0)
>>> round(float(img[3, 4]), 2)
1.5
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numba
import numpy as np

from sim2real.envs.geometry import FloatArray

__all__ = [
    "DepthCamera",
    "DepthScene",
    "camera_frame",
    "camera_rays",
    "render_depth",
    "render_frame",
    "rpy_matrix",
    "world_rays",
]


@dataclass(frozen=True, kw_only=True)
class DepthScene:
    """Bodies for the depth renderer.

    Attributes
    ----------
    cylinders : ndarray, shape (C, 4)
        ``(x, y, r, h)`` of upright cylinders standing on the floor, m.
    boxes : ndarray, shape (B, 6)
        ``(cx, cy, length, width, yaw, h)`` of upright boxes, m and rad.
    """

    cylinders: FloatArray
    boxes: FloatArray

    @classmethod
    def build(
        cls,
        *,
        cylinders: Sequence[Sequence[float]] | FloatArray = (),
        boxes: Sequence[Sequence[float]] | FloatArray = (),
    ) -> DepthScene:
        """Scene from ``(x, y, r, h)`` cylinders and ``(cx, cy, l, w, yaw, h)`` boxes."""
        return cls(
            cylinders=np.asarray(cylinders, dtype=np.float64).reshape(-1, 4),
            boxes=np.asarray(boxes, dtype=np.float64).reshape(-1, 6),
        )


def camera_rays(width: int, height: int, hfov_deg: float) -> FloatArray:
    """Camera-frame pixel rays (x forward = 1, y left, z up), shape (height * width, 3)."""
    tan_h = math.tan(math.radians(hfov_deg) / 2.0)
    tan_v = tan_h * height / width
    # pybullet's TinyRenderer samples at u_j = 2 j / W - 1, v_i = 2 (i + 1) / H - 1; we do the
    # same so that images agree with getCameraImage pixel for pixel
    u = 2.0 * np.arange(width) / width - 1.0
    v = 2.0 * (np.arange(height) + 1.0) / height - 1.0
    vv, uu = np.meshgrid(v, u, indexing="ij")
    rays = np.stack([np.ones_like(uu), -uu * tan_h, -vv * tan_v], axis=-1)
    return np.asarray(rays.reshape(-1, 3))


@numba.njit(cache=True)
def _side_or_cap(
    ez: float, dz: float, t_in: float, t_out: float, h: float, best: float
) -> float:  # pragma: no cover - compiled
    """First hit of a ray on an extrusion of height h given its 2-D entry/exit (or best)."""
    z = ez + t_in * dz
    if 0.0 <= z <= h:
        return min(best, t_in)
    if ez > h and dz < 0.0:
        t_cap = (h - ez) / dz
        if t_in <= t_cap <= t_out:
            return min(best, t_cap)
    return best


@numba.njit(cache=True)
def _cylinder_span(
    ex: float, ey: float, dx: float, dy: float, a: float, cyl: FloatArray
) -> tuple[float, float]:  # pragma: no cover - compiled
    """2-D entry and exit (ray parameters) of the ray from (ex, ey) along (dx, dy), with
    ``a = dx^2 + dy^2``, into the circle ``cyl = (x, y, r, ...)``; entry > exit: no hit."""
    fx, fy = ex - cyl[0], ey - cyl[1]
    b = dx * fx + dy * fy
    q = fx * fx + fy * fy - cyl[2] * cyl[2]
    if b >= 0.0 and q > 0.0:  # outside and heading away
        return np.inf, -np.inf
    disc = b * b - a * q
    if disc < 0.0:
        return np.inf, -np.inf
    root = np.sqrt(disc)
    t_out = (-b + root) / a
    if t_out <= 0.0:
        return np.inf, -np.inf
    return max((-b - root) / a, 0.0), t_out


@numba.njit(cache=True)
def _box_span(
    ex: float, ey: float, dx: float, dy: float, a: float, box: FloatArray
) -> tuple[float, float]:  # pragma: no cover - compiled
    """:func:`_cylinder_span` for the box ``(cx, cy, half_l, half_w, cos, sin, h, r_bound)``:
    a slab test in the box frame after a cheap reject with the bounding circle."""
    px, py = ex - box[0], ey - box[1]
    b = dx * px + dy * py
    q = px * px + py * py - box[7] * box[7]
    if q > 0.0 and (b >= 0.0 or b * b < a * q):
        return np.inf, -np.inf
    co, si = box[4], box[5]
    lx, ly = co * px + si * py, -si * px + co * py
    ldx, ldy = co * dx + si * dy, -si * dx + co * dy
    t_in, t_out = 0.0, np.inf
    for o, v, half in ((lx, ldx, box[2]), (ly, ldy, box[3])):
        if abs(v) < 1e-15:
            if abs(o) > half:
                return np.inf, -np.inf
        else:
            t1, t2 = (-half - o) / v, (half - o) / v
            if t1 > t2:
                t1, t2 = t2, t1
            t_in, t_out = max(t_in, t1), min(t_out, t2)
    return t_in, t_out


@numba.njit(cache=True)
def _render_rays(
    eye: FloatArray, d: FloatArray, cyl: FloatArray, boxes: FloatArray, out: FloatArray
) -> None:  # pragma: no cover - compiled
    """Every ray against every body (any camera orientation)."""
    ex, ey, ez = eye[0], eye[1], eye[2]
    for i in range(d.shape[0]):
        dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
        best = np.inf
        if dz < 0.0:
            best = -ez / dz
        a = dx * dx + dy * dy
        if a < 1e-18:
            out[i] = best
            continue
        for c in range(cyl.shape[0]):
            t_in, t_out = _cylinder_span(ex, ey, dx, dy, a, cyl[c])
            if t_in <= t_out and t_in < best:
                best = _side_or_cap(ez, dz, t_in, t_out, cyl[c, 3], best)
        for k in range(boxes.shape[0]):
            t_in, t_out = _box_span(ex, ey, dx, dy, a, boxes[k])
            if t_in <= t_out and t_in < best:
                best = _side_or_cap(ez, dz, t_in, t_out, boxes[k, 6], best)
        out[i] = best


@numba.njit(cache=True)
def _columns_are_vertical(d: FloatArray, width: int) -> bool:  # pragma: no cover - compiled
    """Whether every ray of each image column (pixels ``i * width + j``) has the same (x, y)."""
    for k in range(width, d.shape[0]):
        if d[k, 0] != d[k - width, 0] or d[k, 1] != d[k - width, 1]:
            return False
    return True


@numba.njit(cache=True)
def _render_columns(
    eye: FloatArray, d: FloatArray, cyl: FloatArray, boxes: FloatArray, width: int, out: FloatArray
) -> None:  # pragma: no cover - compiled
    """:func:`_render_rays` for a camera whose image columns are vertical planes (no pitch or
    roll): the 2-D entry and exit of a column's rays into each body depend on the column only,
    so they are computed once per column, with the same arithmetic as per ray, and each ray
    then only picks its side or top face (the image is the same to the bit)."""
    ex, ey, ez = eye[0], eye[1], eye[2]
    n_rows = d.shape[0] // width
    n_bodies = cyl.shape[0] + boxes.shape[0]
    hit_in = np.empty(n_bodies)
    hit_out = np.empty(n_bodies)
    hit_h = np.empty(n_bodies)
    for j in range(width):
        dx, dy = d[j, 0], d[j, 1]
        a = dx * dx + dy * dy
        n_hit = 0
        if a >= 1e-18:
            for c in range(cyl.shape[0]):
                t_in, t_out = _cylinder_span(ex, ey, dx, dy, a, cyl[c])
                if t_in <= t_out:
                    hit_in[n_hit], hit_out[n_hit], hit_h[n_hit] = t_in, t_out, cyl[c, 3]
                    n_hit += 1
            for k in range(boxes.shape[0]):
                t_in, t_out = _box_span(ex, ey, dx, dy, a, boxes[k])
                if t_in <= t_out:
                    hit_in[n_hit], hit_out[n_hit], hit_h[n_hit] = t_in, t_out, boxes[k, 6]
                    n_hit += 1
        # nearest entry first: a body entered beyond a ray's best hit cannot change it (every
        # hit on it lies at or beyond its entry), so each ray stops there
        for m in range(1, n_hit):
            t_in, t_out, h = hit_in[m], hit_out[m], hit_h[m]
            q = m - 1
            while q >= 0 and hit_in[q] > t_in:
                hit_in[q + 1], hit_out[q + 1], hit_h[q + 1] = hit_in[q], hit_out[q], hit_h[q]
                q -= 1
            hit_in[q + 1], hit_out[q + 1], hit_h[q + 1] = t_in, t_out, h
        for i in range(n_rows):
            r = i * width + j
            dz = d[r, 2]
            best = np.inf
            if dz < 0.0:
                best = -ez / dz
            for m in range(n_hit):
                if not hit_in[m] < best:
                    break
                best = _side_or_cap(ez, dz, hit_in[m], hit_out[m], hit_h[m], best)
            out[r] = best


@numba.njit(cache=True)
def world_rays(rays: FloatArray, rotation: FloatArray) -> FloatArray:  # pragma: no cover - compiled
    """``rays @ rotation.T`` with each row's three products summed in index order (the same
    numbers on every machine, unlike a BLAS product)."""
    d = np.empty((rays.shape[0], 3))
    for p in range(rays.shape[0]):
        for a in range(3):
            d[p, a] = rays[p, 0] * rotation[a, 0] + rays[p, 1] * rotation[a, 1]
            d[p, a] += rays[p, 2] * rotation[a, 2]
    return d


@numba.njit(cache=True)
def _level(rays: FloatArray, rotation: FloatArray, width: int) -> bool:  # pragma: no cover
    """Whether the world rays' columns are vertical for sure: the rotation keeps the camera's
    z out of the world's x and y, and each image column's camera rays share their (x, y)
    (then :func:`_columns_are_vertical` holds for ``world_rays(rays, rotation)``)."""
    if rotation[0, 2] != 0.0 or rotation[1, 2] != 0.0 or rays.shape[0] % width != 0:
        return False
    return _columns_are_vertical(rays, width)


@numba.njit(cache=True)
def render_frame(
    eye: FloatArray,
    rotation: FloatArray,
    rays: FloatArray,
    cyl: FloatArray,
    boxes: FloatArray,
    near: float,
    far: float,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    """Depth image ``out`` (height, width) clipped to [near, far]: the camera-frame ``rays``
    turned into the world by ``rotation`` (sums in index order), then cast from ``eye``
    (``boxes`` packed by ``_packed_boxes``); the native vector env calls it per sub-env with
    the pose of :func:`camera_frame`."""
    height, width = out.shape
    flat = np.empty(rays.shape[0])
    if _level(rays, rotation, width):
        # what the per-column renderer reads of world_rays: the first row's (x, y), every z
        d = np.empty((rays.shape[0], 3))
        for p in range(rays.shape[0]):
            if p < width:
                for a in range(2):
                    d[p, a] = rays[p, 0] * rotation[a, 0] + rays[p, 1] * rotation[a, 1]
                    d[p, a] += rays[p, 2] * rotation[a, 2]
            d[p, 2] = rays[p, 0] * rotation[2, 0] + rays[p, 1] * rotation[2, 1]
            d[p, 2] += rays[p, 2] * rotation[2, 2]
        _render_columns(eye, d, cyl, boxes, width, flat)
    else:
        d = world_rays(rays, rotation)
        if d.shape[0] % width == 0 and _columns_are_vertical(d, width):
            _render_columns(eye, d, cyl, boxes, width, flat)
        else:
            _render_rays(eye, d, cyl, boxes, flat)
    for i in range(height):
        for j in range(width):
            out[i, j] = min(max(flat[i * width + j], near), far)


@numba.njit(cache=True)
def camera_frame(
    x: float, y: float, yaw: float, base_height: float, xyz: FloatArray, r_mount: FloatArray
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover - compiled
    """Camera position (m) and world-from-camera rotation for a base at (x, y, yaw) carrying
    the camera at ``xyz`` (base frame) turned by ``r_mount``; products summed in index order."""
    cy, sy = math.cos(yaw), math.sin(yaw)
    # rpy_matrix(0, 0, yaw)
    r_base = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    eye = np.empty(3)
    base = (x, y, base_height)
    rot = np.empty((3, 3))
    for a in range(3):
        eye[a] = base[a] + (r_base[a, 0] * xyz[0] + r_base[a, 1] * xyz[1] + r_base[a, 2] * xyz[2])
        for b in range(3):
            rot[a, b] = (
                r_base[a, 0] * r_mount[0, b]
                + r_base[a, 1] * r_mount[1, b]
                + r_base[a, 2] * r_mount[2, b]
            )
    return eye, rot


def _packed_boxes(boxes: FloatArray) -> FloatArray:
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 6)
    return np.column_stack(
        [
            b[:, 0],
            b[:, 1],
            0.5 * b[:, 2],
            0.5 * b[:, 3],
            np.cos(b[:, 4]),
            np.sin(b[:, 4]),
            b[:, 5],
            0.5 * np.hypot(b[:, 2], b[:, 3]),
        ]
    )


def render_depth(
    scene: DepthScene,
    *,
    eye: FloatArray,
    rotation: FloatArray,
    width: int,
    height: int,
    hfov_deg: float,
    near_m: float,
    far_m: float,
    rays: FloatArray | None = None,
) -> FloatArray:
    """Depth image (m along the optical axis), shape (height, width); no return reads far_m.

    Parameters
    ----------
    scene : DepthScene
        The bodies (the floor z = 0 is implicit).
    eye : ndarray, shape (3,)
        Camera position in the world, m.
    rotation : ndarray, shape (3, 3)
        World-from-camera rotation; columns are the camera's x (optical axis), y (left) and
        z (up) axes.
    width, height, hfov_deg, near_m, far_m
        Image size (pixels), horizontal field of view (degrees) and clip range (m).
    rays : ndarray, optional
        Cached :func:`camera_rays` for this size and FOV.
    """
    cam = camera_rays(width, height, hfov_deg) if rays is None else rays
    out = np.empty((height, width))
    render_frame(
        np.asarray(eye, dtype=np.float64).reshape(3),
        np.ascontiguousarray(rotation, dtype=np.float64).reshape(3, 3),
        np.ascontiguousarray(cam, dtype=np.float64),
        np.ascontiguousarray(scene.cylinders, dtype=np.float64).reshape(-1, 4),
        _packed_boxes(scene.boxes),
        float(near_m),
        float(far_m),
        out,
    )
    return out


def rpy_matrix(roll: float, pitch: float, yaw: float) -> FloatArray:
    """Rotation matrix R = Rz(yaw) Ry(pitch) Rx(roll) (fixed-axis roll-pitch-yaw)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


class DepthCamera:
    """A depth camera mounted on a planar base; the mount pose can change at run time.

    Parameters
    ----------
    width, height : int
        Image size, pixels.
    hfov_deg : float
        Horizontal field of view, degrees.
    near_m, far_m : float
        Clip range, m; pixels with no return read ``far_m``.
    xyz_m, rpy_rad : sequence of 3 floats
        Mount pose of the camera body frame (x along the optical axis, z up) in the base
        frame, m and rad.
    base_height_m : float
        Height of the base frame above the floor, m.

    Examples
    --------
    >>> cam = DepthCamera(width=8, height=6, hfov_deg=60.0, near_m=0.05, far_m=8.0,
    ...                   xyz_m=(0.0, 0.0, 0.3), rpy_rad=(0.0, 0.0, 0.0), base_height_m=0.0)
    >>> img = cam.render(DepthScene.build(boxes=[(3.0, 0.0, 0.2, 4.0, 0.0, 1.0)]), 0.0, 0.0, 0.0)
    >>> round(float(img[2, 4]), 2)
    2.9
    """

    def __init__(
        self,
        *,
        width: int,
        height: int,
        hfov_deg: float,
        near_m: float,
        far_m: float,
        xyz_m: Sequence[float],
        rpy_rad: Sequence[float],
        base_height_m: float,
    ) -> None:
        self.width, self.height = int(width), int(height)
        self.hfov_deg = float(hfov_deg)
        self.near_m, self.far_m = float(near_m), float(far_m)
        self.base_height_m = float(base_height_m)
        self._rays = camera_rays(self.width, self.height, self.hfov_deg)
        self.set_pose(xyz_m, rpy_rad)
        self.view_matrix: FloatArray = np.eye(4).reshape(-1)

    def set_pose(
        self, xyz_m: Sequence[float] | FloatArray, rpy_rad: Sequence[float] | FloatArray
    ) -> None:
        """Mount pose in the base frame (m, rad)."""
        self.xyz_m = np.asarray(xyz_m, dtype=np.float64).reshape(3).copy()
        self.rpy_rad = np.asarray(rpy_rad, dtype=np.float64).reshape(3).copy()
        self._r_mount = rpy_matrix(*self.rpy_rad)

    def world_pose(self, x: float, y: float, yaw: float) -> tuple[FloatArray, FloatArray]:
        """Camera position (m) and world-from-camera rotation for the base at (x, y, yaw)."""
        eye, rot = camera_frame(
            float(x), float(y), float(yaw), self.base_height_m, self.xyz_m, self._r_mount
        )
        return np.asarray(eye), np.asarray(rot)

    def update_view(self, x: float, y: float, yaw: float) -> FloatArray:
        """pybullet's column-major view matrix (16 floats) for the base at (x, y, yaw)."""
        from robots._pybullet import pybullet as p

        eye, rot = self.world_pose(x, y, yaw)
        target = eye + rot[:, 0]
        view = p.computeViewMatrix(eye.tolist(), target.tolist(), rot[:, 2].tolist())
        self.view_matrix = np.asarray(view, dtype=np.float64)
        return self.view_matrix

    def render(self, scene: DepthScene, x: float, y: float, yaw: float) -> FloatArray:
        """Depth image (m along the optical axis), shape (height, width)."""
        self.update_view(x, y, yaw)
        eye, rot = self.world_pose(x, y, yaw)
        out = np.empty((self.height, self.width))
        cyl = np.ascontiguousarray(scene.cylinders, dtype=np.float64).reshape(-1, 4)
        boxes = _packed_boxes(scene.boxes)
        render_frame(eye, rot, self._rays, cyl, boxes, self.near_m, self.far_m, out)
        return out
