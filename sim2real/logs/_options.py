"""How a real log is read for a robot: topics, clock, velocity source, screening (private).

One object for the reading choices that ``sysid fit``, ``sysid calibrate`` and ``agree`` share
(:func:`sim2real.logs.read_for_robot` takes it), so a command hands them on as one value.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ReadOptions"]


@dataclass(frozen=True, kw_only=True)
class ReadOptions:
    """How each log is read (the keywords of :func:`sim2real.logs.read_trace`) and screened.

    Attributes
    ----------
    cmd_topic, odom_topic : str, optional
        The command and odometry topics (default: auto-detect).
    time_source : {"auto", "header", "log"}
        Message timing: header stamps, recorder log times, or ``"auto"`` (header stamps
        unless they run on another clock than the log times).
    odom_velocity : {"auto", "twist", "pose"}
        Where the measured velocities come from: the Odometry twist, its pose, or ``"auto"``
        (the pose when the twist is zero or spiky while the pose moves).
    keep_all : bool
        Keep the unattended samples (motion with no command in force, a command held while
        the wheels stay stopped; :func:`sim2real.logs.without_unattended`), which are
        otherwise left out with a note.

    Examples
    --------
    >>> ReadOptions(time_source="log", keep_all=True).time_source
    'log'
    >>> ReadOptions() == ReadOptions(odom_velocity="auto")
    True
    """

    cmd_topic: str | None = None
    odom_topic: str | None = None
    time_source: str = "auto"
    odom_velocity: str = "auto"
    keep_all: bool = False
