"""Structured-bad velocity logs for the hostile-input tests, written as real ROS 2 MCAP files.

Each fault is one kind of damage seen in real recordings (a flipped byte in one stamp, a
recording paused for a year, a clock offset, an absurd value, a file without CRCs, a cut
file, a message whose channel does not exist); :func:`write_faulty` applies a list of them to
a clean synthetic log of a TurtleBot3 Burger (the project's own writer, or the ``mcap``
library's writer for the container-level faults).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robots.params import DriveParams
from robots.spec import load_spec
from sim2real.logs import ODOMETRY, SCHEMA_TEXT, TWIST, _cdr, write_velocity_log
from sysid.synthetic import step_commands, synthetic_log

__all__ = [
    "ROBOT",
    "Fault",
    "base_arrays",
    "figures_finite",
    "read_json",
    "truth",
    "write_faulty",
]

ROBOT = "turtlebot3_burger"
T0_NS = 1_000_000_000 * 10**9  # 2001: ten-year faults stay inside builtin_interfaces/Time
YEAR_NS = 365 * 86_400 * 10**9


def truth() -> DriveParams:
    """The drive parameters of the base that :func:`base_arrays` records."""
    return load_spec(ROBOT).drive.replace(delay_s=0.1)


def base_arrays(duration_s: float = 12.0, seed: int = 1) -> dict[str, np.ndarray]:
    """A clean log: random step commands at 10 Hz, realistic odometry at 30 Hz."""
    spec = load_spec(ROBOT)
    t, v, w = step_commands(duration_s, seed=seed, v_max_mps=0.2, w_max_radps=1.5)
    log = synthetic_log(
        truth(),
        spec.geometry,
        cmd_t_s=t,
        cmd_v=v,
        cmd_w=w,
        seed=seed,
        odom_rate_hz=30.0,
        spike_mps=None,
    )
    return {
        "cmd_t_ns": T0_NS + np.round(log.cmd_t_s * 1e9).astype(np.int64),
        "cmd_v": np.array(log.cmd_v),
        "cmd_w": np.array(log.cmd_w),
        "meas_t_ns": T0_NS + np.round(log.meas_t_s * 1e9).astype(np.int64),
        "meas_v": np.array(log.meas_v),
        "meas_w": np.array(log.meas_w),
    }


@dataclass(frozen=True)
class Fault:
    """One fault: ``kind`` and its parameters (``at`` is a fraction of the samples)."""

    kind: str
    at: float = 0.5
    size: float = 1.0
    extra: dict[str, Any] = field(default_factory=dict)


def _i(n: int, at: float) -> int:
    return min(max(int(at * n), 0), n - 1)


def _apply(a: dict[str, np.ndarray], f: Fault, log_t: dict[str, np.ndarray]) -> None:
    n = a["meas_t_ns"].size
    i = _i(n, f.at)
    if f.kind == "stamp_outlier":  # a flipped byte: one header stamp up to 10 years away
        a["meas_t_ns"][i] += int(min(f.size, 1.0) * 10 * YEAR_NS)
    elif f.kind == "gap":  # the robot was off for a while (f.size: fraction of a year)
        cut = a["meas_t_ns"][i]
        shift = max(int(min(f.size, 1.0) * YEAR_NS), 5 * 10**9)
        for key in ("meas_t_ns", "cmd_t_ns"):
            a[key][a[key] >= cut] += shift
            log_t[key][log_t[key] >= cut] += shift
    elif f.kind == "backwards":  # a block of stamps reversed
        k = max(2, int(f.size * 10))
        a["meas_t_ns"][i : i + k] = a["meas_t_ns"][i : i + k][::-1].copy()
    elif f.kind == "duplicate":  # repeated stamps
        k = max(1, int(f.size * 10))
        a["meas_t_ns"][i + 1 : i + 1 + k] = a["meas_t_ns"][i]
    elif f.kind in ("nan", "inf", "absurd"):
        value = {"nan": np.nan, "inf": np.inf, "absurd": 4.5e306}[f.kind]
        key = f.extra.get("key", "meas_v")
        k = max(1, int(f.size * 3))
        m = a[key].size
        a[key][_i(m, f.at) : _i(m, f.at) + k] = value
    elif f.kind == "clock_offset":  # odometry stamped by another clock
        a["meas_t_ns"] += int(f.size * 15 * 10**9)
    elif f.kind == "cmd_outlier":  # one command stamped years away
        a["cmd_t_ns"][_i(a["cmd_t_ns"].size, f.at)] -= int(min(f.size, 1.0) * 10 * YEAR_NS)
    else:  # container-level faults are applied by write_faulty
        return


def write_faulty(path: Path, faults: list[Fault], base: dict[str, np.ndarray]) -> Path:
    """Write ``base`` with ``faults`` applied to ``path`` (a real MCAP file)."""
    a = {k: v.copy() for k, v in base.items()}
    log_t = {"meas_t_ns": base["meas_t_ns"].copy(), "cmd_t_ns": base["cmd_t_ns"].copy()}
    for f in faults:
        _apply(a, f, log_t)
    kinds = {f.kind for f in faults}
    if "no_crc" in kinds or "unknown_channel" in kinds:
        _write_raw(path, a, log_t, unknown_channel="unknown_channel" in kinds)
    else:
        write_velocity_log(path, **a, meas_log_t_ns=log_t["meas_t_ns"])
    for f in faults:
        if f.kind == "truncate":  # the recorder was killed mid-write
            data = path.read_bytes()
            path.write_bytes(data[: max(64, int(len(data) * min(max(f.at, 0.05), 0.98)))])
    return path


def _write_raw(
    path: Path, a: dict[str, np.ndarray], log_t: dict[str, np.ndarray], *, unknown_channel: bool
) -> None:
    """What rosbags and several recorders write: uncompressed chunks, no CRCs at all.

    With ``unknown_channel`` one extra message names channel id 99, which no Channel record
    defines.
    """
    from mcap.writer import CompressionType, Writer

    with path.open("wb") as fh:
        w = Writer(fh, compression=CompressionType.NONE, enable_crcs=False, chunk_size=4000)
        w.start(profile="ros2", library="hostile-logs")
        tw = w.register_schema(TWIST, "ros2msg", SCHEMA_TEXT[TWIST].encode())
        od = w.register_schema(ODOMETRY, "ros2msg", SCHEMA_TEXT[ODOMETRY].encode())
        cmd = w.register_channel("/cmd_vel", "cdr", tw)
        odo = w.register_channel("/odom", "cdr", od)
        for t, p in zip(
            log_t["cmd_t_ns"].tolist(), _cdr.encode_twist(a["cmd_v"], a["cmd_w"]), strict=True
        ):
            w.add_message(cmd, log_time=t, data=p, publish_time=t)
        x = np.zeros(a["meas_v"].size)
        odoms = _cdr.encode_odometry(
            a["meas_t_ns"],
            a["meas_v"],
            a["meas_w"],
            x=x,
            y=x,
            yaw=x,
            frame_id="odom",
            child_frame_id="base_link",
        )
        for k, (t, p) in enumerate(zip(log_t["meas_t_ns"].tolist(), odoms, strict=True)):
            w.add_message(odo, log_time=t, data=p, publish_time=t)
            if unknown_channel and k == len(odoms) // 2:
                w.add_message(99, log_time=t, data=p, publish_time=t)
        w.finish()


def figures_finite(figures: dict[str, Any]) -> list[str]:
    """Keys of the agree JSON whose documented number is missing or not finite."""
    provenance = {"params_file", "log_file", "log_sha256", "robot", "notes"}  # notes: sentences
    bad = []
    for key, value in figures.items():
        if key in provenance:
            continue
        if not isinstance(value, int | float) or not np.isfinite(value):
            bad.append(key)
    return bad


def read_json(path: Path) -> dict[str, Any]:
    """The JSON at ``path`` (parsed strictly: NaN/Infinity tokens are an error)."""

    def refuse(token: str) -> float:
        raise ValueError(f"non-standard JSON number {token}")

    return json.loads(path.read_text(), parse_constant=refuse)  # type: ignore[no-any-return]
