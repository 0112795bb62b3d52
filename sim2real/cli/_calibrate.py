"""``sim2real sysid calibrate``: fit the spread of a params file's randomisation to a log.

The arguments are defined with the ``sysid`` group (:mod:`sim2real.cli._parsers.sysid`); the
work is done by :func:`sim2real.agreement.calibration.calibrate` and
:func:`sim2real.agreement.calibration.write_calibrated`.
"""

from __future__ import annotations

import argparse
import math

from robots.spec import load_spec
from sim2real._io import check_not_an_input, check_output_path
from sim2real.agreement.calibration import CalibrationResult, calibrate, write_calibrated
from sim2real.agreement.study import parse_odom_v_window
from sim2real.cli._common import read_options

__all__ = ["handle_calibrate"]


def handle_calibrate(args: argparse.Namespace) -> int:
    """``sysid calibrate PARAMS LOG``: fit the band's spread, write it, print the factors."""
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
        read=read_options(args),
    )
    write_calibrated(args.params, args.out, result)
    for note in result.notes:  # what reading the logs chose or repaired: say it
        print(f"note: {note}")
    _print_calibration(args, result)
    print(f"wrote {args.out}")
    return 0


def _print_calibration(args: argparse.Namespace, result: CalibrationResult) -> None:
    """The calibrated factors, noise stds, likelihood and coverage, one line each."""

    def factor(x: float) -> str:
        return f"x{x:.3g} the file's" if math.isfinite(x) else "(file had none)"

    print(f"calibrated {args.params} on {', '.join(args.logs)} ({result.n_active} active samples)")
    print(
        f"  dynamics spread factor  x{result.dynamics_factor:.3g} (the calibration logs' "
        f"optimum x{result.likelihood_dynamics_factor:.3g} pooled by sessions with the fit's "
        f"{result.fit_sessions} log(s) + prior: {result.validation_sessions} calibration "
        "log(s))"
    )
    print(f"  session spread factor   x{result.session_factor:.3g} (times the spec's)")
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
            f"  {level} band, {axis}: covers {100 * before:.1f} % of the calibration samples with "
            f"the identified noise and the pooled spread, {100 * after:.1f} % calibrated (noise "
            f"x{scale:.3g} the identified std)"
        )
