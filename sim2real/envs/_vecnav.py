"""Compiled kernels of the native vector envs: N reduced-dynamics robots stepped in one call.

Every per-env computation here is the single env's, operation for operation, so that a vector
env and N single envs with the same seeds give the same numbers:

- the drive: :class:`robots.reduced.ReducedDrive` (command history, transport delay, the shared
  kernel through :func:`robots.reduced._advance_history`) inside the kinematic pose integration
  of :class:`sim2real.envs._robot.ReducedBackend`;
- the lidar: :func:`sim2real.envs.geometry.ray_distance` from the mount of
  :meth:`sim2real.envs._nav.NavEnvBase._lidar_ranges`, against each env's own obstacles (held
  padded to a common count, with the count per env);
- the goal (distance and bearing) and the clearance of :func:`sim2real.envs.geometry.disc_clearance`;
- CrowdNav's eq. (1) pedestrians (:meth:`sim2real.envs.pedestrians.Crowd.step`: the clock and
  goals here, then the single env's kernel ``_walk_kernel``; new goals are drawn in Python from
  each env's own generator) and depth images (:func:`sim2real.envs.depth.camera_frame` and
  :func:`~sim2real.envs.depth.render_frame`).

The lidar casts each obstacle only along the beams it can be seen under
(:func:`sim2real.envs.geometry.cast_beams`): the same per-beam arithmetic as
:func:`~sim2real.envs.geometry.ray_distance`, whose nearest hit does not depend on the order.
This module's numba cache is keyed on the sources of every kernel it calls
(:func:`robots._jit.key_cache`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np

import robots._kernel
import robots.reduced
from robots import _jit
from robots.reduced import _advance_history
from sim2real.envs import _robot, depth, geometry, pedestrians
from sim2real.envs._robot import arc_step
from sim2real.envs.depth import camera_frame, render_frame
from sim2real.envs.geometry import FloatArray, cast_beams, segment_distance
from sim2real.envs.pedestrians import _walk_kernel

#: the single env's pose integration, compiled: one source for both
_arc_step = numba.njit(cache=True)(arc_step)

__all__ = [
    "Crowds",
    "Drives",
    "Episodes",
    "Readings",
    "crowd_clock",
    "finish_crowd_nav",
    "finish_random_map",
    "history_rows",
    "move_robots",
    "render_depths",
    "sense",
    "walk_crowds",
]

IntArray = np.ndarray


def history_rows(max_delay_s: float, substep_s: float) -> int:
    """Command-history rows per env that always leave room after a compaction.

    A compaction keeps the commands of the last ``delay + 1 s`` (see
    :meth:`robots.reduced.ReducedDrive._compact_history`); one row is added per sub-step.
    """
    return max(256, math.ceil((max_delay_s + 1.0) / substep_s) + 64)


class Drives(NamedTuple):
    """The reduced drive models of a vector env's robots, row ``i`` for env ``i``: one kernel
    argument.

    Row ``i`` holds what :class:`robots.reduced.ReducedDrive` holds of env ``i``'s robot; the
    split of a control step is :class:`sim2real.envs._robot.ReducedBackend`'s (the same for
    every env). The kernels change the arrays in place.

    Attributes
    ----------
    state : ndarray
        (N, 6) ``[v, w, ref_v, ref_w, ir, il]``: m/s, rad/s, m/s, rad/s, rad, rad.
    hist : ndarray
        (N, rows, 3) command history: time (s), v (m/s), w (rad/s).
    n_hist : ndarray
        (N,) rows of ``hist`` in use (int64).
    time_s : ndarray
        (N,) drive clocks, s.
    delay_s, timeout_s : ndarray
        (N,) command delays and command time-outs, s.
    packed : ndarray
        (N, P) drive parameters as the drive kernel reads them (``ReducedDrive._packed``).
    n_sub : int
        Pose sub-steps per control step.
    sub_s : float
        One pose sub-step, s.
    n_inner : int
        Drive-model steps per pose sub-step.
    inner_s : float
        One drive-model step, s.

    Examples
    --------
    >>> import numpy as np
    >>> d = Drives(state=np.zeros((2, 6)), hist=np.zeros((2, 256, 3)),
    ...            n_hist=np.zeros(2, np.int64), time_s=np.zeros(2), delay_s=np.zeros(2),
    ...            timeout_s=np.full(2, 0.5), packed=np.zeros((2, 20)), n_sub=1, sub_s=0.1,
    ...            n_inner=10, inner_s=0.01)
    >>> d.state.shape
    (2, 6)
    """

    state: FloatArray
    hist: FloatArray
    n_hist: IntArray
    time_s: FloatArray
    delay_s: FloatArray
    timeout_s: FloatArray
    packed: FloatArray
    n_sub: int
    sub_s: float
    n_inner: int
    inner_s: float


class Readings(NamedTuple):
    """What :func:`sense` gives of each env's robot (row ``i`` for env ``i``).

    Attributes
    ----------
    ranges : ndarray
        (N, beams) lidar ranges, m.
    goal_polar : ndarray
        (N, 2) goal distance (m) and bearing (rad) in the robot frame.
    clearance : ndarray
        (N,) gap between the robot's footprint disc and the nearest obstacle, m.
    """

    ranges: FloatArray
    goal_polar: FloatArray
    clearance: FloatArray


class Episodes(NamedTuple):
    """Each env's episode so far (row ``i`` for env ``i``) and when one ends.

    Attributes
    ----------
    steps : ndarray
        (N,) steps taken (int64).
    vw_hist : ndarray
        (N, max_steps + 1, 2) measured (v, w) after each step (row 0: the start), m/s, rad/s.
    prev_goal : ndarray
        (N,) goal distance after the previous step, m.
    max_steps : int
        Steps before a timeout.
    goal_tol : float
        Goal distance that counts as reached, m.
    """

    steps: IntArray
    vw_hist: FloatArray
    prev_goal: FloatArray
    max_steps: int
    goal_tol: float


class Crowds(NamedTuple):
    """The pedestrians of the envs' eq. (1) crowds, row ``i`` for env ``i`` (its first
    ``n_ped[i]`` slots), under the names :class:`~sim2real.envs.pedestrians.Crowd` gives them.

    Attributes
    ----------
    position_m, velocity_mps, goals : ndarray
        (N, M, 2) positions (m), velocities (m/s) and goals (m).
    radius_m, height_m : ndarray
        (N, M) disc radii and body heights, m.
    pref_speed_mps : ndarray
        (N, M) preferred speeds, m/s.
    alpha : ndarray
        (N, M) stride constants of eq. (1).
    start_time_s : ndarray
        (N, M) times before which each pedestrian stands still, s.
    """

    position_m: FloatArray
    velocity_mps: FloatArray
    goals: FloatArray
    radius_m: FloatArray
    height_m: FloatArray
    pref_speed_mps: FloatArray
    alpha: FloatArray
    start_time_s: FloatArray


@numba.njit(cache=True)
def _compact(i: int, d: Drives) -> None:  # pragma: no cover - compiled
    """Forget env ``i``'s commands that can no longer act (ReducedDrive._compact_history)."""
    n = d.n_hist[i]
    horizon = d.time_s[i] - d.delay_s[i] - 1.0
    first = max(np.searchsorted(d.hist[i, :n, 0], horizon, side="right") - 1, 0)
    if first == 0:
        return
    kept = n - first
    for k in range(kept):
        d.hist[i, k, 0] = d.hist[i, first + k, 0]
        d.hist[i, k, 1] = d.hist[i, first + k, 1]
        d.hist[i, k, 2] = d.hist[i, first + k, 2]
    d.n_hist[i] = kept


@numba.njit(cache=True)
def _drive_and_move(
    i: int, cmd_v: float, cmd_w: float, d: Drives, pose: FloatArray
) -> None:  # pragma: no cover - compiled
    """One control step of env ``i``'s robot: ReducedBackend.step, sub-step by sub-step."""
    x, y, yaw = pose[i, 0], pose[i, 1], pose[i, 2]
    v0, w0 = d.state[i, 0], d.state[i, 1]
    hist = d.hist[i]
    for _ in range(d.n_sub):
        if d.n_hist[i] == hist.shape[0]:
            _compact(i, d)
        k = d.n_hist[i]
        hist[k, 0] = d.time_s[i]
        hist[k, 1] = cmd_v
        hist[k, 2] = cmd_w
        d.n_hist[i] = k + 1
        _advance_history(
            d.state[i],
            hist,
            k + 1,
            d.time_s[i],
            d.inner_s,
            d.n_inner,
            d.delay_s[i],
            d.timeout_s[i],
            d.packed[i],
        )
        d.time_s[i] += d.sub_s
        v1, w1 = d.state[i, 0], d.state[i, 1]
        x, y, yaw = _arc_step(x, y, yaw, 0.5 * (v0 + v1), 0.5 * (w0 + w1), d.sub_s)
        v0, w0 = v1, w1
    pose[i, 0], pose[i, 1], pose[i, 2] = x, y, yaw


@numba.njit(cache=True)
def move_robots(
    active: np.ndarray, cmd: FloatArray, drives: Drives, pose: FloatArray, path_m: FloatArray
) -> None:  # pragma: no cover - compiled
    """One control step of the robots of the ``active`` envs; ``path_m`` grows by the distance.

    ``cmd`` (N, 2) holds the clipped commands; the other envs are left untouched.
    """
    for i in range(active.shape[0]):
        if not active[i]:
            continue
        x0, y0 = pose[i, 0], pose[i, 1]
        _drive_and_move(i, cmd[i, 0], cmd[i, 1], drives, pose)
        path_m[i] += math.hypot(pose[i, 0] - x0, pose[i, 1] - y0)


@numba.njit(cache=True)
def _clearance(
    x: float,
    y: float,
    cxy: FloatArray,
    cr: FloatArray,
    sa: FloatArray,
    sb: FloatArray,
) -> float:  # pragma: no cover - compiled
    """Gap between (x, y) and the nearest obstacle (disc_clearance before the robot radius)."""
    gap = np.inf
    for c in range(cr.shape[0]):
        gap = min(gap, np.hypot(cxy[c, 0] - x, cxy[c, 1] - y) - cr[c])
    for k in range(sa.shape[0]):
        gap = min(gap, segment_distance(x, y, sa[k, 0], sa[k, 1], sb[k, 0], sb[k, 1]))
    return gap


#: Obstacles farther than the lidar range plus this margin (m) cannot change a ray's reading.
_CULL_MARGIN_M = 1e-6


@numba.njit(cache=True)
def sense(
    active: np.ndarray,
    pose: FloatArray,
    lidar_xy: FloatArray,
    beam_angles: FloatArray,
    range_min: float,
    range_max: float,
    cxy: FloatArray,
    cr: FloatArray,
    n_circles: IntArray,
    sa: FloatArray,
    sb: FloatArray,
    n_segments: IntArray,
    goal: FloatArray,
    radius: float,
    out: Readings,
) -> None:  # pragma: no cover - compiled
    """Lidar, goal and clearance of the ``active`` envs' robots against their obstacles.

    ``out.ranges`` gets the lidar (below ``range_min`` reads ``range_max``), ``out.goal_polar``
    the goal distance and bearing, ``out.clearance`` the gap between the footprint disc and
    the nearest obstacle (:class:`Readings`). The rays are cast against the obstacles
    within the lidar's range only (the others cannot change a reading: each hit lies at least
    as far as the obstacle), each only along the beams under which it is seen
    (:func:`~sim2real.envs.geometry.cast_beams`), which gives the same numbers as casting every ray against all.
    """
    ranges, goal_polar, clearance = out
    lx, ly = lidar_xy[0], lidar_xy[1]
    offset = math.hypot(lx, ly)
    reach = range_max + _CULL_MARGIN_M
    nb = beam_angles.shape[0]
    sorted_beams = True
    for k in range(1, nb):
        sorted_beams &= beam_angles[k] > beam_angles[k - 1]
    cap_c, cap_s = max(cr.shape[1], 1), max(sa.shape[1], 1)
    near_cxy, near_cr = np.empty((cap_c, 2)), np.empty(cap_c)
    near_sa, near_sb = np.empty((cap_s, 2)), np.empty((cap_s, 2))
    dx, dy, best = np.empty(nb), np.empty(nb), np.empty(nb)
    for i in range(active.shape[0]):
        if not active[i]:
            continue
        x, y, yaw = pose[i, 0], pose[i, 1], pose[i, 2]
        c, s = math.cos(yaw), math.sin(yaw)
        ox = x + c * lx - s * ly
        oy = y + s * lx + c * ly
        m = 0
        for k in range(n_circles[i]):
            fx, fy, lim = cxy[i, k, 0] - ox, cxy[i, k, 1] - oy, reach + cr[i, k]
            if fx * fx + fy * fy <= lim * lim:
                near_cxy[m, 0], near_cxy[m, 1], near_cr[m] = cxy[i, k, 0], cxy[i, k, 1], cr[i, k]
                m += 1
        q = 0
        for k in range(n_segments[i]):
            d = segment_distance(ox, oy, sa[i, k, 0], sa[i, k, 1], sb[i, k, 0], sb[i, k, 1])
            if d <= reach:
                near_sa[q, 0], near_sa[q, 1] = sa[i, k, 0], sa[i, k, 1]
                near_sb[q, 0], near_sb[q, 1] = sb[i, k, 0], sb[i, k, 1]
                q += 1
        ci, ri, ai, bi = near_cxy[:m], near_cr[:m], near_sa[:q], near_sb[:q]
        for k in range(nb):
            a = beam_angles[k] + yaw
            dx[k], dy[k] = np.cos(a), np.sin(a)
            best[k] = range_max
        if cast_beams(ox, oy, yaw, beam_angles, sorted_beams, dx, dy, ci, ri, ai, bi, best):
            best[:] = 0.0
        for k in range(nb):
            r = best[k]
            ranges[i, k] = range_max if r < range_min else r
        dx_g, dy_g = goal[i, 0] - x, goal[i, 1] - y
        goal_polar[i, 0] = math.hypot(dx_g, dy_g)
        b = math.atan2(dy_g, dx_g) - yaw
        goal_polar[i, 1] = math.atan2(math.sin(b), math.cos(b))
        # the nearest obstacle is among the near ones unless all lie beyond range - offset
        gap = _clearance(x, y, ci, ri, ai, bi)
        if not gap <= range_max - offset - _CULL_MARGIN_M:
            nc, ns = n_circles[i], n_segments[i]
            gap = _clearance(x, y, cxy[i, :nc], cr[i, :nc], sa[i, :ns], sb[i, :ns])
        clearance[i] = gap - radius


@numba.njit(cache=True, inline="always")
def _count_step(
    i: int, state: FloatArray, episodes: Episodes, clearance_m: float, goal_dist_m: float
) -> tuple[int, float]:  # pragma: no cover - compiled
    """Count env ``i``'s step, record its (v, w) for the episode metrics, move its previous
    goal distance on and return its outcome and its progress towards the goal (m, the drop of
    the goal distance in the step). Outcomes: 1 collision (no clearance left), 2 success
    (within ``goal_tol`` of the goal), 3 timeout (``max_steps`` reached), else 0 (running)."""
    steps, vw_hist = episodes.steps, episodes.vw_hist
    steps[i] += 1
    vw_hist[i, steps[i], 0] = state[i, 0]
    vw_hist[i, steps[i], 1] = state[i, 1]
    progress_m = episodes.prev_goal[i] - goal_dist_m
    episodes.prev_goal[i] = goal_dist_m
    if clearance_m <= 0.0:
        return 1, progress_m
    if goal_dist_m < episodes.goal_tol:
        return 2, progress_m
    if steps[i] >= episodes.max_steps:
        return 3, progress_m
    return 0, progress_m


@numba.njit(cache=True)
def finish_random_map(
    active: np.ndarray,
    sensed: Readings,
    state: FloatArray,
    episodes: Episodes,
    goal_dist_max: float,
    range_max: float,
    obs_low: FloatArray,
    obs_high: FloatArray,
    consts: FloatArray,
    obs: np.ndarray,
    rewards: FloatArray,
    outcome: IntArray,
) -> None:  # pragma: no cover - compiled
    """Observation, outcome and reward of RandomMap-v0 for the ``active`` envs.

    ``consts`` = the fields of :class:`~sim2real.envs.RandomMapReward` in their order, tuples
    flattened: (reach, progress_per_m, 3 crash band edges, 3 penalties, free_weight,
    step_penalty, goal_speed_per_mps, goal_speed_radius_m). ``outcome``: 0 running,
    1 collision, 2 success, 3 timeout. Also counts the step, records (v, w) for the episode
    metrics and moves the previous goal distance on. Inactive envs get reward 0, outcome 0.
    """
    ranges, goal_polar, clearance = sensed
    nb = ranges.shape[1]
    for i in range(active.shape[0]):
        rewards[i] = 0.0
        outcome[i] = 0
        if not active[i]:
            continue
        d = goal_polar[i, 0]
        c = clearance[i]
        outcome[i], progress_m = _count_step(i, state, episodes, c, d)
        free = 0.0
        for k in range(nb):
            r = ranges[i, k]
            obs[i, k] = np.float32(min(max(r, obs_low[k]), obs_high[k]))
            u = 1.0 - r / range_max
            free += u * u * u * u
        tail = (min(d, goal_dist_max), goal_polar[i, 1], state[i, 0], state[i, 1])
        for k in range(4):
            obs[i, nb + k] = np.float32(min(max(tail[k], obs_low[nb + k]), obs_high[nb + k]))
        r_goal = consts[0] if outcome[i] == 2 else consts[1] * progress_m
        r_crash = 0.0
        for b in range(3):
            if c <= consts[2 + b]:
                r_crash = -consts[5 + b]
                break
        ramp = max(0.0, 1.0 - d / consts[11])
        r_stop = -consts[10] * abs(state[i, 0]) * ramp
        rewards[i] = r_goal + r_crash - consts[8] * free + r_stop - consts[9]


@numba.njit(cache=True)
def finish_crowd_nav(
    active: np.ndarray,
    sensed: Readings,
    state: FloatArray,
    episodes: Episodes,
    prev_vw: FloatArray,
    vel_low: FloatArray,
    vel_high: FloatArray,
    consts: FloatArray,
    lidar: np.ndarray,
    goal_obs: np.ndarray,
    vel_obs: np.ndarray,
    rewards: FloatArray,
    outcome: IntArray,
) -> None:  # pragma: no cover - compiled
    """Lidar, goal and velocity observations, outcome and reward of CrowdNav-v0.

    ``consts`` = the fields of :class:`~sim2real.envs.CrowdNavReward` in their order (reach,
    collision, progress_per_m, proximity, safe_clearance_m, dv_per_mps, dw_per_radps,
    step_penalty), applied in the single env's order. Outcome codes and bookkeeping as
    :func:`finish_random_map`; the previous velocity (smoothness terms) moves on too.
    """
    ranges, goal_polar, clearance = sensed
    for i in range(active.shape[0]):
        rewards[i] = 0.0
        outcome[i] = 0
        if not active[i]:
            continue
        v, w = state[i, 0], state[i, 1]
        d, c = goal_polar[i, 0], clearance[i]
        outcome[i], progress_m = _count_step(i, state, episodes, c, d)
        for k in range(ranges.shape[1]):
            lidar[i, k] = np.float32(ranges[i, k])
        goal_obs[i, 0] = np.float32(min(d, 20.0))
        goal_obs[i, 1] = np.float32(goal_polar[i, 1])
        vel_obs[i, 0] = np.float32(min(max(v, vel_low[0]), vel_high[0]))
        vel_obs[i, 1] = np.float32(min(max(w, vel_low[1]), vel_high[1]))
        r = consts[2] * progress_m - consts[7]
        if outcome[i] == 2:
            r += consts[0]
        elif outcome[i] == 1:
            r -= consts[1]
        r -= consts[3] * max(0.0, 1.0 - c / consts[4])
        r -= consts[5] * abs(v - prev_vw[i, 0]) + consts[6] * abs(w - prev_vw[i, 1])
        rewards[i] = r
        prev_vw[i, 0], prev_vw[i, 1] = v, w


@numba.njit(cache=True)
def crowd_clock(
    eq1: np.ndarray,
    dt: float,
    time_s: FloatArray,
    n_ped: IntArray,
    crowds: Crowds,
    goal_reached_m: float,
    walking: np.ndarray,
    reached: np.ndarray,
    any_reached: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """The start of :meth:`Crowd.step` for the ``eq1`` envs' crowds: the clock ticks, and
    ``walking`` and ``reached`` (goal closer than ``goal_reached_m``) are marked per pedestrian
    (``any_reached`` per env: those draw new goals from their own generator)."""
    pos, goals = crowds.position_m, crowds.goals
    start_s, pref = crowds.start_time_s, crowds.pref_speed_mps
    for i in range(eq1.shape[0]):
        any_reached[i] = False
        if not eq1[i]:
            continue
        time_s[i] += dt
        for j in range(n_ped[i]):
            walking[i, j] = (time_s[i] >= start_s[i, j]) & (pref[i, j] > 0)
            dx, dy = goals[i, j, 0] - pos[i, j, 0], goals[i, j, 1] - pos[i, j, 1]
            reached[i, j] = np.sqrt(dx * dx + dy * dy) < goal_reached_m
            any_reached[i] |= reached[i, j]


@numba.njit(cache=True)
def walk_crowds(
    eq1: np.ndarray,
    n_ped: IntArray,
    crowds: Crowds,
    walking: np.ndarray,
    goal_dir: FloatArray,
    cxy: FloatArray,
    cr: FloatArray,
    n_static: IntArray,
    sa: FloatArray,
    sb: FloatArray,
    n_segments: IntArray,
    robot_pose: FloatArray,
    robot_r: float,
    dt: float,
    offsets: FloatArray,
    cos_off: FloatArray,
    pen_off: FloatArray,
    depth_cyl: FloatArray,
    n_depth_static: IntArray,
) -> None:  # pragma: no cover - compiled
    """The rest of :meth:`Crowd.step` for the ``eq1`` envs' crowds (the single env's kernel,
    :func:`sim2real.envs.pedestrians._walk_kernel`, around each env's static obstacles: its
    first ``n_static`` circles and its segments); the pedestrians' new discs are written after
    the static circles (lidar scene) and cylinders (depth scene)."""
    pos = crowds.position_m
    for i in range(eq1.shape[0]):
        m = n_ped[i]
        if not eq1[i] or m == 0:
            continue
        nc, ns = n_static[i], n_segments[i]
        _walk_kernel(
            pos[i, :m],
            crowds.velocity_mps[i, :m],
            crowds.radius_m[i, :m],
            crowds.height_m[i, :m],
            crowds.pref_speed_mps[i, :m],
            crowds.alpha[i, :m],
            walking[i, :m],
            goal_dir[i, :m],
            cxy[i, :nc],
            cr[i, :nc],
            sa[i, :ns],
            sb[i, :ns],
            robot_pose[i, 0],
            robot_pose[i, 1],
            robot_r,
            dt,
            offsets,
            cos_off,
            pen_off,
        )
        nd = n_depth_static[i]
        for j in range(m):
            cxy[i, nc + j, 0], cxy[i, nc + j, 1] = pos[i, j, 0], pos[i, j, 1]
            depth_cyl[i, nd + j, 0], depth_cyl[i, nd + j, 1] = pos[i, j, 0], pos[i, j, 1]


@numba.njit(cache=True)
def render_depths(
    active: np.ndarray,
    pose: FloatArray,
    base_height: float,
    xyz: FloatArray,
    r_mount: FloatArray,
    rays: FloatArray,
    cyl: FloatArray,
    n_cyl: IntArray,
    boxes: FloatArray,
    n_boxes: IntArray,
    near: float,
    far: float,
    frame: FloatArray,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Depth images of the ``active`` envs (the single env's :func:`render_frame`; env i's
    camera mount ``xyz[i]``, ``r_mount[i]``), as float32 into ``out`` (N, height, width);
    ``frame`` (height, width) is scratch."""
    for i in range(active.shape[0]):
        if not active[i]:
            continue
        eye, rot = camera_frame(pose[i, 0], pose[i, 1], pose[i, 2], base_height, xyz[i], r_mount[i])
        render_frame(eye, rot, rays, cyl[i, : n_cyl[i]], boxes[i, : n_boxes[i]], near, far, frame)
        for r in range(frame.shape[0]):
            for c in range(frame.shape[1]):
                out[i, r, c] = np.float32(frame[r, c])


def _key_cache() -> None:
    """Key this module's numba cache on the sources of every kernel it calls (robots' drive
    kernels, the pose step, the pedestrians' and the depth camera's kernels): numba alone keys
    it on this file, and would load stale machine code after an edit of one of those."""
    modules = (
        robots._kernel,
        robots.reduced,
        _robot,
        depth,
        geometry,
        pedestrians,
    )
    sources = {Path(__file__)} | {Path(str(m.__file__)) for m in modules}
    _jit.key_cache(move_robots, sources)


_key_cache()
