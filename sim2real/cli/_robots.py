"""`sim2real robots`: list the shipped specs, show one, write a new one, check one."""

from __future__ import annotations

import argparse
import importlib.util
import math
import tempfile
from pathlib import Path

import yaml

from robots.check import check_spec
from robots.errors import SpecError
from robots.mjcf import mjcf_mapping, mjcf_text
from robots.params import load_drive_params
from robots.spec import RobotSpec, list_robots, load_spec
from robots.template import spec_text
from sim2real._io import atomic_write
from sim2real.errors import Sim2RealValueError
from sim2real.mujoco import INSTALL_HINT, check_drive

__all__ = ["handle_check", "handle_export", "handle_list", "handle_new", "handle_show"]


def handle_export(args: argparse.Namespace) -> int:
    """``robots export ROBOT -o robot.xml``: the MJCF model with the identified drive."""
    spec = load_spec(args.robot)
    params = (
        spec.drive
        if args.params is None
        else load_drive_params(args.params, robot=spec.name, base=spec.drive)
    )
    out = Path(args.out)
    if out.suffix != ".xml":
        raise Sim2RealValueError(f"-o {out}: an MJCF model must end in .xml; e.g. -o robot.xml")
    text = mjcf_text(spec, params)
    checked = ""
    if importlib.util.find_spec("mujoco") is not None:
        report = check_drive(spec, params, xml=text)
        checked = f", loaded in MuJoCo and drive-checked ({report})"
    with atomic_write(out, "w", what="MJCF model") as fh:
        fh.write(text)
    entries = mjcf_mapping(spec, params)
    in_mjcf = sum(e.mjcf is not None for e in entries)
    print(
        f"wrote {out}: robot '{spec.name}', {in_mjcf} drive values in the MJCF, "
        f"{len(entries) - in_mjcf} for sim2real.mujoco.MujocoDrive{checked}"
    )
    if not checked:
        print(f"note: not loaded in MuJoCo (not installed); {INSTALL_HINT} to check it")
    return 0


def handle_new(args: argparse.Namespace) -> int:
    """``robots new NAME``: write a checked spec from a few published numbers."""
    text = spec_text(
        args.name,
        wheel_separation_m=args.wheel_separation,
        wheel_radius_m=args.wheel_radius,
        mass_kg=args.mass,
        max_speed_mps=args.max_speed,
        max_turn_rate_radps=args.max_turn_rate,
        footprint_radius_m=args.footprint_radius,
        drive=args.drive,
        driver_track_factor=args.driver_track_factor,
        track_factor=args.track_factor,
        wheel_cap=args.wheel_cap,
        new_move=args.command_starts_new_move,
    )
    out = Path(args.out or f"{args.name}.yaml")
    if out.suffix not in (".yaml", ".yml"):
        raise Sim2RealValueError(
            f"-o {out}: a spec file must end in .yaml; e.g. -o {args.name}.yaml"
        )
    if out.exists() and not args.force:
        raise Sim2RealValueError(
            f"-o {out}: the file exists; pass --force to overwrite it or pick another name"
        )
    with tempfile.TemporaryDirectory() as tmp:
        probe = Path(tmp) / out.name
        probe.write_text(text, encoding="utf-8")
        report = check_spec(load_spec(probe))
    if not report.passed:  # the rules should never produce this; refuse rather than write it
        raise SpecError(report.reason().replace(str(probe), str(out)))
    with atomic_write(out, "w", what="spec file") as fh:
        fh.write(text)
    print(f"wrote {out}: robot '{args.name}', checks passed ({len(report.items)})")
    if args.drive == "skid":
        print(
            "note: skid steer: track_factor (effective / geometric track, prior 1.6) is fitted "
            "by 'sysid fit'; set driver_track_factor to your driver's "
            "wheel_separation_multiplier (Husky: 1.875, Jackal: 1.5)"
        )
    print(f"use it with --robot {out}; edit any number you know better, then `robots check {out}`")
    return 0


def handle_check(args: argparse.Namespace) -> int:
    """``robots check SPEC``: print each check; exit 2 when one fails."""
    report = check_spec(load_spec(args.spec), drive_test=not args.no_drive)
    for item in report.items:
        print(f"{'ok  ' if item.passed else 'FAIL'}  {item.name}: {item.detail}")
    if not report.passed:
        raise SpecError(report.reason())
    print(f"{report.robot}: all {len(report.items)} checks passed")
    return 0


def _sensors(spec: RobotSpec) -> str:
    lid = spec.lidar
    text = f"lidar {lid.beams}x {lid.range_min_m:g}-{lid.range_max_m:g} m"
    cam = spec.depth_camera
    if cam is not None:
        text += f", depth {cam.width}x{cam.height} {cam.hfov_deg:g} deg"
    return text


def handle_list(args: argparse.Namespace) -> int:
    """``robots list``: one line per shipped robot."""
    specs = [load_spec(name) for name in list_robots()]
    head = ("name", "mass_kg", "wheel_r_m", "track_m", "max_v_mps", "max_w_radps", "sensors")
    rows = [
        (
            s.name,
            f"{s.rigid_mass_kg:.3f}",
            f"{s.wheels.radius_m:.3f}",
            f"{s.wheels.separation_m:.3f}",
            f"{s.max_v_mps:.2f}",
            f"{s.max_w_radps:.2f}",
            _sensors(s),
        )
        for s in specs
    ]
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]
    for row in [head, *rows]:
        print("  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip())
    return 0


def _sensor_lines(spec: RobotSpec) -> list[str]:
    lid, cam = spec.lidar, spec.depth_camera
    lines = [
        f"lidar:          {lid.beams} beams {lid.angle_min_rad:.4f}..{lid.angle_max_rad:.4f} rad, "
        f"{lid.range_min_m:g}-{lid.range_max_m:g} m, {lid.rate_hz:g} Hz, at {list(lid.xyz_m)} m",
    ]
    if cam is None:
        lines.append("depth camera:   none")
    else:
        lines.append(
            f"depth camera:   {cam.width}x{cam.height}, hfov {cam.hfov_deg:g} deg, "
            f"{cam.near_m:g}-{cam.far_m:g} m, {cam.rate_hz:g} Hz, at {list(cam.xyz_m)} m "
            f"rpy {list(cam.rpy_rad)} rad"
        )
    return lines


def _num(x: float) -> str:
    return "inf" if math.isinf(x) else f"{x:.6g}"


def handle_show(args: argparse.Namespace) -> int:
    """``robots show NAME``: the full spec, or the spec file with ``--yaml``."""
    spec = load_spec(args.name)
    if args.yaml:
        print(yaml.safe_dump(spec.to_dict(), sort_keys=False, width=100), end="")
        return 0
    g = spec.geometry
    lines = [
        f"{spec.name}: {spec.description}",
        f"spec file:      {spec.path}",
        f"rigid mass:     {spec.rigid_mass_kg:.4f} kg (base link {spec.base_mass_kg:.4f} kg)",
        f"model geometry: effective mass {g.mass_kg:.4f} kg, yaw inertia "
        f"{g.yaw_inertia_kgm2:.5g} kg m^2, wheel radius {g.wheel_radius_m:g} m, "
        f"separation {g.wheel_separation_m:g} m",
        f"body:           {spec.body.shape} {list(spec.body.size_m)} m at {list(spec.body.xyz_m)}",
        f"casters:        {[list(c.xyz_m) for c in spec.casters]}",
        f"speed caps:     {spec.max_v_mps:g} m/s, {spec.max_w_radps:g} rad/s",
        *_sensor_lines(spec),
        f"odometry:       v from {spec.odometry.v_source}, w from {spec.odometry.w_source}, "
        f"{spec.odometry.rate_hz:g} Hz",
        "drive defaults:",
    ]
    lines += [f"  {k:<26} {_num(v)}" for k, v in spec.drive.to_dict().items()]
    lines.append("sources:")
    lines += [f"  {src}" for src in spec.sources]
    print("\n".join(lines))
    return 0
