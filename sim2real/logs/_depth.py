"""``read_depth``: the depth images of a log's ``sensor_msgs/Image`` topic (private).

A depth topic is an Image topic whose encoding is ``16UC1`` (millimetres, 0 = no return) or
``32FC1`` (metres, NaN or inf = no return; REP 118). Payloads are decoded message by message:
ROS 2 CDR (a 4-byte encapsulation header, fields aligned to their size from the end of that
header) or ROS 1 (packed, a ``seq`` before the stamp). The layout is ``Header``, ``height``,
``width``, ``encoding``, ``is_bigendian``, ``step``, then the ``data`` bytes. Only a grid of
at most :data:`MAX_PIXELS` pixels is kept (every k-th row and column).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from sim2real.errors import LogFormatError, LogValueError, MissingTopicError
from sim2real.logs._cdr import message_header
from sim2real.logs._channels import Chan, _listing
from sim2real.logs._mcap import Segment
from sim2real.logs._reader import load_log

__all__ = ["DEPTH_ENCODINGS", "IMAGE", "MAX_PIXELS", "DepthImages", "read_depth"]

IMAGE = "sensor_msgs/msg/Image"
#: Depth encodings and the factor from a pixel's value to metres.
DEPTH_ENCODINGS = {"16UC1": 0.001, "32FC1": 1.0}
MAX_PIXELS = 4096  # most pixels kept per image (a regular grid of them)


@dataclass(frozen=True, kw_only=True)
class DepthImages:
    """Depth images of one topic, sorted by stamp, with these attributes:

    topic, encoding : str
        The topic and its encoding (``16UC1`` or ``32FC1``).
    stamp_ns : ndarray of int64, shape (n,)
        Header stamps (log times where a stamp is 0), ns.
    depth_m : ndarray of float64, shape (n, pixels)
        Depth of the kept pixels, m; no return is NaN.
    size_px : tuple of int
        Image width and height, pixels; every ``stride``-th row and column is kept.
    """

    topic: str
    encoding: str
    stamp_ns: NDArray[np.int64]
    depth_m: NDArray[np.float64]
    size_px: tuple[int, int]
    stride: int


def _image(buf: bytes, ros1: bool) -> tuple[int, int, int, str, int, int, int]:
    """Stamp (ns), height, width, encoding, big-endian flag, step and data offset."""
    stamp, pos = message_header(buf, ros1=ros1)
    base = 0 if ros1 else 4  # where CDR alignment counts from
    height, width, n = struct.unpack_from("<III", buf, pos)
    encoding = buf[pos + 12 : pos + 12 + n].rstrip(b"\0").decode("ascii")
    pos += 12 + n
    big = buf[pos]
    pos += 1
    pos += (-(pos - base)) % 4 if not ros1 else 0
    step, count = struct.unpack_from("<II", buf, pos)
    if count < step * height:
        raise ValueError(f"{count} data bytes for {height} rows of {step}")
    return stamp, height, width, encoding, big, step, pos + 8


def _payloads(parts: Sequence[object]) -> list[tuple[bytes, int]]:
    """Raw payloads and log times of a channel's segments."""
    return [
        (bytes(seg.buf[o : o + n]), int(seg.log_time_ns[k]))
        for seg in parts
        if isinstance(seg, Segment)
        for k, (o, n) in enumerate(
            zip(seg.payload_off.tolist(), seg.payload_len.tolist(), strict=True)
        )
    ]


def _pixels(
    buf: bytes, head: tuple[int, int, int, str, int, int, int], stride: int
) -> NDArray[np.float64]:
    """The kept pixels of one image in metres (no return: NaN)."""
    _stamp, height, width, encoding, big, step, pos = head
    kind = ">" if big else "<"
    dtype = np.dtype(f"{kind}u2" if encoding == "16UC1" else f"{kind}f4")
    rows = np.frombuffer(buf, np.uint8, step * height, pos).reshape(height, step)
    img = rows[:, : width * dtype.itemsize].copy().view(dtype)[::stride, ::stride]
    depth = img.astype(np.float64).reshape(-1) * DEPTH_ENCODINGS[encoding]
    depth[~np.isfinite(depth) | (depth <= 0.0)] = np.nan
    return depth


def read_depth(path: str | Path, *, depth_topic: str | None = None) -> DepthImages | None:
    """Read the depth images of a log (MCAP, ROS 1 bag, rosbag2), or None when it has none.

    The topic is ``depth_topic`` or else the only non-empty Image topic with a depth encoding
    (``16UC1`` mm or ``32FC1`` m; of several, the one whose name has ``depth``). A
    ``depth_topic`` that is not a depth Image topic of the log raises
    :class:`~sim2real.errors.MissingTopicError` (the message lists the topics); images that
    change size or encoding raise :class:`~sim2real.errors.LogValueError`.

    Examples
    --------
    >>> read_depth("recording.mcap").depth_m.shape  # 640 x 480 kept every 10th  # doctest: +SKIP
    (300, 3072)
    """
    found = []
    log = load_log(path, sort_times=False, keep_types=(IMAGE,))
    for chan in log.chans:
        if chan.type != IMAGE or chan.count == 0 or (depth_topic and chan.topic != depth_topic):
            continue
        msgs = _payloads(log.container.parts.get(chan.record.id, []))
        try:
            head = _image(msgs[0][0], chan.encoding == "ros1") if msgs else None
        except (struct.error, ValueError, IndexError, UnicodeDecodeError):
            head = None
        if head is not None and head[3] in DEPTH_ENCODINGS:
            found.append((chan, msgs))
    if depth_topic is not None and not found:
        raise MissingTopicError(
            f"log file '{log.name}' has no {IMAGE} topic '{depth_topic}' with a 16UC1 or 32FC1 "
            f"depth encoding; topics present: {_listing(log.chans)}; pick one with --depth-topic"
        )
    if len(found) > 1:
        named = [f for f in found if "depth" in f[0].topic]
        found = named if len(named) == 1 else found
    if len(found) > 1:
        raise MissingTopicError(
            f"log file '{log.name}' has several depth image topics "
            f"({', '.join(f[0].topic for f in found)}); pick one with --depth-topic"
        )
    return _decode(found[0][0], found[0][1], log.name) if found else None


def _decode(chan: Chan, msgs: list[tuple[bytes, int]], name: str) -> DepthImages:
    ros1 = chan.encoding == "ros1"
    stamps: list[int] = []
    rows: list[NDArray[np.float64]] = []
    first = None
    stride = 1
    for buf, log_ns in msgs:
        try:
            head = _image(buf, ros1)
        except (struct.error, ValueError, IndexError, UnicodeDecodeError) as exc:
            raise LogFormatError(
                f"a message of topic '{chan.topic}' in log file '{name}' cannot be decoded "
                f"as {IMAGE} ({exc}); the file is corrupt or its schema is wrong"
            ) from None
        if first is None:
            first = head
            stride = max(1, math.ceil(math.sqrt(head[1] * head[2] / MAX_PIXELS)))
        if head[1:4] != first[1:4]:
            raise LogValueError(
                f"topic '{chan.topic}' of log file '{name}' changes its images (the first is "
                f"{first[2]} x {first[1]} {first[3]}, message {len(rows)} is {head[2]} x "
                f"{head[1]} {head[3]}); identify a camera from images of one layout"
            )
        stamps.append(head[0] if head[0] > 0 else log_ns)
        rows.append(_pixels(buf, head, stride))
    assert first is not None  # found topics have messages
    order = np.argsort(np.array(stamps, np.int64), kind="stable")
    return DepthImages(
        topic=chan.topic,
        encoding=first[3],
        stamp_ns=np.array(stamps, np.int64)[order],
        depth_m=np.vstack(rows)[order],
        size_px=(first[2], first[1]),
        stride=stride,
    )
