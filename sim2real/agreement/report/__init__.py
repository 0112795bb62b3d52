"""The agreement report: one self-contained HTML page plus the same figures as PNG files.

The page leads with a verdict (``<section id="verdict">``, :mod:`sim2real.agreement.report._verdict`):
the agreement of the main simulation, the coverage of the randomised band and the timing,
each with one sentence saying what it means, and the next step. Right under it, on the same
first screen, the main plot: v and w over time, real and the main simulation in a
colour-blind-safe pair, the band drawn, the legend outside the data. Below: the headline
cards and agreement figures of every run, a close-up, error histograms, rolling agreement;
then, collapsed, the step-like segments (rise time, overshoot, steady-state error, real vs
sim), the parameter table with intervals, the provenance (files with SHA-256, versions, seed,
command line) and the definitions. Plots are drawn by :mod:`sim2real.agreement.report._plots`, the page
by :mod:`sim2real.agreement.report._html`.

Owns the page and the plots, and computes nothing of its own: the figures, the band and the
verdict come from :mod:`sim2real.agreement.figures` and :mod:`sim2real.agreement.verdict`.
May import those, :mod:`sim2real.agreement.replay`'s result types, :mod:`robots.params`,
:mod:`sysid.metrics` and matplotlib (drawn lazily, off the CLI's start-up path); never
:mod:`sim2real.agreement.study`, which calls it.

Examples
--------
>>> from sim2real.agreement.report import ReportInput, ReportRun, write_report
>>> files = write_report("report.html", ReportInput(trace=trace, runs=(  # doctest: +SKIP
...     ReportRun(label="spec defaults", replay=sim0, agreement=rep0),
...     ReportRun(label="sysid params", replay=sim1, agreement=rep1))))
>>> files.html.name  # doctest: +SKIP
'report.html'
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robots.params import DriveParams, ParamsFile, load_params_document
from sim2real._io import atomic_write, check_output_path
from sim2real.agreement.figures import AgreementReport, EnsembleResult
from sim2real.agreement.replay import ReplayResult, TraceLike
from sim2real.agreement.report._html import (
    Figure,
    FleetEntry,
    HeadlineCard,
    Table,
    render_fleet_page,
    render_page,
)
from sim2real.agreement.report._plots import (
    Band,
    SimSeries,
    error_histograms_png,
    rolling_agreement,
    rolling_agreement_png,
    time_series_png,
)
from sim2real.agreement.report._steps import find_steps, step_response
from sim2real.agreement.report._verdict import lag_phrase, make_verdict
from sim2real.agreement.verdict import AgreementVerdict
from sim2real.errors import Sim2RealValueError
from sysid.metrics import active_mask

__all__ = [
    "ParamRow",
    "ReportFiles",
    "ReportInput",
    "ReportRun",
    "param_rows",
    "write_fleet_report",
    "write_report",
]

#: Window of the rolling-agreement plot, s.
ROLLING_WINDOW_S = 5.0

_UNIT_SUFFIXES = (
    ("_nms_per_rad", "N m s/rad"),
    ("_ns_per_m", "N s/m"),
    ("_radps2", "rad/s^2"),
    ("_mps2", "m/s^2"),
    ("_radps", "rad/s"),
    ("_mps", "m/s"),
    ("_kgm2", "kg m^2"),
    ("_kg", "kg"),
    ("_nm", "N m"),
    ("_n", "N"),
    ("_s", "s"),
)


@dataclass(frozen=True, kw_only=True)
class ReportRun:
    """One replay of the log and its agreement (e.g. "spec defaults" or "sysid params")."""

    label: str
    replay: ReplayResult
    agreement: AgreementReport


@dataclass(frozen=True, kw_only=True)
class ParamRow:
    """One drive parameter: spec default, value used, and the sysid uncertainty if any."""

    name: str
    unit: str
    default: float
    value: float
    std: float | None
    ci95: tuple[float, float] | None
    status: str


@dataclass(frozen=True, kw_only=True)
class ReportInput:
    """Everything the report shows.

    Attributes
    ----------
    trace : Trace
        The real log.
    runs : sequence of ReportRun
        One or more replays; by convention spec defaults first, sysid parameters second.
    ensemble : EnsembleResult, optional
        Ensemble band and coverage (drawn around the last run).
    params : sequence of ParamRow
        The parameter table.
    provenance : sequence of (str, str)
        Key/value lines (files, sha256, versions, seed, command line).
    title : str
        Page title.
    verdict : AgreementVerdict, optional
        The run's verdict (:func:`sim2real.agreement.verdict.decide`, as ``sim2real agree``
        printed it); decided from ``runs`` and ``ensemble`` when absent.
    notes : sequence of str
        Notes on the data (segments left out, figures left undefined), shown under the verdict.
    """

    trace: TraceLike
    runs: Sequence[ReportRun]
    ensemble: EnsembleResult | None = None
    params: Sequence[ParamRow] = ()
    provenance: Sequence[tuple[str, str]] = ()
    title: str = "sim2real agreement report"
    verdict: AgreementVerdict | None = None
    notes: Sequence[str] = ()


@dataclass(frozen=True, kw_only=True)
class ReportFiles:
    """Files written by :func:`write_report`."""

    html: Path
    images: tuple[Path, ...]


def _unit(name: str) -> str:
    for suffix, unit in _UNIT_SUFFIXES:
        if name.endswith(suffix):
            return unit
    return ""


def _float_or_none(x: Any) -> float | None:
    if isinstance(x, bool) or not isinstance(x, int | float):
        return None
    return float(x)


def param_rows(
    defaults: DriveParams, used: DriveParams, params_file: str | Path | ParamsFile | None = None
) -> tuple[ParamRow, ...]:
    """Rows of the parameter table: defaults, values used, std/ci95/status from the file.

    ``params_file`` is the file, or a :class:`~robots.params.ParamsFile` read already.

    Examples
    --------
    >>> rows = param_rows(DriveParams(), DriveParams(delay_s=0.1))
    >>> rows[0].name, rows[0].value, rows[0].status
    ('delay_s', 0.1, 'spec')
    """
    entries: Mapping[str, Any] = {}
    if params_file is not None:
        doc = (
            params_file.document
            if isinstance(params_file, ParamsFile)
            else load_params_document(params_file)
        )
        if isinstance(doc, dict) and isinstance(doc.get("parameters"), dict):
            entries = doc["parameters"]
    rows = []
    for name in DriveParams.names():
        entry = entries.get(name)
        entry = entry if isinstance(entry, dict) else {}
        ci = entry.get("ci95")
        ci95 = None
        if isinstance(ci, list | tuple) and len(ci) == 2:
            lo, hi = _float_or_none(ci[0]), _float_or_none(ci[1])
            ci95 = (lo, hi) if lo is not None and hi is not None else None
        rows.append(
            ParamRow(
                name=name,
                unit=str(entry.get("unit") or _unit(name)),
                default=float(getattr(defaults, name)),
                value=float(getattr(used, name)),
                std=_float_or_none(entry.get("std")),
                ci95=ci95,
                status=str(entry.get("status") or ("file" if entry else "spec")),
            )
        )
    return tuple(rows)


def _fmt(x: float | None, spec: str = ".4g") -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    if isinstance(x, float) and math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return format(x, spec)


def _pct(x: float) -> str:
    return f"{100 * x:.1f} %" if math.isfinite(x) else "n/a"


def _summary_table(data: ReportInput) -> Table:
    rows: list[list[str]] = []
    metrics = (
        ("agreement (both axes)", "agreement", _pct),
        ("agreement v", "agreement_v", _pct),
        ("agreement w", "agreement_w", _pct),
        ("FIT % v", "fit_percent_v", lambda x: _fmt(x, ".1f")),
        ("FIT % w", "fit_percent_w", lambda x: _fmt(x, ".1f")),
        ("RMSE v [m/s]", "rmse_v", lambda x: _fmt(x, ".4f")),
        ("RMSE w [rad/s]", "rmse_w", lambda x: _fmt(x, ".4f")),
        ("timing v", "lag_s_v", lag_phrase),
        ("timing w", "lag_s_w", lag_phrase),
        ("active / all samples", "n_active", None),
    )
    for label, key, fmt in metrics:
        row = [label]
        for run in data.runs:
            a = run.agreement
            row.append(f"{a.n_active} / {a.n_samples}" if fmt is None else fmt(getattr(a, key)))
        rows.append(row)
    first = data.runs[0].agreement
    note = (
        f"Tolerances: |v_sim - v_real| <= {first.tol_v:g} m/s and |w_sim - w_real| <= "
        f"{first.tol_w:g} rad/s; only active samples count (see the definitions at the end)."
    )
    return Table(
        title="Agreement figures",
        header=["figure", *(r.label for r in data.runs)],
        rows=rows,
        note=note,
    )


def _per_axis(fraction_v: float, fraction_w: float) -> str:
    """A headline card's per-axis figures, e.g. ``"v 93.1 % · w 88.0 %"``."""
    return f"v {_pct(fraction_v)} · w {_pct(fraction_w)}"


def _cards(data: ReportInput) -> list[HeadlineCard]:
    cards = []
    for run in data.runs:
        a = run.agreement
        cards.append(
            HeadlineCard(
                label=f"agreement — {run.label}",
                fraction=a.agreement,
                detail=f"{_per_axis(a.agreement_v, a.agreement_w)} · {a.n_active} active samples",
            )
        )
    if len(data.runs) >= 2:
        gain = data.runs[-1].agreement.agreement - data.runs[0].agreement.agreement
        if math.isfinite(gain):
            cards.append(
                HeadlineCard(
                    label="change",
                    fraction=data.runs[-1].agreement.agreement,
                    detail=f"agreement points from {data.runs[0].label} to {data.runs[-1].label}",
                    text=f"{100 * gain:+.1f} pts",
                )
            )
    if data.ensemble is not None:
        e = data.ensemble
        cards.append(
            HeadlineCard(
                label=f"coverage of the {100 * e.band_level:g} % band (N={e.n})",
                fraction=e.coverage,
                # the band's verdict and next step are the page's verdict, said once above
                detail=f"{_per_axis(e.coverage_v, e.coverage_w)} · median width "
                f"{e.band_width_v_mps:.2g} m/s, {e.band_width_w_radps:.2g} rad/s",
            )
        )
    return cards


def _steps_table(data: ReportInput) -> Table:
    trace = data.trace
    t = np.asarray(trace.meas_t_s, dtype=np.float64)
    steps = find_steps(
        np.asarray(trace.cmd_t_s, dtype=np.float64),
        np.asarray(trace.cmd_v, dtype=np.float64),
        np.asarray(trace.cmd_w, dtype=np.float64),
    )
    who = " | ".join(["real", *(r.label for r in data.runs)])
    header = ["t [s]", "axis", "command", f"rise time [s] ({who})"]
    header += [f"overshoot [%] ({who})", f"steady-state error ({who})"]
    rows = []
    for step in steps:
        ys = [trace.meas_v if step.axis == "v" else trace.meas_w]
        ys += [r.replay.v if step.axis == "v" else r.replay.w for r in data.runs]
        resp = [step_response(t, np.asarray(y, dtype=np.float64), step) for y in ys]
        unit = "m/s" if step.axis == "v" else "rad/s"
        rows.append(
            [
                f"{step.t_start_s:.2f}",
                step.axis,
                f"{step.before:+.3g} → {step.after:+.3g} {unit}",
                " | ".join(_fmt(r.rise_time_s, ".2f") for r in resp),
                " | ".join(_fmt(r.overshoot_pct, ".1f") for r in resp),
                " | ".join(_fmt(r.ss_error, "+.3f") for r in resp),
            ]
        )
    return Table(
        title="Step-like segments",
        header=header,
        rows=rows,
        note="Held command changes (>= 0.05 m/s or 0.3 rad/s, held >= 1 s; first 12). Rise "
        "time: 10-90 % of the response's own change; overshoot in % of the commanded change; "
        "steady-state error: mean of the last 30 % of the hold minus the command."
        + ("" if rows else " No step-like segment found in this log."),
    )


def _params_table(rows: Sequence[ParamRow]) -> Table:
    body = []
    for r in rows:
        ci = f"[{_fmt(r.ci95[0])}, {_fmt(r.ci95[1])}]" if r.ci95 else ""
        std = _fmt(r.std) if r.std else ""
        body.append([r.name, r.unit, _fmt(r.default), _fmt(r.value), std, ci, r.status])
    return Table(
        title="Drive parameters",
        header=["parameter", "unit", "spec default", "used", "std", "95 % interval", "status"],
        rows=body,
        note="'used' is the value of the last simulation column; std and interval come from "
        "the sysid result (fitted parameters only).",
    )


_DEFINITIONS = {
    "active sample": "a measurement sample where the held command is non-zero (|cmd| > 1e-3) "
    "or the real robot moves (|v| > tol_v or |w| > tol_w); idle samples are excluded",
    "agreement": "fraction of active samples where both |v_sim - v_real| <= tol_v and "
    "|w_sim - w_real| <= tol_w (agreement v / w: one axis each)",
    "FIT %": "MATLAB compare fit over active samples, 100 (1 - ||y - y_sim|| / ||y - mean(y)||)",
    "lag": "shift of the simulated trace behind the real one at the cross-correlation peak",
    "coverage": "fraction of active real samples inside the central predictive band (level "
    "given, 90 % by default) of robots drawn from the params file's randomisation plus sampled "
    "odometry noise (coverage v / w: one axis each); a calibrated 90 % band covers 80-99 %",
}


#: Height of the main (first-screen) plot, inches at 100 dpi: with the verdict above it, it
#: fits a 1280x800 screen.
LEAD_PLOT_HEIGHT_IN = 4.1


def _figures(data: ReportInput) -> list[tuple[str, Figure]]:
    trace = data.trace
    t = np.asarray(trace.meas_t_s, dtype=np.float64)
    rv = np.asarray(trace.meas_v, dtype=np.float64)
    rw = np.asarray(trace.meas_w, dtype=np.float64)
    sims = [SimSeries(label=r.label, v=r.replay.v, w=r.replay.w) for r in data.runs]
    band = _band(data.ensemble)
    first = data.runs[0].agreement
    cmd_v, cmd_w = trace.cmd_at_meas()
    active = active_mask(cmd_v, cmd_w, rv, rw, tol_v=first.tol_v, tol_w=first.tol_w)
    rolling = _rolling(data.runs, t, rv, rw, active)
    zoom = _zoom_figure(data, sims, band)
    figures = [
        (
            "timeseries",
            Figure(
                title="Velocity over time",
                png=time_series_png(
                    t,
                    rv,
                    rw,
                    sims,
                    cmd_t_s=np.asarray(trace.cmd_t_s, dtype=np.float64),
                    cmd_v=np.asarray(trace.cmd_v, dtype=np.float64),
                    cmd_w=np.asarray(trace.cmd_w, dtype=np.float64),
                    band=band,
                    height_in=LEAD_PLOT_HEIGHT_IN,
                ),
                caption="Forward velocity v and yaw rate w: real odometry, each simulation, the "
                "command (dashed) and, when present, the ensemble's predictive band (sampled "
                "robots plus sampled odometry noise).",
            ),
        ),
        *([("zoom", zoom)] if zoom is not None else []),
        (
            "errors",
            Figure(
                title="Error histograms",
                png=error_histograms_png(
                    rv, rw, sims, active, tol_v=first.tol_v, tol_w=first.tol_w
                ),
                caption="sim - real on active samples; dashed lines mark the tolerances.",
            ),
        ),
        (
            "rolling",
            Figure(
                title="Rolling agreement",
                png=rolling_agreement_png(t, rolling, window_s=ROLLING_WINDOW_S, active=active),
                caption=f"Share of agreeing active samples in a centred {ROLLING_WINDOW_S:g} s "
                "window; grey: idle time (excluded from the score).",
            ),
        ),
    ]
    return figures


def _band(ensemble: EnsembleResult | None) -> Band | None:
    """The ensemble's predictive band as the plots draw it (None without an ensemble)."""
    if ensemble is None:
        return None
    return Band(
        lo_v=ensemble.lo_v,
        hi_v=ensemble.hi_v,
        lo_w=ensemble.lo_w,
        hi_w=ensemble.hi_w,
        label=f"{100 * ensemble.band_level:g} % predictive band (N={ensemble.n})",
    )


def _rolling(
    runs: Sequence[ReportRun], t: np.ndarray, rv: np.ndarray, rw: np.ndarray, active: np.ndarray
) -> list[tuple[str, np.ndarray]]:
    """Each run's rolling agreement (the first run's tolerances, as the figures use)."""
    first = runs[0].agreement
    rolling = []
    for r in runs:
        ok = (np.abs(r.replay.v - rv) <= first.tol_v) & (np.abs(r.replay.w - rw) <= first.tol_w)
        rolling.append((r.label, rolling_agreement(t, ok, active, window_s=ROLLING_WINDOW_S)))
    return rolling


#: Length of the close-up window, s.
ZOOM_WINDOW_S = 12.0


def _zoom_figure(data: ReportInput, sims: list[SimSeries], band: Band | None) -> Figure | None:
    """A close-up of the first step-like segment (or the first command), both axes."""
    trace = data.trace
    t = np.asarray(trace.meas_t_s, dtype=np.float64)
    cmd_t = np.asarray(trace.cmd_t_s, dtype=np.float64)
    cmd_v = np.asarray(trace.cmd_v, dtype=np.float64)
    cmd_w = np.asarray(trace.cmd_w, dtype=np.float64)
    steps = find_steps(cmd_t, cmd_v, cmd_w, max_steps=1)
    moving = np.flatnonzero((np.abs(cmd_v) > 1e-3) | (np.abs(cmd_w) > 1e-3))
    if steps:
        start = steps[0].t_start_s - 1.0
    elif moving.size:
        start = float(cmd_t[moving[0]]) - 1.0
    else:
        return None
    sel = (t >= start) & (t <= start + ZOOM_WINDOW_S)
    csel = (cmd_t >= start) & (cmd_t <= start + ZOOM_WINDOW_S)
    if sel.sum() < 4:
        return None
    z_sims = [SimSeries(label=s.label, v=s.v[sel], w=s.w[sel]) for s in sims]
    z_band = None
    if band is not None:
        z_band = Band(
            lo_v=band.lo_v[sel], hi_v=band.hi_v[sel], lo_w=band.lo_w[sel], hi_w=band.hi_w[sel],
            label=band.label,
        )  # fmt: skip
    png = time_series_png(
        t[sel],
        np.asarray(trace.meas_v, dtype=np.float64)[sel],
        np.asarray(trace.meas_w, dtype=np.float64)[sel],
        z_sims,
        cmd_t_s=cmd_t[csel],
        cmd_v=cmd_v[csel],
        cmd_w=cmd_w[csel],
        band=z_band,
    )
    return Figure(
        title="Close-up",
        png=png,
        caption=f"{ZOOM_WINDOW_S:g} s from {start:.1f} s: delay, acceleration and settling "
        "of the real base against each simulation.",
    )


def write_report(path: str | Path, data: ReportInput, *, write_pngs: bool = True) -> ReportFiles:
    """Write the HTML report to ``path`` and the plots as ``<stem>_<name>.png`` beside it.

    Parameters
    ----------
    path : str or Path
        The HTML file to write (its folder must exist).
    data : ReportInput
        What to show.
    write_pngs : bool
        Also write each figure as a PNG file next to the HTML file.

    Returns
    -------
    ReportFiles
        The paths written.
    """
    target = check_output_path(path, what="report file")
    if not data.runs:
        raise Sim2RealValueError(
            "ReportInput.runs is empty; give at least one ReportRun (a replay and its agreement)"
        )
    figures = _figures(data)
    first = data.runs[0].agreement
    subtitle = (
        f"log {first.log_file or '?'} · robot {first.robot} · engine {data.runs[0].replay.engine}"
        f" · {first.n_samples} samples, {first.n_active} active"
    )
    tables = [_steps_table(data)]
    if data.params:
        tables.append(_params_table(data.params))
    if data.provenance:
        tables.append(
            Table(
                title="Provenance", header=["item", "value"], rows=list(data.provenance), wrap=True
            )
        )
    page = render_page(
        title=data.title,
        subtitle=subtitle,
        verdict=make_verdict(
            data.runs, data.ensemble, robot=first.robot, verdict=data.verdict, notes=data.notes
        ),
        lead=figures[0][1],
        cards=_cards(data),
        summary=_summary_table(data),
        figures=[f for _, f in figures[1:]],
        tables=tables,
        definitions=_DEFINITIONS,
    )
    images: list[Path] = []
    if write_pngs:
        for name, fig in figures:
            png_path = target.with_name(f"{target.stem}_{name}.png")
            with atomic_write(png_path, "wb", what="report image") as fh:
                fh.write(fig.png)
            images.append(png_path)
    with atomic_write(target, "wb", what="report file") as fh:
        fh.write(page.encode("utf-8"))
    return ReportFiles(html=target, images=tuple(images))


def write_fleet_report(
    path: str | Path,
    *,
    figures: Sequence[Mapping[str, Any]],
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    subtitle: str,
    pooled: str = "",
    title: str = "sim2real agreement report: fleet",
) -> Path:
    """Write the page of a multi-log ``agree``: the fleet table, then each log's verdict.

    Parameters
    ----------
    path : str or Path
        The HTML file to write (written to a temp file and renamed).
    figures : sequence of mapping
        Each log's figures as ``agree --json`` writes them under ``logs``: its ``log_file``
        and ``verdict`` (:meth:`sim2real.agreement.verdict.AgreementVerdict.to_dict`) and
        ``notes``, or ``error`` for a log that could not be used.
    header, rows : sequence
        The fleet table as the terminal prints it (already formatted cells).
    subtitle, pooled, title : str
        The line under the title, the pooled band sentence ("" for none), the page title.

    Returns
    -------
    Path
        The page written.

    Examples
    --------
    >>> write_fleet_report("fleet.html", figures=[{"log_file": "a.mcap", "error": "empty"}],
    ...                    header=["log"], rows=[["a.mcap"]], subtitle="1 log")  # doctest: +SKIP
    PosixPath('fleet.html')
    """
    target = check_output_path(path, what="report file")
    entries = []
    for f in figures:
        verdict = f.get("verdict")
        entries.append(
            FleetEntry(
                name=Path(str(f.get("log_file"))).name,
                verdict=AgreementVerdict.from_dict(verdict)
                if "error" not in f and isinstance(verdict, Mapping)
                else None,
                error=str(f.get("error", "no verdict was decided for this log")),
                notes=tuple(str(n) for n in f.get("notes", ())),
            )
        )
    page = render_fleet_page(
        title=title,
        subtitle=subtitle,
        summary=Table(title="Logs", header=list(header), rows=[list(r) for r in rows]),
        pooled=pooled,
        entries=entries,
    )
    with atomic_write(target, "wb", what="report file") as fh:
        fh.write(page.encode("utf-8"))
    return target
