"""Bulk decoding of ROS 1 serialized drive messages with numpy (private).

ROS 1 serialisation (wiki.ros.org/msg, "Serialization") writes the fields in declaration
order, little endian, with no alignment padding; a string is a ``uint32`` byte count then the
bytes (no NUL); ``std_msgs/Header`` is ``seq u32, stamp (sec u32, nsec u32), frame_id``.
The container (bag chunks, index, connections) is read by ``rosbags``; these functions only
pick the few numbers we need out of many payloads at once, mirroring the CDR fast path of
:mod:`sim2real.logs._cdr`. Every other type goes through rosbags' own deserialiser, and the
tests check that both give the same numbers.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sim2real.logs._cdr import CdrLayoutError, gather, stamp_ns
from sim2real.logs._schemas import ODOMETRY, TWIST, TWIST_STAMPED

__all__ = ["BULK_ROS1"]

_TWIST_BYTES = 48  # 2 x Vector3 of 3 float64
_POSE_COV_BYTES = 7 * 8 + 36 * 8  # Pose (Point + Quaternion) + float64[36]
_TWIST_COV_BYTES = _TWIST_BYTES + 36 * 8


def _need(ok: np.ndarray, reason: str) -> None:
    if not bool(np.all(ok)):
        raise CdrLayoutError(int(np.argmin(ok)), reason)


def _twist(u8: np.ndarray, off: np.ndarray, ln: np.ndarray) -> dict[str, np.ndarray]:
    _need(ln >= _TWIST_BYTES, "is shorter than a Twist (48 bytes)")
    return {"v": gather(u8, off, "<f8"), "w": gather(u8, off + 40, "<f8")}


def _header(u8: np.ndarray, off: np.ndarray, ln: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stamp (ns) and the payload-relative offset just past ``header.frame_id``."""
    _need(ln >= 16, "is shorter than a std_msgs/Header")
    stamp = stamp_ns(gather(u8, off + 4, "<u4"), gather(u8, off + 8, "<u4"))
    rel = 16 + gather(u8, off + 12, "<u4").astype(np.int64)
    _need(rel <= ln, "has a header.frame_id longer than the message")
    return stamp, rel


def _twist_stamped(u8: np.ndarray, off: np.ndarray, ln: np.ndarray) -> dict[str, np.ndarray]:
    stamp, rel = _header(u8, off, ln)
    _need(rel + _TWIST_BYTES <= ln, "is cut short inside its twist")
    at = off + rel
    return {"stamp_ns": stamp, "v": gather(u8, at, "<f8"), "w": gather(u8, at + 40, "<f8")}


def _odometry(u8: np.ndarray, off: np.ndarray, ln: np.ndarray) -> dict[str, np.ndarray]:
    stamp, rel = _header(u8, off, ln)
    _need(rel + 4 <= ln, "is cut short before child_frame_id")
    pose = rel + 4 + gather(u8, off + rel, "<u4").astype(np.int64)
    twist = pose + _POSE_COV_BYTES
    _need(twist + _TWIST_COV_BYTES <= ln, "is cut short inside its pose or twist")
    p, t = off + pose, off + twist
    out = {"stamp_ns": stamp, "v": gather(u8, t, "<f8"), "w": gather(u8, t + 40, "<f8")}
    for i, key in enumerate(("x", "y", "z", "qx", "qy", "qz", "qw")):
        if key != "z":
            out[key] = gather(u8, p + 8 * i, "<f8")
    return out


#: Fixed-layout types decoded in bulk from ROS 1 payloads (same keys as the CDR decoders).
BULK_ROS1: dict[str, Callable[[np.ndarray, np.ndarray, np.ndarray], dict[str, np.ndarray]]] = {
    TWIST: _twist,
    TWIST_STAMPED: _twist_stamped,
    ODOMETRY: _odometry,
}
