"""Identify a robot's lidar from log files: the one path behind ``sim2real sysid sensors``.

:func:`identify_sensor` reads each log's LaserScan topic and odometry poses
(:func:`sim2real.logs.read_scans`), puts both on seconds since the log's first scan, takes the
lidar's mount position from the robot spec and calls :func:`sysid.sensors.estimate_sensor`;
where a log has a depth image topic (:func:`sim2real.logs.read_depth`), the camera's noise
from its still frames (:func:`sysid.sensors.estimate_depth`) is the result's ``depth``.

Examples
--------
>>> from sim2real.sensor_id import identify_sensor
>>> est = identify_sensor(["run.mcap"], robot="neato.yaml")  # doctest: +SKIP
>>> est.save("sensors.yaml")  # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

from robots.spec import load_spec
from robots.units import seconds
from sim2real.logs import DepthImages, LaserScans, read_depth, read_scans
from sysid.sensors import (
    DepthEstimate,
    PoseArrays,
    ScanArrays,
    SensorEstimate,
    estimate_depth,
    estimate_sensor,
)

__all__ = ["identify_depth", "identify_sensor", "read_sensor_logs", "scan_arrays"]


def scan_arrays(scans: LaserScans) -> tuple[ScanArrays, PoseArrays]:
    """The scans and odometry of one log as the estimator takes them (s since the first scan)."""
    t0 = int(scans.stamp_ns[0])
    return (
        ScanArrays(
            t_s=seconds(scans.stamp_ns - t0),
            ranges_m=scans.ranges_m,
            angle_min_rad=scans.angle_min_rad,
            angle_increment_rad=scans.angle_increment_rad,
            range_min_m=scans.range_min_m,
            range_max_m=scans.range_max_m,
        ),
        PoseArrays(
            t_s=seconds(scans.odom_stamp_ns - t0),
            x_m=scans.odom_x_m,
            y_m=scans.odom_y_m,
            yaw_rad=scans.odom_yaw_rad,
        ),
    )


def read_sensor_logs(
    paths: Sequence[str | Path], *, scan_topic: str | None = None, odom_topic: str | None = None
) -> tuple[list[ScanArrays], list[PoseArrays]]:
    """The scans and odometry of each log, as the estimator takes them."""
    scans, odoms = [], []
    for path in paths:
        s, o = scan_arrays(read_scans(path, scan_topic=scan_topic, odom_topic=odom_topic))
        scans.append(s)
        odoms.append(o)
    return scans, odoms


def identify_sensor(
    paths: Sequence[str | Path],
    *,
    robot: str | Path,
    scan_topic: str | None = None,
    odom_topic: str | None = None,
    depth_topic: str | None = None,
    n_boot: int = 200,
    seed: int = 0,
    logs: tuple[list[ScanArrays], list[PoseArrays]] | None = None,
) -> SensorEstimate:
    """Identify the lidar of ``robot`` from one or more logs of it.

    Parameters
    ----------
    paths : sequence of path
        MCAP files, ROS 1 bags or rosbag2 folders with a LaserScan topic and odometry.
    robot : str or Path
        Robot spec name or file (its lidar mount position is used).
    scan_topic, odom_topic : str, optional
        Topics to read (default: ``/scan`` / ``/odom`` or the only one of the type).
    depth_topic : str, optional
        The depth Image topic (default: the only one with a depth encoding, if any); the
        first log with depth images gives :attr:`SensorEstimate.depth`.
    n_boot, seed : int
        Bootstrap resamples and their seed.
    logs : tuple, optional
        The logs already read by :func:`read_sensor_logs` (``paths`` then name them and are
        read for depth images only).

    Returns
    -------
    SensorEstimate
    """
    spec = load_spec(robot)
    mount = (float(spec.lidar.xyz_m[0]), float(spec.lidar.xyz_m[1]))
    scans, odoms = (
        logs
        if logs is not None
        else read_sensor_logs(paths, scan_topic=scan_topic, odom_topic=odom_topic)
    )
    names = [str(p) for p in paths]
    est = estimate_sensor(scans, odoms, mount_xy_m=mount, names=names, n_boot=n_boot, seed=seed)
    for path in paths:
        depth = read_depth(path, depth_topic=depth_topic)
        if depth is not None:
            found = identify_depth(path, depth, odom_topic=odom_topic, n_boot=n_boot, seed=seed)
            if found is None:
                note = (
                    f"depth: the depth images of '{depth.topic}' in '{path}' have no still "
                    "stretch of 5 frames, so the depth camera's noise is not identified"
                )
                return dataclasses.replace(est, unidentified=(*est.unidentified, note))
            return dataclasses.replace(est, depth=found)
    return est


def identify_depth(
    path: str | Path,
    depth: DepthImages,
    *,
    odom_topic: str | None = None,
    n_boot: int = 200,
    seed: int = 0,
) -> DepthEstimate | None:
    """Identify the depth camera of one log from its depth images and odometry (None
    without a still stretch)."""
    scans = read_scans(path, odom_topic=odom_topic)
    t0 = int(scans.stamp_ns[0])
    _, odom = scan_arrays(scans)
    source = (depth.topic, depth.encoding, depth.size_px)
    t_s = seconds(depth.stamp_ns - t0)
    return estimate_depth(t_s, depth.depth_m, odom, source=source, n_boot=n_boot, seed=seed)
