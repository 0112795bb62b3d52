"""Arguments of `sim2real robots`: list the shipped specs, show one, write a new one, check one."""

from __future__ import annotations

import argparse

from sim2real.cli._common import add_command, add_group

__all__ = ["register"]

_GROUP_EXAMPLES = """\
  sim2real robots list                              # name, mass, wheels, speed caps, sensors
  sim2real robots show turtlebot3_burger            # the full spec with drive defaults, sources
  sim2real robots show turtlebot2 --yaml > tb2.yaml # as a spec file (edit, then load it by path)
  sim2real robots new neato --wheel-separation 0.248 --max-speed 0.3 -o neato.yaml
  sim2real robots check neato.yaml                  # geometry + 1 s pybullet drive test
  sim2real robots export turtlebot2 --params params.yaml -o tb2.xml   # MJCF for MuJoCo
"""
_EXPORT_EXAMPLES = """\
  sim2real robots export turtlebot3_burger -o burger.xml          # the spec's drive
  sim2real robots export turtlebot3_burger --params params.yaml -o burger.xml
  sim2real robots export husky.yaml --params husky_params.yaml -o husky.xml
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
    group_sub = add_group(
        sub,
        "robots",
        help="robot specs: list them, show one",
        description="The robot models shipped with sim2real (specs of published numbers).",
        examples=_GROUP_EXAMPLES,
    )
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
    lst.set_defaults(handler="robots:handle_list")
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
    show.set_defaults(handler="robots:handle_show")
    _register_new(group_sub)
    _register_check(group_sub)
    _register_export(group_sub)


_EXPORT_DESCRIPTION = (
    "Write an MJCF model of the base (bodies, wheels, casters, inertias with the identified "
    "added mass and yaw inertia; wheel speed actuators with the speed loop's gain, speed cap "
    "and torque cap; the axis friction as tendon damping and frictionloss), every value "
    "commented with the params field it comes from. What MJCF cannot express (delay, "
    "acceleration limits, command timeout, ...) is sim2real.mujoco.MujocoDrive "
    "(docs/mujoco.md). With mujoco installed (the [mujoco] extra) the model is loaded and "
    "drive-checked before it is written."
)


def _register_export(group_sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    help_ = "write the robot with its identified drive as a MuJoCo MJCF model"
    kw = {"help": help_, "description": _EXPORT_DESCRIPTION, "examples": _EXPORT_EXAMPLES}
    export = add_command(group_sub, "export", **kw)
    export.add_argument("robot", metavar="ROBOT", help="a robot name or spec .yaml file")
    export.add_argument(
        "--params", metavar="PARAMS.yaml", help="sysid result (default: the spec's drive)"
    )
    export.add_argument("-o", "--out", required=True, metavar="ROBOT.xml", help="output MJCF")
    export.set_defaults(handler="robots:handle_export")


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
    new.add_argument(
        "--track-factor",
        type=float,
        metavar="X",
        help="skid steer: effective / geometric track as the recordings see it (default prior "
        "1.6; 1 when they read the yaw rate from the wheel encoders)",
    )
    new.add_argument(
        "--wheel-cap",
        choices=("joint", "per-side"),
        help="how the driver holds wheel targets to the speed cap: 'joint' scales both together "
        "(default; most drivers), 'per-side' clips each wheel's target on its own",
    )
    new.add_argument(
        "--command-starts-new-move",
        action="store_true",
        help="the firmware runs each command as a new move, so its wheel loops keep no integral "
        "of the speed error across commands (the Neato's SetMotor); default: the loops run on",
    )
    new.add_argument("--force", action="store_true", help="overwrite an existing output file")
    new.set_defaults(handler="robots:handle_new")


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
    check.set_defaults(handler="robots:handle_check")
