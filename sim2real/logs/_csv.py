"""CSV velocity logs (private): one row per sample, commands and measurements side by side.

Format (a header row, then one row per sample, comma separated, columns in any order):

========  ======================================================================
column    meaning
========  ======================================================================
``t``     time in seconds (decimal; since any origin, e.g. the Unix epoch or 0)
``cmd_v`` commanded forward speed (m/s) in force from ``t`` on
``cmd_w`` commanded yaw rate (rad/s) in force from ``t`` on
``meas_v`` measured forward speed (m/s) at ``t`` (odometry ``twist.linear.x``)
``meas_w`` measured yaw rate (rad/s) at ``t`` (odometry ``twist.angular.z``)
``x``, ``y``, ``yaw``  optional: odometry pose at ``t`` (m, m, rad), all three or none
========  ======================================================================

Other columns are ignored. Times are read from their decimal text into integer nanoseconds
exactly (no float rounding), must increase strictly, and every cell must be a finite number:
a CSV has no message stamps or repair rules, so a bad row is an error naming it.
"""

from __future__ import annotations

import csv
import hashlib
from pathlib import Path

import numpy as np

from robots.units import NS_PER_S, nanoseconds, seconds
from sim2real._io import atomic_write
from sim2real.errors import LogFormatError, LogValueError
from sim2real.logs._timeline import drop_outliers
from sim2real.logs.trace import Trace, trace_from_columns

__all__ = ["CSV_COLUMNS", "read_csv_trace", "write_csv_trace"]

#: The required columns of a CSV log, in the order :func:`write_csv_trace` writes them.
CSV_COLUMNS = ("t", "cmd_v", "cmd_w", "meas_v", "meas_w")
_POSE = ("x", "y", "yaw")
_T_MAX_NS = 2**63  # times are held as int64 nanoseconds


def _ns(text: str) -> int:
    """Decimal seconds text -> integer nanoseconds, exactly (``"1.5"`` -> 1500000000)."""
    s = text.strip()
    if "e" in s.lower():  # scientific notation: no exact digits to keep
        return nanoseconds(float(s))
    neg = s.startswith("-")
    whole, _, frac = s.lstrip("+-").partition(".")
    if not (whole or frac) or not (whole + frac).isdigit():
        raise ValueError(s)
    ns = int(whole or "0") * NS_PER_S + int((frac + "0" * 9)[:9])
    return -ns if neg else ns


def read_csv_trace(path: str | Path) -> Trace:
    """Read a CSV velocity log (see the module docstring for the columns).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
    >>> _ = p.write_text("t,cmd_v,cmd_w,meas_v,meas_w\\n0.0,0.2,0,0,0\\n0.1,0.2,0,0.1,0\\n")
    >>> read_csv_trace(p).meas_v
    array([0. , 0.1])
    """
    p = Path(path)
    raw = p.read_bytes()
    rows = list(csv.reader(raw.decode("utf-8-sig", errors="replace").splitlines()))
    idx = _column_index(rows, p)
    body = [(n, r) for n, r in enumerate(rows[1:], start=2) if any(c.strip() for c in r)]
    if len(body) < 2:
        raise LogValueError(
            f"CSV log '{p}' has {len(body)} data row(s); a trace needs at least 2 samples"
        )
    t_ns, cols = _parse_rows(body, idx, p)
    warnings: list[str] = []
    t_ns, cols = drop_outliers(t_ns, cols, "t", warnings)  # a row with a corrupt far time
    pose = {k: cols[k] for k in _POSE if k in cols}
    return trace_from_columns(
        t_ns,
        {"v": cols["cmd_v"], "w": cols["cmd_w"]},
        t_ns,
        {"v": cols["meas_v"], "w": cols["meas_w"], **pose},
        path=str(p),
        sha256=hashlib.sha256(raw).hexdigest(),
        cmd_topic="cmd_v,cmd_w",
        cmd_type="csv",
        meas_topic="meas_v,meas_w",
        meas_type="csv",
        cmd_time_source="csv",
        meas_time_source="csv",
        encoding="csv",
        warnings=tuple(warnings),
    )


def _column_index(rows: list[list[str]], p: Path) -> dict[str, int]:
    """Where each column of the trace stands in the header row (the pose only when whole)."""
    header = [h.strip() for h in rows[0]] if rows else []
    missing = [c for c in CSV_COLUMNS if c not in header]
    if missing:
        raise LogFormatError(
            f"CSV log '{p}' lacks the column(s) {', '.join(missing)} (header: "
            f"{','.join(header) or 'empty'}); its first row must name the columns "
            f"{','.join(CSV_COLUMNS)} (optional x,y,yaw)"
        )
    pose = all(c in header for c in _POSE)
    names = list(CSV_COLUMNS) + (list(_POSE) if pose else [])
    return {c: header.index(c) for c in names}


def _parse_rows(
    body: list[tuple[int, list[str]]], idx: dict[str, int], p: Path
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Times (int64 ns, strictly increasing) and the other columns of the data rows."""
    t_ns = np.empty(len(body), np.int64)
    cols = {c: np.empty(len(body)) for c in idx if c != "t"}
    for i, (line, row) in enumerate(body):
        t = _cell(row, idx["t"], "t", line, p, _ns)
        if not -_T_MAX_NS < t < _T_MAX_NS:  # int64 nanoseconds: +-292 years around 1970
            raise LogValueError(
                f"CSV log '{p}' line {line} column 't' holds {row[idx['t']].strip()!r}, which "
                "as seconds lies more than 292 years from 1970; t must be in seconds (divide "
                "nanoseconds by 1e9, milliseconds by 1e3)"
            )
        t_ns[i] = t
        for c, arr in cols.items():
            arr[i] = _cell(row, idx[c], c, line, p, float)
    steps = np.diff(t_ns)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        raise LogValueError(
            f"CSV log '{p}' has times that do not increase (line {body[k + 1][0]}: t = "
            f"{seconds(t_ns[k + 1])} s after {seconds(t_ns[k])} s); sort the rows by t and remove "
            "repeated times"
        )
    return t_ns, cols


def _cell(row: list[str], i: int, col: str, line: int, p: Path, conv: type | object) -> float:
    text = row[i].strip() if i < len(row) else ""
    try:
        value = conv(text)  # type: ignore[operator]
    except (ValueError, OverflowError):
        value = None
    if value is None or not np.isfinite(float(value)):
        raise LogValueError(
            f"CSV log '{p}' line {line} column '{col}' holds {text!r}, not a finite number; "
            "fix or delete that row (every cell must be a number, NaN rows are not allowed)"
        )
    return value  # type: ignore[no-any-return]


def write_csv_trace(path: str | Path, trace: Trace) -> Path:
    """Write a trace whose commands and measurements share their times as a CSV log.

    Times are written as exact decimal seconds since the Unix epoch (nanosecond digits).
    """
    if not np.array_equal(trace.cmd_t_ns, trace.meas_t_ns):
        raise LogValueError(
            "a CSV log has one time column, so the trace's command and measurement times must "
            "be equal; resample the commands onto the measurement times first"
        )

    names = list(CSV_COLUMNS) + (list(_POSE) if trace.has_pose else [])
    lines = [",".join(names)]
    for i, t in enumerate(trace.meas_t_ns.tolist()):
        cells = [f"{t // NS_PER_S}.{t % NS_PER_S:09d}"]
        vals = [trace.cmd_v[i], trace.cmd_w[i], trace.meas_v[i], trace.meas_w[i]]
        if trace.has_pose:
            vals += [trace.pose_x[i], trace.pose_y[i], trace.pose_yaw[i]]  # type: ignore[index]
        cells += [repr(float(v)) for v in vals]
        lines.append(",".join(cells))
    out = Path(path)
    with atomic_write(out) as fh:
        fh.write(("\n".join(lines) + "\n").encode())
    return out
