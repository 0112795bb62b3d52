"""Arguments of `sim2real logs`: inspect velocity logs (MCAP, ROS 1 bag, rosbag2, CSV)."""

from __future__ import annotations

import argparse

from sim2real.cli._common import add_command, add_group

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
    group_sub = add_group(
        sub,
        "logs",
        help="inspect velocity logs (MCAP, ROS 1 bag, rosbag2 folder, CSV)",
        description=(
            "Inspect robot velocity logs: MCAP (ROS 2 CDR or JSON), ROS 1 bags, rosbag2 "
            "folders (sqlite3 or mcap storage) and CSV files."
        ),
        examples=_INFO_EXAMPLES,
    )
    info = add_command(
        group_sub,
        "info",
        help="topics, types, counts, rates and the command/measurement topics of a log",
        description=(
            "Print the topics of an MCAP log with their message types, encodings, message "
            "counts and mean rates (by log time; - for a topic of too few or bunched messages), "
            "the log's duration, and which topics "
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
    info.set_defaults(handler="logs:handle_info")
