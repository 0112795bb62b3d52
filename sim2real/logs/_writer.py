"""Write velocity logs as ROS 2 MCAP files (private; re-exported by :mod:`sim2real.logs`).

The files carry the real ``ros2msg`` schemas (see :mod:`sim2real.logs._schemas`) and CDR
payloads, in zstd-compressed chunks with chunk and data-section CRCs, under the ``ros2``
profile, so Foxglove, ``ros2 bag`` tooling, mcap-ros2-support and our reader all open them.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from robots.units import NS_PER_S, seconds
from sim2real import __version__
from sim2real._io import atomic_write
from sim2real.errors import Sim2RealValueError
from sim2real.logs import _cdr
from sim2real.logs._schemas import JOINT_STATE, ODOMETRY, SCHEMA_TEXT, TWIST, TWIST_STAMPED
from sim2real.logs.trace import Trace

__all__ = [
    "integrate_pose",
    "write_commands",
    "write_joint_state_log",
    "write_trace",
    "write_velocity_log",
]

_ENCODINGS = ("cdr", "json")
_T_MIN_NS, _T_MAX_NS = -(2**31) * NS_PER_S, 2**31 * NS_PER_S


@dataclass
class _Stream:
    topic: str
    type: str
    log_t_ns: np.ndarray
    payloads: list[bytes]


def _ints(name: str, a: Any) -> np.ndarray:
    arr = np.asarray(a)
    if arr.ndim != 1 or not (np.issubdtype(arr.dtype, np.integer) or arr.size == 0):
        raise Sim2RealValueError(
            f"{name} must be a 1-D array of integer nanoseconds, got dtype {arr.dtype} and "
            f"shape {arr.shape}; convert seconds with robots.units.nanoseconds(t_s)"
        )
    out = arr.astype(np.int64)
    if out.size and (out.min() < _T_MIN_NS or out.max() >= _T_MAX_NS):
        raise Sim2RealValueError(
            f"{name} holds {int(out.min())}..{int(out.max())} ns, outside the range of "
            "builtin_interfaces/Time (int32 seconds, years 1901-2038); give epoch nanoseconds"
        )
    return out


def _floats(name: str, a: Any, n: int) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.shape != (n,):
        raise Sim2RealValueError(
            f"{name} must hold one value per timestamp ({n}), got shape {arr.shape}; "
            "give arrays of equal length"
        )
    return arr


def integrate_pose(
    t_ns: np.ndarray, v: np.ndarray, w: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dead-reckon a planar pose from body velocities (forward Euler, starts at the origin).

    .. math:: \\psi_{k+1} = \\psi_k + w_k \\Delta t_k,\\quad
              x_{k+1} = x_k + v_k \\cos\\psi_k \\Delta t_k,\\quad
              y_{k+1} = y_k + v_k \\sin\\psi_k \\Delta t_k

    Examples
    --------
    >>> x, y, yaw = integrate_pose(np.array([0, 10**9]), np.array([1.0, 1.0]), np.zeros(2))
    >>> float(x[-1])
    1.0
    """
    dt = seconds(np.diff(np.asarray(t_ns, dtype=np.int64)).astype(np.float64))
    v, w = np.nan_to_num(v[:-1]), np.nan_to_num(w[:-1])
    yaw = np.concatenate([[0.0], np.cumsum(w * dt)])
    x = np.concatenate([[0.0], np.cumsum(v * np.cos(yaw[:-1]) * dt)])
    y = np.concatenate([[0.0], np.cumsum(v * np.sin(yaw[:-1]) * dt)])
    return x, y, np.arctan2(np.sin(yaw), np.cos(yaw))


def _stamp(t: int) -> dict[str, int]:
    sec, nsec = divmod(int(t), NS_PER_S)
    return {"sec": sec, "nanosec": nsec}


def _vec(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> dict[str, float]:
    return {"x": float(x), "y": float(y), "z": float(z)}


def _json_twist(v: float, w: float) -> dict[str, Any]:
    return {"linear": _vec(v), "angular": _vec(z=w)}


def _json_payloads(type_name: str, cols: dict[str, Any], n: int) -> list[bytes]:
    out = []
    for i in range(n):
        msg: dict[str, Any]
        if type_name == TWIST:
            msg = _json_twist(cols["v"][i], cols["w"][i])
        else:
            header = {"stamp": _stamp(cols["t"][i]), "frame_id": cols["frame_id"]}
            if type_name == TWIST_STAMPED:
                msg = {"header": header, "twist": _json_twist(cols["v"][i], cols["w"][i])}
            elif type_name == ODOMETRY:
                half = 0.5 * float(cols["yaw"][i])
                quat = {"x": 0.0, "y": 0.0, "z": float(np.sin(half)), "w": float(np.cos(half))}
                msg = {
                    "header": header,
                    "child_frame_id": cols["child_frame_id"],
                    "pose": {
                        "pose": {"position": _vec(cols["x"][i], cols["y"][i]), "orientation": quat},
                        "covariance": [0.0] * 36,
                    },
                    "twist": {
                        "twist": _json_twist(cols["v"][i], cols["w"][i]),
                        "covariance": [0.0] * 36,
                    },
                }
            else:  # JointState
                msg = {
                    "header": header,
                    "name": list(cols["names"]),
                    "position": [float(p) for p in cols["position"][i]],
                    "velocity": [float(p) for p in cols["velocity"][i]],
                    "effort": [],
                }
        out.append(json.dumps(msg).encode("utf-8"))
    return out


def _write(path: str | Path, streams: Sequence[_Stream], *, encoding: str) -> Path:
    from mcap.writer import CompressionType, Writer

    lt = np.concatenate([s.log_t_ns for s in streams])
    owner = np.concatenate([np.full(s.log_t_ns.size, k) for k, s in enumerate(streams)])
    index = np.concatenate([np.arange(s.log_t_ns.size) for s in streams])
    order = np.argsort(lt, kind="stable")
    with atomic_write(path, "wb", what="log file") as fh:
        writer = Writer(fh, compression=CompressionType.ZSTD, enable_data_crcs=True)
        writer.start(profile="ros2", library=f"sim2real {__version__}")
        channel_ids = []
        for s in streams:
            if encoding == "cdr":
                sid = writer.register_schema(
                    name=s.type, encoding="ros2msg", data=SCHEMA_TEXT[s.type].encode()
                )
            else:
                text = json.dumps({"title": s.type, "type": "object"}).encode()
                sid = writer.register_schema(name=s.type, encoding="jsonschema", data=text)
            channel_ids.append(
                writer.register_channel(topic=s.topic, message_encoding=encoding, schema_id=sid)
            )
        seq = [0] * len(streams)
        rows = zip(owner[order].tolist(), index[order].tolist(), lt[order].tolist(), strict=True)
        for k, i, t in rows:
            writer.add_message(
                channel_id=channel_ids[k],
                log_time=t,
                data=streams[k].payloads[i],
                publish_time=t,
                sequence=seq[k],
            )
            seq[k] += 1
        writer.finish()
    return Path(path)


def _check_encoding(encoding: str) -> None:
    if encoding not in _ENCODINGS:
        raise Sim2RealValueError(
            f"encoding must be 'cdr' or 'json', got {encoding!r}; use 'cdr' for ROS 2 tools"
        )


def _cmd_stream(
    cmd_type: str,
    topic: str,
    cmd_t_ns: Any,
    cmd_v: Any,
    cmd_w: Any,
    cmd_log_t_ns: Any,
    frame_id: str,
    encoding: str,
) -> _Stream:
    """The command stream of a writer: its arrays checked (the writers' argument names in the
    errors), then encoded; ``cmd_log_t_ns`` None logs each command at its ``cmd_t_ns``."""
    t = _ints("cmd_t_ns", cmd_t_ns)
    v, w = _floats("cmd_v", cmd_v, t.size), _floats("cmd_w", cmd_w, t.size)
    lt = t if cmd_log_t_ns is None else _ints("cmd_log_t_ns", cmd_log_t_ns)
    if lt.size != t.size:
        raise Sim2RealValueError(f"cmd_log_t_ns must have {t.size} values, got {lt.size}")
    if cmd_type not in (TWIST, TWIST_STAMPED):
        raise Sim2RealValueError(
            f"cmd_type must be '{TWIST}' or '{TWIST_STAMPED}', got {cmd_type!r}"
        )
    if encoding == "json":
        cols = {"t": t, "v": v, "w": w, "frame_id": frame_id}
        return _Stream(topic, cmd_type, lt, _json_payloads(cmd_type, cols, t.size))
    if cmd_type == TWIST:
        return _Stream(topic, cmd_type, lt, _cdr.encode_twist(v, w))
    return _Stream(topic, cmd_type, lt, _cdr.encode_twist_stamped(t, v, w, frame_id=frame_id))


def write_velocity_log(
    path: str | Path,
    *,
    cmd_t_ns: np.ndarray,
    cmd_v: np.ndarray,
    cmd_w: np.ndarray,
    meas_t_ns: np.ndarray,
    meas_v: np.ndarray,
    meas_w: np.ndarray,
    pose_x: np.ndarray | None = None,
    pose_y: np.ndarray | None = None,
    pose_yaw: np.ndarray | None = None,
    cmd_type: str = TWIST,
    cmd_topic: str = "/cmd_vel",
    odom_topic: str = "/odom",
    odom_frame_id: str = "odom",
    base_frame_id: str = "base_link",
    cmd_log_t_ns: np.ndarray | None = None,
    meas_log_t_ns: np.ndarray | None = None,
    encoding: str = "cdr",
) -> Path:
    """Write commands and odometry to a ROS 2 MCAP file (atomically).

    Parameters
    ----------
    path : str or Path
        Output ``.mcap`` file; its folder must exist.
    cmd_t_ns, cmd_v, cmd_w : array_like
        Command times (int ns), forward speed (m/s), yaw rate (rad/s).
    meas_t_ns, meas_v, meas_w : array_like
        Odometry header stamps (int ns) and twist (m/s, rad/s).
    pose_x, pose_y, pose_yaw : array_like, optional
        Odometry pose (m, m, rad); dead-reckoned from (v, w) with :func:`integrate_pose`
        when omitted.
    cmd_type : str
        ``geometry_msgs/msg/Twist`` (no header: ``cmd_t_ns`` is the log time) or
        ``geometry_msgs/msg/TwistStamped`` (``cmd_t_ns`` is the header stamp, frame
        ``base_frame_id``).
    cmd_topic, odom_topic, odom_frame_id, base_frame_id : str
        Topic names; Odometry ``header.frame_id`` and ``child_frame_id``.
    cmd_log_t_ns, meas_log_t_ns : array_like, optional
        Recorder log times (int ns) when they differ from the stamps (transport delay or
        bursts); default: the stamps.
    encoding : {"cdr", "json"}
        ROS 2 CDR with ``ros2msg`` schemas (default) or JSON with ``jsonschema`` schemas.

    Notes
    -----
    Values are written as given (NaN, unsorted or repeated times included), so the writer
    can also build test logs of bad data.

    Examples
    --------
    >>> t = np.arange(5) * 100_000_000
    >>> write_velocity_log("run.mcap", cmd_t_ns=t, cmd_v=np.ones(5), cmd_w=np.zeros(5),
    ...                    meas_t_ns=t, meas_v=np.ones(5), meas_w=np.zeros(5))  # doctest: +SKIP
    PosixPath('run.mcap')
    """
    _check_encoding(encoding)
    cmd = _cmd_stream(
        cmd_type, cmd_topic, cmd_t_ns, cmd_v, cmd_w, cmd_log_t_ns, base_frame_id, encoding
    )
    mt = _ints("meas_t_ns", meas_t_ns)
    mv, mw = _floats("meas_v", meas_v, mt.size), _floats("meas_w", meas_w, mt.size)
    mlt = mt if meas_log_t_ns is None else _ints("meas_log_t_ns", meas_log_t_ns)
    if mlt.size != mt.size:
        raise Sim2RealValueError(f"meas_log_t_ns must have {mt.size} values, got {mlt.size}")
    if pose_x is None or pose_y is None or pose_yaw is None:
        if not (pose_x is None and pose_y is None and pose_yaw is None):
            raise Sim2RealValueError("give all of pose_x, pose_y and pose_yaw, or none of them")
        px, py, pyaw = integrate_pose(mt, mv, mw) if mt.size else (mv, mv, mv)
    else:
        px, py = _floats("pose_x", pose_x, mt.size), _floats("pose_y", pose_y, mt.size)
        pyaw = _floats("pose_yaw", pose_yaw, mt.size)
    if encoding == "json":
        cols: dict[str, Any] = {"t": mt, "v": mv, "w": mw, "x": px, "y": py, "yaw": pyaw}
        cols |= {"frame_id": odom_frame_id, "child_frame_id": base_frame_id}
        odom = _Stream(odom_topic, ODOMETRY, mlt, _json_payloads(ODOMETRY, cols, mt.size))
    else:
        payloads = _cdr.encode_odometry(
            mt, mv, mw, x=px, y=py, yaw=pyaw, frame_id=odom_frame_id, child_frame_id=base_frame_id
        )
        odom = _Stream(odom_topic, ODOMETRY, mlt, payloads)
    return _write(path, [cmd, odom], encoding=encoding)


def write_commands(
    path: str | Path,
    *,
    cmd_t_ns: np.ndarray,
    cmd_v: np.ndarray,
    cmd_w: np.ndarray,
    cmd_topic: str = "/cmd_vel",
) -> Path:
    """Write a command script: ``geometry_msgs/msg/Twist`` on ``cmd_topic`` only, ROS 2 CDR.

    ``ros2 bag play`` sends the messages at their log times ``cmd_t_ns`` (int ns) with
    ``linear.x = cmd_v`` (m/s) and ``angular.z = cmd_w`` (rad/s); written atomically.

    Examples
    --------
    >>> t = np.arange(5) * 100_000_000
    >>> write_commands("script.mcap", cmd_t_ns=t, cmd_v=np.ones(5), cmd_w=np.zeros(5))  # doctest: +SKIP
    PosixPath('script.mcap')
    """
    cmd = _cmd_stream(TWIST, cmd_topic, cmd_t_ns, cmd_v, cmd_w, None, "", "cdr")
    return _write(path, [cmd], encoding="cdr")


def write_trace(
    path: str | Path, trace: Trace, *, cmd_topic: str = "/cmd_vel", odom_topic: str = "/odom"
) -> Path:
    """Write a :class:`Trace` as ``/cmd_vel`` (Twist) and ``/odom`` (Odometry) in ROS 2 CDR.

    Reading the file back with :func:`~sim2real.logs.read_trace` gives the same times and
    velocities bit for bit, and the same pose up to the yaw -> quaternion -> yaw round-off
    (~1e-16 rad). A trace without pose is written with the dead-reckoned pose of
    :func:`integrate_pose`. The trace's arrays (its fields but ``meta``) are the
    :func:`write_velocity_log` keywords of the same names.

    Examples
    --------
    >>> write_trace("sim.mcap", trace)  # doctest: +SKIP
    PosixPath('sim.mcap')
    """
    arrays = {f.name: getattr(trace, f.name) for f in fields(trace) if f.name != "meta"}
    return write_velocity_log(path, **arrays, cmd_topic=cmd_topic, odom_topic=odom_topic)


def write_joint_state_log(
    path: str | Path,
    *,
    cmd_t_ns: np.ndarray,
    cmd_v: np.ndarray,
    cmd_w: np.ndarray,
    js_t_ns: np.ndarray,
    left_radps: np.ndarray,
    right_radps: np.ndarray,
    joint_names: tuple[str, str] = ("wheel_left_joint", "wheel_right_joint"),
    cmd_topic: str = "/cmd_vel",
    js_topic: str = "/joint_states",
    encoding: str = "cdr",
) -> Path:
    """Write commands (Twist) and wheel speeds (``sensor_msgs/msg/JointState``) to MCAP.

    Wheel positions are the integrated speeds (rad). Meant for tests and examples; the
    JointState payloads are encoded one by one.

    Examples
    --------
    >>> t = np.arange(3) * 50_000_000
    >>> write_joint_state_log("js.mcap", cmd_t_ns=t, cmd_v=np.ones(3), cmd_w=np.zeros(3),
    ...     js_t_ns=t, left_radps=np.ones(3), right_radps=np.ones(3))  # doctest: +SKIP
    PosixPath('js.mcap')
    """
    _check_encoding(encoding)
    cmd = _cmd_stream(TWIST, cmd_topic, cmd_t_ns, cmd_v, cmd_w, None, "", encoding)
    jt = _ints("js_t_ns", js_t_ns)
    left = _floats("left_radps", left_radps, jt.size)
    right = _floats("right_radps", right_radps, jt.size)
    vel = np.stack([left, right], axis=1)
    dt = seconds(np.diff(jt, prepend=jt[:1]).astype(np.float64))
    pos = np.cumsum(np.nan_to_num(vel) * dt[:, None], axis=0)
    if encoding == "json":
        cols = {"t": jt, "frame_id": "", "names": joint_names, "position": pos, "velocity": vel}
        payloads = _json_payloads(JOINT_STATE, cols, jt.size)
    else:
        payloads = [
            _cdr.encode_joint_state(
                int(jt[i]),
                frame_id="",
                names=joint_names,
                position=pos[i].tolist(),
                velocity=vel[i].tolist(),
                effort=[],
            )
            for i in range(jt.size)
        ]
    return _write(path, [cmd, _Stream(js_topic, JOINT_STATE, jt, payloads)], encoding=encoding)
