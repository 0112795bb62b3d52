"""Arguments of `sim2real sysid`: fit drive parameters to logs, calibrate the band, show a result."""

from __future__ import annotations

import argparse

from sim2real.cli._common import (
    add_command,
    add_group,
    add_logs_argument,
    add_odom_v_window_argument,
    add_ray_argument,
    add_read_arguments,
)
from sysid.definitions import FIT_PERCENT_DEFINITION, LOSSES

__all__ = ["register"]

_GROUP_EXAMPLES = """\
  sim2real sysid fit run.mcap --robot turtlebot3_burger -o params.yaml
  sim2real sysid fit run.bag --robot turtlebot3_burger -o params.yaml   # ROS 1 bag
  sim2real sysid show params.yaml
"""
_FIT_EXAMPLES = """\
  sim2real sysid fit run.mcap --robot turtlebot3_burger -o params.yaml
  sim2real sysid fit a.mcap b.mcap c.mcap --robot turtlebot2 -o p.yaml   # a fleet of sessions
  sim2real sysid fit a.mcap b.mcap --robot turtlebot2 -o p.yaml --validate c.mcap
  sim2real sysid fit goal.mcap --robot turtlebot3_waffle_pi -o p.yaml \\
      --window 0:20 --validate goal.mcap --validate-window 20:40   # fit one part, check another
  sim2real sysid fit run.mcap --robot turtlebot2 -o p.yaml --free delay_s,added_mass_kg
  sim2real sysid fit run.mcap --robot turtlebot2 -o p.yaml --cmd-topic /mobile_base/cmd_vel
  sim2real sysid fit real.mcap --robot turtlebot3_burger -o p.yaml --odom-v-window auto
  sim2real sysid fit neato.bag --robot neato.yaml -o p.yaml --odom-velocity pose   # twist is junk
  sim2real sysid fit run.mcap --robot turtlebot2 -o p.yaml --bootstrap 20 --seed 1
  sim2real sysid fit 'fleet/*.mcap' --robot turtlebot3_burger -o fleet.yaml --ray auto
"""
_FIT_DESCRIPTION = (
    "Simulate the reduced drive model from the logged commands and fit its parameters "
    "to the measured velocities: a MAP fit (robust least squares plus the spec's priors "
    "of every drive parameter). Prints each parameter's prior, posterior (value, 95 % "
    "interval) and how much the data informed it (post/prior sd: ~1 = not at all), "
    "what the logs could not identify, and FIT % / agreement on the fitting and "
    "validation logs. Several logs are several sessions: each is fitted and a "
    "population (mean, between-session spread) is estimated. Writes a params file "
    "with a 'randomization' block (the distribution to train on, with the odometry "
    "noise) that 'sim2real agree --params' and the envs read. "
    f"{FIT_PERCENT_DEFINITION}."
)
_SENSORS_EXAMPLES = """\
  sim2real sysid sensors run.mcap --robot turtlebot3_burger -o sensors.yaml
  sim2real sysid sensors a.mcap b.mcap --robot neato.yaml -o sensors.yaml   # one sensor, 2 logs
  sim2real sysid sensors run.bag --robot my_base.yaml -o s.yaml --scan-topic /base_scan
  sim2real sysid sensors run.mcap --robot my_base.yaml -o s.yaml --report sensors.html
  sim2real sysid sensors run.mcap --robot my_base.yaml -o s.yaml --depth-topic /camera/depth
"""
_SENSORS_DESCRIPTION = (
    "Identify a 2-D lidar from recordings of its LaserScan topic and odometry: range noise "
    "std vs range (scan-to-scan spread per beam while the robot stands still), the "
    "invalid-return rate (NaN/inf/0/beyond range_max) vs range and beam, spurious short "
    "returns, the scan stamp offset against odometry and the mounting yaw (consecutive "
    "scans matched while driving through a static room), each with a 95 %% interval, and "
    "what the recordings could not identify. A good recording: stand still 10 s facing a "
    "wall at several distances, then drive slowly through a static room with turns. Writes "
    "a YAML file with the sensor's range limits, beam count and angles; without a still "
    "stretch the range noise comes from the matched moving scans. A depth image topic "
    "(16UC1 or 32FC1) adds the camera's noise vs depth and invalid-pixel rate."
)
_SHOW_EXAMPLES = """\
  sim2real sysid show params.yaml
"""
_PLAN_EXAMPLES = """\
  sim2real sysid plan --robot turtlebot2 --duration 90 -o excite.mcap
  ros2 bag play excite.mcap    # while 'ros2 bag record /cmd_vel /odom' records the session
  sim2real sysid plan --robot my_base.yaml --duration 120 --area 2.5 -o excite.mcap
"""


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register the ``sysid`` command group (``sysid fit``, ``show``, ``calibrate``, ``plan``)."""
    group_sub = add_group(
        sub,
        "sysid",
        help="fit drive-model parameters to logs, show a result",
        description=(
            "System identification: fit the drive-model parameters (delay, friction, inertia, "
            "limits) of a robot to logs of commanded and measured velocity."
        ),
        examples=_GROUP_EXAMPLES,
    )
    _register_fit(group_sub)
    show = add_command(
        group_sub,
        "show",
        help="print a sysid result file",
        description="Print the parameters, intervals, scores and warnings of a sysid result file.",
        examples=_SHOW_EXAMPLES,
    )
    show.add_argument("params", metavar="PARAMS.yaml", help="file written by 'sysid fit'")
    show.set_defaults(handler="result:handle_show")
    _register_calibrate(group_sub)
    _register_plan(group_sub)
    _register_sensors(group_sub)


def _register_sensors(group_sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = add_command(
        group_sub,
        "sensors",
        help="identify a lidar's noise, dropouts, timing and mounting yaw from recordings",
        description=_SENSORS_DESCRIPTION,
        examples=_SENSORS_EXAMPLES,
    )
    p.add_argument("logs", nargs="+", metavar="LOG", help="MCAP file, ROS 1 bag or rosbag2 folder")
    p.add_argument("--robot", required=True, help="robot spec name or spec file (lidar mount)")
    p.add_argument("-o", "--output", required=True, help="the sensors.yaml file to write")
    p.add_argument("--scan-topic", help="LaserScan topic (default: /scan or the only one)")
    p.add_argument("--odom-topic", help="Odometry topic (default: /odom or the only one)")
    p.add_argument(
        "--depth-topic",
        help="depth Image topic, 16UC1 mm or 32FC1 m (default: the only one, if any): its "
        "noise vs depth and invalid-pixel rate from the still frames",
    )
    p.add_argument("--bootstrap", type=int, default=200, help="bootstrap resamples (default 200)")
    p.add_argument("--seed", type=int, default=0, help="bootstrap seed (default 0)")
    p.add_argument(
        "--report",
        metavar="REPORT.html",
        help="also write an HTML check: noise vs range with its band and the simulated "
        "lidar over the real spreads, invalid returns per beam and range",
    )
    p.set_defaults(handler="sensors:handle_sensors")


def _register_plan(group_sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    plan = add_command(
        group_sub,
        "plan",
        help="write the command script to record for a fit (ros2 bag play)",
        description=(
            "Design a command script for a base from its spec: held v and w steps up to 110 % "
            "of the speed limits with stops and reversals, steps around held speed levels, "
            "slow ramps both ways, and turns while driving up to the wheel-speed cap reversed "
            "at once, each driven out and back so the base stays within --area. Writes "
            "/cmd_vel (geometry_msgs/msg/Twist) in a ROS 2 MCAP file that 'ros2 bag play' "
            "sends to the base; record /cmd_vel and /odom meanwhile and fit the recording with "
            "'sim2real sysid fit'. Prints what each block is designed to identify; what no "
            "command within the limits can identify, computed from the spec (a wheel torque "
            "cap far above the largest torque the commands ask, e.g. behind a velocity "
            "smoother); and what one session may leave near its prior on this base and why: "
            "the mass-gain direction (velocity data fix mass over gain), a torque cap a base "
            "whose wheels do not saturate bounds only from below, and viscous friction that "
            "PI wheel loops hide (shown only in transients, where its prior spread is a few "
            "percent of the loop's gain). Then the best case one session of this length could reach for "
            "each smooth parameter (Fisher information of the plan and of each of its block "
            "kinds alone, on the drive model at the priors' centres, 4 mm/s and 0.02 rad/s "
            "odometry noise, 10 ms command jitter) and what no session of this length can "
            "identify (best case above half the prior sd)."
        ),
        examples=_PLAN_EXAMPLES,
    )
    plan.add_argument("--robot", required=True, help="robot spec name or spec file")
    plan.add_argument(
        "--duration", type=float, default=90.0, help="length of the script, s (default 90)"
    )
    plan.add_argument(
        "--area",
        type=float,
        default=3.0,
        help="side of the free floor square the base starts in the middle of, m (default 3)",
    )
    plan.add_argument(
        "--rate", type=float, default=10.0, help="command publishing rate, Hz (default 10)"
    )
    plan.add_argument(
        "--no-bound",
        dest="bound",
        action="store_false",
        help="skip the best case of one session of this length (its Fisher information on "
        "the drive model: about 20 s of computing for 90 s)",
    )
    plan.add_argument("-o", "--output", required=True, help="the .mcap command script to write")
    plan.set_defaults(handler="sysid:handle_plan")


def _register_fit(group_sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """``sysid fit``: its logs, robot, output and how the logs are read."""
    fit = add_command(
        group_sub,
        "fit",
        help="fit the drive parameters to one or more logs",
        description=_FIT_DESCRIPTION,
        examples=_FIT_EXAMPLES,
    )
    several = "several logs are several sessions (a population)"
    add_logs_argument(fit, "logs", what="fitting log(s)", several=several)
    fit.add_argument("--robot", required=True, help="robot spec name (see 'sim2real robots list')")
    add_ray_argument(fit, several="with several sessions, fit each as a Ray task")
    fit.add_argument("-o", "--output", required=True, metavar="PARAMS.yaml", help="result file")
    fit.add_argument(
        "--validate", action="append", default=[], metavar="VAL.mcap", help="validation log(s)"
    )
    add_read_arguments(fit)
    _add_fit_options(fit)
    fit.set_defaults(handler="sysid:handle_fit")


def _add_fit_options(fit: argparse.ArgumentParser) -> None:
    """``sysid fit``'s options of the fit itself: windows, free parameters, loss, bootstrap."""
    fit.add_argument("--window", metavar="START:END", help="use only this part of the fit logs (s)")
    fit.add_argument(
        "--validate-window", metavar="START:END", help="use only this part of the validation logs"
    )
    fit.add_argument(
        "--free",
        default="auto",
        help="comma-separated parameters to fit, or 'auto' (chosen from the excitation)",
    )
    fit.add_argument(
        "--loss",
        default="soft_l1",
        choices=LOSSES,
        help="robust loss (default: soft_l1)",
    )
    fit.add_argument(
        "--dt", type=float, default=None, help="model integration step, s (default 1/240)"
    )
    fit.add_argument(
        "--bootstrap",
        type=int,
        default=0,
        metavar="N",
        help="also refit N block-bootstrap resamples of 10 s segments (a check on the errors)",
    )
    fit.add_argument("--seed", type=int, default=0, help="seed of the bootstrap draws")
    add_odom_v_window_argument(fit, compared="model")


_CALIBRATE_EXAMPLES = """\
  sim2real sysid fit day1.mcap day2.mcap day3.mcap --robot turtlebot2 -o params.yaml
  sim2real sysid calibrate params.yaml day4.mcap --robot turtlebot2 -o calibrated.yaml
  sim2real agree day5.mcap --robot turtlebot2 --params calibrated.yaml --ensemble 30 \\
      --json agree.json            # coverage of the 90 % band on a session neither step saw
  sim2real sysid calibrate p.yaml neato_val.bag --robot neato.yaml -o cal.yaml \\
      --odom-velocity pose          # the driver's twist is junk: velocities from the pose
  sim2real sysid calibrate p.yaml val.mcap --robot turtlebot2 -o cal.yaml --time-source log
"""

_CALIBRATE_DESCRIPTION = """\
Fit the spread of the randomisation in PARAMS.yaml (its 'randomization' block: drive
parameters and odometry noise) to calibration logs that the fit did not use, by likelihood:
N robots are drawn with the covariance scaled by a dynamics factor s^2, the logs are replayed
with each, and s and the odometry noise stds of v and w are chosen to maximise the Gaussian
predictive log-likelihood of the real velocities (members' mean and variance plus noise, over
the active samples) -- in the spirit of DROPO (Tiboni et al., 2023). Then each axis's noise
std is scaled so that the 90 % band, built as 'agree --ensemble' builds it, covers 90-95 % of
the calibration samples: widened to 90 % where it covers less, narrowed to 95 % where it covers
more (a Gaussian likelihood over-widens the noise where errors are heavy-tailed). The point
estimate (the mean) is kept. The output is PARAMS.yaml with the calibrated 'randomization'
block and a 'calibration' block (factors, noise stds, likelihood before and after, validation
coverage before and after the matching, the calibration logs with SHA-256). Use it with
'sim2real agree --ensemble' on yet another log, and in training with
DynamicsRandomizer.from_sysid and VelocityObservationNoise.from_sysid.
A log the params file was fitted on is refused. Exit codes: 0 ok, 2 bad input.
"""


def _register_calibrate(group_sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``sysid calibrate`` in the ``sysid`` group's subparsers."""
    p = add_command(
        group_sub,
        "calibrate",
        help="fit the randomisation's spread to a calibration log the fit did not use",
        description=_CALIBRATE_DESCRIPTION,
        examples=_CALIBRATE_EXAMPLES,
    )
    p.add_argument("params", metavar="PARAMS.yaml", help="params file written by 'sysid fit'")
    p.add_argument(
        "logs", nargs="+", metavar="CALIBRATION.mcap", help="calibration log(s) the fit did not use"
    )
    p.add_argument("--robot", required=True, help="robot name (the params file's robot)")
    p.add_argument(
        "-o", "--out", required=True, metavar="CALIBRATED.yaml", help="output params file"
    )
    p.add_argument(
        "--ensemble",
        type=int,
        default=32,
        metavar="N",
        help="robots drawn per likelihood evaluation (>= 4; default 32)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the draws (default 0)")
    p.add_argument(
        "--engine",
        choices=("reduced", "pybullet", "mujoco", "mujoco-lifted"),
        default="reduced",
        help="simulator (default reduced: the calibration replays the log hundreds of times; "
        "mujoco needs the [mujoco] extra)",
    )
    p.add_argument(
        "--odom-v-window",
        default=None,
        metavar="S|auto",
        help="odometry window of v, s, or 'auto' (default: the fit's, from the params file)",
    )
    add_read_arguments(p, time_source_note="read the calibration logs as the fit read its logs")
    p.set_defaults(handler="calibrate:handle_calibrate")
