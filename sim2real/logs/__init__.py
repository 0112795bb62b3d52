"""Read and write robot velocity logs (MCAP, ROS 1 bags, rosbag2 folders, CSV).

:func:`read_trace` turns a log into a :class:`Trace` of commanded and measured planar
velocities; :func:`write_trace` / :func:`write_velocity_log` write one back with the real ROS 2
message definitions, so a simulated run and a real run open side by side in Foxglove, in
``ros2 bag`` tooling and in this reader. :func:`inspect_log` describes a log
(``sim2real logs info``).

Owns the log formats, the :class:`Trace`, its time base and repairs, and the screening of a
recording for a robot (:func:`read_for_robot`). May import :mod:`robots.units` (the one time
conversion), :mod:`sim2real.errors`, :mod:`sim2real._io` and :mod:`sim2real._arrays`; nothing
that simulates, fits or measures, so every other room can read logs.

Formats
-------
A reader factory picks the reader from the path: an MCAP file (ROS 2 CDR or JSON, our own
bulk reader), a ROS 1 ``.bag`` or a rosbag2 *folder* with sqlite3 or mcap storage (both
through the maintained ``rosbags`` library; :func:`write_rosbag` writes them), or a ``.csv``
with the columns ``t, cmd_v, cmd_w, meas_v, meas_w`` (optional ``x, y, yaw``; times in
decimal seconds, read exactly; see :func:`write_csv_trace`). In bags, channels of other types
are only counted, never decoded; channels of non-standard (custom) types are listed in one
note. The same recording gives the identical :class:`Trace` in every format.

Conventions
-----------
Units
    SI: forward speed ``v`` in m/s (``linear.x``), yaw rate ``w`` in rad/s (``angular.z``),
    pose in m and rad (yaw from the Odometry quaternion). Measured velocities are Odometry's
    ``twist.twist`` (child frame, i.e. the robot body), or, for ``sensor_msgs/msg/JointState``,
    the differential-drive kinematics ``v = r (wR + wL) / 2``, ``w = r (wR - wL) / b`` with
    wheel radius ``r`` and separation ``b`` (``wheel_radius_m``, ``wheel_separation_m``).
Time base
    Times are ``int64`` nanoseconds since the Unix epoch (``cmd_t_ns``, ``meas_t_ns``), exact
    for ROS stamps. ``Trace.t0_ns`` is the earlier of the first command and the first
    measurement; ``cmd_t_s`` / ``meas_t_s`` are float64 seconds since ``t0_ns``.
Header stamp vs log time
    ``time_source="header"`` (default) times a message by its ``header.stamp``, set by the
    publisher when the sample was taken. The MCAP *log time* is when the recorder received
    the message: it adds transport delay and jitter, and serial bridges deliver in bursts
    (in the Drexel TurtleBot3 log, rosserial odometry arrives up to 1.3 s after its stamp and
    many stamps share one log time), which would corrupt delay and rate estimates.
    ``geometry_msgs/msg/Twist`` has no header, so commands of that type are always timed by
    log time (``meta.cmd_time_source == "log"``); stamps that are 0 (unstamped publishers)
    also fall back to log time with a warning. ``time_source="log"`` uses log time for both.
    When one stream uses stamps and the other log time, a warning is recorded if their
    clocks differ by more than 0.5 s (median). ``time_source="auto"`` (the CLI's default)
    makes that choice itself: header stamps unless their median offset from the times they
    are compared with (the other stream's stamps, else the log times) exceeds 0.5 s, then log
    times for both; ``meta.time_note`` says which and why.
Gaps and far stamps
    Times are checked before use. A pause in the measurements longer than
    ``max(2 s, 20 x the median sampling step)`` splits the log into segments
    (:meth:`Trace.segments`); replay and the sysid CLI run each segment on its own, so no
    time grid spans a gap and memory follows the number of messages, not the time span. A
    segment of fewer than 5 samples beside a longer one is a far stamp outlier (a corrupt
    stamp) and is dropped, as are commands more than 60 s from every measurement.
    :meth:`Trace.without_absurd` drops velocities beyond 10x the robot's limits.
Zero-order hold
    A command holds until the next one: :meth:`Trace.cmd_at_meas` gives, at each measurement
    time, the last command at or before it (0 before the first command), and
    :meth:`Trace.window` keeps the command in force at the window start.
Topic detection
    Commands: ``geometry_msgs/msg/Twist`` or ``TwistStamped``; measurements:
    ``nav_msgs/msg/Odometry`` or else ``sensor_msgs/msg/JointState``. Among the non-empty
    candidates ``/cmd_vel``, ``/odom`` or ``/joint_states`` wins, else the only command
    channel / the only Odometry channel (JointState only when there is no Odometry);
    otherwise pass ``cmd_topic=`` / ``odom_topic=`` (CLI ``--cmd-topic``/``--odom-topic``).
Repairs
    Samples with NaN/inf values are dropped; samples are sorted by time and of equal stamps
    the last is kept; far stamp outliers are dropped (above). Each repair adds a sentence to ``Trace.meta.warnings``. A truncated
    file (recording stopped mid-write) keeps its complete records, with a warning; corrupt
    records (failed CRC, impossible lengths) raise :class:`~sim2real.errors.LogFormatError`.

Fixed-layout CDR payloads (Twist, TwistStamped, Odometry) are decoded in bulk with numpy;
other types and encodings fall back to mcap-ros2-support's generic decoder or ``json``.
A log is read into memory whole (fine for velocity logs up to a few hundred MB); chunks
may be uncompressed, zstd or lz4.

Examples
--------
>>> from sim2real.logs import read_trace, write_trace
>>> tr = read_trace("run.mcap")  # doctest: +SKIP
>>> v_cmd, w_cmd = tr.cmd_at_meas()  # doctest: +SKIP
>>> part = tr.window(5.0, 20.0)  # doctest: +SKIP
>>> write_trace("copy.mcap", part)  # doctest: +SKIP
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from sim2real.logs._bagwrite import BAG_FORMATS, write_rosbag
    from sim2real.logs._csv import CSV_COLUMNS, write_csv_trace
    from sim2real.logs._depth import DepthImages, read_depth
    from sim2real.logs._info import LogInfo, TopicInfo, inspect_log
    from sim2real.logs._options import ReadOptions
    from sim2real.logs._reader import read_trace
    from sim2real.logs._scans import LASER_SCAN, LaserScans, read_scans
    from sim2real.logs._schemas import JOINT_STATE, ODOMETRY, SCHEMA_TEXT, TWIST, TWIST_STAMPED
    from sim2real.logs._screen import read_for_robot
    from sim2real.logs._unattended import Unattended, find_unattended, without_unattended
    from sim2real.logs._writer import (
        integrate_pose,
        write_commands,
        write_joint_state_log,
        write_trace,
        write_velocity_log,
    )
    from sim2real.logs.trace import Trace, TraceMeta

#: Where each public name lives. The submodules are imported on first use (PEP 562), so
#: ``from sim2real.logs import read_trace`` loads the reading path only: not the writers,
#: ``logs info``, the bag writer or their imports (tempfile, shutil, lzma, ...).
_LAZY = {
    "BAG_FORMATS": "_bagwrite",
    "write_rosbag": "_bagwrite",
    "CSV_COLUMNS": "_csv",
    "write_csv_trace": "_csv",
    "DepthImages": "_depth",
    "read_depth": "_depth",
    "LogInfo": "_info",
    "TopicInfo": "_info",
    "inspect_log": "_info",
    "ReadOptions": "_options",
    "read_trace": "_reader",
    "LASER_SCAN": "_scans",
    "LaserScans": "_scans",
    "read_scans": "_scans",
    "read_for_robot": "_screen",
    "JOINT_STATE": "_schemas",
    "ODOMETRY": "_schemas",
    "SCHEMA_TEXT": "_schemas",
    "TWIST": "_schemas",
    "TWIST_STAMPED": "_schemas",
    "integrate_pose": "_writer",
    "write_commands": "_writer",
    "write_joint_state_log": "_writer",
    "write_trace": "_writer",
    "write_velocity_log": "_writer",
    "Trace": "trace",
    "TraceMeta": "trace",
    "Unattended": "_unattended",
    "find_unattended": "_unattended",
    "without_unattended": "_unattended",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'sim2real.logs' has no attribute {name!r}")
    value = getattr(import_module(f"sim2real.logs.{module}"), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "BAG_FORMATS",
    "CSV_COLUMNS",
    "JOINT_STATE",
    "LASER_SCAN",
    "ODOMETRY",
    "SCHEMA_TEXT",
    "TWIST",
    "TWIST_STAMPED",
    "DepthImages",
    "LaserScans",
    "LogInfo",
    "ReadOptions",
    "TopicInfo",
    "Trace",
    "TraceMeta",
    "Unattended",
    "find_unattended",
    "inspect_log",
    "integrate_pose",
    "read_depth",
    "read_for_robot",
    "read_scans",
    "read_trace",
    "without_unattended",
    "write_commands",
    "write_csv_trace",
    "write_joint_state_log",
    "write_rosbag",
    "write_trace",
    "write_velocity_log",
]
