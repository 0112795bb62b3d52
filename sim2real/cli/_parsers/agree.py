"""Arguments of `sim2real agree`: replay a log in simulation and measure sim-vs-real agreement."""

from __future__ import annotations

import argparse

from sim2real.cli._common import (
    add_command,
    add_logs_argument,
    add_odom_v_window_argument,
    add_ray_argument,
    add_read_arguments,
)

__all__ = ["register"]

_EXAMPLES = """\
  sim2real agree val.mcap --robot turtlebot3_burger
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --report report.html
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --json agree.json \\
      --min-agreement 0.9          # CI gate: exit 1 below 90 %
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml --ensemble 20 --seed 1
  sim2real agree test.mcap --robot turtlebot2 --params calibrated.yaml --ensemble 30 \\
      --band-level 0.9 --json agree.json   # coverage_v/_w and band widths of the 90 % band
  sim2real agree val.mcap --robot turtlebot3_burger --engine reduced --sim-out sim.mcap
  sim2real agree val.mcap --robot turtlebot3_burger --params params.yaml \\
      --odom-v-window 0            # compare the instantaneous simulated v
  sim2real agree neato.bag --robot neato.yaml --params p.yaml --odom-velocity pose
  sim2real agree 'fleet/*.mcap' --robot turtlebot3_burger --params params.yaml \\
      --json fleet.json --ray auto # one Ray task per log; {"logs": [...], "summary": {...}}
  sim2real agree a.mcap b.mcap c.mcap --robot turtlebot3_burger --params params.yaml \\
      --report fleet.html          # the fleet table and one verdict per log
"""

_DESCRIPTION = """\
Replay the commanded velocities of LOG.mcap, at their logged times, on the simulated robot
(pybullet by default, or the reduced drive model) with the spec's default drive parameters or
a sysid result (--params), and compare the simulated base velocity with the measured one at
every odometry time.

Only active samples count (a command is held or the robot moves). A sample agrees when
|v_sim - v_real| <= tol_v and |w_sim - w_real| <= tol_w. --json writes agreement,
agreement_v, agreement_w, fit_percent_v, fit_percent_w, rmse_v, rmse_w, lag_s_v, lag_s_w,
n_samples, n_active, tol_v, tol_w, robot, params_file, log_file, log_sha256. The simulated
v is averaged over the preceding --odom-v-window, as wheel-encoder odometry reports v; the
default 'auto' takes it from the robot spec (one odometry period for an encoder base), like
'sysid fit'.

With --ensemble N, N robots are drawn from the params file's 'randomization' block (the
sampler DynamicsRandomizer.from_sysid uses in training: same --seed, same robots), each
simulated trace gets the file's odometry noise (as VelocityObservationNoise adds it), and the
central --band-level band of these traces is the predictive band; --json then adds coverage,
coverage_v, coverage_w (share of active real samples inside the band), band_level,
band_width_v_mps, band_width_w_radps (median width), ensemble_n and coverage_by_level, and a
sentence says whether the band is too narrow, calibrated (80-99 % for a 90 % band) or too
wide. Fit the spread to a validation log with 'sim2real sysid calibrate'.
One verdict follows the table (the report shows the same words): its headline (the band, or
a fit worse than the spec defaults with its likely cause, a latency that differs, too little
data), the reasons (commands outside the envelope the fit saw, a band calibrated by being
wide) and the next step. Samples where the robot moves with no command in force or a command
is held while the wheels stay stopped are left out with one note (--keep-all keeps them).
A figure undefined on the log (the lag of v on a spin in place) is left out of the JSON,
with a note naming it in its 'notes' list; the JSON never holds null for a number. With
several logs, a log that cannot be used gets a row saying why and the others go on.
Exit codes: 0 ok, 1 agreement below --min-agreement, 2 bad input (also when nothing can be
compared: no active sample, no measured motion, or no log of several could be used).
"""


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``sim2real agree``."""
    p = add_command(
        sub,
        "agree",
        help="replay a log in simulation and measure sim-vs-real velocity agreement",
        description=_DESCRIPTION,
        examples=_EXAMPLES,
    )
    several = "several logs print one row each and a fleet summary"
    add_logs_argument(p, "log", what="the real log(s)", several=several)
    p.add_argument("--robot", required=True, help="robot name (see 'sim2real robots list')")
    p.add_argument("--params", metavar="PARAMS.yaml", help="sysid result (default: spec values)")
    p.add_argument(
        "--engine",
        choices=("pybullet", "reduced", "mujoco", "mujoco-lifted"),
        default="pybullet",
        help="simulator (mujoco: the exported MJCF robot; needs the [mujoco] extra; "
        "mujoco-lifted: the same with the base held up, for a log recorded with the wheels "
        "off the ground)",
    )
    p.add_argument("--tol-v", type=float, default=0.02, help="tolerance on v, m/s")
    p.add_argument("--tol-w", type=float, default=0.1, help="tolerance on w, rad/s")
    p.add_argument("--json", metavar="OUT.json", help="write the figures as JSON")
    p.add_argument(
        "--report",
        metavar="OUT.html",
        help=(
            "write the HTML report (+ PNGs); with several logs, one page with the fleet "
            "table and each log's verdict"
        ),
    )
    p.add_argument("--sim-out", metavar="SIM.mcap", help="write the simulated run as MCAP")
    p.add_argument(
        "--min-agreement", type=float, metavar="F", help="exit 1 when agreement < F (0..1)"
    )
    _add_band_options(p)
    add_read_arguments(p)
    add_ray_argument(p, several="with several logs, run one Ray task per log")
    p.set_defaults(handler="agree:handle_agree")


def _add_band_options(p: argparse.ArgumentParser) -> None:
    """``agree``'s options of the ensemble's predictive band and of the odometry window."""
    p.add_argument(
        "--ensemble",
        type=int,
        metavar="N",
        help="also replay N robots drawn from the params file's randomisation (N >= 2) and "
        "measure how much of the log their predictive band covers",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the ensemble draws")
    p.add_argument(
        "--spread",
        type=float,
        default=1.0,
        help="multiply every standard deviation of the ensemble draws, dynamics and noise "
        "(1 = the params file's; prefer 'sim2real sysid calibrate' over tuning this by hand)",
    )
    p.add_argument(
        "--band-level",
        type=float,
        default=0.9,
        metavar="P",
        help="central probability of the ensemble's predictive band, in (0, 1) (default 0.9)",
    )
    add_odom_v_window_argument(
        p,
        compared="simulated",
        averaged="; the simulated v is averaged the same way",
        like="; like 'sysid fit'",
    )
