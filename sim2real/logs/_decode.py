"""Decode the messages of one channel into arrays (private).

CDR messages of the fixed-layout types go through the numpy bulk decoders of
:mod:`sim2real.logs._cdr`; every other case (big-endian CDR, ``JointState``) goes through
mcap-ros2-support's generic decoder, and JSON messages through :func:`json.loads`. ROS 1
payloads (from ``.bag`` files) take the bulk decoders of :mod:`sim2real.logs._ros1` or
rosbags' ROS 1 deserialiser. All paths
return the same keys: ``log_ns``, ``v``, ``w``, plus ``stamp_ns`` for stamped types, pose
fields ``x``, ``y``, ``yaw`` for Odometry (the quaternion becomes the yaw per chunk), and ``left``/``right`` wheel
speeds (rad/s) for JointState.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from robots.units import NS_PER_S
from sim2real.errors import LogFormatError, LogValueError
from sim2real.logs import _cdr
from sim2real.logs._accum import BULK_CDR, with_yaw
from sim2real.logs._channels import Chan
from sim2real.logs._mcap import Columns, Container, Segment
from sim2real.logs._ros1 import BULK_ROS1
from sim2real.logs._schemas import JOINT_STATE, ODOMETRY, TWIST, TWIST_STAMPED

__all__ = ["decode_channel", "infer_json_type"]


def decode_channel(
    container: Container,
    chan: Chan,
    *,
    name: str,
    type_name: str,
    wheel_joints: tuple[str, str] | None = None,
    release: bool = False,
) -> dict[str, np.ndarray]:
    """All messages of ``chan`` as arrays (in file order, not yet sorted).

    The container's sink (:func:`sim2real.logs._accum.add_segment`) decoded the fixed-layout
    types while the file streamed past; kept payloads are decoded here. ``release`` drops
    the channel's parts from the container as they are joined (memory: one copy, not two).
    """
    cid = chan.record.id
    if cid in container.failed:
        raise LogFormatError(container.failed[cid])
    items = container.parts.pop(cid, []) if release else container.parts.get(cid, [])
    parts: list[dict[str, np.ndarray]] = []
    for item in items:
        if isinstance(item, Columns):
            parts.append(item.take())
            continue
        try:
            part = _decode_part(
                item, item.payload_off, item.payload_len, chan, type_name, wheel_joints
            )
        except _cdr.CdrLayoutError as exc:
            raise LogFormatError(
                f"message {exc.index} of topic '{chan.topic}' in log file '{name}' does not "
                f"fit the {type_name} layout (it {exc.reason}); the file is corrupt or its "
                "schema is wrong"
            ) from None
        except _BadMessage as exc:
            raise LogFormatError(
                f"a message of topic '{chan.topic}' in log file '{name}' cannot be decoded as "
                f"{type_name} ({exc}); the file is corrupt or its schema is wrong"
            ) from None
        part = with_yaw(part)
        part["log_ns"] = item.log_time_ns
        parts.append(part)
    del items
    return _joined(parts, release=release)


def _joined(parts: list[dict[str, np.ndarray]], *, release: bool) -> dict[str, np.ndarray]:
    """The parts joined field by field (``release``: each field's pieces dropped once joined)."""
    if not parts:
        return {"log_ns": np.zeros(0, np.int64)}
    if len(parts) == 1:
        return dict(parts[0])
    out = {}
    for key in list(parts[0]):
        out[key] = np.concatenate([p.pop(key) if release else p[key] for p in parts])
    return out


class _BadMessage(Exception):
    """Internal: one message failed generic decoding."""


def _decode_part(
    seg: Segment,
    off: np.ndarray,
    ln: np.ndarray,
    chan: Chan,
    type_name: str,
    wheel_joints: tuple[str, str] | None,
) -> dict[str, np.ndarray]:
    if chan.encoding == "cdr":
        u8 = seg.u8
        if type_name in BULK_CDR and _cdr.is_little_endian(u8, off, ln):
            return BULK_CDR[type_name](u8, off, ln)
        decode = _generic_cdr(chan)
    elif chan.encoding == "ros1":  # ROS 1 bags (sim2real.logs._bags)
        if type_name in BULK_ROS1:
            return BULK_ROS1[type_name](seg.u8, off, ln)
        decode = _generic_ros1(type_name)
    elif chan.encoding == "json":
        decode = _json_loads
    else:
        raise _BadMessage(f"message encoding '{chan.encoding}' is neither cdr, ros1 nor json")
    msgs = []
    for o, n in zip(off.tolist(), ln.tolist(), strict=True):
        try:
            msgs.append(decode(bytes(seg.buf[o : o + n])))
        except Exception as exc:  # third-party decoders raise many types on corrupt bytes
            raise _BadMessage(f"{type(exc).__name__}: {exc}") from None
    return _fields(msgs, type_name, wheel_joints, topic=chan.topic)


def _generic_cdr(chan: Chan) -> Callable[[bytes], Any]:
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory

    schema = chan.schema
    if schema is None or schema.encoding != "ros2msg":
        raise _BadMessage("CDR messages need a ros2msg schema")
    rec = Schema(id=schema.id, name=schema.name, encoding=schema.encoding, data=schema.data)
    try:
        decoder = DecoderFactory().decoder_for("cdr", rec)
    except Exception as exc:  # schema text that mcap_ros2 cannot parse
        raise _BadMessage(f"schema parse failed: {exc}") from None
    if decoder is None:
        raise _BadMessage("no decoder for this schema")
    return decoder


def _generic_ros1(type_name: str) -> Callable[[bytes], Any]:
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    if type_name not in store.types:
        raise _BadMessage(f"type '{type_name}' is not a standard ROS 1 message")
    return lambda raw: store.deserialize_ros1(raw, type_name)


def _json_loads(raw: bytes) -> Any:
    import json  # JSON logs only: not on the CDR read path

    return json.loads(raw)


def _get(obj: Any, *path: str) -> Any:
    for key in path:
        obj = obj[key] if isinstance(obj, dict) else getattr(obj, key)
    return obj


def _stamp(obj: Any) -> int:
    stamp = _get(obj, "header", "stamp")
    if isinstance(stamp, dict):
        sec = stamp.get("sec", stamp.get("secs"))
        nsec = stamp.get("nanosec", stamp.get("nsec", stamp.get("nsecs")))
        if sec is None or nsec is None:
            raise KeyError("header.stamp.sec/nanosec")
        return int(sec) * NS_PER_S + int(nsec)
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def _floats(msgs: Sequence[Any], *path: str) -> np.ndarray:
    return np.array([float(_get(m, *path)) for m in msgs], dtype=np.float64)


def _fields(
    msgs: Sequence[Any], type_name: str, wheel_joints: tuple[str, str] | None, *, topic: str
) -> dict[str, np.ndarray]:
    try:
        if type_name == TWIST:
            return {"v": _floats(msgs, "linear", "x"), "w": _floats(msgs, "angular", "z")}
        stamps = np.array([_stamp(m) for m in msgs], dtype=np.int64)
        if type_name == TWIST_STAMPED:
            return {
                "stamp_ns": stamps,
                "v": _floats(msgs, "twist", "linear", "x"),
                "w": _floats(msgs, "twist", "angular", "z"),
            }
        if type_name == ODOMETRY:
            out = {
                "stamp_ns": stamps,
                "v": _floats(msgs, "twist", "twist", "linear", "x"),
                "w": _floats(msgs, "twist", "twist", "angular", "z"),
            }
            for key, leaf in zip(_cdr.POSE_KEYS, ("x", "y", "x", "y", "z", "w"), strict=True):
                part = "position" if key in ("x", "y") else "orientation"
                out[key] = _floats(msgs, "pose", "pose", part, leaf)
            return out
        if type_name == JOINT_STATE:
            left, right = _wheel_speeds(msgs, wheel_joints, topic)
            return {"stamp_ns": stamps, "left": left, "right": right}
    except LogValueError:
        raise
    except (KeyError, AttributeError, TypeError, ValueError, OverflowError) as exc:
        raise _BadMessage(f"missing or non-numeric field: {exc}") from None
    raise _BadMessage(f"type '{type_name}' is not supported")


def _pick_joint(names: Sequence[str], side: str) -> str | None:
    hits = [n for n in names if side in n.lower()]
    wheels = [n for n in hits if "wheel" in n.lower()]
    for group in (wheels, hits):
        if len(group) == 1:
            return group[0]
    return None


def _wheel_speeds(
    msgs: Sequence[Any], wheel_joints: tuple[str, str] | None, topic: str
) -> tuple[np.ndarray, np.ndarray]:
    left = np.empty(len(msgs))
    right = np.empty(len(msgs))
    for i, m in enumerate(msgs):
        names = [str(n) for n in _get(m, "name")]
        vel = [float(x) for x in _get(m, "velocity")]
        lname, rname = wheel_joints or (_pick_joint(names, "left"), _pick_joint(names, "right"))
        if lname in names and rname in names and len(vel) != len(names):
            raise LogValueError(
                f"JointState message {i} of topic '{topic}' has joints {names} but "
                f"{len(vel)} velocities (one per joint is needed), so the wheel speeds "
                f"({lname}, {rname}) cannot be read; record the joint velocities, or choose "
                "the base's Odometry topic with --odom-topic"
            )
        if lname not in names or rname not in names or len(vel) != len(names):
            raise LogValueError(
                f"JointState message {i} of topic '{topic}' has joints {names} with "
                f"{len(vel)} velocities, so the left/right wheel speeds ({lname}, {rname}) "
                "cannot be read (no one joint's name holds 'left' and one 'right'); if it holds "
                "no wheels, choose the base's Odometry topic with --odom-topic, else name the "
                "wheel joints (Python: read_trace(..., wheel_joints=(left, right)))"
            )
        left[i], right[i] = vel[names.index(lname)], vel[names.index(rname)]
    return left, right


def infer_json_type(raw: bytes) -> str:
    """Guess the ROS type of a schema-less JSON message from its keys ("" when unknown)."""
    try:
        obj = _json_loads(raw)
    except ValueError:
        return ""
    if not isinstance(obj, dict):
        return ""
    keys = set(obj)
    if {"header", "pose", "twist"} <= keys:
        return ODOMETRY
    if {"header", "twist"} <= keys:
        return TWIST_STAMPED
    if {"linear", "angular"} <= keys:
        return TWIST
    if {"name", "velocity"} <= keys:
        return JOINT_STATE
    return ""
