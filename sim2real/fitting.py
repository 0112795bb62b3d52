"""Fit a robot's drive parameters to log files: the one fit behind ``sim2real sysid fit``.

:func:`fit_logs` reads each file as :func:`sim2real.logs.read_for_robot` reads it (drops
velocities no robot of the spec could reach and the unattended samples), crops to a time
window, splits a recording at its pauses and sets aside the segments with nothing to identify (each said in a note), then calls
:func:`sysid.fit_drive` with the spec's geometry, drive defaults, priors and odometry window.
The command line and Python callers share its defaults, so they get the same numbers.

Examples
--------
>>> from sim2real.fitting import fit_logs
>>> fit = fit_logs(["data/demo_train.mcap"], robot="turtlebot3_burger")  # doctest: +SKIP
>>> fit.result.save("params.yaml")  # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from robots.errors import RobotsError
from robots.params import SPECS_DIR
from robots.reduced import DEFAULT_DT_S
from robots.spec import RobotSpec, load_spec
from robots.units import seconds
from sim2real.errors import LogValueError, Sim2RealError, Sim2RealValueError
from sim2real.logs import ReadOptions, Trace, read_for_robot
from sysid import LogArrays, SysidResult, crop_log, fit_drive, why_not_fittable

__all__ = ["BEYOND_SPEC_FACTOR", "LogFit", "beyond_spec_notes", "fit_logs", "read_fit_logs"]

#: ``map_sessions`` of :func:`sysid.fit_drive`: maps a function over the sessions' groups.
MapSessions = Callable[[Callable[[Any], Any], Sequence[Any]], Sequence[Any]]


@dataclass(frozen=True, kw_only=True)
class LogFit:
    """The outcome of :func:`fit_logs`.

    Attributes
    ----------
    result : SysidResult
        The fit (parameters, intervals, scores, randomisation); ``result.save(path)`` writes
        the params file.
    notes : tuple of str
        What reading the logs chose or set aside, one sentence each (a time source picked
        by ``time_source="auto"``, a segment where the robot stood still).
    """

    result: SysidResult
    notes: tuple[str, ...]


def fit_logs(
    logs: Sequence[str | Path],
    *,
    robot: str | Path | RobotSpec,
    validate: Sequence[str | Path] = (),
    window: tuple[float, float] | None = None,
    validate_window: tuple[float, float] | None = None,
    free: str | Sequence[str] = "auto",
    read: ReadOptions | None = None,
    odom_v_window_s: float | None = None,
    loss: str = "soft_l1",
    dt_s: float | None = None,
    bootstrap: int = 0,
    seed: int = 0,
    progress: Callable[[str, float], None] | None = None,
    map_sessions: MapSessions | None = None,
) -> LogFit:
    """MAP fit of a robot's drive parameters to log files (one or several sessions).

    Parameters
    ----------
    logs : sequence of path
        Fitting logs (MCAP, ROS 1 bag, rosbag2 folder or CSV); several are several sessions.
    robot : str, path or RobotSpec
        A shipped robot name, a spec file, or a loaded spec: geometry, drive defaults, priors
        and odometry.
    validate : sequence of path
        Validation logs, scored but not fitted.
    window, validate_window : (float, float), optional
        ``(start_s, end_s)`` since each log's first sample: the part of the fitting
        (validation) logs to use.
    free : "auto" or sequence of str
        The parameters to fit (``"auto"``: chosen from the excitation).
    read : sim2real.logs.ReadOptions, optional
        How each file is read: topics, clock, velocity source, and whether the unattended
        samples are kept (default ``ReadOptions()``).
    odom_v_window_s : float, optional
        The odometry's velocity window, s (default: the spec's, e.g. one encoder period).
    dt_s : float, optional
        The model's integration step, s (default: :func:`sysid.fit_drive`'s, 1/240 s).
    loss, bootstrap, seed, progress, map_sessions
        Passed to :func:`sysid.fit_drive` (robust loss, block-bootstrap refits, their seed,
        a ``(stage, fraction)`` callback, a parallel map over sessions).

    Returns
    -------
    LogFit
        The :class:`sysid.SysidResult` and the notes of reading the logs. When ``robot`` is
        a spec file (not a shipped spec), ``result.settings["spec_file"]`` is its absolute
        path, which errors about the params file name as the ``--robot`` that loads it.

    Raises
    ------
    Sim2RealValueError
        A log cannot be read or holds too little data, or the fit gave a drive model the
        parameter schema refuses (the sentence names the logs and what to try).

    Examples
    --------
    >>> fit = fit_logs(["data/demo_train.mcap"], robot="turtlebot3_burger")  # doctest: +SKIP
    >>> round(fit.result.values["delay_s"], 3)  # doctest: +SKIP
    0.05
    """
    spec = robot if isinstance(robot, RobotSpec) else load_spec(robot)
    notes: list[str] = []

    def read_set(paths: Sequence[str | Path], crop: tuple[float, float] | None) -> list[Any]:
        return read_fit_logs(paths, spec=spec, window=crop, notes=notes, read=read)

    fit_set, val_set = read_set(logs, window), read_set(validate, validate_window)
    notes.extend(beyond_spec_notes(fit_set, spec))
    try:
        result = fit_drive(
            fit_set,
            geometry=spec.geometry,
            base_params=spec.drive,
            priors=spec.priors,
            free=free,
            validate=val_set,
            robot=spec.name,
            loss=loss,
            dt_s=DEFAULT_DT_S if dt_s is None else dt_s,
            odom_v_window_s=spec.odometry.v_window_s
            if odom_v_window_s is None
            else odom_v_window_s,
            w_source=spec.odometry.w_source,
            bootstrap=bootstrap,
            seed=seed,
            progress=progress,
            map_sessions=map_sessions,
        )
    except RobotsError as exc:  # the fit itself made a model the schema refuses
        raise _fit_failure(logs, exc) from exc
    if spec.path.resolve().parent != SPECS_DIR:  # a spec file: its name alone would not load it
        result = replace(
            result, settings={**result.settings, "spec_file": str(spec.path.resolve())}
        )
    return LogFit(result=result, notes=tuple(notes))


#: A log whose robot moves this much faster than the spec's top speed contradicts the spec.
BEYOND_SPEC_FACTOR = 1.25


def beyond_spec_notes(pieces: Sequence[Trace | LogArrays], spec: RobotSpec) -> list[str]:
    """A note for each axis on which the logs measure the robot well beyond its spec's top speed.

    The spec's top speeds (``limits.max_v_mps``, ``limits.max_w_radps``, and the wheel speed
    cap derived from them) are priors; the fit centres the wheel speed cap's prior on the
    measured speeds when they exceed it this far, but the spec's limits and what derives from
    them stay. A robot measured at
    :data:`BEYOND_SPEC_FACTOR` times the cap or more (99th percentile of the measured speed,
    so single odometry spikes do not count) tells that the spec's number is wrong, not the
    robot. The note says what to set.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> from sysid import LogArrays
    >>> t = np.arange(100) * 0.1
    >>> fast = LogArrays(cmd_t_s=t, cmd_v=np.full(100, 1.0), cmd_w=np.zeros(100), meas_t_s=t,
    ...                  meas_v=np.full(100, 1.0), meas_w=np.zeros(100), name="run.mcap")
    >>> print(beyond_spec_notes([fast], load_spec("turtlebot3_burger"))[0][:67])
    the logs measure v up to 1 m/s, 4.55x the spec's top speed 0.22 m/s
    """
    limits = (
        ("v", "m/s", spec.max_v_mps, "meas_v", "--max-speed", "top speed"),
        ("w", "rad/s", spec.max_w_radps, "meas_w", "--max-turn-rate", "top yaw rate"),
    )
    notes: list[str] = []
    for axis, unit, cap, column, option, what in limits:
        speeds = [np.abs(np.asarray(getattr(p, column), dtype=float)) for p in pieces]
        speeds = [x[np.isfinite(x)] for x in speeds if x.size]
        if not speeds or not np.isfinite(cap) or cap <= 0.0:
            continue
        top = float(np.percentile(np.concatenate(speeds), 99.0))
        if top >= BEYOND_SPEC_FACTOR * cap:
            notes.append(
                f"the logs measure {axis} up to {top:.3g} {unit}, {top / cap:.3g}x the spec's "
                f"{what} {cap:.3g} {unit}: the spec's number is wrong (the fit centres the "
                f"prior of its wheel speed cap on the measured speeds, but the spec's limits and "
                f"the priors derived from them stay); give the spec the robot's own {what} "
                f"('sim2real robots new NAME ... {option}', which sets the limits and the wheel "
                f"speed cap together) and refit"
            )
    return notes


def read_fit_logs(
    paths: Sequence[str | Path],
    *,
    spec: RobotSpec,
    window: tuple[float, float] | None = None,
    notes: list[str] | None = None,
    read: ReadOptions | None = None,
) -> list[Trace | LogArrays]:
    """The logs to fit: each file read, screened, cropped and split at its pauses.

    Velocities beyond 10x the spec's limits are dropped (:meth:`Trace.without_absurd`), a
    log with too little data is refused, and of the segments a file's pauses split it into,
    those with nothing to identify are set aside. Of several logs, one that cannot be read or
    holds too little data is left out (the others go on); only when none can be used is the
    first error raised. What was chosen, set aside or left out is appended to ``notes``.

    Examples
    --------
    >>> spec = load_spec("turtlebot3_burger")
    >>> traces = read_fit_logs(["data/demo_train.mcap"], spec=spec)  # doctest: +SKIP
    """
    notes = [] if notes is None else notes
    out: list[Trace | LogArrays] = []
    errors: list[Sim2RealError] = []
    for path in paths:
        try:
            trace = _read_one(path, spec, notes, read)
        except Sim2RealError as exc:
            if len(paths) == 1:
                raise
            errors.append(exc)  # one bad log of several: the others go on, its row says why
            notes.append(f"left out: {exc}")
            continue
        out.extend(_fittable(_pieces(trace, window), notes))
    if errors and not out:
        raise LogValueError(f"none of the {len(paths)} logs could be used; the first: {errors[0]}")
    return out


def _read_one(
    path: str | Path,
    spec: RobotSpec,
    notes: list[str],
    read: ReadOptions | None,
) -> Trace:
    """One log read as the fit reads it (:func:`sim2real.logs.read_for_robot`), noted."""
    trace, note = read_for_robot(path, spec, read)
    if trace.meta.time_note:
        notes.append(f"{path}: {trace.meta.time_note}")
    if note:
        notes.append(note)
    return trace


def _fittable(pieces: list[Trace | LogArrays], notes: list[str]) -> list[Trace | LogArrays]:
    """Of several segments of one file, those with something to identify (the rest noted).

    A segment where the robot stood still (or too short) cannot be fitted on its own; it is
    set aside with a note. A single piece, or a file none of whose segments can be fitted, is
    returned as it is, so the fit's own error names the file.
    """
    if len(pieces) < 2:
        return pieces
    kept = []
    for k, piece in enumerate(pieces):
        why = why_not_fittable(piece, k)
        if why:
            notes.append(f"set aside: {why}")
        else:
            kept.append(piece)
    return kept or pieces


def _pieces(trace: Trace, window: tuple[float, float] | None) -> list[Trace | LogArrays]:
    """The segments of ``trace`` (its pauses split it), cropped to ``window`` (s since t0)."""
    segments = trace.segments()
    if window is None:
        return list(segments)
    out: list[Trace | LogArrays] = []
    for seg in segments:
        shift_s = seconds(seg.t0_ns - trace.t0_ns)
        lo, hi = window[0] - shift_s, window[1] - shift_s
        t = seg.meas_t_s
        if bool(((t >= lo) & (t < hi)).any()):
            out.append(crop_log(seg, lo, hi))
    return out or [crop_log(trace, *window)]  # none overlaps: crop_log says so


def _fit_failure(paths: Sequence[str | Path], exc: Exception) -> Sim2RealValueError:
    """The error of a fit whose result breaks a rule of the drive-parameter schema.

    That is a failure of the fit on these logs (not bad input, which is checked before): the
    sentence names the logs, the rule and what to try.
    """
    rule = str(exc).split("; ")[0]  # the rule and the value, without a fix meant for a file
    names = ", ".join(f"'{p}'" for p in paths)
    return Sim2RealValueError(
        f"sysid fit of {names} gave a drive model the schema refuses ({rule}); fit fewer "
        "parameters (--free) or a longer, richer log, and please report it with the log"
    )
