"""The HTML check of a lidar identification: ``sim2real sysid sensors --report report.html``.

One self-contained page (base64 PNGs drawn with matplotlib's Agg backend): the noise std
against range, real per-beam spreads of the still stretches with the identified model and
its 95 % band, and the same spreads of the simulated lidar over them (the project's ray
caster in a map of what each still stretch sees, with the identified noise and invalid-return
rate applied by :class:`randomizers.LidarNoise`); the invalid-return rate per beam and per
range bin; and the table of estimates.

Examples
--------
>>> from sim2real.sensor_report import write_sensor_report
>>> write_sensor_report("report.html", estimate, scans, odoms)  # doctest: +SKIP
"""

from __future__ import annotations

import base64
import dataclasses
import html
import io
import math
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from randomizers import LidarNoise
from sim2real._io import atomic_write
from sim2real.envs.geometry import Scene2D, cast_rays
from sysid.sensors import (
    PoseArrays,
    ScanArrays,
    SensorEstimate,
    StillSpread,
    still_spread,
    still_stretches,
)

__all__ = ["simulated_scans", "simulated_spread", "write_sensor_report"]


class _Scan(gym.Env[NDArray[np.float64], np.int64]):
    """A still lidar whose next scan is set from outside (the ray caster's)."""

    action_space = gym.spaces.Discrete(1)

    def __init__(self, beams: int, range_min_m: float, range_max_m: float) -> None:
        self.observation_space = gym.spaces.Box(range_min_m, range_max_m, (beams,), np.float64)
        self.scan = np.full(beams, range_max_m)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float64], dict[str, Any]]:
        super().reset(seed=seed)
        return self.scan, {}

    def step(
        self, action: np.int64
    ) -> tuple[NDArray[np.float64], float, bool, bool, dict[str, Any]]:
        return self.scan, 0.0, False, False, {}


def _facets(median_m: NDArray[np.float64], angles_rad: NDArray[np.float64]) -> Scene2D:
    """A map of the surfaces one still scan sees: per beam with a return, a short wall through
    its median point, along the line to its neighbours' points where they see the same
    surface (across the beam otherwise), short enough never to reach a neighbour's beam."""
    px, py = median_m * np.cos(angles_rad), median_m * np.sin(angles_rad)
    nxt, prv = np.roll(np.arange(median_m.size), -1), np.roll(np.arange(median_m.size), 1)
    tx, ty = px[nxt] - px[prv], py[nxt] - py[prv]
    with np.errstate(invalid="ignore"):
        near = np.hypot(tx, ty) <= 4.0 * median_m * abs(float(angles_rad[1] - angles_rad[0]))
    tx, ty = np.where(near, tx, -np.sin(angles_rad)), np.where(near, ty, np.cos(angles_rad))
    norm = np.maximum(np.hypot(tx, ty), 1e-12)
    half = 0.45 * median_m * abs(float(angles_rad[1] - angles_rad[0]))
    hx, hy = half * tx / norm, half * ty / norm
    ok = np.isfinite(median_m)
    segs = np.column_stack([px - hx, py - hy, px + hx, py + hy])[ok]
    return Scene2D.build(segments=[(s[0], s[1], s[2], s[3]) for s in segs.tolist()])


def simulated_scans(
    est: SensorEstimate, scans: ScanArrays, odom: PoseArrays, seed: int = 0
) -> ScanArrays:
    """The simulated lidar on the still stretches of one recording.

    Per still stretch, the ray caster (:func:`sim2real.envs.geometry.cast_rays`) casts the
    recording's beams from the lidar into a map of what the stretch's scans see (a short wall
    through each beam's median return) and :class:`randomizers.LidarNoise` with the identified
    noise model and invalid-return rate turns each cast into one scan. Scans outside the
    stretches are all invalid (NaN).

    Examples
    --------
    >>> sim = simulated_scans(estimate, scans, odom)  # doctest: +SKIP
    >>> still_spread(sim, odom)  # the simulated lidar's spreads  # doctest: +SKIP
    """
    ranges = np.full(scans.ranges_m.shape, np.nan)
    beams = scans.ranges_m.shape[1]
    env = _Scan(beams, scans.range_min_m, scans.range_max_m)
    noise = LidarNoise(
        env,
        std_m=est.noise_std_0_m,
        std_per_m=est.noise_std_per_m,
        std_per_m2=est.noise_std_per_m2,
        dropout=0.0 if math.isnan(est.dropout) else est.dropout,
        range_min_m=scans.range_min_m,
        range_max_m=scans.range_max_m,
    )
    noise.reset(seed=seed)
    valid = scans.valid()
    ang = scans.angles_rad
    for a, b in still_stretches(scans, odom):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # beams never valid: NaN medians
            median = np.nanmedian(np.where(valid[a:b], scans.ranges_m[a:b], np.nan), axis=0)
        seen = valid[a:b].sum(axis=0)
        median = np.where((seen >= 3) & (seen >= 0.3 * (b - a)), median, np.nan)
        scene = _facets(median, ang)
        for k in range(a, b):
            env.scan = cast_rays(scene, np.zeros(2), ang, scans.range_max_m)
            ranges[k] = noise.observation(env.scan)
    return dataclasses.replace(scans, ranges_m=ranges)


def simulated_spread(
    est: SensorEstimate,
    scans: Sequence[ScanArrays],
    odoms: Sequence[PoseArrays],
    seed: int = 0,
) -> StillSpread:
    """The spreads of the simulated lidar (:func:`simulated_scans`) on the still stretches of
    each recording, grouped like the real spreads (:func:`sysid.sensors.still_spread`)."""
    sims = [
        simulated_scans(est, s, o, seed + i)
        for i, (s, o) in enumerate(zip(scans, odoms, strict=True))
    ]
    return still_spread(sims, list(odoms))


def _png(fig: Figure) -> str:
    buf = io.BytesIO()
    FigureCanvasAgg(fig).print_png(buf)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _noise_figure(est: SensorEstimate, spread: StillSpread, sim: StillSpread) -> str:
    fig = Figure(figsize=(7.0, 4.2), dpi=110)
    ax = fig.add_subplot()
    for points, color, label in (
        (spread, "#0072B2", "real, per beam and still stretch"),
        (sim, "#E69F00", "simulated lidar (ray caster, identified noise), same stretches"),
    ):
        ax.scatter(points.median_m, 1e3 * points.std_m, s=6, alpha=0.5, color=color, label=label)
    r = np.asarray(est.noise_range_m)
    ax.fill_between(
        r,
        1e3 * np.asarray(est.noise_std_lo_m),
        1e3 * np.asarray(est.noise_std_hi_m),
        color="#009E73",
        alpha=0.3,
        label="identified std, 95 % band",
    )
    ax.plot(r, 1e3 * np.asarray(est.noise_std_m), color="#009E73")
    if est.moving_noise_std_m and est.noise_source == "still":
        ax.errorbar(
            r,
            1e3 * np.asarray(est.moving_noise_std_m),
            yerr=1e3
            * np.abs(
                np.array([est.moving_noise_std_lo_m, est.moving_noise_std_hi_m])
                - est.moving_noise_std_m
            ),
            fmt="s",
            ms=4,
            color="#CC79A7",
            label="moving scans alone, 95 % interval",
        )
    ax.set_xlabel("range, m")
    ax.set_ylabel("scan-to-scan std, mm")
    ax.legend(loc="upper left", fontsize=8)
    return _png(fig)


def _dropout_figure(est: SensorEstimate) -> str:
    fig = Figure(figsize=(7.0, 3.2), dpi=110)
    ax, bx = fig.subplots(1, 2)
    angles = np.degrees(est.angle_min_rad + est.angle_increment_rad * np.arange(est.beams))
    ax.plot(angles, 100 * np.asarray(est.dropout_by_beam), ".", ms=3, color="#D55E00")
    ax.set_xlabel("beam angle, deg")
    ax.set_ylabel("invalid returns, %")
    bx.bar(
        [f"{r:.1f}" for r in est.noise_range_m],
        100 * np.asarray(est.dropout_by_range),
        color="#D55E00",
    )
    bx.set_xlabel("range bin centre, m")
    fig.tight_layout()
    return _png(fig)


def _rows(est: SensorEstimate) -> list[tuple[str, str, str]]:
    def ci(v: tuple[float, float], k: float = 1.0) -> str:
        return "-" if math.isnan(v[0]) else f"[{v[0] * k:.4g}, {v[1] * k:.4g}]"

    return [
        ("noise std at 0 m, mm", f"{est.noise_std_0_m * 1e3:.4g}", ci(est.noise_std_0_ci, 1e3)),
        (
            "noise std growth, mm per m",
            f"{est.noise_std_per_m * 1e3:.4g}",
            ci(est.noise_std_per_m_ci, 1e3),
        ),
        (
            "noise std growth with range squared, mm per m²",
            f"{est.noise_std_per_m2 * 1e3:.4g}",
            ci(est.noise_std_per_m2_ci, 1e3),
        ),
        ("invalid returns, %", f"{est.dropout * 100:.4g}", ci(est.dropout_ci, 100)),
        (
            "spurious short returns, %",
            f"{est.spurious_short * 100:.4g}",
            ci(est.spurious_short_ci, 100),
        ),
        ("scan time offset, ms", f"{est.time_offset_s * 1e3:.4g}", ci(est.time_offset_ci, 1e3)),
        (
            "mounting yaw, deg",
            f"{math.degrees(est.mounting_yaw_rad):.4g}",
            ci(est.mounting_yaw_ci, 180 / math.pi),
        ),
    ]


def _depth_rows(est: SensorEstimate) -> list[tuple[str, str, str]]:
    """The depth camera's noise at its depth bins and invalid pixels (none without one)."""
    d = est.depth
    if d is None:
        return []
    rows = [
        (
            f"depth camera {d.topic}: std at {r:.2f} m, mm",
            f"{s * 1e3:.4g}",
            f"[{lo * 1e3:.4g}, {hi * 1e3:.4g}]",
        )
        for r, s, lo, hi in zip(
            d.noise_range_m, d.noise_std_m, d.noise_std_lo_m, d.noise_std_hi_m, strict=True
        )
    ]
    lo, hi = d.dropout_ci
    return [
        *rows,
        (
            "depth camera: invalid pixels, %",
            f"{d.dropout * 100:.4g}",
            f"[{lo * 100:.4g}, {hi * 100:.4g}]",
        ),
    ]


def write_sensor_report(
    path: str | Path,
    est: SensorEstimate,
    scans: Sequence[ScanArrays],
    odoms: Sequence[PoseArrays],
) -> None:
    """Write the one-page HTML check of ``est`` on the recordings it came from (temp file,
    then renamed)."""
    spread = still_spread(list(scans), list(odoms))
    rows = "".join(
        f"<tr><td>{html.escape(a)}</td><td>{b}</td><td>{c}</td></tr>"
        for a, b, c in [*_rows(est), *_depth_rows(est)]
    )
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in est.unidentified) or "<li>none</li>"
    figs = ""
    if not math.isnan(est.noise_std_0_m):
        sim = simulated_spread(est, scans, odoms) if spread.median_m.size else spread
        figs += (
            '<h2>Range noise</h2><img alt="noise vs range" '
            f'src="data:image/png;base64,{_noise_figure(est, spread, sim)}">'
            "<p>Blue: the scan-to-scan spread of each beam in each still stretch. Orange: the "
            "simulated lidar on the same stretches (the ray caster in a map of what each "
            "stretch sees, with the identified noise and invalid-return rate). Where orange "
            "does not cover blue, the noise model does not describe the sensor. Pink: the "
            f"noise of the matched moving scans alone (the model comes from the "
            f"{'moving scans' if est.noise_source == 'moving' else 'still stretches'}).</p>"
        )
    if not math.isnan(est.dropout):
        figs += f'<h2>Invalid returns</h2><img alt="invalid returns" src="data:image/png;base64,{_dropout_figure(est)}">'
    sources = html.escape(", ".join(est.sources))
    page = (
        "<!doctype html><html><head><meta charset='utf-8'><title>Lidar identification</title>"
        "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto}"
        "td,th{padding:.2em .8em;border-bottom:1px solid #ddd}</style></head><body>"
        f"<h1>Lidar identification</h1><p>{sources}: {est.beams} beams, "
        f"{est.range_min_m:g}-{est.range_max_m:g} m, {est.scan_rate_hz:.2f} Hz, "
        f"{est.still_scans} still scans, {est.matched_pairs} matched scan pairs.</p>"
        "<table><tr><th>quantity</th><th>estimate</th><th>95 % interval</th></tr>"
        f"{rows}</table><h2>Not identified</h2><ul>{notes}</ul>{figs}</body></html>"
    )
    with atomic_write(path, "w", what="report file") as fh:
        fh.write(page)
