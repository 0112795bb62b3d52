"""Bulk ROS 2 CDR decoding and encoding with numpy (private).

A ROS 2 message in an MCAP file is an XCDR1 "plain CDR" payload: a 4-byte encapsulation
header (``00 01 00 00`` for little endian) followed by the fields in declaration order, each
aligned to its own size counted from the end of that header (OMG DDS-XTypes 1.3, section
7.4.1 and the rmw_fastrtps serializer ROS 2 uses). Strings are ``uint32`` length (including the
terminating NUL) then the bytes.

``Twist`` is a fixed 48-byte body. ``TwistStamped`` and ``Odometry`` start with a
``std_msgs/Header`` whose ``frame_id`` string (and Odometry's ``child_frame_id``) has a
variable length, so the offsets of the doubles behind them are computed per message with
vectorised integer arithmetic and the doubles are then gathered in one numpy indexing step.
The decoders read the payloads of many messages at once: ``u8`` is the buffer as uint8,
``off`` the payload start of each message in it and ``ln`` the payload lengths.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import numpy as np

from robots.units import NS_PER_S

__all__ = [
    "POSE_KEYS",
    "CdrLayoutError",
    "decode_odometry",
    "decode_twist",
    "decode_twist_stamped",
    "encode_joint_state",
    "encode_odometry",
    "encode_twist",
    "encode_twist_stamped",
    "gather",
    "is_little_endian",
    "items",
    "message_header",
    "rows",
    "stamp_ns",
]

#: The pose columns of a decoded Odometry message: position x, y and the orientation quaternion.
POSE_KEYS = ("x", "y", "qx", "qy", "qz", "qw")
_LE_HEADER = b"\x00\x01\x00\x00"
_TWIST_BYTES = 48  # 2 x Vector3 of 3 float64
_POSE_COV_BYTES = 7 * 8 + 36 * 8  # Pose (Point + Quaternion) + float64[36]
_TWIST_COV_BYTES = _TWIST_BYTES + 36 * 8


class CdrLayoutError(Exception):
    """Internal: message ``index`` of a batch does not fit its declared layout."""

    def __init__(self, index: int, reason: str) -> None:
        super().__init__(f"message {index} {reason}")
        self.index = index
        self.reason = reason


def gather(u8: np.ndarray, offsets: np.ndarray, dtype: str) -> np.ndarray:
    """Read one little-endian scalar of ``dtype`` at each byte offset of ``u8``.

    Examples
    --------
    >>> u8 = np.frombuffer(np.array([1.5, 2.5]).tobytes(), dtype=np.uint8)
    >>> gather(u8, np.array([8, 0]), "<f8")
    array([2.5, 1.5])
    """
    dt = np.dtype(dtype)
    if offsets.size == 0:
        return np.zeros(0, dtype=dt)
    if u8.flags.c_contiguous and u8.size >= dt.itemsize:  # one item copy per offset
        return items(u8, dt.itemsize)[offsets].view(dt).astype(dt.newbyteorder("="), copy=False)
    idx = offsets[:, None] + np.arange(dt.itemsize)
    return np.ascontiguousarray(u8[idx]).view(dt).reshape(-1).astype(dt.newbyteorder("="))


def rows(u8: np.ndarray, offsets: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """The ``dtype`` record (a structured, packed little-endian layout) at each byte offset.

    One row copy of ``dtype.itemsize`` bytes per offset through a sliding window over ``u8``
    (every offset must leave room for a whole record), instead of one gather per field.

    Examples
    --------
    >>> u8 = np.frombuffer(np.array([1.5, 2.5, 3.5]).tobytes(), dtype=np.uint8)
    >>> rows(u8, np.array([8, 0]), np.dtype([("a", "<f8"), ("b", "<f8")]))["b"]
    array([3.5, 2.5])
    """
    size = dtype.itemsize
    if offsets.size == 0 or u8.size < size:
        return np.zeros(0, dtype=dtype)
    if u8.flags.c_contiguous:  # the common case: one memcpy of a void item per offset
        return items(u8, size)[offsets].view(dtype)
    return window(u8, size)[offsets].view(dtype).reshape(-1)


def items(u8: np.ndarray, size: int) -> np.ndarray:
    """Read-only view of the contiguous ``u8`` as overlapping void items of ``size`` bytes:
    item ``i`` is ``u8[i:i + size]`` (``u8.size >= size``; no copy).

    Indexing it with offsets copies each record whole (faster than the same rows of
    :func:`window`, which numpy copies byte by byte).
    """
    out = np.ndarray(
        (u8.size - size + 1,), dtype=np.dtype((np.void, size)), buffer=u8, strides=(1,)
    )
    out.flags.writeable = False
    return out


def window(u8: np.ndarray, size: int) -> np.ndarray:
    """Read-only sliding window of ``size`` bytes over ``u8``: row ``i`` is ``u8[i:i + size]``
    (``u8.size >= size``; no copy)."""
    if u8.flags.c_contiguous:  # the common case, without as_strided's overhead
        out = np.ndarray((u8.size - size + 1, size), dtype=np.uint8, buffer=u8, strides=(1, 1))
        out.flags.writeable = False
        return out
    step = u8.strides[0]
    return np.lib.stride_tricks.as_strided(
        u8, shape=(u8.size - size + 1, size), strides=(step, step), writeable=False
    )


def _f64(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


#: ``std_msgs/Header`` head: stamp (sec, nanosec) and the length of ``frame_id``.
_HEADER_ROW = np.dtype([("sec", "<i4"), ("nanosec", "<u4"), ("frame_len", "<u4")])
#: ``geometry_msgs/Twist``: linear xyz, angular xyz.
_TWIST_ROW = np.dtype(
    {"names": ["v", "w"], "formats": ["<f8", "<f8"], "offsets": [0, 40], "itemsize": 48}
)
#: ``nav_msgs/Odometry`` ``pose.pose``: position (x, y, z), orientation (x, y, z, w).
_POSE_ROW = np.dtype(
    {
        "names": ["x", "y", "qx", "qy", "qz", "qw"],
        "formats": ["<f8"] * 6,
        "offsets": [0, 8, 24, 32, 40, 48],
        "itemsize": 56,
    }
)


def _need(ok: np.ndarray, reason: str) -> None:
    if not bool(ok.all()):
        raise CdrLayoutError(int(np.argmin(ok)), reason)


def _align(rel: np.ndarray, size: int) -> np.ndarray:
    return (rel + (size - 1)) & ~(size - 1)


def is_little_endian(u8: np.ndarray, off: np.ndarray, ln: np.ndarray) -> bool:
    """True when every payload carries the little-endian plain-CDR header ``00 01``."""
    _need(ln >= 4, "is shorter than the 4-byte CDR header")
    if off.size == 0:
        return True
    return bool(((u8[off] == 0) & (u8[off + 1] == 1)).all())


def stamp_ns(sec: np.ndarray, nanosec: np.ndarray) -> np.ndarray:
    """Nanoseconds since the epoch from ``builtin_interfaces/Time`` fields (int64)."""
    return sec.astype(np.int64) * NS_PER_S + nanosec.astype(np.int64)


def decode_twist(u8: np.ndarray, off: np.ndarray, ln: np.ndarray) -> dict[str, np.ndarray]:
    """``geometry_msgs/msg/Twist`` payloads -> ``v`` (linear.x, m/s), ``w`` (angular.z, rad/s)."""
    body = off + 4
    _need(ln - 4 >= _TWIST_BYTES, "is shorter than a Twist (48 bytes after the header)")
    row = rows(u8, body, _TWIST_ROW)
    return {"v": _f64(row["v"]), "w": _f64(row["w"])}


def _header(u8: np.ndarray, off: np.ndarray, ln: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stamp (ns) and the body-relative offset just past ``header.frame_id``."""
    body, size = off + 4, ln - 4
    _need(size >= 12, "is shorter than a std_msgs/Header")
    head = rows(u8, body, _HEADER_ROW)
    stamp = stamp_ns(head["sec"], head["nanosec"])
    rel = 12 + head["frame_len"].astype(np.int64)
    _need(rel <= size, "has a header.frame_id longer than the message")
    return stamp, rel


def decode_twist_stamped(u8: np.ndarray, off: np.ndarray, ln: np.ndarray) -> dict[str, np.ndarray]:
    """``geometry_msgs/msg/TwistStamped`` payloads -> ``stamp_ns``, ``v``, ``w``."""
    stamp, rel = _header(u8, off, ln)
    rel = _align(rel, 8)
    _need(rel + _TWIST_BYTES <= ln - 4, "is cut short inside its twist")
    row = rows(u8, off + 4 + rel, _TWIST_ROW)
    return {"stamp_ns": stamp, "v": _f64(row["v"]), "w": _f64(row["w"])}


def decode_odometry(u8: np.ndarray, off: np.ndarray, ln: np.ndarray) -> dict[str, np.ndarray]:
    """``nav_msgs/msg/Odometry`` payloads -> ``stamp_ns``, ``v``, ``w``, ``x``, ``y``, ``qx..qw``.

    ``v``/``w`` are ``twist.twist.linear.x`` / ``angular.z`` (child frame, m/s and rad/s);
    ``x``/``y`` and the quaternion are ``pose.pose`` (header frame, m).
    """
    stamp, rel = _header(u8, off, ln)
    size, body = ln - 4, off + 4
    rel = _align(rel, 4)
    _need(rel + 4 <= size, "is cut short before child_frame_id")
    rel = rel + 4 + gather(u8, body + rel, "<u4").astype(np.int64)
    pose = _align(rel, 8)
    _need(
        pose + _POSE_COV_BYTES + _TWIST_COV_BYTES <= size, "is cut short inside its pose or twist"
    )
    # two narrow rows (pose, then twist past the pose covariance): the covariances are
    # never copied
    at = body + pose
    row = rows(u8, at, _POSE_ROW)
    twist = rows(u8, at + _POSE_COV_BYTES, _TWIST_ROW)
    out = {"stamp_ns": stamp, "v": _f64(twist["v"]), "w": _f64(twist["w"])}
    for key in POSE_KEYS:
        out[key] = _f64(row[key])
    return out


# ---------------------------------------------------------------------------------- encoding


def _rows(parts: Sequence[np.ndarray]) -> list[bytes]:
    """Join per-message byte columns ``(n, k_i)`` into one payload per message."""
    table = np.concatenate([np.ascontiguousarray(p, dtype=np.uint8) for p in parts], axis=1)
    width = table.shape[1]
    flat = table.tobytes()
    return [flat[i : i + width] for i in range(0, len(flat), width)]


def _const(n: int, raw: bytes) -> np.ndarray:
    return np.broadcast_to(np.frombuffer(raw, dtype=np.uint8), (n, len(raw)))


def _f64_cols(*cols: np.ndarray) -> np.ndarray:
    mat = np.stack([np.asarray(c, dtype="<f8") for c in cols], axis=1)
    return np.ascontiguousarray(mat).view(np.uint8).reshape(mat.shape[0], 8 * mat.shape[1])


def _stamp_cols(t_ns: np.ndarray) -> np.ndarray:
    t = np.asarray(t_ns, dtype=np.int64)
    sec, nsec = np.divmod(t, NS_PER_S)
    if (sec < -(2**31)).any() or (sec >= 2**31).any():
        raise OverflowError("a stamp does not fit builtin_interfaces/Time (int32 seconds)")
    out = np.empty((t.size, 8), dtype=np.uint8)
    out[:, :4] = sec.astype("<i4").view(np.uint8).reshape(-1, 4)
    out[:, 4:] = nsec.astype("<u4").view(np.uint8).reshape(-1, 4)
    return out


def _string(text: str, rel: int, align_to: int = 4) -> tuple[bytes, int]:
    """Padding + CDR string at body-relative offset ``rel``; returns bytes and new offset."""
    raw = text.encode("utf-8") + b"\x00"
    pad = (-rel) % align_to
    blob = b"\x00" * pad + struct.pack("<I", len(raw)) + raw
    return blob, rel + len(blob)


def encode_twist(v: np.ndarray, w: np.ndarray) -> list[bytes]:
    """``geometry_msgs/msg/Twist`` payloads with linear.x = v and angular.z = w (rest 0)."""
    n = np.size(v)
    zero = np.zeros(n)
    return _rows([_const(n, _LE_HEADER), _f64_cols(v, zero, zero, zero, zero, w)])


def encode_twist_stamped(
    t_ns: np.ndarray, v: np.ndarray, w: np.ndarray, *, frame_id: str
) -> list[bytes]:
    """``geometry_msgs/msg/TwistStamped`` payloads stamped ``t_ns`` in frame ``frame_id``."""
    n = np.size(v)
    frame, rel = _string(frame_id, 8)
    pad = b"\x00" * ((-rel) % 8)
    zero = np.zeros(n)
    return _rows(
        [
            _const(n, _LE_HEADER),
            _stamp_cols(t_ns),
            _const(n, frame + pad),
            _f64_cols(v, zero, zero, zero, zero, w),
        ]
    )


def encode_odometry(
    t_ns: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    *,
    x: np.ndarray,
    y: np.ndarray,
    yaw: np.ndarray,
    frame_id: str,
    child_frame_id: str,
) -> list[bytes]:
    """``nav_msgs/msg/Odometry`` payloads: planar pose (x, y, yaw) and twist (v, w).

    The yaw becomes the quaternion ``(0, 0, sin(yaw/2), cos(yaw/2))``; covariances are 0.
    """
    n = np.size(v)
    frame, rel = _string(frame_id, 8)
    child, rel = _string(child_frame_id, rel)
    pad = b"\x00" * ((-rel) % 8)
    zero = np.zeros(n)
    half = 0.5 * np.asarray(yaw, dtype=np.float64)
    cov = np.zeros((n, 36 * 8), dtype=np.uint8)
    return _rows(
        [
            _const(n, _LE_HEADER),
            _stamp_cols(t_ns),
            _const(n, frame + child + pad),
            _f64_cols(x, y, zero, zero, zero, np.sin(half), np.cos(half)),
            cov,
            _f64_cols(v, zero, zero, zero, zero, w),
            cov,
        ]
    )


def encode_joint_state(
    t_ns: int,
    *,
    frame_id: str,
    names: Sequence[str],
    position: Sequence[float],
    velocity: Sequence[float],
    effort: Sequence[float],
) -> bytes:
    """One ``sensor_msgs/msg/JointState`` payload (a plain loop: used for test logs)."""
    sec, nsec = divmod(int(t_ns), NS_PER_S)
    out = bytearray(_LE_HEADER + struct.pack("<iI", sec, nsec))
    blob, rel = _string(frame_id, 8)
    out += blob
    blob, rel = _u32(len(names), rel)
    out += blob
    for name in names:
        blob, rel = _string(name, rel)
        out += blob
    for values in (position, velocity, effort):
        blob, rel = _u32(len(values), rel)
        out += blob
        if len(values):
            pad = (-rel) % 8
            out += b"\x00" * pad + struct.pack(f"<{len(values)}d", *values)
            rel += pad + 8 * len(values)
    return bytes(out)


def _u32(value: int, rel: int) -> tuple[bytes, int]:
    pad = (-rel) % 4
    return b"\x00" * pad + struct.pack("<I", value), rel + pad + 4


def message_header(buf: bytes, *, ros1: bool) -> tuple[int, int]:
    """The stamp (ns) of one message's ``std_msgs/Header`` and the offset of the field after
    it: ROS 1 packs the header (a ``seq`` before the stamp); little-endian ROS 2 CDR has a
    4-byte encapsulation header first and aligns the next 4-byte field. A big-endian CDR
    message raises ``ValueError``."""
    if ros1:
        _seq, sec, nsec, n = struct.unpack_from("<IIII", buf, 0)
        return sec * NS_PER_S + nsec, 16 + n
    if buf[1] != 1:
        raise ValueError("not little-endian CDR")
    sec, nsec, n = struct.unpack_from("<iII", buf, 4)
    pos = 16 + n
    return sec * NS_PER_S + nsec, pos + (-(pos - 4)) % 4
