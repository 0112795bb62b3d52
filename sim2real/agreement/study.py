"""The agreement study: replay a log, measure agreement, build the band, write the outputs.

:func:`run_study` is what ``sim2real agree`` (and ``sim2real demo``) run: it reads the log,
replays it with the spec defaults and (when given) a params file, measures the agreement of
each replay (:mod:`sim2real.agreement.figures`), optionally replays an ensemble drawn from the params
file's randomisation and measures how much of the real log its predictive band covers, and
writes the requested outputs (JSON figures, HTML report, simulated MCAP). The CLI only parses
arguments into a :class:`StudyConfig`, calls :func:`run_study` and prints
:func:`summary_table` of the returned :class:`StudyResult`.

Examples
--------
>>> from sim2real.agreement.study import StudyConfig, run_study
>>> result = run_study(StudyConfig(log="val.mcap", robot="turtlebot3_burger",  # doctest: +SKIP
...                                params_path="params.yaml", engine="reduced"))
>>> round(result.main.agreement, 2)  # doctest: +SKIP
0.93
"""

from __future__ import annotations

import hashlib
import json
import math
import platform
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

from robots.errors import RobotsValueError
from robots.params import ParamsFile, load_drive_params, read_params_file
from robots.randomization import DriveDistribution, ObservationNoise
from robots.spec import load_spec
from sim2real._io import atomic_write, check_not_an_input, check_output_path, output_set
from sim2real.agreement.figures import (
    AgreementReport,
    EnsembleResult,
    check_band_level,
    check_ensemble_size,
    check_tolerances,
    lag_phrase,
    measure_agreement,
    run_ensemble,
    since_command_step_s,
)
from sim2real.agreement.latency import (
    NoiseCeiling,
    SessionLatency,
    band_sample_noise,
    bounded_ceiling,
    fit_speed_noise,
    log_noise,
    motion_ceiling,
    noise_note,
    session_latency,
)
from sim2real.agreement.replay import replay
from sim2real.agreement.report import ReportInput, ReportRun, param_rows, write_report
from sim2real.agreement.verdict import (
    AgreementVerdict,
    SessionFigures,
    band_miss_reason,
    decide,
    speed_shortfall,
)
from sim2real.errors import LogValueError, Sim2RealValueError
from sim2real.logs import ReadOptions, read_for_robot, write_velocity_log
from sim2real.logs._bags import open_log_source
from sim2real.logs._digest import FileDigest
from sysid.envelope import Envelope, EnvelopeCheck, check_envelope, unknown_envelope
from sysid.metrics import active_mask

__all__ = [
    "StudyConfig",
    "StudyResult",
    "check_figures",
    "defined_figures",
    "envelope_check",
    "fitted_noise",
    "odom_v_window_seconds",
    "parse_odom_v_window",
    "provenance_rows",
    "reference_figures",
    "run_study",
    "session_figures",
    "study_figures",
    "summary_table",
    "write_json",
]


@dataclass(frozen=True, kw_only=True)
class StudyConfig:
    """What to compare and what to write (the arguments of ``sim2real agree``).

    Attributes
    ----------
    log : str or Path
        The real log (ROS 2 MCAP).
    robot : str
        Robot (spec) name.
    params_path : str or Path, optional
        A sysid result; without it only the spec defaults are replayed.
    engine : {"pybullet", "reduced", "mujoco"}
        Simulator of every replay.
    tol_v, tol_w : float
        Agreement tolerances, m/s and rad/s.
    ensemble_n : int, optional
        Size of the ensemble drawn from the params file (>= 2); None = no ensemble.
    seed : int
        Seed of the ensemble draws.
    spread : float
        Multiplier on the ensemble's standard deviations.
    band_level : float
        Central probability of the predictive band, in (0, 1).
    odom_v_window : float or "auto"
        Odometry window of v, s (see :func:`sim2real.agreement.replay.replay`); ``"auto"`` (default)
        takes the robot's (:attr:`robots.spec.OdometrySpec.v_window_s`), like ``sysid fit``.
    read : sim2real.logs.ReadOptions
        How the log is read: topics, clock, velocity source, and whether the unattended
        samples (motion with no command in force, a command held while the wheels stay
        stopped) are kept rather than left out with a note.
    json_path, report_path, sim_out : str or Path, optional
        Outputs: the figures as JSON, the HTML report (+ PNGs), the simulated run as MCAP.
    command_line : str
        The command line shown in the report's provenance.
    title : str
        The report's title.
    params_shown : str, optional
        How the outputs (JSON ``params_file``, report) name the params file when it is read
        from elsewhere (``sim2real demo`` reads it from its staging folder); default
        ``params_path``.
    """

    log: str | Path
    robot: str
    params_path: str | Path | None = None
    engine: str = "pybullet"
    tol_v: float = 0.02
    tol_w: float = 0.1
    ensemble_n: int | None = None
    seed: int = 0
    spread: float = 1.0
    band_level: float = 0.9
    odom_v_window: float | str = "auto"
    read: ReadOptions = field(default_factory=ReadOptions)
    json_path: str | Path | None = None
    report_path: str | Path | None = None
    sim_out: str | Path | None = None
    command_line: str = ""
    title: str = "sim2real agreement report"
    params_shown: str | None = None


@dataclass(frozen=True, kw_only=True)
class StudyResult:
    """What :func:`run_study` computed.

    Attributes
    ----------
    main : AgreementReport
        The figures of the requested configuration (the params file, else the spec defaults).
    runs : tuple of ReportRun
        Every replay made (spec defaults first, then the params file when given).
    ensemble : EnsembleResult or None
        The ensemble, when requested.
    figures : dict
        The JSON figures (:data:`sim2real.agreement.figures.AGREEMENT_KEYS`, plus the band's keys with
        an ensemble, plus :data:`sim2real.agreement.latency.REFERENCE_KEYS` with a params
        file); what ``--json`` writes.
    warnings : tuple of str
        Repairs made while reading the log (dropped NaN samples, re-sorted stamps, ...).
    written : tuple of Path
        Output files written (JSON, report HTML, simulated MCAP), in that order.
    time_note : str
        Which time base ``time_source="auto"`` chose and why ("" otherwise).
    verdict : AgreementVerdict or None
        The verdict of the run (:func:`sim2real.agreement.verdict.decide`): what the terminal
        prints and the report shows.
    notes : tuple of str
        Notes on the data: segments left out, figures left undefined on this log.
    latency : SessionLatency or None
        With a params file: this log's own best command latency and the agreement at it
        (:func:`sim2real.agreement.latency.session_latency`).
    ceiling : NoiseCeiling or None
        With a params file: the agreement and the band width that the odometry noise the fit
        estimated alone allows (:func:`sim2real.agreement.latency.noise_ceiling` of
        :func:`fitted_noise`).
    """

    main: AgreementReport
    runs: tuple[ReportRun, ...]
    ensemble: EnsembleResult | None
    figures: dict[str, Any]
    warnings: tuple[str, ...] = ()
    written: tuple[Path, ...] = ()
    time_note: str = ""
    verdict: AgreementVerdict | None = None
    notes: tuple[str, ...] = ()
    latency: SessionLatency | None = None
    ceiling: NoiseCeiling | None = None


def _sha256(path: str | Path) -> str:
    """SHA-256 of a file, or of a rosbag2 folder as its reader hashes it (the log_sha256 of --json)."""
    if Path(path).is_dir():
        return FileDigest(open_log_source(Path(path)).digest_paths, name=str(path))()
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _versions() -> str:
    parts = [f"python {platform.python_version()}"]
    for dist in ("sim2real", "numpy", "scipy", "pybullet", "mcap", "matplotlib"):
        try:
            parts.append(f"{dist} {version(dist)}")
        except PackageNotFoundError:
            parts.append(f"{dist} (not installed)")
    return ", ".join(parts)


def provenance_rows(
    *,
    files: Sequence[tuple[str, str | Path]],
    robot: Any,
    engine: str,
    seed: int | None,
    command_line: str,
    odom_v_window_s: float = 0.0,
    shown: Mapping[str, str] | None = None,
) -> list[tuple[str, str]]:
    """Provenance lines of a report: files with SHA-256, spec, versions, seed, command.

    ``shown`` maps a file's path to the name the report gives it (default: the path).
    """
    names = shown or {}
    rows = [
        (role, f"{names.get(str(path), path)}  (sha256 {_sha256(path)})") for role, path in files
    ]
    spec_path = getattr(robot, "path", None)
    rows.append(("robot spec", f"{robot.name}" + (f"  ({spec_path})" if spec_path else "")))
    rows.append(("engine", engine))
    if odom_v_window_s:
        rows.append(("odometry v window", f"{odom_v_window_s:.4g} s (simulated v averaged)"))
    rows.append(("ensemble seed", "n/a" if seed is None else str(seed)))
    rows.append(("versions", _versions()))
    rows.append(("command line", command_line))
    return rows


def parse_odom_v_window(value: float | str, rate_hz: float, *, v_source: str = "wheels") -> float:
    """Seconds of ``--odom-v-window``: a number in [0, 1] or ``"auto"``.

    ``"auto"`` is the robot's own window (:attr:`robots.spec.OdometrySpec.v_window_s`): one
    odometry period ``1 / rate_hz`` when v comes from wheel encoders (``v_source="wheels"``),
    0 otherwise.

    Examples
    --------
    >>> parse_odom_v_window("auto", 30.0), parse_odom_v_window(0.05, 30.0)
    (0.03333333333333333, 0.05)
    """
    if isinstance(value, str) and value.strip() == "auto":
        return 1.0 / rate_hz if v_source == "wheels" else 0.0
    return odom_v_window_seconds(value)


def odom_v_window_seconds(value: float | str) -> float:
    """A number of seconds ``--odom-v-window`` gives, checked to lie in [0, 1].

    Examples
    --------
    >>> odom_v_window_seconds("0.05")
    0.05
    """
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        seconds = math.nan
    if not (math.isfinite(seconds) and 0.0 <= seconds <= 1.0):
        raise Sim2RealValueError(
            f"--odom-v-window must be 'auto' or seconds in [0, 1], got {value!r}; e.g. "
            "--odom-v-window auto (one odometry period) or 0.0333"
        )
    return seconds


def _check_config(config: StudyConfig) -> None:
    check_tolerances(config.tol_v, config.tol_w)
    outputs = (
        (config.json_path, "--json file"),
        (config.report_path, "report file"),
        (config.sim_out, "--sim-out file"),
    )
    for path, what in outputs:
        if path is not None:
            check_output_path(path, what=what)
            check_not_an_input(path, [config.log, config.params_path], what=what)
    n = config.ensemble_n
    if n is not None:
        check_ensemble_size(n)
    if n is not None and config.params_path is None:
        raise Sim2RealValueError(
            "--ensemble needs --params: the ensemble draws parameters from the randomisation "
            "of a sysid result; add --params params.yaml"
        )
    check_band_level(config.band_level)
    spread = config.spread
    if isinstance(spread, bool) or not (
        isinstance(spread, int | float) and math.isfinite(spread) and spread >= 0
    ):
        raise Sim2RealValueError(
            f"ensemble spread (--spread) must be a finite number >= 0, got {spread!r}; e.g. 1"
        )


def run_study(
    config: StudyConfig, *, progress: Callable[[int, int], None] | None = None
) -> StudyResult:
    """Replay ``config.log`` with spec defaults (and the params file), measure, write outputs.

    Parameters
    ----------
    config : StudyConfig
        What to compare and what to write.
    progress : callable, optional
        ``progress(done, n)`` after each ensemble member (the CLI draws a bar with it).

    Returns
    -------
    StudyResult

    Raises
    ------
    sim2real.errors.Sim2RealError, robots.errors.RobotsError
        On bad input (one sentence naming the argument or file and the fix).
    """
    _check_config(config)
    spec = load_spec(config.robot)
    window_s = parse_odom_v_window(
        config.odom_v_window, spec.odometry.rate_hz, v_source=spec.odometry.v_source
    )
    # the params file is read once here and handed to whatever uses it
    params_file = None if config.params_path is None else read_params_file(config.params_path)
    params = None
    if params_file is not None:
        params = load_drive_params(params_file, robot=spec.name, base=spec.drive)
    trace, screened = read_for_robot(config.log, spec, config.read)
    runs = _replays(config, trace, spec, params, window_s)
    ensemble, band_note = _ensemble(
        config, trace, spec, params_file, (window_s, runs[-1].replay), progress
    )
    latency, ceiling = _reference_figures(
        config, trace, spec, (params, runs[-1].replay), params_file, window_s
    )
    figures = study_figures(runs[-1].agreement, ensemble)
    figures.update(reference_figures(latency, ceiling))
    check_figures(figures, config.log)
    figures, undefined = defined_figures(figures)
    notes = tuple(n for n in (screened, band_note) if n) + undefined
    # whose noise the ceiling assumes: the terminal and the report say it in the verdict
    said = (ceiling.note,) if ceiling is not None and ceiling.note else ()
    if notes + said:
        figures["notes"] = list(notes + said)
    verdict = _verdict(config, spec, trace, runs, ensemble, params, params_file, (latency, ceiling))
    report = None
    if config.report_path is not None:
        report = _report_input(
            config, trace, spec, tuple(runs), ensemble, window_s, params_file, verdict, notes
        )
    written = _write_outputs(config, figures, trace, runs[-1].replay, report)
    return StudyResult(
        main=runs[-1].agreement,
        runs=tuple(runs),
        ensemble=ensemble,
        figures=figures,
        warnings=tuple(trace.meta.warnings),
        written=tuple(written),
        time_note=trace.meta.time_note,
        verdict=verdict,
        notes=notes,
        latency=latency,
        ceiling=ceiling,
    )


def _replays(
    config: StudyConfig, trace: Any, spec: Any, params: Any, window_s: float
) -> list[ReportRun]:
    """The spec defaults' replay, then the params file's (when given), each measured."""
    runs = []
    configs: list[tuple[str, Any, str | None]] = [("spec defaults", spec.drive, None)]
    if params is not None:
        configs.append(("sysid params", params, config.params_shown or str(config.params_path)))
    for label, p, pfile in configs:
        sim = replay(trace, robot=spec, params=p, engine=config.engine, odom_v_window_s=window_s)
        rep = measure_agreement(
            trace, sim, tol_v=config.tol_v, tol_w=config.tol_w, params_file=pfile
        )
        runs.append(ReportRun(label=label, replay=sim, agreement=rep))
    return runs


def _write_outputs(
    config: StudyConfig,
    figures: dict[str, Any],
    trace: Any,
    sim: Any,
    report: ReportInput | None,
) -> list[Path]:
    """Write the JSON figures, the report and the simulated log (the replay ``sim``) that
    ``config`` asks for."""
    written: list[Path] = []
    # the outputs are one set: all move in at the end, or none (a kill keeps the old set)
    with output_set([config.json_path, config.report_path, config.sim_out]) as out:
        if config.json_path is not None:
            write_json(out.staged(config.json_path), figures)
            written.append(Path(config.json_path))
        if config.report_path is not None and report is not None:
            write_report(out.staged(config.report_path), report)
            written.append(Path(config.report_path))
        if config.sim_out is not None:
            _write_sim_log(out.staged(config.sim_out), trace, sim)
            written.append(Path(config.sim_out))
    return written


def _reference_figures(
    config: StudyConfig,
    trace: Any,
    spec: Any,
    fitted: tuple[Any, Any],
    params_file: ParamsFile | None,
    window_s: float,
) -> tuple[SessionLatency | None, NoiseCeiling | None]:
    """The session's own best latency and the noise ceiling (None without a params file).

    ``fitted`` is the params and their replay of ``trace``. The ceiling assumes this log's own
    odometry noise when it has enough steady samples, else the fit's (none without a
    randomisation block), per axis no larger than the log's own upper bound on its noise
    (:func:`sim2real.agreement.latency.bounded_ceiling`); its note says which
    (:func:`sim2real.agreement.latency.noise_note`)."""
    params, replayed = fitted
    if params is None or params_file is None:
        return None, None
    latency = session_latency(
        trace,
        robot=spec,
        params=params,
        engine=config.engine,
        odom_v_window_s=window_s,
        tol_v=config.tol_v,
        tol_w=config.tol_w,
        params_file=config.params_shown or str(config.params_path),
    )
    fit = None
    if "randomization" in params_file.document:
        fit = fitted_noise(
            DriveDistribution.from_params_file(params_file, robot=spec.name).noise,
            params_file.document.get("calibration"),
        )
    own = log_noise(trace)
    noise = (
        ObservationNoise(std_v_mps=own.std_v_mps, std_w_radps=own.std_w_radps)
        if own.measured
        else fit
    )
    if noise is None:  # no noise model and too few steady samples: no ceiling
        return latency, None
    tols = {"tol_v": config.tol_v, "tol_w": config.tol_w, "level": config.band_level}
    law = fit_speed_noise(params_file.document.get("settings"))
    ceiling = (
        motion_ceiling(trace, noise, **tols, fallback=law)
        if own.measured
        else bounded_ceiling(noise, trace, replayed, **tols)
    )
    note = "; ".join(n for n in (noise_note(own, fit), ceiling.note) if n)
    return latency, replace(ceiling, note=note)


def fitted_noise(noise: ObservationNoise, calibration: Any) -> ObservationNoise:
    """The odometry noise the fit estimated: a calibrated file's noise with the calibration's
    factors (``noise_factor_v`` / ``_w``: calibrated std / fitted std) undone; the file's
    noise when it was not calibrated or a factor is not a number > 0."""
    if not isinstance(calibration, Mapping):
        return noise
    stds = {}
    for axis, name in (("v", "std_v_mps"), ("w", "std_w_radps")):
        factor = calibration.get(f"noise_factor_{axis}")
        ok = isinstance(factor, int | float) and math.isfinite(factor) and factor > 0
        stds[name] = getattr(noise, name) / factor if ok else getattr(noise, name)
    try:
        return replace(noise, **stds)
    except RobotsValueError:  # an absurd quotient (a factor near 0): the file's own noise
        return noise


def reference_figures(
    latency: SessionLatency | None, ceiling: NoiseCeiling | None
) -> dict[str, float]:
    """The JSON keys of the session's latency and the noise ceiling (:data:`REFERENCE_KEYS`;
    absent when not measured)."""
    out: dict[str, float] = {}
    if latency is not None:
        out["best_delay_s"] = latency.delay_s
        out["fitted_delay_s"] = latency.fitted_delay_s
        out["agreement_at_best_delay"] = latency.report.agreement
    if ceiling is not None:
        out["noise_ceiling"] = ceiling.agreement
        out["noise_band_width_v_mps"] = ceiling.band_width_v_mps
        out["noise_band_width_w_radps"] = ceiling.band_width_w_radps
        out["noise_std_v_mps"] = ceiling.std_v_mps
        out["noise_std_w_radps"] = ceiling.std_w_radps
    return out


def session_figures(
    trace: Any,
    spec: Any,
    runs: Sequence[Any],
    params: Any,
    params_file: ParamsFile | None = None,
    reference: tuple[SessionLatency | None, NoiseCeiling | None] = (None, None),
    ensemble: EnsembleResult | None = None,
) -> SessionFigures:
    """The checked session's figures the verdict weighs (top speeds, fitted delay, shortfall,
    the log against the envelope the fit saw when ``params_file`` is given, this log's own
    best latency and the noise ceiling, why the ``ensemble``'s band misses)."""
    main = runs[-1]
    cmd_v, cmd_w = trace.cmd_at_meas()
    a = main.agreement
    limits = (float(spec.max_v_mps), float(spec.max_w_radps))  # steps of the command as clipped
    extrapolation = None
    if params_file is not None:
        extrapolation = envelope_check(params_file, trace, tol_v=a.tol_v, tol_w=a.tol_w)
    active = active_mask(cmd_v, cmd_w, trace.meas_v, trace.meas_w, tol_v=a.tol_v, tol_w=a.tol_w)
    shortfall = None
    if params is not None:
        shortfall = speed_shortfall(
            trace.meas_v,
            trace.meas_w,
            main.replay.v,
            main.replay.w,
            active,
            tol_v=a.tol_v,
            tol_w=a.tol_w,
        )
    latency, ceiling = reference
    return SessionFigures(
        extrapolation=extrapolation,
        fitted_delay_s=None if params is None else float(params.delay_s),
        best_delay_s=None if latency is None else latency.delay_s,
        agreement_at_best_delay=None if latency is None else latency.report.agreement,
        noise_ceiling=None if ceiling is None else ceiling.agreement,
        noise_band_width_v_mps=None if ceiling is None else ceiling.band_width_v_mps,
        noise_band_width_w_radps=None if ceiling is None else ceiling.band_width_w_radps,
        noise_note=None if ceiling is None or not ceiling.note else ceiling.note,
        top_v_mps=float(spec.max_v_mps),
        top_w_radps=float(spec.max_w_radps),
        speed_shortfall=shortfall,
        fit_log=None if params_file is None else params_file.fitted_on(trace.meta.sha256),
        band_misses=None
        if ensemble is None
        else band_miss_reason(
            ensemble,
            trace.meas_v,
            trace.meas_w,
            since_command_step_s(trace, tol_v=a.tol_v, tol_w=a.tol_w, limits=limits),
        ),
    )


def envelope_check(
    params_file: ParamsFile, trace: Any, *, tol_v: float, tol_w: float
) -> EnvelopeCheck:
    """The checked log against the ``envelope`` block of a params file (unknown without one)."""
    block = params_file.document.get("envelope")
    envelope = Envelope.from_dict(block) if isinstance(block, dict) else None
    if envelope is None:
        return unknown_envelope(str(params_file.path))
    return check_envelope(envelope, trace, tol_v=tol_v, tol_w=tol_w)


def _verdict(
    config: StudyConfig,
    spec: Any,
    trace: Any,
    runs: Sequence[Any],
    ensemble: EnsembleResult | None,
    params: Any,
    params_file: ParamsFile | None,
    reference: tuple[SessionLatency | None, NoiseCeiling | None] = (None, None),
) -> AgreementVerdict:
    return decide(
        defaults=runs[0].agreement,
        fitted=runs[-1].agreement if params is not None else None,
        robot=str(config.robot),
        ensemble=ensemble,
        session=session_figures(trace, spec, runs, params, params_file, reference, ensemble),
    )


def _ensemble(
    config: StudyConfig,
    trace: Any,
    spec: Any,
    params_file: ParamsFile | None,
    window: tuple[float, Any],
    progress: Callable[[int, int], None] | None = None,
) -> tuple[EnsembleResult | None, str]:
    """The band on the checked log, its odometry noise per sample the model's share beside
    the log's own (:func:`sim2real.agreement.latency.band_sample_noise`, at the rates of the
    params' replay: ``window`` = (odometry window s, that replay)), and the note that says so
    ("" if not)."""
    if config.ensemble_n is None or params_file is None:
        return None, ""
    window_s, replayed = window
    distribution = DriveDistribution.from_params_file(params_file, robot=spec.name)
    noise, note = band_sample_noise(
        distribution.noise,
        params_file.document.get("settings"),
        trace,
        replayed,
        calibration=params_file.document.get("calibration"),
    )
    ensemble = run_ensemble(
        trace,
        robot=spec,
        distribution=distribution,
        noise=noise,
        n=config.ensemble_n,
        seed=config.seed,
        spread=config.spread,
        engine=config.engine,
        tol_v=config.tol_v,
        tol_w=config.tol_w,
        odom_v_window_s=window_s,
        band_level=config.band_level,
        progress=progress,
    )
    return ensemble, note


#: JSON keys documented as possibly null (provenance: no params file, a trace built in memory).
_MAY_BE_NULL = frozenset({"params_file", "log_file", "log_sha256"})

_WHY = {
    "agreement": "no sample is active (no command is held and the robot never moves)",
    "rmse": "no sample is active (no command is held and the robot never moves)",
    "fit_percent": "the measured {axis} is constant over the active samples (and the "
    "simulated too, within the tolerance)",
    "lag_s": "the measured or simulated {axis} is constant (it varies by less than the tolerance)",
    "coverage": "no sample is active on {axis} or the band could not be built",
    "band_width": "no sample is active or the band could not be built",
}


def _why(key: str) -> str:
    axis = "w" if key.endswith(("_w", "_w_radps")) else "v"
    return next((w for k, w in _WHY.items() if key.startswith(k)), "it is undefined").format(
        axis=axis
    )


def _undefined(figures: dict[str, Any]) -> list[str]:
    return [
        key
        for key, value in figures.items()
        if key not in _MAY_BE_NULL
        and (value is None or (isinstance(value, float) and not math.isfinite(value)))
    ]


def check_figures(figures: dict[str, Any], log: str | Path) -> None:
    """Refuse a log on which nothing can be compared (a figure undefined on one axis is not).

    A log has nothing to compare when no sample is active, or when the measured velocity is
    constant on both axes (the robot never moved, or the odometry topic holds no motion).

    Raises
    ------
    sim2real.errors.LogValueError
        Naming the missing figure, why it is undefined on this log and what to do, so
        ``sim2real agree`` exits 2 instead of reporting success without a number.
    """
    missing = set(_undefined(figures))
    key = next(
        (k for k in ("agreement", "rmse_v") if k in missing),
        "fit_percent_v" if {"fit_percent_v", "fit_percent_w"} <= missing else None,
    )
    if key is not None:
        why = _why(key) if key != "fit_percent_v" else "the measured value is constant on both axes"
        raise LogValueError(
            f"figure '{key}' cannot be computed on log file '{log}' because {why}; "
            "compare on a log in which the robot drives or turns under command (or "
            "choose the topics with --cmd-topic / --odom-topic)"
        )


def defined_figures(figures: dict[str, Any]) -> tuple[dict[str, Any], tuple[str, ...]]:
    """The figures without those undefined on this log, and one note naming each left out.

    A spin-in-place log (v = 0 throughout) has no FIT % or lag of v, a straight-only log none
    of w: those keys are left out (never null) and each note says why.

    Examples
    --------
    >>> figs, notes = defined_figures({"agreement": 0.9, "lag_s_v": None, "log_file": None})
    >>> sorted(figs), notes[0].split(":")[0]
    (['agreement', 'log_file'], "figure 'lag_s_v' is left out")
    """
    missing = _undefined(figures)
    kept = {k: v for k, v in figures.items() if k not in missing}
    notes = tuple(f"figure '{k}' is left out: {_why(k)} on this log" for k in missing)
    return kept, notes


def study_figures(main: AgreementReport, ensemble: EnsembleResult | None) -> dict[str, Any]:
    """The JSON figures: the agreement keys, plus the band's keys when there is an ensemble.

    Figures undefined on the log are ``None`` here; :func:`defined_figures` leaves them out.
    """
    figures = main.to_dict()
    if ensemble is not None:
        figures.update(ensemble.band_figures())
    return figures


def _report_input(
    config: StudyConfig,
    trace: Any,
    spec: Any,
    runs: tuple[ReportRun, ...],
    ensemble: EnsembleResult | None,
    window_s: float,
    params_file: ParamsFile | None,
    verdict: AgreementVerdict | None = None,
    notes: tuple[str, ...] = (),
) -> ReportInput:
    """What the HTML report shows of this run (figures, parameter table, provenance)."""
    files: list[tuple[str, str | Path]] = [("log", config.log)]
    if config.params_path is not None:
        files.append(("params", config.params_path))
    shown = {str(config.params_path): config.params_shown} if config.params_shown else {}
    return ReportInput(
        trace=trace,
        runs=runs,
        ensemble=ensemble,
        params=param_rows(spec.drive, runs[-1].replay.params, params_file),
        provenance=provenance_rows(
            files=files,
            shown=shown,
            robot=spec,
            engine=config.engine,
            seed=config.seed if ensemble is not None else None,
            command_line=config.command_line,
            odom_v_window_s=window_s,
        ),
        title=config.title,
        verdict=verdict,
        notes=notes,
    )


def _write_sim_log(path: str | Path, trace: Any, sim: Any) -> None:
    """The replayed commands and the simulated velocities (at the real stamps) as MCAP.

    The odometry pose is dead-reckoned from the simulated (v, w) by the writer.
    """
    write_velocity_log(
        path,
        cmd_t_ns=trace.cmd_t_ns,
        cmd_v=trace.cmd_v,
        cmd_w=trace.cmd_w,
        meas_t_ns=sim.t_ns,
        meas_v=sim.v,
        meas_w=sim.w,
    )


def write_json(path: str | Path, figures: dict[str, Any]) -> None:
    """Write ``figures`` as pretty JSON (NaN already mapped to null) via a temp file."""
    with atomic_write(path, "wb", what="--json file") as fh:
        fh.write((json.dumps(figures, indent=2, allow_nan=False) + "\n").encode("utf-8"))


def summary_table(
    runs: Sequence[Any], ensemble: Any = None, *, latency: Any = None, ceiling: Any = None
) -> str:
    """A plain-text table of the agreement figures, one column per replay; with ``latency``
    and ``ceiling`` (:class:`StudyResult`'s) also the session's own best latency, the
    agreement at it and what the measurement noise allows.
    """

    def pct(x: float) -> str:
        return f"{100 * x:.1f} %" if math.isfinite(x) else "n/a"

    def num(x: float, spec: str) -> str:
        return format(x, spec) if math.isfinite(x) else "n/a"

    lines = [("", [r.label for r in runs])]
    a = [r.agreement for r in runs]
    lines += [
        ("agreement", [pct(x.agreement) for x in a]),
        ("agreement v", [pct(x.agreement_v) for x in a]),
        ("agreement w", [pct(x.agreement_w) for x in a]),
        ("FIT % v", [num(x.fit_percent_v, ".1f") for x in a]),
        ("FIT % w", [num(x.fit_percent_w, ".1f") for x in a]),
        ("RMSE v [m/s]", [num(x.rmse_v, ".4f") for x in a]),
        ("RMSE w [rad/s]", [num(x.rmse_w, ".4f") for x in a]),
        ("timing v", [lag_phrase(x.lag_s_v) for x in a]),  # the report's words
        ("timing w", [lag_phrase(x.lag_s_w) for x in a]),
        ("active/samples", [f"{x.n_active}/{x.n_samples}" for x in a]),
    ]

    def last(text: str) -> list[str]:
        return ([""] * (len(runs) - 1)) + [text]

    if latency is not None:
        lines += [
            ("delay: fitted / this log's best [s]",
             last(f"{latency.fitted_delay_s:.3f} / {latency.delay_s:.3f}")),
            ("agreement at this log's best delay", last(pct(latency.report.agreement))),
        ]  # fmt: skip
    if ceiling is not None:
        lines += [
            ("noise ceiling (perfect model)", last(pct(ceiling.agreement))),
            ("noise-only band width v [m/s]", last(num(ceiling.band_width_v_mps, ".4f"))),
            ("noise-only band width w [rad/s]", last(num(ceiling.band_width_w_radps, ".4f"))),
        ]
    if ensemble is not None:
        level = f"{100 * ensemble.band_level:g} % band"

        lines += [
            (f"coverage v, {level} (N={ensemble.n})", last(pct(ensemble.coverage_v))),
            (f"coverage w, {level} (N={ensemble.n})", last(pct(ensemble.coverage_w))),
            ("coverage v and w", last(pct(ensemble.coverage))),
            ("band width v [m/s]", last(num(ensemble.band_width_v_mps, ".4f"))),
            ("band width w [rad/s]", last(num(ensemble.band_width_w_radps, ".4f"))),
        ]
    w0 = max(len(k) for k, _ in lines)
    widths = [max(len(row[i]) for _, row in lines) for i in range(len(runs))]
    out = []
    for key, row in lines:
        cells = "  ".join(c.rjust(w) for c, w in zip(row, widths, strict=True))
        out.append(f"{key.ljust(w0)}  {cells}")
    return "\n".join(out)
