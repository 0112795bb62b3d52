"""ROS 2 message definitions as ``ros2msg`` schema text (private).

The text is what ``ros2 bag record`` stores in an MCAP Schema record: the top-level ``.msg``
fields, then one ``MSG: pkg/Type`` section per nested type, separated by a line of 80 ``=``.
Only field lines are given (comments carry no information for decoding); the field lists are
those of ROS 2 Humble's ``geometry_msgs``, ``nav_msgs``, ``sensor_msgs``, ``std_msgs`` and
``builtin_interfaces`` packages.
"""

from __future__ import annotations

__all__ = [
    "JOINT_STATE",
    "ODOMETRY",
    "SCHEMA_TEXT",
    "TWIST",
    "TWIST_STAMPED",
    "normalize_type",
    "schema_text",
]

TWIST = "geometry_msgs/msg/Twist"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
ODOMETRY = "nav_msgs/msg/Odometry"
JOINT_STATE = "sensor_msgs/msg/JointState"

_SEPARATOR = "=" * 80

#: Field lines of every type the four messages need, keyed by ``pkg/Type``.
_FIELDS: dict[str, str] = {
    "builtin_interfaces/Time": "int32 sec\nuint32 nanosec",
    "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
    "geometry_msgs/Pose": "Point position\nQuaternion orientation",
    "geometry_msgs/PoseWithCovariance": "Pose pose\nfloat64[36] covariance",
    "geometry_msgs/Twist": "Vector3  linear\nVector3  angular",
    "geometry_msgs/TwistWithCovariance": "Twist twist\nfloat64[36] covariance",
    "geometry_msgs/TwistStamped": "std_msgs/Header header\nTwist twist",
    "nav_msgs/Odometry": (
        "std_msgs/Header header\n"
        "string child_frame_id\n"
        "geometry_msgs/PoseWithCovariance pose\n"
        "geometry_msgs/TwistWithCovariance twist"
    ),
    "sensor_msgs/JointState": (
        "std_msgs/Header header\n"
        "string[] name\n"
        "float64[] position\n"
        "float64[] velocity\n"
        "float64[] effort"
    ),
}

#: Nested types in the order ``ros2 bag`` lists them (depth first, first use).
_DEPENDENCIES: dict[str, tuple[str, ...]] = {
    TWIST: ("geometry_msgs/Vector3",),
    TWIST_STAMPED: (
        "std_msgs/Header",
        "builtin_interfaces/Time",
        "geometry_msgs/Twist",
        "geometry_msgs/Vector3",
    ),
    ODOMETRY: (
        "std_msgs/Header",
        "builtin_interfaces/Time",
        "geometry_msgs/PoseWithCovariance",
        "geometry_msgs/Pose",
        "geometry_msgs/Point",
        "geometry_msgs/Quaternion",
        "geometry_msgs/TwistWithCovariance",
        "geometry_msgs/Twist",
        "geometry_msgs/Vector3",
    ),
    JOINT_STATE: ("std_msgs/Header", "builtin_interfaces/Time"),
}


def normalize_type(name: str) -> str:
    """Return a message type as ``pkg/msg/Type`` (accepts ``pkg/Type`` and ``pkg/msg/Type``).

    Examples
    --------
    >>> normalize_type("geometry_msgs/Twist")
    'geometry_msgs/msg/Twist'
    """
    parts = name.strip().split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return name.strip()


def schema_text(type_name: str) -> str:
    """The ``ros2msg`` schema text of one of the four supported message types.

    Examples
    --------
    >>> schema_text("geometry_msgs/msg/Twist").splitlines()[0]
    'Vector3  linear'
    """
    if type_name not in _DEPENDENCIES:
        raise KeyError(type_name)
    pkg, _, short = type_name.split("/")
    parts = [_FIELDS[f"{pkg}/{short}"]]
    for dep in _DEPENDENCIES[type_name]:
        parts.append(f"{_SEPARATOR}\nMSG: {dep}\n{_FIELDS[dep]}")
    return "\n".join(parts) + "\n"


#: Schema text of the four supported message types.
SCHEMA_TEXT: dict[str, str] = {name: schema_text(name) for name in _DEPENDENCIES}
