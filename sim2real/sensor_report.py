"""The HTML check of a lidar identification: ``sim2real sysid sensors --report report.html``.

One self-contained page (base64 PNGs drawn with matplotlib's Agg backend): the noise std
against range, real per-beam spreads of the still stretches with the identified model and
its 95 % band, and the same spreads of the simulated lidar (the identified noise applied to
the same stretches' ranges, as :class:`randomizers.LidarNoise` draws it) over them; the
invalid-return rate per beam and per range bin; and the table of estimates.

Examples
--------
>>> from sim2real.sensor_report import write_sensor_report
>>> write_sensor_report("report.html", estimate, spread)  # doctest: +SKIP
"""

from __future__ import annotations

import base64
import html
import io
import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from sim2real._io import atomic_write
from sysid.sensors import SensorEstimate, StillSpread

__all__ = ["simulated_spread", "write_sensor_report"]


def simulated_spread(est: SensorEstimate, spread: StillSpread, seed: int = 0) -> np.ndarray:
    """Sample standard deviations of the identified noise on the same groups (same ranges
    and degrees of freedom), m."""
    rng = np.random.default_rng(seed)
    r = spread.median_m
    sigma = est.noise_std_0_m + (est.noise_std_per_m + est.noise_std_per_m2 * r) * r
    out = np.empty(spread.median_m.size)
    for i, (s, k) in enumerate(zip(sigma.tolist(), spread.dof.tolist(), strict=True)):
        out[i] = float(np.std(rng.normal(0.0, s, int(k) + 1), ddof=1))
    return out


def _png(fig: Figure) -> str:
    buf = io.BytesIO()
    FigureCanvasAgg(fig).print_png(buf)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _noise_figure(est: SensorEstimate, spread: StillSpread, sim: np.ndarray) -> str:
    fig = Figure(figsize=(7.0, 4.2), dpi=110)
    ax = fig.add_subplot()
    ax.scatter(
        spread.median_m,
        1e3 * spread.std_m,
        s=6,
        alpha=0.5,
        color="#0072B2",
        label="real, per beam and still stretch",
    )
    ax.scatter(
        spread.median_m,
        1e3 * sim,
        s=6,
        alpha=0.5,
        color="#E69F00",
        label="simulated lidar, same beams",
    )
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


def write_sensor_report(path: str | Path, est: SensorEstimate, spread: StillSpread) -> None:
    """Write the one-page HTML check of ``est`` (temp file, then renamed)."""
    rows = "".join(
        f"<tr><td>{html.escape(a)}</td><td>{b}</td><td>{c}</td></tr>" for a, b, c in _rows(est)
    )
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in est.unidentified) or "<li>none</li>"
    figs = ""
    if spread.median_m.size:
        sim = simulated_spread(est, spread)
        figs += f'<h2>Range noise</h2><img alt="noise vs range" src="data:image/png;base64,{_noise_figure(est, spread, sim)}">'
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
