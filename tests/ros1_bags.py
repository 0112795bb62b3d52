"""Test helper: a ROS 1 bag of Twist commands and ``sensor_msgs/JointState`` measurements."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

__all__ = ["write_joint_state_bag"]


def write_joint_state_bag(
    path: Path,
    *,
    cmd_t_ns: Sequence[int],
    cmd_v: Sequence[float],
    cmd_w: Sequence[float],
    js_t_ns: Sequence[int],
    names: Sequence[str],
    velocity: np.ndarray,
    cmd_topic: str = "/cmd_vel",
) -> Path:
    """Write ``path``: Twist commands (m/s, rad/s) on ``cmd_topic`` and JointState messages on
    ``/joint_states`` with joints ``names`` and ``velocity`` (rad/s, shape (messages, joints)),
    each stamped with its log time (ns); zero positions, no efforts."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    vec, twist = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Twist"]
    with Writer(path) as wr:
        cmd = wr.add_connection(cmd_topic, "geometry_msgs/msg/Twist", typestore=store)
        js = wr.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        for t, v, w in zip(cmd_t_ns, cmd_v, cmd_w, strict=True):
            msg = twist(linear=vec(x=float(v), y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=float(w)))
            wr.write(cmd, int(t), store.serialize_ros1(msg, "geometry_msgs/msg/Twist"))
        for i, (t, vel) in enumerate(zip(js_t_ns, np.asarray(velocity, float), strict=True)):
            t = int(t)
            head = T["std_msgs/msg/Header"](
                seq=i,
                stamp=T["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9),
                frame_id="",
            )
            msg = T["sensor_msgs/msg/JointState"](
                header=head,
                name=list(names),
                position=np.zeros(len(names)),
                velocity=vel,
                effort=np.zeros(0),
            )
            wr.write(js, t, store.serialize_ros1(msg, "sensor_msgs/msg/JointState"))
    return path
