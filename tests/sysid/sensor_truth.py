"""Lidar recordings with known truth: the project's ray caster in a static room.

A differential-drive base stands still three times (facing walls at different distances) and
drives a meandering path between, in a 7 m x 5 m room with boxes and pillars. Scans are cast
with :func:`sim2real.envs.geometry.cast_rays` from the lidar's true pose (mounted behind the
base centre with a yaw), get Gaussian range noise growing with range and random dropouts
(reported as 0, as the Neato driver does), and are stamped ``offset_s`` *early* (so the
estimator must find ``+offset_s``). The odometry integrates the true velocities with scale
errors and per-step noise (zero while the base stands still, like wheel encoders).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim2real.envs.geometry import Scene2D, cast_rays, rectangle_segments
from sysid.sensors import PoseArrays, ScanArrays

MOUNT_XY_M = (-0.09, 0.0)
RANGE_MAX_M = 5.0


@dataclass(frozen=True, kw_only=True)
class Truth:
    std0_m: float
    std_per_m: float
    dropout: float
    offset_s: float
    yaw_rad: float

    def std_at(self, r_m: float) -> float:
        return self.std0_m + self.std_per_m * r_m


def room() -> Scene2D:
    walls = rectangle_segments(0.0, 0.0, 7.0, 5.0, 0.0)
    boxes = [
        rectangle_segments(2.0, 1.2, 0.8, 0.5, 0.3),
        rectangle_segments(-2.2, -1.0, 0.6, 0.6, 0.0),
    ]
    segs = np.vstack([walls, *boxes])
    return Scene2D.build(
        circles=[(1.5, -1.5, 0.2), (-1.0, 1.6, 0.15), (-2.5, 1.0, 0.25)],
        segments=[tuple(s) for s in segs],
    )


def draw_truth(rng: np.random.Generator) -> Truth:
    """Noise std 5 mm at 0 m growing to 5-40 mm at 5 m, dropout 0-10 %, 30 ms, 2 deg."""
    std0 = 0.005
    top = rng.uniform(0.015, 0.040)
    return Truth(
        std0_m=std0,
        std_per_m=(top - std0) / RANGE_MAX_M,
        dropout=float(rng.uniform(0.0, 0.10)),
        offset_s=0.030,
        yaw_rad=math.radians(2.0),
    )


def _trajectory(
    rng: np.random.Generator, duration_s: float, dt: float, stops: bool = True
) -> np.ndarray:
    """True (t, x, y, yaw, v, w) at ``dt``: still, drive, still, drive, still (without
    ``stops``: driving all along)."""
    n = round(duration_s / dt)
    t = np.arange(n) * dt
    out = np.zeros((n, 6))
    out[:, 0] = t
    x = y = yaw = v = w = 0.0
    yaw = rng.uniform(-math.pi, math.pi)
    still = (t < 8.0) | ((t > 26.0) & (t < 34.0)) | (t > 52.0)
    if not stops:
        still[:] = False
    cmd_v = cmd_w = 0.0
    next_cmd = 0.0
    for i in range(n):
        if still[i]:
            cmd_v = cmd_w = 0.0
        elif t[i] >= next_cmd:
            next_cmd = t[i] + rng.uniform(0.6, 1.6)
            cmd_v = float(rng.choice([0.08, 0.15, 0.22]))
            cmd_w = float(rng.uniform(-1.0, 1.0))
            if math.hypot(x, y) > 1.0:
                home = math.atan2(-y, -x) - yaw
                cmd_w = float(np.clip(2.0 * math.atan2(math.sin(home), math.cos(home)), -1, 1))
        a = dt / 0.15
        v += a * (cmd_v - v)
        w += a * (cmd_w - w)
        if still[i] and abs(v) < 0.01 and abs(w) < 0.02:
            v = w = 0.0
        x += v * math.cos(yaw) * dt
        y += v * math.sin(yaw) * dt
        yaw += w * dt
        out[i, 1:] = (x, y, yaw, v, w)
    return out


def synthetic_recording(
    truth: Truth, seed: int, *, duration_s: float = 60.0, stops: bool = True
) -> tuple[ScanArrays, PoseArrays]:
    """One recording: 5 Hz 360-beam scans and 20 Hz odometry (``stops=False``: the base
    never stands still)."""
    rng = np.random.default_rng(seed)
    dt = 0.005
    traj = _trajectory(rng, duration_s, dt, stops)
    scene = room()
    # odometry: integrate measured speeds (scale errors, noise proportional to motion)
    kv, kw = 1.0 + rng.normal(0, 0.01), 1.0 + rng.normal(0, 0.02)
    v_m = traj[:, 4] * kv * (1.0 + 0.03 * rng.standard_normal(traj.shape[0]))
    w_m = traj[:, 5] * kw * (1.0 + 0.03 * rng.standard_normal(traj.shape[0]))
    yaw_start = traj[0, 3] - traj[0, 5] * dt  # the pose before the first step
    yaw_o = yaw_start + np.cumsum(w_m * dt)
    yaw_before = np.concatenate([[yaw_start], yaw_o[:-1]])  # each step moves along the old yaw
    x_o = np.cumsum(v_m * np.cos(yaw_before) * dt)
    y_o = np.cumsum(v_m * np.sin(yaw_before) * dt)
    step = round(0.05 / dt)
    odom = PoseArrays(
        t_s=traj[::step, 0] + rng.normal(0, 0.001, traj[::step].shape[0]),
        x_m=x_o[::step],
        y_m=y_o[::step],
        yaw_rad=np.angle(np.exp(1j * yaw_o[::step])),
    )
    beams = 360
    inc = 2 * math.pi / beams
    angles = -math.pi + inc * np.arange(beams)
    scan_t = np.arange(1.0, duration_s - 1.0, 0.2) + rng.uniform(0, 0.2)
    ranges = np.empty((scan_t.size, beams))
    for k, ts in enumerate(scan_t):
        i = round(ts / dt)
        _, x, y, yaw, _, _ = traj[i]
        c, s = math.cos(yaw), math.sin(yaw)
        lx = x + c * MOUNT_XY_M[0] - s * MOUNT_XY_M[1]
        ly = y + s * MOUNT_XY_M[0] + c * MOUNT_XY_M[1]
        r = cast_rays(scene, np.array([lx, ly]), yaw + truth.yaw_rad + angles, RANGE_MAX_M)
        noisy = r + rng.standard_normal(beams) * (truth.std0_m + truth.std_per_m * r)
        noisy = np.where(r >= RANGE_MAX_M, RANGE_MAX_M, noisy)
        noisy[rng.random(beams) < truth.dropout] = 0.0
        ranges[k] = noisy
    scans = ScanArrays(
        t_s=np.round(scan_t / dt) * dt - truth.offset_s,
        ranges_m=ranges,
        angle_min_rad=-math.pi,
        angle_increment_rad=inc,
        range_min_m=0.06,
        range_max_m=RANGE_MAX_M,
    )
    return scans, odom
