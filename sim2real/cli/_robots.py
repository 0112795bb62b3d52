"""`sim2real robots` commands: list the shipped specs, show one, write a new one, check one."""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from sim2real.cli._common import add_command

if TYPE_CHECKING:
    from robots.spec import RobotSpec

__all__ = ["register"]

_GROUP_EXAMPLES = """\
  sim2real robots list                              # name, mass, wheels, speed caps, sensors
  sim2real robots show turtlebot3_burger            # the full spec with drive defaults, sources
  sim2real robots show turtlebot2 --yaml > tb2.yaml # as a spec file (edit, then load it by path)
  sim2real robots new neato --wheel-separation 0.248 --max-speed 0.3 -o neato.yaml
  sim2real robots check neato.yaml                  # geometry + 1 s pybullet drive test
"""
_NEW_EXAMPLES = """\
  sim2real robots new neato --wheel-separation 0.248 --max-speed 0.3 -o neato.yaml
  sim2real robots new husky --wheel-separation 0.555 --wheel-radius 0.165 --mass 50 \\
      --max-speed 1.0 --drive skid -o husky.yaml
  sim2real robots new husky_diff --wheel-separation 0.555 --wheel-radius 0.165 \\
      --driver-track-factor 1.875 -o husky_diff.yaml    # diff model, the driver's multiplier
  sim2real sysid fit run.bag --robot neato.yaml -o params.yaml   # the file works as --robot
"""
_CHECK_EXAMPLES = """\
  sim2real robots check neato.yaml
  sim2real robots check turtlebot3_burger
  sim2real robots check my_robot.yaml --no-drive    # geometry only (no pybullet)
"""
_LIST_EXAMPLES = """\
  sim2real robots list
"""
_SHOW_EXAMPLES = """\
  sim2real robots show turtlebot3_waffle_pi
  sim2real robots show turtlebot2 --yaml
  sim2real robots show ./my_robot.yaml             # a spec file by path
"""


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register the ``robots`` command group (``robots list``, ``robots show``)."""
    group = add_command(
        sub,
        "robots",
        help="robot specs: list them, show one",
        description="The robot models shipped with sim2real (specs of published numbers).",
        examples=_GROUP_EXAMPLES,
    )
    group_sub = group.add_subparsers(dest="robots_command", metavar="SUBCOMMAND")
    group_sub.required = True
    lst = add_command(
        group_sub,
        "list",
        help="table of the shipped robots",
        description=(
            "One line per shipped robot: total rigid mass, wheel radius and separation, top "
            "speed and yaw rate, and its sensors."
        ),
        examples=_LIST_EXAMPLES,
    )
    lst.set_defaults(handler=_list)
    show = add_command(
        group_sub,
        "show",
        help="the full spec of one robot",
        description=(
            "Print a robot's spec: bodies, wheels, casters, speed caps, default drive "
            "parameters, sensors, odometry and the sources of the numbers."
        ),
        examples=_SHOW_EXAMPLES,
    )
    show.add_argument("name", metavar="NAME", help="a robot name (see `robots list`) or spec path")
    show.add_argument("--yaml", action="store_true", help="print the spec as a YAML spec file")
    show.set_defaults(handler=_show)
    _register_new(group_sub)
    _register_check(group_sub)


def _register_new(group_sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    new = add_command(
        group_sub,
        "new",
        help="write a complete spec from a few published numbers",
        description=(
            "Write a complete, commented robot spec from the wheel separation and whatever else "
            "you know. Every fact not given is a documented prior with a wide spread (which "
            "`sysid fit` narrows with your logs); the spec is checked (robots check) before it "
            "is written. Load it anywhere with --robot FILE.yaml."
        ),
        examples=_NEW_EXAMPLES,
    )
    new.add_argument("name", metavar="NAME", help="robot name (letters, digits, _ and -)")
    new.add_argument("-o", "--out", metavar="NAME.yaml", help="output spec (default NAME.yaml)")
    new.add_argument(
        "--wheel-separation", type=float, required=True, metavar="M", help="track width, m"
    )
    new.add_argument("--wheel-radius", type=float, metavar="M", help="wheel radius, m")
    new.add_argument("--mass", type=float, metavar="KG", help="total mass, kg")
    new.add_argument("--max-speed", type=float, metavar="MPS", help="top forward speed, m/s")
    new.add_argument("--max-turn-rate", type=float, metavar="RADPS", help="top yaw rate, rad/s")
    new.add_argument(
        "--footprint-radius", type=float, metavar="M", help="radius of the base's outline, m"
    )
    new.add_argument(
        "--drive",
        choices=("diff", "skid"),
        default="diff",
        help="drive type: 'skid' adds the skid steer's slip (track_factor) and tread scrub priors",
    )
    new.add_argument(
        "--driver-track-factor",
        type=float,
        metavar="X",
        help="the driver's wheel_separation_multiplier (e.g. 1.875 for a Husky; default 1 for "
        "diff, 1.6 for skid)",
    )
    new.add_argument("--force", action="store_true", help="overwrite an existing output file")
    new.set_defaults(handler=_new)


def _register_check(group_sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    check = add_command(
        group_sub,
        "check",
        help="sanity-check a spec (geometry and a 1 s pybullet drive test)",
        description=(
            "Check a spec: body clear of the ground, wheels on it, centre of mass inside the "
            "support polygon, and a 1 s pybullet drive test (a forward command moves the base "
            "forward within 20 % of the commanded speed; a turn command turns it the right "
            "way). The same checks run whenever a spec loads into pybullet. Exit 2 when a "
            "check fails."
        ),
        examples=_CHECK_EXAMPLES,
    )
    check.add_argument("spec", metavar="SPEC", help="a robot name or spec .yaml file")
    check.add_argument("--no-drive", action="store_true", help="skip the pybullet drive test")
    check.set_defaults(handler=_check)


def _new(args: argparse.Namespace) -> int:
    from robots.check import check_spec
    from robots.errors import SpecError
    from robots.spec import load_spec
    from robots.template import spec_text
    from sim2real._io import atomic_write
    from sim2real.errors import Sim2RealValueError

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


def _check(args: argparse.Namespace) -> int:
    from robots.check import check_spec
    from robots.errors import SpecError
    from robots.spec import load_spec

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


def _list(args: argparse.Namespace) -> int:
    from robots.spec import list_robots, load_spec

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


def _show(args: argparse.Namespace) -> int:
    import yaml

    from robots.spec import load_spec

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
