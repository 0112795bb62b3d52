"""Figures of the agreement report, drawn with matplotlib's Agg backend into PNG bytes.

Every function builds its own :class:`matplotlib.figure.Figure` (no pyplot global state), so
they are safe to call from tests and threads and never open a window.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sim2real._arrays import BoolArray, FloatArray

__all__ = [
    "MIN_BAND_SHARE",
    "Band",
    "SimSeries",
    "band_legend",
    "error_histograms_png",
    "rolling_agreement",
    "rolling_agreement_png",
    "time_series_png",
    "visible_band",
]


# Okabe & Ito's colour-blind-safe palette (Okabe and Ito 2008, "Color Universal Design"):
# real in blue, the main simulation (the last run, e.g. the sysid fit) and its band in
# vermillion, earlier runs (e.g. the spec defaults) in grey and reddish purple.
_REAL_COLOR = "#0072B2"
_MAIN_SIM_COLOR = "#D55E00"
_OTHER_SIM_COLORS = ("#7F7F7F", "#CC79A7", "#009E73")
_BAND_COLOR = _MAIN_SIM_COLOR
_CMD_COLOR = "#AAAAAA"
_DPI = 100
#: A band narrower than this share of its axis's data span is drawn that wide (centred on
#: the band), so a reader sees where it lies; its legend gives its true median width.
MIN_BAND_SHARE = 0.05


def _sim_color(k: int, n: int) -> str:
    """Colour of simulation ``k`` of ``n``: the last one is the main simulation."""
    if k == n - 1:
        return _MAIN_SIM_COLOR
    return _OTHER_SIM_COLORS[k % len(_OTHER_SIM_COLORS)]


@dataclass(frozen=True, kw_only=True)
class SimSeries:
    """One simulated trace to draw: a label and v (m/s), w (rad/s) at the measurement times."""

    label: str
    v: FloatArray
    w: FloatArray


@dataclass(frozen=True, kw_only=True)
class Band:
    """An ensemble's predictive band (lower and upper edge) at the measurement times."""

    lo_v: FloatArray
    hi_v: FloatArray
    lo_w: FloatArray
    hi_w: FloatArray
    label: str


def visible_band(
    lo: FloatArray, hi: FloatArray, span: float
) -> tuple[FloatArray, FloatArray, bool]:
    """The band's edges as drawn: at least :data:`MIN_BAND_SHARE` of ``span`` wide, centred
    on the band; and whether it was widened anywhere.

    Examples
    --------
    >>> lo, hi, widened = visible_band(np.array([0.1]), np.array([0.1015]), span=0.5)
    >>> round(float(hi[0] - lo[0]), 4), widened
    (0.025, True)
    """
    mid, half = (hi + lo) / 2.0, (hi - lo) / 2.0
    least = MIN_BAND_SHARE * span / 2.0
    return mid - np.maximum(half, least), mid + np.maximum(half, least), bool(np.any(half < least))


def band_legend(band: Band, *, widened: bool) -> str:
    """The band's legend: its label and true median widths, and, when it was ``widened`` to
    be seen on an axis (:func:`visible_band`), that it is drawn wider.

    Examples
    --------
    >>> b = Band(lo_v=np.zeros(3), hi_v=np.full(3, 0.0015), lo_w=np.zeros(3),
    ...          hi_w=np.full(3, 0.054), label="90 % band")
    >>> band_legend(b, widened=True)
    '90 % band: median 0.0015 m/s, 0.054 rad/s wide (drawn >= 5 % of the axis to be seen)'
    """
    width_v = float(np.median(band.hi_v - band.lo_v))
    width_w = float(np.median(band.hi_w - band.lo_w))
    text = f"{band.label}: median {width_v:.2g} m/s, {width_w:.2g} rad/s wide"
    share = f"{100 * MIN_BAND_SHARE:g} %"
    return text + (f" (drawn >= {share} of the axis to be seen)" if widened else "")


def _span(*series: FloatArray) -> float:
    """The data span of an axis (max - min over the finite values), at least 1e-9."""
    values = np.concatenate([np.asarray(x, dtype=np.float64).ravel() for x in series])
    values = values[np.isfinite(values)]
    return max(float(np.ptp(values)), 1e-9) if values.size else 1.0


def _figure(width_in: float, height_in: float, rows: int = 1, cols: int = 1):  # type: ignore[no-untyped-def]
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), dpi=_DPI, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False)
    return fig, axes


def _png(fig) -> bytes:  # type: ignore[no-untyped-def]
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=_DPI)
    return buf.getvalue()


def time_series_png(
    t_s: FloatArray,
    real_v: FloatArray,
    real_w: FloatArray,
    sims: Sequence[SimSeries],
    *,
    cmd_t_s: FloatArray | None = None,
    cmd_v: FloatArray | None = None,
    cmd_w: FloatArray | None = None,
    band: Band | None = None,
    height_in: float = 5.6,
) -> bytes:
    """v and w over time: real, each simulation, the command and the ensemble band.

    Real and the main (last) simulation are a colour-blind-safe blue/vermillion pair, the band
    is drawn in the main simulation's colour (at least :data:`MIN_BAND_SHARE` of the axis's
    data span wide, so a narrow band stays visible; the legend gives its true median width),
    and the legend sits above the axes, outside the data.
    """
    fig, axes = _figure(11.0, height_in, rows=2)
    widened = False
    for row, (name, unit, real, cmd) in enumerate(
        (("v", "m/s", real_v, cmd_v), ("w", "rad/s", real_w, cmd_w))
    ):
        ax = axes[row, 0]
        if band is not None:
            lo, hi = (band.lo_v, band.hi_v) if name == "v" else (band.lo_w, band.hi_w)
            span = _span(real, *[sim.v if name == "v" else sim.w for sim in sims])
            lo, hi, wider = visible_band(lo, hi, span)
            widened = widened or wider
            ax.fill_between(t_s, lo, hi, color=_BAND_COLOR, alpha=0.25, lw=0, label="band")
        if cmd_t_s is not None and cmd is not None:
            ax.step(cmd_t_s, cmd, where="post", color=_CMD_COLOR, lw=0.8, ls="--", label="command")
        ax.plot(t_s, real, color=_REAL_COLOR, lw=1.1, label="real")
        for k, sim in enumerate(sims):
            y = sim.v if name == "v" else sim.w
            main = k == len(sims) - 1
            ax.plot(
                t_s, y, color=_sim_color(k, len(sims)), lw=1.0 if main else 0.8,
                ls="-" if main else ":", label=f"sim: {sim.label}",
            )  # fmt: skip
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(True, alpha=0.3)
        ax.margins(x=0.005)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if band is not None:
        labels[0] = band_legend(band, widened=widened)
    ncols = len(labels) if band is None else min(len(labels), 3)  # the band's label is long
    fig.legend(handles, labels, loc="outside upper center", ncols=ncols, fontsize=9)
    axes[1, 0].set_xlabel("time since log start [s]")
    return _png(fig)


def error_histograms_png(
    real_v: FloatArray,
    real_w: FloatArray,
    sims: Sequence[SimSeries],
    active: BoolArray,
    *,
    tol_v: float,
    tol_w: float,
) -> bytes:
    """Histograms of sim - real on the active samples, with the tolerance marked."""
    fig, axes = _figure(11.0, 3.4, cols=2)
    for col, (name, unit, real, tol) in enumerate(
        (("v", "m/s", real_v, tol_v), ("w", "rad/s", real_w, tol_w))
    ):
        ax = axes[0, col]
        errs = [((s.v if name == "v" else s.w) - real)[active] for s in sims]
        span = max([4.0 * tol] + [float(np.percentile(np.abs(e), 99)) for e in errs if e.size])
        bins = np.linspace(-span, span, 61)
        for k, (sim, e) in enumerate(zip(sims, errs, strict=True)):
            ax.hist(
                np.clip(e, -span, span),
                bins=bins,
                histtype="stepfilled",
                alpha=0.45,
                color=_sim_color(k, len(sims)),
                label=sim.label,
            )
        for x in (-tol, tol):
            ax.axvline(x, color="#222222", lw=0.8, ls="--")
        ax.set_xlabel(f"{name}_sim - {name}_real [{unit}]  (dashed: ±tol)")
        ax.set_ylabel("active samples")
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    return _png(fig)


def rolling_agreement(
    t_s: FloatArray,
    ok: BoolArray,
    active: BoolArray,
    *,
    window_s: float,
) -> FloatArray:
    """Fraction of active samples that agree within a centred window of ``window_s`` seconds.

    NaN where the window holds no active sample.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(5.0)
    >>> rolling_agreement(t, np.array([1, 1, 0, 0, 0], bool), np.ones(5, bool), window_s=2.0)
    array([1.        , 0.66666667, 0.33333333, 0.        , 0.        ])
    """
    t = np.asarray(t_s, dtype=np.float64)
    good = np.concatenate(([0], np.cumsum(ok & active)))
    act = np.concatenate(([0], np.cumsum(active)))
    lo = np.searchsorted(t, t - 0.5 * window_s, side="left")
    hi = np.searchsorted(t, t + 0.5 * window_s, side="right")
    n_act = act[hi] - act[lo]
    n_good = good[hi] - good[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        frac: FloatArray = np.where(n_act > 0, n_good / np.maximum(n_act, 1), np.nan)
    return frac


def rolling_agreement_png(
    t_s: FloatArray,
    series: Sequence[tuple[str, FloatArray]],
    *,
    window_s: float,
    active: BoolArray,
) -> bytes:
    """Rolling agreement over time for each simulation, with idle time shaded."""
    fig, axes = _figure(11.0, 3.0)
    ax = axes[0, 0]
    idle = ~active
    if idle.any():
        ax.fill_between(
            t_s, 0, 100, where=idle, color="#cccccc", alpha=0.5, lw=0, label="idle (excluded)"
        )
    for k, (label, frac) in enumerate(series):
        ax.plot(t_s, 100.0 * frac, color=_sim_color(k, len(series)), lw=1.2, label=label)
    ax.set_ylim(0, 102)
    ax.set_ylabel(f"agreement in {window_s:g} s window [%]")
    ax.set_xlabel("time since log start [s]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    return _png(fig)
