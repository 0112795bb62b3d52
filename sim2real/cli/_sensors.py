"""`sim2real sysid sensors`: identify a lidar from recordings and print the estimate."""

from __future__ import annotations

import argparse
import math

from sim2real.errors import Sim2RealValueError
from sim2real.sensor_id import identify_sensor, read_sensor_logs
from sim2real.sensor_report import write_sensor_report
from sysid.sensors import SensorEstimate

__all__ = ["handle_sensors", "summary_lines"]


def handle_sensors(args: argparse.Namespace) -> int:
    """``sysid sensors LOG [LOG ...] --robot ROBOT -o sensors.yaml``."""
    if args.bootstrap < 20:
        raise Sim2RealValueError(
            f"--bootstrap is {args.bootstrap}, but 95 % intervals need at least 20 resamples; "
            "pass --bootstrap 200"
        )
    logs = read_sensor_logs(args.logs, scan_topic=args.scan_topic, odom_topic=args.odom_topic)
    topics = {"odom_topic": args.odom_topic, "depth_topic": args.depth_topic}
    boot = {"n_boot": args.bootstrap, "seed": args.seed}
    est = identify_sensor(args.logs, robot=args.robot, logs=logs, **topics, **boot)
    est.save(args.output)
    print("\n".join(summary_lines(est)))
    print(f"wrote {args.output}")
    if args.report:
        write_sensor_report(args.report, est, *logs)
        print(f"wrote {args.report}")
    return 0


_SOURCES = {
    "still": "still stretches",
    "moving": "matched moving scans",
    "none": "not identified",
}


def _ci(lo: float, hi: float, scale: float = 1.0, fmt: str = ".3g") -> str:
    if math.isnan(lo):
        return "-"
    return f"[{lo * scale:{fmt}}, {hi * scale:{fmt}}]"


def summary_lines(est: SensorEstimate) -> list[str]:
    """The estimate as lines of text (95 % intervals in brackets)."""
    lines = [
        f"lidar: {est.beams} beams from {math.degrees(est.angle_min_rad):.1f} deg every "
        f"{math.degrees(est.angle_increment_rad):.3f} deg, {est.range_min_m:g}-"
        f"{est.range_max_m:g} m, {est.scan_rate_hz:.2f} Hz; {est.still_scans} still scans, "
        f"{est.matched_pairs} matched scan pairs",
        f"range noise std ({_SOURCES.get(est.noise_source, est.noise_source)}) = "
        f"{est.noise_std_0_m * 1e3:.2f} mm "
        f"{_ci(*est.noise_std_0_ci, 1e3)} + {est.noise_std_per_m * 1e3:.2f} mm/m "
        f"{_ci(*est.noise_std_per_m_ci, 1e3)} x range + {est.noise_std_per_m2 * 1e3:.2f} mm/m2 "
        f"{_ci(*est.noise_std_per_m2_ci, 1e3)} x range^2",
    ]
    moving = est.moving_noise_std_m or (math.nan,) * len(est.noise_range_m)
    m_lo = est.moving_noise_std_lo_m or moving
    m_hi = est.moving_noise_std_hi_m or moving
    for r, s, lo, hi, d, m, mlo, mhi in zip(
        est.noise_range_m,
        est.noise_std_m,
        est.noise_std_lo_m,
        est.noise_std_hi_m,
        est.dropout_by_range,
        moving,
        m_lo,
        m_hi,
        strict=True,
    ):
        if not math.isnan(r):
            check = (
                ""
                if math.isnan(m) or est.noise_source != "still"
                else f", moving scans {m * 1e3:.2f} mm {_ci(mlo, mhi, 1e3)}"
            )
            lines.append(
                f"  at {r:.2f} m: std {s * 1e3:.2f} mm {_ci(lo, hi, 1e3)}{check}, invalid {d:.1%}"
            )
    lines += [
        f"invalid returns (beams on a surface): {est.dropout:.2%} "
        f"{_ci(*est.dropout_ci, 100, '.2f')} %",
        f"spurious short returns: {est.spurious_short:.3%} "
        f"{_ci(*est.spurious_short_ci, 100, '.3f')} %",
        f"scan time offset (add to stamps): {est.time_offset_s * 1e3:.1f} ms "
        f"{_ci(*est.time_offset_ci, 1e3, '.1f')}, odometry yaw scale {est.yaw_scale:.3f}",
        f"mounting yaw: {math.degrees(est.mounting_yaw_rad):.2f} deg "
        f"{_ci(*est.mounting_yaw_ci, 180 / math.pi, '.2f')}",
    ]
    if est.depth is not None:
        d = est.depth
        lines.append(
            f"depth camera {d.topic} ({d.size_px[0]} x {d.size_px[1]} {d.encoding}, "
            f"{d.pixels} pixels, "
            f"{d.still_frames} still frames): noise std = {d.noise_std_0_m * 1e3:.2f} mm "
            f"{_ci(*d.noise_std_0_ci, 1e3)} + {d.noise_std_per_m * 1e3:.2f} mm/m "
            f"{_ci(*d.noise_std_per_m_ci, 1e3)} x depth + {d.noise_std_per_m2 * 1e3:.2f} mm/m2 "
            f"{_ci(*d.noise_std_per_m2_ci, 1e3)} x depth^2; invalid pixels {d.dropout:.2%} "
            f"{_ci(*d.dropout_ci, 100, '.2f')} %"
        )
    lines += [f"not identified: {note}" for note in est.unidentified]
    return lines
