"""`sim2real logs` commands: inspect velocity logs (MCAP, ROS 1 bag, rosbag2, CSV)."""

from __future__ import annotations

import argparse
import json
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robots.units import seconds
from sim2real.cli._common import add_command

if TYPE_CHECKING:
    from sim2real.logs import LogInfo, Trace

__all__ = ["register"]

_INFO_EXAMPLES = """\
  sim2real logs info run.mcap                       # topics, counts, rates, chosen topics
  sim2real logs info run.mcap --json                # the same as JSON
  sim2real logs info run.mcap --sha256              # also hash the whole file
  sim2real logs info run.bag                        # a ROS 1 bag (or a rosbag2 folder)
  sim2real logs info run.csv                        # a CSV log: rows, duration, rate, columns
  sim2real logs info run.mcap --cmd-topic /cmd_vel_nav --odom-topic /odometry/wheel
"""


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register the ``logs`` command group (``logs info``)."""
    group = add_command(
        sub,
        "logs",
        help="inspect velocity logs (MCAP, ROS 1 bag, rosbag2 folder, CSV)",
        description=(
            "Inspect robot velocity logs: MCAP (ROS 2 CDR or JSON), ROS 1 bags, rosbag2 "
            "folders (sqlite3 or mcap storage) and CSV files."
        ),
        examples=_INFO_EXAMPLES,
    )
    group_sub = group.add_subparsers(dest="logs_command", metavar="SUBCOMMAND")
    group_sub.required = True
    info = add_command(
        group_sub,
        "info",
        help="topics, types, counts, rates and the command/measurement topics of a log",
        description=(
            "Print the topics of an MCAP log with their message types, encodings, message "
            "counts and mean rates (by log time), the log's duration, and which topics "
            "`read_trace` would use as command (Twist/TwistStamped) and measurement "
            "(Odometry/JointState). A CSV log (columns t, cmd_v, cmd_w, meas_v, meas_w in "
            "s, m/s, rad/s; optional pose x, y, yaw in m, m, rad; other columns ignored) has no "
            "topics: its rows, duration, rate and columns are printed."
        ),
        examples=_INFO_EXAMPLES,
    )
    info.add_argument(
        "log", metavar="LOG", help="the log: a .mcap file, ROS 1 .bag, rosbag2 folder or .csv"
    )
    info.add_argument("--cmd-topic", metavar="TOPIC", help="command topic (default: detect)")
    info.add_argument("--odom-topic", metavar="TOPIC", help="measurement topic (default: detect)")
    info.add_argument("--json", action="store_true", help="print JSON instead of a table")
    info.add_argument(
        "--sha256",
        action="store_true",
        help="also print the SHA-256 of the whole file (reads every byte; off by default)",
    )
    info.set_defaults(handler=_info)


def _info(args: argparse.Namespace) -> int:
    from sim2real.logs import inspect_log
    from sim2real.logs._bags import source_kind

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
    import csv

    from sim2real.errors import Sim2RealValueError
    from sim2real.logs import read_trace

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
            f"{t.count:>7}  {t.rate_hz:7.2f}"
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
