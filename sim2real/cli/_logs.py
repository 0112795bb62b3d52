"""`sim2real logs info`: inspect a velocity log (MCAP, ROS 1 bag, rosbag2, CSV)."""

from __future__ import annotations

import argparse
import csv
import json
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from robots.units import seconds
from sim2real.errors import Sim2RealValueError
from sim2real.logs import LogInfo, Trace, inspect_log, read_trace
from sim2real.logs._bags import source_kind

__all__ = ["handle_info"]


def handle_info(args: argparse.Namespace) -> int:
    """``logs info LOG``: topics, counts, rates and the chosen topics (or a CSV's columns)."""
    path = Path(args.log)
    if path.is_file() and source_kind(path) == "csv":
        return _csv_info(path, args)
    info = inspect_log(args.log, cmd_topic=args.cmd_topic, odom_topic=args.odom_topic)
    if args.json:
        print(json.dumps(info.to_dict(sha256=args.sha256), indent=2))
    else:
        print(_table(info, sha256=args.sha256))
    return 0


def _csv_info(path: Path, args: argparse.Namespace) -> int:
    """``logs info`` of a CSV log: read as ``sysid fit``/``agree`` read it, then summarised."""
    if args.cmd_topic or args.odom_topic:
        raise Sim2RealValueError(
            f"log file '{path}' is a CSV log, which has columns, not topics; drop "
            "--cmd-topic/--odom-topic (the columns are named t, cmd_v, cmd_w, meas_v, meas_w)"
        )
    trace = read_trace(path)
    with path.open(encoding="utf-8-sig", errors="replace", newline="") as f:
        # parsed as read_csv_trace parses it: a spreadsheet quotes the names ("t","cmd_v",...)
        header = [h.strip() for h in next(csv.reader(f), [])]
    summary = _csv_summary(path, trace, header)
    if args.json:
        if args.sha256:
            summary["sha256"] = trace.meta.sha256
        print(json.dumps(summary, indent=2))
        return 0
    digest = f", sha256 {trace.meta.sha256}" if args.sha256 else ""
    lines = [
        f"file:      {path} ({summary['size_bytes'] / 1e6:.2f} MB{digest})",
        "format:    CSV log, one row per sample (times in s; commands in force from t on)",
        f"duration:  {summary['duration_s']:.1f} s from {_when(int(trace.meas_t_ns[0]))}, "
        f"{summary['rows']} rows ({summary['rate_hz']:.2f} Hz)",
        "command:   columns cmd_v, cmd_w (m/s, rad/s)",
        "measured:  columns meas_v, meas_w (m/s, rad/s)"
        + ("; pose x, y, yaw (m, m, rad)" if summary["pose"] else "; no pose (x, y, yaw)"),
    ]
    if summary["ignored_columns"]:
        lines.append(f"ignored:   columns {', '.join(summary['ignored_columns'])}")
    lines.extend(f"warning: {w}" for w in trace.meta.warnings)
    print("\n".join(lines))
    return 0


def _csv_summary(path: Path, trace: Trace, header: list[str]) -> dict[str, Any]:
    used = {"t", "cmd_v", "cmd_w", "meas_v", "meas_w"}
    pose = trace.pose_x is not None
    if pose:
        used |= {"x", "y", "yaw"}
    return {
        "path": str(path),
        "format": "csv",
        "size_bytes": path.stat().st_size,
        "rows": int(trace.meas_t_ns.size),
        "start_ns": int(trace.meas_t_ns[0]),
        "end_ns": int(trace.meas_t_ns[-1]),
        "duration_s": trace.duration_s,
        "rate_hz": trace.meta.meas_rate_hz,
        "pose": pose,
        "ignored_columns": [h for h in header if h and h not in used],
        "warnings": list(trace.meta.warnings),
    }


def _when(t_ns: int) -> str:
    return datetime.fromtimestamp(seconds(t_ns), tz=timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")


def _table(info: LogInfo, *, sha256: bool = False) -> str:
    digest = f", sha256 {info.sha256}" if sha256 else ""
    how = (
        "summary section and message indexes (no chunk decompressed)"
        if info.source == "summary"
        else "every record"
    )
    lines = [
        f"file:      {info.path} ({info.size_bytes / 1e6:.2f} MB{digest})",
        f"read from: {how}",
        f"profile:   {info.profile or '-'} (written by {info.library or 'unknown'})",
        f"duration:  {info.duration_s:.1f} s from {_when(info.start_ns)}, "
        f"{info.message_count} messages",
        "",
    ]
    w_topic = max([len("topic"), *(len(t.topic) for t in info.topics)])
    w_type = max([len("type"), *(len(t.type) for t in info.topics)])
    lines.append(f"{'topic':<{w_topic}}  {'type':<{w_type}}  encoding  {'count':>7}  rate_hz")
    for t in info.topics:
        lines.append(
            f"{t.topic:<{w_topic}}  {t.type:<{w_type}}  {t.message_encoding:<8}  "
            f"{t.count:>7}  {'-' if t.rate_hz is None else f'{t.rate_hz:.2f}':>7}"
        )
    lines.append("")
    for label, topic, note in (
        ("command topic:    ", info.cmd_topic, info.cmd_note),
        ("measurement topic:", info.meas_topic, info.meas_note),
    ):
        if topic is None:
            lines.append(f"{label} none ({note})")
        else:
            lines.append(f"{label} {topic} ({info.topic(topic).type})")
    lines.extend(f"warning: {w}" for w in info.warnings)
    return "\n".join(lines)
