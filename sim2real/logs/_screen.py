"""Read a log for a robot as ``sysid fit``, ``sysid calibrate`` and ``agree`` read it (private).

One place for the sequence every consumer of a real log runs: :func:`read_trace` with the
robot's wheels (a JointState topic), velocities beyond 10x the robot's limits dropped
(:meth:`Trace.without_absurd`), too little data refused (:meth:`Trace.check_enough`), and the
unattended samples left out with a note (:func:`without_unattended`; ``read.keep_all`` keeps
them).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sim2real.logs._options import ReadOptions
from sim2real.logs._reader import read_trace
from sim2real.logs._unattended import without_unattended
from sim2real.logs.trace import Trace

__all__ = ["read_for_robot"]


def read_for_robot(
    path: str | Path,
    spec: Any,
    read: ReadOptions | None = None,
) -> tuple[Trace, str]:
    """The screened :class:`Trace` of ``path`` for the robot ``spec``, and the screening note.

    Parameters
    ----------
    path : str or Path
        The log (MCAP, ROS 1 bag, rosbag2 folder or CSV).
    spec : robots.spec.RobotSpec
        The robot: its wheels (radius, separation), its limits (``max_v_mps``,
        ``max_w_radps``) and its command timeout (``drive.cmd_timeout_s``).
    read : ReadOptions, optional
        Topics, clock and velocity source (as for :func:`sim2real.logs.read_trace`), and
        ``keep_all`` (keep the unattended samples: no screening); default ``ReadOptions()``.

    Returns
    -------
    trace : Trace
    note : str
        What the screening left out ("" when nothing).

    Raises
    ------
    sim2real.errors.Sim2RealError
        The log cannot be read, holds too little data or is mostly unattended.

    Examples
    --------
    >>> from robots.spec import load_spec  # doctest: +SKIP
    >>> trace, note = read_for_robot("run.mcap", load_spec("turtlebot2"))  # doctest: +SKIP
    """
    read = ReadOptions() if read is None else read
    trace = read_trace(
        path,
        cmd_topic=read.cmd_topic,
        odom_topic=read.odom_topic,
        time_source=read.time_source,
        odom_velocity=read.odom_velocity,
        wheel_radius_m=spec.wheels.radius_m,  # a wheel JointState topic: the spec's wheels
        wheel_separation_m=spec.wheels.separation_m,
    )
    trace = trace.without_absurd(max_v_mps=spec.max_v_mps, max_w_radps=spec.max_w_radps)
    trace.check_enough()
    timeout = float(getattr(getattr(spec, "drive", None), "cmd_timeout_s", float("inf")))
    return without_unattended(trace, keep_all=read.keep_all, cmd_timeout_s=timeout)
