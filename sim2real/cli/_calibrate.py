"""``sim2real sysid calibrate``: fit the spread of a params file's randomisation to a log.

Registered under the ``sysid`` group by :mod:`sim2real.cli._sysid`; the work is done by
:func:`sim2real.agreement.calibration.calibrate` and :func:`sim2real.agreement.calibration.write_calibrated`.
"""

from __future__ import annotations

import argparse
import math

from sim2real.cli._common import add_command, add_read_arguments

__all__ = ["register"]

_EXAMPLES = """\
  sim2real sysid fit day1.mcap day2.mcap day3.mcap --robot turtlebot2 -o params.yaml
  sim2real sysid calibrate params.yaml day4.mcap --robot turtlebot2 -o calibrated.yaml
  sim2real agree day5.mcap --robot turtlebot2 --params calibrated.yaml --ensemble 30 \\
      --json agree.json            # coverage of the 90 % band on a session neither step saw
  sim2real sysid calibrate p.yaml neato_val.bag --robot neato.yaml -o cal.yaml \\
      --odom-velocity pose          # the driver's twist is junk: velocities from the pose
  sim2real sysid calibrate p.yaml val.mcap --robot turtlebot2 -o cal.yaml --time-source log
"""

_DESCRIPTION = """\
Fit the spread of the randomisation in PARAMS.yaml (its 'randomization' block: drive
parameters and odometry noise) to validation logs that the fit did not use, by likelihood:
N robots are drawn with the covariance scaled by a dynamics factor s^2, the logs are replayed
with each, and s and the odometry noise stds of v and w are chosen to maximise the Gaussian
predictive log-likelihood of the real velocities (members' mean and variance plus noise, over
the active samples) -- in the spirit of DROPO (Tiboni et al., 2023). Then each axis's noise
std is scaled so that the 90 % band, built as 'agree --ensemble' builds it, covers 90-95 % of
the validation samples: widened to 90 % where it covers less, narrowed to 95 % where it covers
more (a Gaussian likelihood over-widens the noise where errors are heavy-tailed). The point
estimate (the mean) is kept. The output is PARAMS.yaml with the calibrated 'randomization'
block and a 'calibration' block (factors, noise stds, likelihood before and after, validation
coverage before and after the matching, the validation logs with SHA-256). Use it with
'sim2real agree --ensemble' on yet another log, and in training with
DynamicsRandomizer.from_sysid and VelocityObservationNoise.from_sysid.
A log the params file was fitted on is refused. Exit codes: 0 ok, 2 bad input.
"""


def register(group_sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``sysid calibrate`` in the ``sysid`` group's subparsers."""
    p = add_command(
        group_sub,
        "calibrate",
        help="fit the randomisation's spread to a validation log (likelihood)",
        description=_DESCRIPTION,
        examples=_EXAMPLES,
    )
    p.add_argument("params", metavar="PARAMS.yaml", help="params file written by 'sysid fit'")
    p.add_argument("logs", nargs="+", metavar="VALIDATION.mcap", help="validation log(s)")
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
        choices=("reduced", "pybullet"),
        default="reduced",
        help="simulator (default reduced: the calibration replays the log hundreds of times)",
    )
    p.add_argument(
        "--odom-v-window",
        default=None,
        metavar="S|auto",
        help="odometry window of v, s, or 'auto' (default: the fit's, from the params file)",
    )
    add_read_arguments(p, time_source_note="read the validation logs as the fit read its logs")
    p.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> int:
    from robots.spec import load_spec
    from sim2real._io import check_not_an_input, check_output_path
    from sim2real.agreement.calibration import calibrate, write_calibrated
    from sim2real.agreement.study import parse_odom_v_window

    check_output_path(args.out, what="calibrated params file (-o)")
    check_not_an_input(args.out, [args.params, *args.logs], what="calibrated params file (-o)")
    window = None
    if args.odom_v_window is not None:
        window = parse_odom_v_window(args.odom_v_window, load_spec(args.robot).odometry.rate_hz)
    result = calibrate(
        args.params,
        args.logs,
        robot=args.robot,
        n=args.ensemble,
        seed=args.seed,
        engine=args.engine,
        odom_v_window_s=window,
        cmd_topic=args.cmd_topic,
        odom_topic=args.odom_topic,
        time_source=args.time_source,
        odom_velocity=args.odom_velocity,
        keep_all=args.keep_all,
    )
    write_calibrated(args.params, args.out, result)
    for note in result.notes:  # what reading the logs chose or repaired: say it
        print(f"note: {note}")

    def factor(x: float) -> str:
        return f"x{x:.3g}" if math.isfinite(x) else "(file had none)"

    print(f"calibrated {args.params} on {', '.join(args.logs)} ({result.n_active} active samples)")
    print(
        f"  dynamics spread factor  x{result.dynamics_factor:.3g} (the validation optimum "
        f"x{result.likelihood_dynamics_factor:.3g} pooled by sessions with the fit's "
        f"{result.fit_sessions} log(s) + prior: {result.validation_sessions} validation log(s))"
    )
    print(
        f"  odometry noise v        {result.noise_std_v_mps:.4g} m/s "
        f"{factor(result.noise_factor_v)}"
    )
    print(
        f"  odometry noise w        {result.noise_std_w_radps:.4g} rad/s "
        f"{factor(result.noise_factor_w)}"
    )
    print(
        f"  log-likelihood/sample   {result.log_likelihood_before:.3f} -> "
        f"{result.log_likelihood:.3f}"
    )
    level = f"{100 * result.match_level:.0f} %"
    for axis, scale, before, after in (
        ("v", result.noise_scale_v, result.coverage_v_likelihood, result.coverage_v),
        ("w", result.noise_scale_w, result.coverage_w_likelihood, result.coverage_w),
    ):
        print(
            f"  {level} band, {axis}: covers {100 * before:.1f} % of the validation samples with "
            f"the likelihood's noise, {100 * after:.1f} % with it x{scale:.3g}"
        )
    print(f"wrote {args.out}")
    return 0
