"""`sim2real robots` commands: list the shipped robot specs and show one in full."""

from __future__ import annotations

import argparse
import math
from typing import TYPE_CHECKING

from sim2real.cli._common import add_command

if TYPE_CHECKING:
    from robots.spec import RobotSpec

__all__ = ["register"]

_GROUP_EXAMPLES = """\
  sim2real robots list                              # name, mass, wheels, speed caps, sensors
  sim2real robots show turtlebot3_burger            # the full spec with drive defaults, sources
  sim2real robots show turtlebot2 --yaml > tb2.yaml # as a spec file (edit, then load it by path)
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
