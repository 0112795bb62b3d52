"""Arguments of `sim2real demo` (what `make demo` runs): the README tour on the bundled logs."""

from __future__ import annotations

import argparse

from sim2real.cli._common import add_command

__all__ = ["DEFAULT_OUT", "register"]

_EXAMPLES = """\
  sim2real demo                       # writes sim2real-demo/{report.html,summary.json,params.yaml}
  sim2real demo --out /tmp/demo --engine reduced
"""

_DESCRIPTION = """\
The main job, what `make demo` runs: the README tour's two commands with default options.
  1. sim2real sysid fit data/demo_train.mcap --robot turtlebot3_burger \\
         --validate data/demo_validate.mcap -o OUT/params.yaml
  2. sim2real agree data/demo_validate.mcap --robot turtlebot3_burger --params OUT/params.yaml \\
         --report OUT/report.html --json OUT/agreement.json --ensemble 10
  3. write OUT/summary.json (before/after agreement, band coverage) and print a table.
The sample logs are three sessions of a foreign plant (sim2real.plants.diff_drive), a base simulated with
physics the fitted model does not have (data/README.md). They are looked up in $SIM2REAL_DATA, then in
data/ of the source checkout, then in <prefix>/share/sim2real/data of an installed package.
"""

DEFAULT_OUT = "sim2real-demo"


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``sim2real demo``."""
    p = add_command(
        sub,
        "demo",
        help="fit sysid on the bundled training log and report agreement on the validation log",
        description=_DESCRIPTION,
        examples=_EXAMPLES,
    )
    p.add_argument("--out", default=DEFAULT_OUT, help="output folder (created if needed)")
    p.add_argument(
        "--engine", choices=("pybullet", "reduced"), default="pybullet", help="replay simulator"
    )
    p.add_argument("--ensemble", type=int, default=10, metavar="N", help="ensemble size (0: none)")
    p.add_argument("--seed", type=int, default=0, help="seed of the ensemble draws")
    p.add_argument("--data", metavar="DIR", help="folder holding the sample logs")
    p.set_defaults(handler="demo:handle_demo")
