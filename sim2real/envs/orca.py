r"""Optimal reciprocal collision avoidance (ORCA) for disc agents in the plane.

J. van den Berg, S. J. Guy, M. Lin and D. Manocha, "Reciprocal n-body collision avoidance",
Robotics Research (ISRR 2009), Springer Tracts in Advanced Robotics 70, 2011, pp. 3-19.
Implemented here from the paper, in double precision and compiled with numba. The tests check
one step against RVO2, the authors' C++ library (the ``pyrvo`` wheel compiles its sources; a
``[dev]`` dependency): between agents the velocities agree to RVO2's single precision, except
where RVO2's float32 "3-D linear program" leaves its own speed disc and ours keeps it.

For agent A and a neighbour B (relative position :math:`p = p_B - p_A`, combined radius
:math:`r = r_A + r_B`, time horizon :math:`\tau`) the velocity obstacle
:math:`VO^\tau_{A|B}` is the cone from the origin towards the disc :math:`D(p, r)`, cut off by
the disc :math:`D(p/\tau, r/\tau)`. With :math:`u` the vector from the relative velocity
:math:`v_A - v_B` to the closest point of the boundary of :math:`VO^\tau_{A|B}` and :math:`n`
the outward normal there (Sec. 4 of the paper), A's permitted velocities are the half-plane

.. math::

    ORCA^\tau_{A|B} = \{v \mid (v - (v_A + s\,u)) \cdot n \ge 0\}

with the share of responsibility :math:`s` = 1/2 against an agent that also runs ORCA and
:math:`s` = 1 against one that does not (a robot driven by something else). Agents that
already overlap use the cut-off disc of one time step instead of :math:`\tau` (Sec. 5.2).

The new velocity is the one closest to the preferred velocity inside all half-planes and the
speed disc :math:`|v| \le v_{max}`: a 2-D linear program solved by randomised incremental
construction (Sec. 5.2). When the half-planes have no common point, the velocity that
minimises the largest violation is taken (the paper's "3-D linear program": here solved as
a 2-D program on the bisectors of each violated constraint and the earlier ones).

Static walls (line segments) are our simplification, not the paper's obstacle velocity
obstacles: for the closest point :math:`c` of a segment at distance :math:`d` and unit normal
:math:`\hat n` from :math:`c` towards the agent, the agent may approach the wall no faster than
it closes the gap in :math:`\tau_{obs}`: :math:`v \cdot \hat n \ge -(d - r_A)/\tau_{obs}`.

Examples
--------
>>> import numpy as np
>>> from sim2real.envs.orca import OrcaAgents
>>> agents = OrcaAgents(position_m=np.array([[-2.0, 0.0], [2.0, 0.0]]),
...                     radius_m=np.array([0.3, 0.3]), max_speed_mps=np.array([1.0, 1.0]))
>>> goals = np.array([[2.0, 0.0], [-2.0, 0.0]])
>>> for _ in range(100):
...     agents.step(0.1, goals=goals)
>>> bool(np.allclose(agents.position_m, goals, atol=0.05))
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from sim2real._arrays import BoolArray
from sim2real.envs.geometry import FloatArray, Scene2D
from sim2real.envs.pedestrians import Crowd
from sim2real.errors import Sim2RealValueError

__all__ = ["KEEP_RIGHT_RAD", "OrcaAgents", "OrcaConfig", "OrcaCrowd", "orca_velocities"]

_EPS = 1e-9
#: Clockwise turn of every agent's preferred direction ("keep right"), rad.
KEEP_RIGHT_RAD = math.radians(2.0)


@dataclass(frozen=True, kw_only=True)
class OrcaConfig:
    """Parameters of ORCA (units in the names).

    Attributes
    ----------
    time_horizon_s : float
        :math:`\\tau`: velocities are collision-free against other agents for this long.
    obstacle_time_horizon_s : float
        :math:`\\tau_{obs}` for static walls.
    neighbor_dist_m : float
        Agents and walls farther than this (centre to centre / to the segment) are ignored.
    """

    time_horizon_s: float = 2.0
    obstacle_time_horizon_s: float = 0.5
    neighbor_dist_m: float = 5.0

    def __post_init__(self) -> None:
        for name in ("time_horizon_s", "obstacle_time_horizon_s", "neighbor_dist_m"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise Sim2RealValueError(
                    f"OrcaConfig.{name} must be a finite number > 0, got {value!r}"
                )


# ---------------------------------------------------------------------------- linear programs
# A half-plane is a row (qx, qy, nx, ny): the points x with (x - q) . n >= 0, |n| = 1.


@numba.njit(cache=True)
def _lp1(
    lines: FloatArray, i: int, radius: float, ox: float, oy: float, direction: bool
) -> tuple[bool, float, float]:  # pragma: no cover - compiled
    """Optimum on the boundary line of half-plane ``i`` subject to lines < i and the disc."""
    qx, qy, nx, ny = lines[i, 0], lines[i, 1], lines[i, 2], lines[i, 3]
    dx, dy = -ny, nx  # direction along the boundary
    b = qx * dx + qy * dy
    disc = b * b + radius * radius - (qx * qx + qy * qy)
    if disc < 0.0:
        return False, 0.0, 0.0  # the line misses the speed disc
    sq = math.sqrt(disc)
    t_lo, t_hi = -b - sq, -b + sq
    for j in range(i):
        mx, my, kx, ky = lines[j, 0], lines[j, 1], lines[j, 2], lines[j, 3]
        den = dx * kx + dy * ky
        num = (mx - qx) * kx + (my - qy) * ky  # need t * den >= num
        if abs(den) < _EPS:
            if num > _EPS:
                return False, 0.0, 0.0  # parallel and outside
            continue
        t = num / den
        if den > 0.0:
            t_lo = max(t_lo, t)
        else:
            t_hi = min(t_hi, t)
        if t_lo > t_hi:
            return False, 0.0, 0.0
    if direction:
        t = t_hi if ox * dx + oy * dy > 0.0 else t_lo
    else:
        t = min(max((ox - qx) * dx + (oy - qy) * dy, t_lo), t_hi)
    return True, qx + t * dx, qy + t * dy


@numba.njit(cache=True)
def _lp2(
    lines: FloatArray, count: int, radius: float, ox: float, oy: float, direction: bool
) -> tuple[int, float, float]:  # pragma: no cover - compiled
    """Closest point to (ox, oy) (or farthest along it, ``direction``) in all half-planes.

    Returns (index of the first infeasible half-plane or ``count``, x, y).
    """
    if direction:
        rx, ry = ox * radius, oy * radius
    else:
        norm = math.hypot(ox, oy)
        if norm > radius:
            rx, ry = ox / norm * radius, oy / norm * radius
        else:
            rx, ry = ox, oy
    for i in range(count):
        if (rx - lines[i, 0]) * lines[i, 2] + (ry - lines[i, 1]) * lines[i, 3] < -_EPS:
            ok, x, y = _lp1(lines, i, radius, ox, oy, direction)
            if not ok:
                return i, rx, ry
            rx, ry = x, y
    return count, rx, ry


@numba.njit(cache=True)
def _lp3(
    lines: FloatArray, count: int, begin: int, radius: float, rx: float, ry: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    """Velocity minimising the largest violation of half-planes ``begin``.. (earlier kept)."""
    worst = 0.0
    proj = np.empty((count, 4))
    for i in range(begin, count):
        qx, qy, nx, ny = lines[i, 0], lines[i, 1], lines[i, 2], lines[i, 3]
        if -((rx - qx) * nx + (ry - qy) * ny) <= worst + _EPS:
            continue
        k = 0
        for j in range(i):
            # points where line j is violated no more than line i:
            # x . (n_j - n_i) >= q_j . n_j - q_i . n_i
            mx, my = lines[j, 2] - nx, lines[j, 3] - ny
            norm = math.hypot(mx, my)
            if norm < _EPS:
                continue  # same direction: line i is the binding one
            off = (lines[j, 0] * lines[j, 2] + lines[j, 1] * lines[j, 3]) - (qx * nx + qy * ny)
            mx, my = mx / norm, my / norm
            off /= norm
            proj[k, 0], proj[k, 1], proj[k, 2], proj[k, 3] = mx * off, my * off, mx, my
            k += 1
        fail, x, y = _lp2(proj, k, radius, nx, ny, True)
        if fail == k:  # else rounding: keep the previous result
            rx, ry = x, y
        worst = -((rx - qx) * nx + (ry - qy) * ny)
    return rx, ry


# ---------------------------------------------------------------------------- ORCA lines


@numba.njit(cache=True)
def _agent_line(
    px: float,
    py: float,
    vx: float,
    vy: float,
    r: float,
    tau: float,
    dt: float,
) -> tuple[float, float, float, float]:  # pragma: no cover - compiled
    """(ux, uy, nx, ny) for relative position p, relative velocity v and combined radius r."""
    dist2 = px * px + py * py
    if dist2 > r * r:
        cx, cy, cr = px / tau, py / tau, r / tau
        wx, wy = vx - cx, vy - cy
        wl2 = wx * wx + wy * wy
        wp = wx * px + wy * py
        if wp < 0.0 and wp * wp > r * r * wl2:  # closest boundary point on the cut-off arc
            wl = math.sqrt(wl2)  # > 0 here, since wp < 0
            nx, ny = wx / wl, wy / wl
            return (cr - wl) * nx, (cr - wl) * ny, nx, ny
        leg = math.sqrt(dist2 - r * r)
        if px * wy - py * wx > 0.0:  # left leg (counter-clockwise of p)
            dx, dy = (px * leg - py * r) / dist2, (px * r + py * leg) / dist2
            nx, ny = -dy, dx
        else:  # right leg
            dx, dy = (px * leg + py * r) / dist2, (-px * r + py * leg) / dist2
            nx, ny = dy, -dx
        s = vx * dx + vy * dy
        return s * dx - vx, s * dy - vy, nx, ny
    # overlapping: leave the cut-off disc of one time step
    cx, cy, cr = px / dt, py / dt, r / dt
    wx, wy = vx - cx, vy - cy
    wl = math.hypot(wx, wy)
    if wl < _EPS:  # exactly at the centre: push straight back (or along x if coincident)
        wx, wy = -px, -py
        wl = math.hypot(wx, wy)
        if wl < _EPS:
            wx, wy, wl = 1.0, 0.0, 1.0
    nx, ny = wx / wl, wy / wl
    return (cr - wl) * nx, (cr - wl) * ny, nx, ny


@numba.njit(cache=True)
def _orca_kernel(
    pos: FloatArray,
    vel: FloatArray,
    rad: FloatArray,
    pref: FloatArray,
    vmax: FloatArray,
    active: NDArray[np.bool_],
    reciprocal: NDArray[np.bool_],
    seg_a: FloatArray,
    seg_b: FloatArray,
    tau: float,
    tau_obs: float,
    dt: float,
    neigh: float,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    n = pos.shape[0]
    n_seg = seg_a.shape[0]
    lines = np.empty((n + n_seg, 4))
    for i in range(n):
        if not active[i]:
            out[i, 0], out[i, 1] = vel[i, 0], vel[i, 1]
            continue
        k = 0
        for s in range(n_seg):
            ex, ey = seg_b[s, 0] - seg_a[s, 0], seg_b[s, 1] - seg_a[s, 1]
            ee = ex * ex + ey * ey
            t = 0.0
            if ee > 0.0:
                t = ((pos[i, 0] - seg_a[s, 0]) * ex + (pos[i, 1] - seg_a[s, 1]) * ey) / ee
                t = min(max(t, 0.0), 1.0)
            cx, cy = seg_a[s, 0] + t * ex, seg_a[s, 1] + t * ey
            gx, gy = pos[i, 0] - cx, pos[i, 1] - cy
            d = math.hypot(gx, gy)
            if d > neigh or d < _EPS:
                continue
            nx, ny = gx / d, gy / d
            gap = d - rad[i]
            bound = -gap / tau_obs if gap > 0.0 else -gap / dt
            lines[k, 0], lines[k, 1], lines[k, 2], lines[k, 3] = nx * bound, ny * bound, nx, ny
            k += 1
        for j in range(n):
            if j == i:
                continue
            px, py = pos[j, 0] - pos[i, 0], pos[j, 1] - pos[i, 1]
            if px * px + py * py > neigh * neigh:
                continue
            ux, uy, nx, ny = _agent_line(
                px,
                py,
                vel[i, 0] - vel[j, 0],
                vel[i, 1] - vel[j, 1],
                rad[i] + rad[j],
                tau,
                dt,
            )
            share = 0.5 if reciprocal[j] else 1.0
            lines[k, 0], lines[k, 1] = vel[i, 0] + share * ux, vel[i, 1] + share * uy
            lines[k, 2], lines[k, 3] = nx, ny
            k += 1
        fail, x, y = _lp2(lines, k, vmax[i], pref[i, 0], pref[i, 1], False)
        if fail < k:
            x, y = _lp3(lines, k, fail, vmax[i], x, y)
        out[i, 0], out[i, 1] = x, y


def _as2(a: FloatArray, n: int, what: str) -> FloatArray:
    arr = np.ascontiguousarray(a, dtype=np.float64)
    if arr.shape != (n, 2) or not np.all(np.isfinite(arr)):
        raise Sim2RealValueError(
            f"ORCA {what} must be {n} finite (x, y) rows, got shape {arr.shape}"
        )
    return arr


def _as1(a: FloatArray | float, n: int, what: str) -> FloatArray:
    arr = np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=np.float64), (n,)))
    if not (np.all(np.isfinite(arr)) and np.all(arr >= 0.0)):
        raise Sim2RealValueError(f"ORCA {what} must be finite numbers >= 0, got {a!r}")
    return arr


def orca_velocities(
    position_m: FloatArray,
    velocity_mps: FloatArray,
    radius_m: FloatArray,
    pref_velocity_mps: FloatArray,
    max_speed_mps: FloatArray,
    dt_s: float,
    *,
    config: OrcaConfig | None = None,
    active: BoolArray | None = None,
    reciprocal: BoolArray | None = None,
    walls: tuple[FloatArray, FloatArray] | None = None,
) -> FloatArray:
    """New velocities of all agents, shape (N, 2), m/s.

    Parameters
    ----------
    position_m, velocity_mps, pref_velocity_mps : ndarray, shape (N, 2)
        Positions, current velocities and preferred velocities.
    radius_m, max_speed_mps : ndarray, shape (N,)
        Disc radii and speed limits.
    dt_s : float
        Time step (used for agents that already overlap).
    config : OrcaConfig, optional
        Horizons and neighbour distance.
    active : ndarray of bool, optional
        Agents that choose a velocity (others keep theirs: e.g. the robot); default all.
    reciprocal : ndarray of bool, optional
        Agents that run ORCA too (share 1/2 of the avoidance); default ``active``.
    walls : (seg_a, seg_b), optional
        Static wall segments, shape (S, 2) each.
    """
    cfg = config if config is not None else OrcaConfig()
    pos = np.ascontiguousarray(position_m, dtype=np.float64)
    n = pos.shape[0] if pos.ndim == 2 else -1
    pos = _as2(pos, max(n, 0), "positions")
    vel = _as2(velocity_mps, n, "velocities")
    pref = _as2(pref_velocity_mps, n, "preferred velocities")
    rad = _as1(radius_m, n, "radii")
    vmax = _as1(max_speed_mps, n, "max speeds")
    if not (math.isfinite(dt_s) and dt_s > 0):
        raise Sim2RealValueError(f"ORCA dt_s must be a finite number > 0, got {dt_s!r}")
    act = np.ones(n, dtype=bool) if active is None else np.asarray(active, dtype=bool)
    rec = act if reciprocal is None else np.asarray(reciprocal, dtype=bool)
    if walls is None:
        sa, sb = np.zeros((0, 2)), np.zeros((0, 2))
    else:
        sa = np.ascontiguousarray(walls[0], dtype=np.float64).reshape(-1, 2)
        sb = np.ascontiguousarray(walls[1], dtype=np.float64).reshape(-1, 2)
    out = np.empty((n, 2))
    _orca_kernel(
        pos,
        vel,
        rad,
        pref,
        vmax,
        np.ascontiguousarray(act),
        np.ascontiguousarray(rec),
        sa,
        sb,
        float(cfg.time_horizon_s),
        float(cfg.obstacle_time_horizon_s),
        float(dt_s),
        float(cfg.neighbor_dist_m),
        out,
    )
    return out


class OrcaAgents:
    """A group of disc agents that walk to goals with ORCA (holonomic, velocity-controlled).

    Parameters
    ----------
    position_m : ndarray, shape (N, 2)
        Initial positions.
    radius_m, max_speed_mps : ndarray, shape (N,)
        Radii and speed limits (the preferred speed).
    config : OrcaConfig, optional
        Horizons and neighbour distance.

    Examples
    --------
    >>> import numpy as np
    >>> a = OrcaAgents(position_m=np.zeros((1, 2)), radius_m=np.array([0.3]),
    ...                max_speed_mps=np.array([1.0]))
    >>> a.step(0.5, goals=np.array([[10.0, 0.0]]))
    >>> a.position_m.round(3).tolist()  # 2 degrees to the right of the goal (keep right)
    [[0.5, -0.017]]
    """

    def __init__(
        self,
        *,
        position_m: FloatArray,
        radius_m: FloatArray,
        max_speed_mps: FloatArray,
        config: OrcaConfig | None = None,
    ) -> None:
        self.position_m = np.array(position_m, dtype=np.float64).reshape(-1, 2)
        n = self.position_m.shape[0]
        self.radius_m = _as1(radius_m, n, "radii").copy()
        self.max_speed_mps = _as1(max_speed_mps, n, "max speeds").copy()
        self.velocity_mps = np.zeros((n, 2))
        self.config = config if config is not None else OrcaConfig()

    def __len__(self) -> int:
        return int(self.position_m.shape[0])

    def preferred_velocity(self, goals: FloatArray, dt_s: float) -> FloatArray:
        """Towards each goal at the max speed, slowing to arrive exactly within one step.

        The direction is turned by :data:`KEEP_RIGHT_RAD` clockwise: exactly symmetric
        head-on encounters are a known dead-lock of ORCA (both agents only slow down), and a
        shared "keep right" bias breaks the symmetry the way pedestrians do.
        """
        to_goal = np.asarray(goals, dtype=np.float64) - self.position_m
        dist = np.linalg.norm(to_goal, axis=1)
        speed = np.minimum(self.max_speed_mps, dist / dt_s)
        c, s = math.cos(KEEP_RIGHT_RAD), math.sin(KEEP_RIGHT_RAD)
        d = to_goal * (speed / np.maximum(dist, _EPS))[:, None]
        bias = np.where((dist > self.radius_m)[:, None], 1.0, 0.0)  # none on the last stretch
        turned = np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
        return np.asarray(bias * turned + (1.0 - bias) * d)

    def step(
        self,
        dt_s: float,
        *,
        goals: FloatArray | None = None,
        pref_velocity_mps: FloatArray | None = None,
        others_xy: FloatArray | None = None,
        others_velocity_mps: FloatArray | None = None,
        others_radius_m: FloatArray | None = None,
        walls: tuple[FloatArray, FloatArray] | None = None,
    ) -> None:
        """Choose ORCA velocities and move every agent by ``dt_s``.

        ``others_*`` are non-reciprocating discs (e.g. the robot): the agents take the whole
        avoidance against them. Give either ``goals`` or ``pref_velocity_mps``.
        """
        n = len(self)
        if pref_velocity_mps is None:
            if goals is None:
                raise Sim2RealValueError("OrcaAgents.step needs goals or pref_velocity_mps")
            pref = self.preferred_velocity(goals, dt_s)
        else:
            pref = np.asarray(pref_velocity_mps, dtype=np.float64).reshape(n, 2)
        oxy = np.zeros((0, 2)) if others_xy is None else np.asarray(others_xy).reshape(-1, 2)
        m = oxy.shape[0]
        ov = np.zeros((m, 2)) if others_velocity_mps is None else np.asarray(others_velocity_mps)
        orad = np.zeros(m) if others_radius_m is None else np.asarray(others_radius_m)
        new = orca_velocities(
            np.vstack([self.position_m, oxy]),
            np.vstack([self.velocity_mps, ov.reshape(m, 2)]),
            np.concatenate([self.radius_m, np.asarray(orad, dtype=float).reshape(m)]),
            np.vstack([pref, ov.reshape(m, 2)]),
            np.concatenate([self.max_speed_mps, np.zeros(m)]),  # others keep their velocity
            dt_s,
            config=self.config,
            active=np.concatenate([np.ones(n, dtype=bool), np.zeros(m, dtype=bool)]),
            walls=walls,
        )
        self.velocity_mps = new[:n]
        self.position_m = self.position_m + self.velocity_mps * dt_s


class OrcaCrowd(Crowd):
    """Pedestrians of :class:`~sim2real.envs.pedestrians.Crowd` that walk with ORCA instead.

    Same state, goals and start times as the eq. (1) crowd; each step every walking pedestrian
    takes the ORCA velocity towards its goal at its preferred speed, avoiding the other
    pedestrians (reciprocally), the robot (fully: it does not run ORCA), static cylinders (as
    standing discs) and walls. Standing pedestrians (preferred speed 0) stay put.
    """

    config: OrcaConfig = OrcaConfig(time_horizon_s=2.0, neighbor_dist_m=4.0)

    def _walk(
        self,
        dt_s: float,
        scene: Scene2D,
        walking: BoolArray,
        robot: tuple[FloatArray, float, FloatArray | None],
    ) -> None:
        """The ORCA step of :meth:`Crowd.step` (the robot moves at its velocity, zero if not
        given)."""
        agents = OrcaAgents(
            position_m=self.position_m,
            radius_m=self.radius_m,
            max_speed_mps=np.where(walking, self.pref_speed_mps, 0.0),
            config=self.config,
        )
        agents.velocity_mps = self.velocity_mps
        robot_xy, robot_radius_m, robot_velocity_mps = robot
        rv = np.zeros(2) if robot_velocity_mps is None else np.asarray(robot_velocity_mps)
        m = scene.circles_r.shape[0]
        agents.step(
            dt_s,
            goals=self.goals,
            others_xy=np.vstack([robot_xy.reshape(1, 2), scene.circles_xy]),
            others_velocity_mps=np.vstack([rv.reshape(1, 2), np.zeros((m, 2))]),
            others_radius_m=np.concatenate([[robot_radius_m], scene.circles_r]),
            walls=(scene.seg_a, scene.seg_b),
        )
        self.velocity_mps = agents.velocity_mps
        self.position_m = agents.position_m
