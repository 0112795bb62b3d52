"""Measured velocities from the odometry pose when the twist is zero or spiky (private).

Some drivers publish an Odometry twist that is zero while the pose moves, or one that is a
raw backward difference of the pose over jittery stamps (the Neato driver: its yaw rate
jumps between 0.6 and 1.6 rad/s during a steady 1 rad/s spin). The pose itself is then the
better measurement: its displacement over a short window averages the stamp jitter out.

Smoothed differentiation: at each sample a straight line is fitted by least squares to
x, y and the unwrapped yaw over the samples within +-W/2 (a centred local-linear, i.e.
first-order Savitzky-Golay, derivative on irregular times; no lag, noise falls as W^-3/2);
v is the fitted (dx/dt, dy/dt) projected on the heading, w is d(yaw)/dt. The window is
``W = clip(5 x median pose update period, 0.3 s, 1.0 s)``.

Held poses: a driver may republish its last pose between updates (the 2017 Neato driver sends
Odometry at 20 Hz with a pose that changes about every third message). The repeats carry no
new measurement, and a line fitted through them is fitted to a staircase: only the first
message of each pose enters the fits (the update period sets the window), and the velocity
at a repeat is interpolated between the updates around it. A pose held for more than two
update periods is the robot standing still, and those repeats stay in.

Detection (``odom_velocity="auto"``), over the samples where the pose moves
(``|v_pose| > 0.05 m/s`` or ``|w_pose| > 0.2 rad/s``; at least 20 of them per channel):

- *zero*: the twist is below 10 % of the pose velocity in more than half of them;
- *spiky*: the median of ``|twist - pose velocity|`` exceeds :data:`SPIKY_RATIO` (10 %) of the
  median pose speed in v *and* in w (stamp jitter spoils both alike; clean encoder odometry
  stays near 1 %, and a yaw rate from a gyro may differ from the pose's on its own).

A pose that jumps (more than 1 % of its derivative beyond 5 m/s or 20 rad/s, e.g. a map
frame) is never used. The choice is stated in one sentence in ``Trace.meta.warnings``.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from robots.measurement import fresh_readings
from robots.units import NS_PER_S, seconds
from sim2real.errors import Sim2RealValueError
from sim2real.logs._timeline import scratch_median

__all__ = [
    "ODOM_VELOCITY_MODES",
    "SPIKY_RATIO",
    "WINDOW_KEY",
    "pose_changes",
    "pose_derivative",
    "velocities_from_pose",
]

#: ``odom_velocity=`` choices of :func:`sim2real.logs.read_trace`.
ODOM_VELOCITY_MODES = ("auto", "twist", "pose")
#: Key of the pose derivative's window (s) in the columns of :func:`velocities_from_pose`.
WINDOW_KEY = "pose_window_s"
#: Median twist-vs-pose deviation (relative to the median pose speed) that counts as spiky.
SPIKY_RATIO = 0.10
_MOVING_V, _MOVING_W = 0.05, 0.2
_JUMP_V, _JUMP_W = 5.0, 20.0
_MIN_MOVING = 20  # samples where the pose moves, per channel, before a verdict


#: Samples per block of the pose derivative: its temporaries stay a few MB on any log.
BLOCK = 1 << 13


def _local_slopes(
    t: np.ndarray, ys: tuple[np.ndarray, ...], half: float, qa: int, qb: int
) -> list[np.ndarray]:
    """Least-squares slope of each y(t) of ``ys`` over the samples within +-half of each of
    ``t[qa:qb]``.

    ``t`` and each y must hold every sample within +-half of the queried ones (a block and its
    halo); the sums run over the block only, centred on its mean time. The windows and the
    sums of the times are shared by every y.
    """
    tq = t[qa:qb]
    lo = np.searchsorted(t, tq - half, "left")
    hi = np.searchsorted(t, tq + half, "right")

    def csum(a: np.ndarray) -> np.ndarray:
        out = np.empty(a.size + 1)
        out[0] = 0.0
        np.cumsum(a, out=out[1:])
        return out

    tc = t - t.mean()
    st, stt = csum(tc), csum(tc * tc)
    n = (hi - lo).astype(np.float64)
    s_t = st[hi] - st[lo]
    den = n * (stt[hi] - stt[lo]) - s_t * s_t
    # a window of one sample has no slope (its den is 0 only up to the sums' rounding)
    ok = (n >= 2) & (den > 1e-12 * n * n)
    safe = np.where(ok, den, 1.0)
    out = []
    for y in ys:
        sy, sty = csum(y), csum(tc * y)
        num = n * (sty[hi] - sty[lo]) - s_t * (sy[hi] - sy[lo])
        out.append(np.where(ok, num / safe, 0.0))
    return out


def _derivative(
    t: np.ndarray,
    origin: float,
    scale: float,
    pose: tuple[np.ndarray, np.ndarray, np.ndarray],
    window_s: float,
    block: int,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pose_derivative` on times ``(t - origin) / scale`` s, ``block`` samples at a time.

    Each block is fitted with its halo (the samples within half a window of its ends, plus
    one), so every window holds the same samples as a fit over the whole log would; only the
    outputs and a block's temporaries are ever in memory (no full-size intermediates).
    """
    x, y, yaw = pose
    n = t.size
    v, w = np.empty(n), np.empty(n)
    half = 0.5 * window_s
    reach: float | int = half * scale  # half a window in the units of t
    if t.dtype.kind in "iu":
        reach = int(np.ceil(reach))  # integer needles: no float copy of t in searchsorted
    for a in range(0, n, block):
        b = min(a + block, n)
        lo = max(int(np.searchsorted(t, t[a] - reach, "left")) - 1, 0)
        hi = min(int(np.searchsorted(t, t[b - 1] + reach, "right")) + 1, n)
        ts = (t[lo:hi] - origin).astype(np.float64) / scale
        # unwrapping a block differs from unwrapping the log by a multiple of 2 pi: same slope
        ys = (x[lo:hi], y[lo:hi], np.unwrap(yaw[lo:hi]))
        vx, vy, w[a:b] = _local_slopes(ts, ys, half, a - lo, b - lo)
        heading = yaw[a:b]
        v[a:b] = vx * np.cos(heading) + vy * np.sin(heading)
    return v, w


def pose_derivative(
    t_s: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    yaw: np.ndarray,
    window_s: float,
    *,
    block: int = BLOCK,
) -> tuple[np.ndarray, np.ndarray]:
    """Body velocities (v along the heading, w) from a planar pose by local-linear fits.

    Computed ``block`` samples at a time: memory beyond the two outputs stays bounded.

    Examples
    --------
    >>> t = np.linspace(0.0, 2.0, 41)
    >>> v, w = pose_derivative(t, 0.3 * t, 0 * t, 0 * t, 0.5)
    >>> bool(np.allclose(v, 0.3)), bool(np.allclose(w, 0.0))
    (True, True)
    """
    t = np.asarray(t_s, dtype=np.float64)
    return _derivative(t, 0.0, 1.0, (x, y, yaw), window_s, block)


def _window_s(t_ns: np.ndarray) -> float:
    """``clip(5 x median period, 0.3 s, 1.0 s)`` of sorted times in ns."""
    # the differences are scratch: the median may reorder them instead of copying them
    period = seconds(float(scratch_median(np.diff(t_ns)))) if t_ns.size > 1 else 0.1
    return min(max(5.0 * period, 0.3), 1.0)  # np.clip's value, without its array overhead


def _update_derivative(
    t_ns: np.ndarray, pose: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray, float]:
    """Pose velocities fitted on the pose updates only (first message of each pose), read at
    every message time, and the window used (see the module docstring)."""
    x, y, yaw = pose
    new = pose_changes(pose)
    idx = np.flatnonzero(new)
    if idx.size < 5 or idx.size == t_ns.size:  # no repeats (or too few updates): every sample
        window = _window_s(t_ns)
        v, w = _derivative(t_ns, t_ns[0], NS_PER_S, pose, window, BLOCK)
        return v, w, window
    # a pose held for longer than two update periods is the robot standing still: those
    # repeats are measurements (of no motion) and stay in
    keep = np.flatnonzero(fresh_readings(t_ns, new)[0])
    tk = t_ns[keep]
    window = _window_s(t_ns[idx])
    vk, wk = _derivative(tk, t_ns[0], NS_PER_S, (x[keep], y[keep], yaw[keep]), window, BLOCK)
    t = seconds(t_ns - t_ns[0])
    tks = seconds(tk - t_ns[0])
    return np.interp(t, tks, vk), np.interp(t, tks, wk), window


def pose_changes(pose: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """Per sample: the pose differs from the previous sample's (the first always does)."""
    x, y, yaw = pose
    new = np.ones(x.size, dtype=bool)
    new[1:] = (np.diff(x) != 0) | (np.diff(y) != 0) | (np.diff(yaw) != 0)
    return new


def _share(v: np.ndarray, lim_v: float, w: np.ndarray, lim_w: float) -> float:
    """Share of the samples with ``|v| > lim_v`` or ``|w| > lim_w`` (block by block)."""
    hits = 0
    for a in range(0, v.size, BLOCK):
        sl = slice(a, a + BLOCK)
        hits += int(np.count_nonzero((np.abs(v[sl]) > lim_v) | (np.abs(w[sl]) > lim_w)))
    return hits / max(v.size, 1)


def _moving_blocks(pv: np.ndarray, moving: float) -> Iterator[tuple[slice, np.ndarray]]:
    """Each block of the log (a slice) with its mask of the samples where ``|pv| > moving``."""
    for a in range(0, pv.size, BLOCK):
        sl = slice(a, a + BLOCK)
        yield sl, np.abs(pv[sl]) > moving


def _verdict(
    twist: tuple[np.ndarray, np.ndarray], pose: tuple[np.ndarray, np.ndarray]
) -> tuple[str, str, float]:
    """("zero" | "spiky" | "", the channel(s), the figure) for the twist against the pose."""
    ratios = {}
    for ch, tw, pv, moving in (
        ("v", twist[0], pose[0], _MOVING_V),
        ("w", twist[1], pose[1], _MOVING_W),
    ):
        # the masks of every block, made once (one byte per sample)
        blocks = list(_moving_blocks(pv, moving))
        count = sum(int(np.count_nonzero(s)) for _, s in blocks)
        if count < _MIN_MOVING:
            continue
        # block by block over the log: one array of the moving samples at a time
        gap, k, hits = np.empty(count), 0, 0
        for sl, s in blocks:
            g, p = tw[sl][s], pv[sl][s]
            hits += int(np.count_nonzero(np.abs(g) < 0.1 * np.abs(p)))
            np.subtract(g, p, out=gap[k : k + g.size])
            k += g.size
        zero = hits / count
        if zero > 0.5:
            return "zero", ch, zero
        np.abs(gap, out=gap)
        # scratch arrays: the medians may reorder them instead of copying them
        med_gap = scratch_median(gap)
        del gap
        speed, k = np.empty(count), 0
        for sl, s in blocks:
            p = pv[sl][s]
            np.abs(p, out=speed[k : k + p.size])
            k += p.size
        ratios[ch] = float(med_gap / scratch_median(speed))
    # stamp jitter spoils v and w alike; one channel alone differing is another sensor (a gyro)
    if ratios and min(ratios.values()) > SPIKY_RATIO:
        return "spiky", " and ".join(ratios), min(ratios.values())
    return "", "", 0.0


def velocities_from_pose(
    t_ns: np.ndarray,
    cols: dict[str, np.ndarray],
    topic: str,
    warnings: list[str],
    *,
    mode: str = "auto",
) -> dict[str, np.ndarray]:
    """Replace ``cols["v"]``/``cols["w"]`` by pose velocities when ``mode`` asks or detects it.

    The columns returned then also hold :data:`WINDOW_KEY`: the derivative's window, s (a
    0-d array), which the measurement operator of the trace needs.
    """
    if mode not in ODOM_VELOCITY_MODES:
        raise Sim2RealValueError(
            f"odom_velocity must be one of {list(ODOM_VELOCITY_MODES)}, got {mode!r}; use "
            "'auto' (default), 'twist' or 'pose'"
        )
    if mode == "twist" or "x" not in cols or t_ns.size < 5:
        if mode == "pose":
            raise Sim2RealValueError(
                f"odom_velocity='pose' needs an Odometry pose, but topic '{topic}' has none "
                "(or fewer than 5 samples); use 'twist'"
            )
        return cols
    v, w, window = _update_derivative(t_ns, (cols["x"], cols["y"], cols["yaw"]))
    jumps = _share(v, _JUMP_V, w, _JUMP_W)
    if jumps > 0.01 and mode == "auto":
        return cols
    if mode == "auto":
        kind, ch, figure = _verdict((cols["v"], cols["w"]), (v, w))
        if not kind:
            return cols
        what = (
            f"zero in {figure:.0%} of the samples where the pose moves"
            if kind == "zero"
            else f"spiky (its {ch} deviate from the pose's by {figure:.0%} or more of the speed, "
            "median)"
        )
        warnings.append(
            f"the odometry twist of topic '{topic}' is {what}, so the measured velocities are "
            f"taken from the pose (local-linear derivative over {window:.2f} s windows); "
            "--odom-velocity twist (read_trace(..., odom_velocity='twist')) keeps the twist"
        )
    else:
        warnings.append(
            f"measured velocities of topic '{topic}' are taken from the pose (local-linear "
            f"derivative over {window:.2f} s windows), as asked"
        )
    return {**cols, "v": v, "w": w, WINDOW_KEY: np.array(window)}
