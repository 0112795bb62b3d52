"""Write a :class:`Trace` as a ROS 1 bag or a rosbag2 folder through ``rosbags`` (private).

The same two topics as :func:`~sim2real.logs.write_trace`: ``/cmd_vel``
(``geometry_msgs/Twist``, timed by log time) and ``/odom`` (``nav_msgs/Odometry`` with the
measurement time as header stamp and log time, pose from the trace or dead-reckoned), so one
recording can be had in every format the readers accept.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from robots.units import NS_PER_S
from sim2real.errors import Sim2RealValueError
from sim2real.logs._writer import integrate_pose
from sim2real.logs.trace import Trace

__all__ = ["BAG_FORMATS", "write_rosbag"]

#: ``format=`` values of :func:`write_rosbag`.
BAG_FORMATS = ("ros1", "sqlite3", "mcap")


def write_rosbag(
    path: str | Path,
    trace: Trace,
    *,
    format: str = "ros1",
    cmd_topic: str = "/cmd_vel",
    odom_topic: str = "/odom",
) -> Path:
    """Write ``trace`` as a ROS 1 ``.bag`` (``format="ros1"``) or a rosbag2 folder.

    Parameters
    ----------
    path : str or Path
        The ``.bag`` file, or the rosbag2 folder to create (must not exist).
    trace : Trace
        Commands and measurements; a trace without pose gets its dead-reckoned pose.
    format : {"ros1", "sqlite3", "mcap"}
        ROS 1 bag, or rosbag2 with sqlite3 or mcap storage.

    Examples
    --------
    >>> write_rosbag("run.bag", trace)  # doctest: +SKIP
    >>> write_rosbag("run_bag2", trace, format="mcap")  # doctest: +SKIP
    """
    if format not in BAG_FORMATS:
        raise Sim2RealValueError(
            f"bag format must be one of {', '.join(BAG_FORMATS)}, got {format!r}"
        )
    out = Path(path)
    if out.exists():
        raise Sim2RealValueError(f"output '{out}' already exists; remove it or pick another path")
    ros1 = format == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    msgs = _messages(trace, store, ros1=ros1)
    if ros1:
        with Writer1(out) as w1:
            _write_all(w1, store, msgs, cmd_topic, odom_topic, ros1=True)
    else:
        plugin = StoragePlugin.SQLITE3 if format == "sqlite3" else StoragePlugin.MCAP
        with Writer2(out, version=9, storage_plugin=plugin) as w2:
            _write_all(w2, store, msgs, cmd_topic, odom_topic, ros1=False)
    return out


def _write_all(
    writer: Any,
    store: Any,
    msgs: dict[str, list[tuple[int, Any]]],
    cmd_topic: str,
    odom_topic: str,
    *,
    ros1: bool,
) -> None:
    conns = {}
    for key, topic, type_name in (
        ("cmd", cmd_topic, "geometry_msgs/msg/Twist"),
        ("odom", odom_topic, "nav_msgs/msg/Odometry"),
    ):
        conns[key] = (writer.add_connection(topic, type_name, typestore=store), type_name)
    merged = sorted(
        ((t, key, m) for key, items in msgs.items() for t, m in items), key=lambda r: r[0]
    )
    for t, key, msg in merged:
        conn, type_name = conns[key]
        raw = store.serialize_ros1(msg, type_name) if ros1 else store.serialize_cdr(msg, type_name)
        writer.write(conn, int(t), raw)


def _pose(trace: Trace) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if trace.pose_x is not None and trace.pose_y is not None and trace.pose_yaw is not None:
        return trace.pose_x, trace.pose_y, trace.pose_yaw

    return integrate_pose(trace.meas_t_ns, trace.meas_v, trace.meas_w)


def _messages(trace: Trace, store: Any, *, ros1: bool) -> dict[str, list[tuple[int, Any]]]:
    T = store.types
    vec, twist = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Twist"]
    time_t, header_t = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    point, quat = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    pose_t, pwc = T["geometry_msgs/msg/Pose"], T["geometry_msgs/msg/PoseWithCovariance"]
    twc, odom = T["geometry_msgs/msg/TwistWithCovariance"], T["nav_msgs/msg/Odometry"]
    cov = np.zeros(36)

    def tw(v: float, w: float) -> Any:
        return twist(linear=vec(x=v, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=w))

    cmd = [
        (int(t), tw(float(v), float(w)))
        for t, v, w in zip(trace.cmd_t_ns, trace.cmd_v, trace.cmd_w, strict=True)
    ]
    x, y, yaw = _pose(trace)
    out = []
    for i, t in enumerate(trace.meas_t_ns.tolist()):
        stamp = time_t(sec=t // NS_PER_S, nanosec=t % NS_PER_S)
        head = (
            header_t(seq=i, stamp=stamp, frame_id="odom")
            if ros1
            else header_t(stamp=stamp, frame_id="odom")
        )
        q = quat(x=0.0, y=0.0, z=float(np.sin(yaw[i] / 2)), w=float(np.cos(yaw[i] / 2)))
        pose = pwc(
            pose=pose_t(position=point(x=float(x[i]), y=float(y[i]), z=0.0), orientation=q),
            covariance=cov,
        )
        msg = odom(
            header=head,
            child_frame_id="base_footprint",
            pose=pose,
            twist=twc(twist=tw(float(trace.meas_v[i]), float(trace.meas_w[i])), covariance=cov),
        )
        out.append((t, msg))
    return {"cmd": cmd, "odom": out}
