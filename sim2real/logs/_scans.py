"""``read_scans``: the ``sensor_msgs/LaserScan`` messages and odometry poses of a log (private).

LaserScan payloads are kept raw while the log streams past (``keep_types``) and decoded here
message by message: ROS 2 CDR (a 4-byte encapsulation header, fields aligned to their size
from the end of that header) or ROS 1 (packed, a ``seq`` before the stamp). The layout is
``Header``, seven ``float32`` (angle_min, angle_max, angle_increment, time_increment,
scan_time, range_min, range_max), then the ``ranges`` and ``intensities`` sequences.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from sim2real.errors import LogFormatError, LogValueError, MissingTopicError
from sim2real.logs._cdr import message_header
from sim2real.logs._channels import Chan, _listing
from sim2real.logs._decode import decode_channel
from sim2real.logs._mcap import Segment
from sim2real.logs._reader import load_log
from sim2real.logs._schemas import ODOMETRY

__all__ = ["LASER_SCAN", "LaserScans", "read_scans"]

LASER_SCAN = "sensor_msgs/msg/LaserScan"
_FLOATS = struct.Struct("<7f")


@dataclass(frozen=True, kw_only=True)
class LaserScans:
    """The scans of one LaserScan topic and the odometry poses of the same log.

    Attributes
    ----------
    name, topic, odom_topic : str
        The log and the two topics read.
    stamp_ns : ndarray of int64, shape (n,)
        Scan header stamps (log times where a stamp is 0), ns since the epoch.
    ranges_m : ndarray of float64, shape (n, beams)
        Ranges as recorded, m.
    angle_min_rad, angle_increment_rad, range_min_m, range_max_m : float
        The layout of the first scan.
    odom_stamp_ns : ndarray of int64
        Odometry header stamps, ns.
    odom_x_m, odom_y_m, odom_yaw_rad : ndarray of float64
        Odometry poses.
    """

    name: str
    topic: str
    odom_topic: str
    stamp_ns: NDArray[np.int64]
    ranges_m: NDArray[np.float64]
    angle_min_rad: float
    angle_increment_rad: float
    range_min_m: float
    range_max_m: float
    odom_stamp_ns: NDArray[np.int64]
    odom_x_m: NDArray[np.float64]
    odom_y_m: NDArray[np.float64]
    odom_yaw_rad: NDArray[np.float64]


def _pick(chans: list[Chan], type_name: str, explicit: str | None, name: str, flag: str) -> Chan:
    """The channel of ``type_name`` (the explicit topic, else the only non-empty one)."""
    if explicit is not None:
        found = [c for c in chans if c.topic == explicit and c.type == type_name]
        if not found:
            raise MissingTopicError(
                f"log file '{name}' has no {type_name} topic '{explicit}'; topics present: "
                f"{_listing(chans)}; pick one with {flag}"
            )
        return found[0]
    found = [c for c in chans if c.type == type_name and c.count > 0]
    preferred = [c for c in found if c.topic in ("/scan", "/odom")]
    if preferred:
        return preferred[0]
    if len(found) != 1:
        what = "no" if not found else "several"
        raise MissingTopicError(
            f"log file '{name}' has {what} non-empty {type_name} topics; topics present: "
            f"{_listing(chans)}; "
            + (f"pick one with {flag}" if found else "record the sensor or choose another log")
        )
    return found[0]


def _scan(buf: bytes, ros1: bool) -> tuple[int, tuple[float, ...], NDArray[np.float32]]:
    """Stamp (ns), the seven floats and the ranges of one LaserScan (ROS 1 or CDR)."""
    stamp, pos = message_header(buf, ros1=ros1)
    floats = _FLOATS.unpack_from(buf, pos)
    pos += 28
    (count,) = struct.unpack_from("<I", buf, pos)
    return stamp, floats, np.frombuffer(buf, "<f4", count, pos + 4)


def _decode_scans(
    parts: list[Segment], chan: Chan, name: str
) -> tuple[
    NDArray[np.int64], NDArray[np.int64], list[tuple[float, ...]], list[NDArray[np.float32]]
]:
    ros1 = chan.encoding == "ros1"
    if chan.encoding not in ("cdr", "ros1"):
        raise LogFormatError(
            f"topic '{chan.topic}' of log file '{name}' is encoded as '{chan.encoding}'; "
            "LaserScan is read from ROS 2 CDR or ROS 1 messages"
        )
    stamps, logs, heads, rows = [], [], [], []
    for seg in parts:
        for k, (o, n) in enumerate(
            zip(seg.payload_off.tolist(), seg.payload_len.tolist(), strict=True)
        ):
            try:
                stamp, floats, ranges = _scan(bytes(seg.buf[o : o + n]), ros1)
            except (struct.error, ValueError, IndexError) as exc:
                raise LogFormatError(
                    f"a message of topic '{chan.topic}' in log file '{name}' cannot be decoded "
                    f"as {LASER_SCAN} ({exc}); the file is corrupt or its schema is wrong"
                ) from None
            stamps.append(stamp)
            logs.append(int(seg.log_time_ns[k]))
            heads.append(floats)
            rows.append(ranges)
    return np.array(stamps, np.int64), np.array(logs, np.int64), heads, rows


def read_scans(
    path: str | Path, *, scan_topic: str | None = None, odom_topic: str | None = None
) -> LaserScans:
    """Read the LaserScan topic and the odometry poses of a log (MCAP, ROS 1 bag, rosbag2).

    The scan topic is ``scan_topic`` or else ``/scan`` or the only non-empty LaserScan topic;
    the odometry likewise (``/odom``). Scans are sorted by stamp.

    Raises
    ------
    MissingTopicError
        No LaserScan or Odometry topic (the message lists the topics present).
    LogValueError
        The beam count changes between scans.

    Examples
    --------
    >>> scans = read_scans("recording.mcap")  # doctest: +SKIP
    >>> scans.ranges_m.shape  # doctest: +SKIP
    (380, 360)
    """
    log = load_log(path, sort_times=False, keep_types=(LASER_SCAN,))
    chan = _pick(log.chans, LASER_SCAN, scan_topic, log.name, "--scan-topic")
    odom = _pick(log.chans, ODOMETRY, odom_topic, log.name, "--odom-topic")
    parts = [p for p in log.container.parts.get(chan.record.id, []) if isinstance(p, Segment)]
    stamps, logs, heads, rows = _decode_scans(parts, chan, log.name)
    counts = np.array([r.size for r in rows])
    bad = np.flatnonzero(counts != counts[0])
    if bad.size:
        raise LogValueError(
            f"topic '{chan.topic}' of log file '{log.name}' changes its beam count (scan 0 has "
            f"{counts[0]} beams, scan {bad[0]} has {counts[bad[0]]}); identify a sensor from "
            "scans of one layout (cut the log with `sim2real logs` tools or pick another topic)"
        )
    stamps = np.where(stamps > 0, stamps, logs)
    order = np.argsort(stamps, kind="stable")
    raw = decode_channel(log.container, odom, name=log.name, type_name=ODOMETRY)
    o_t = np.where(raw["stamp_ns"] > 0, raw["stamp_ns"], raw["log_ns"])
    o_order = np.argsort(o_t, kind="stable")
    amin, _amax, ainc, _ti, _st, rmin, rmax = heads[0]
    return LaserScans(
        name=log.name,
        topic=chan.topic,
        odom_topic=odom.topic,
        stamp_ns=stamps[order],
        ranges_m=np.vstack(rows).astype(np.float64)[order],
        angle_min_rad=float(amin),
        angle_increment_rad=float(ainc),
        range_min_m=float(rmin),
        range_max_m=float(rmax),
        odom_stamp_ns=o_t[o_order],
        odom_x_m=raw["x"][o_order].astype(np.float64),
        odom_y_m=raw["y"][o_order].astype(np.float64),
        odom_yaw_rad=raw["yaw"][o_order].astype(np.float64),
    )
