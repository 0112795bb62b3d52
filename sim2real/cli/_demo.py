"""``sim2real demo`` (what ``make demo`` runs): sysid on a bundled log, agreement on another.

1. fit the drive parameters of the TurtleBot3 Burger to ``data/demo_train.mcap`` (sysid);
2. replay ``data/demo_validate.mcap`` (a different command sequence) in pybullet with the spec
   defaults and with the fitted parameters, and measure the agreement of both (the simulated
   v goes through the odometry model of the fit, ``--odom-v-window auto``, in both);
3. write ``OUT/params.yaml``, ``OUT/report.html`` (+ PNGs) and ``OUT/summary.json``, and print
   a short table.

The sample logs are synthetic (see ``data/README.md``); they are looked up in
``$SIM2REAL_DATA``, then in ``data/`` of the source checkout, then in
``<prefix>/share/sim2real/data`` of an installed package.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path
from typing import Any

from sim2real.cli._common import add_command

__all__ = ["find_data_dir", "register", "run_demo"]

_EXAMPLES = """\
  sim2real demo                       # writes sim2real-demo/{report.html,summary.json,params.yaml}
  sim2real demo --out /tmp/demo --engine reduced
"""

_DESCRIPTION = """\
The main job, what `make demo` runs:
  1. fit the drive parameters of a TurtleBot3 Burger to data/demo_train.mcap (sysid);
  2. replay data/demo_validate.mcap (a different command sequence) in simulation with the
     spec defaults and with the fit, and measure the sim-vs-real agreement of both;
  3. write OUT/params.yaml, OUT/report.html (+ PNGs) and OUT/summary.json and print a table.
The sample logs are synthetic (data/README.md). They are looked up in $SIM2REAL_DATA, then in
data/ of the source checkout, then in <prefix>/share/sim2real/data of an installed package.
"""

TRAIN_LOG = "demo_train.mcap"
VALIDATE_LOG = "demo_validate.mcap"
DEMO_ROBOT = "turtlebot3_burger"
_DEFAULT_OUT = "sim2real-demo"


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``sim2real demo``."""
    p = add_command(
        sub,
        "demo",
        help="fit sysid on the bundled training log and report agreement on the validation log",
        description=_DESCRIPTION,
        examples=_EXAMPLES,
    )
    p.add_argument("--out", default=_DEFAULT_OUT, help="output folder (created if needed)")
    p.add_argument(
        "--engine", choices=("pybullet", "reduced"), default="pybullet", help="replay simulator"
    )
    p.add_argument("--ensemble", type=int, default=10, metavar="N", help="ensemble size (0: none)")
    p.add_argument("--seed", type=int, default=0, help="seed of the ensemble draws")
    p.add_argument("--data", metavar="DIR", help="folder holding the sample logs")
    p.set_defaults(handler=_handle)


def _candidates() -> list[Path]:
    out = []
    env = os.environ.get("SIM2REAL_DATA")
    if env:
        out.append(Path(env))
    out.append(Path(__file__).resolve().parents[2] / "data")  # source checkout / editable
    out.append(Path(sys.prefix) / "share" / "sim2real" / "data")  # installed data files
    return out


def find_data_dir(explicit: str | Path | None = None) -> Path:
    """The folder holding the bundled sample logs (see the module docstring for the order)."""
    from sim2real.errors import Sim2RealFileNotFoundError

    candidates = [Path(explicit)] if explicit is not None else _candidates()
    for folder in candidates:
        if (folder / TRAIN_LOG).is_file() and (folder / VALIDATE_LOG).is_file():
            return folder
    tried = ", ".join(f"'{c}'" for c in candidates)
    raise Sim2RealFileNotFoundError(
        f"the demo's sample logs {TRAIN_LOG} and {VALIDATE_LOG} were not found in {tried}; "
        "run the demo from a source checkout, set SIM2REAL_DATA or pass --data DIR "
        "(regenerate them with 'python -m sim2real._samples data')"
    )


def run_demo(
    out_dir: str | Path,
    *,
    engine: str = "pybullet",
    ensemble_n: int = 10,
    seed: int = 0,
    data_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Run the demo; returns the summary written to ``OUT/summary.json``."""
    from robots.spec import load_spec
    from sim2real.cli._agree import run_agree, summary_table, write_json
    from sim2real.errors import Sim2RealValueError
    from sim2real.logs import read_trace
    from sysid import fit_drive

    start = time.perf_counter()
    data = find_data_dir(data_dir)
    train, validate = data / TRAIN_LOG, data / VALIDATE_LOG
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise Sim2RealValueError(f"--out '{out}' exists and is not a folder; choose a folder")
    for parent in out.parents:  # the nearest existing parent must be a folder to create OUT in
        if parent.exists():
            if not parent.is_dir():
                raise Sim2RealValueError(
                    f"--out '{out}' cannot be created: its parent '{parent}' is a file, not a "
                    f"folder; choose an --out path under a folder, e.g. --out {_DEFAULT_OUT}"
                )
            break
    spec = load_spec(DEMO_ROBOT)
    train_trace = read_trace(train)
    read_trace(validate)  # a bad validation log fails here, before OUT is created or written
    print(f"1/2 fitting drive parameters of {spec.name} to {train} ...", flush=True)
    # The sample logs record v as the TurtleBot3 firmware does: encoder ticks differenced over
    # one odometry period. Modelling that window removes a half-period (~17 ms) bias from the
    # fitted delay and the time constants (what `sysid fit --odom-v-window auto` does).
    result = fit_drive(
        [train_trace],
        geometry=spec.geometry,
        base_params=spec.drive,
        robot=spec.name,
        odom_v_window_s=1.0 / spec.odometry.rate_hz,
    )
    out.mkdir(parents=True, exist_ok=True)
    params_path = out / "params.yaml"
    result.save(params_path)
    fit_s = time.perf_counter() - start
    print(f"2/2 replaying {validate} in {engine} (defaults, fit, ensemble) ...", flush=True)
    outcome = run_agree(
        log=validate,
        robot=spec.name,
        params_path=params_path,
        engine=engine,
        ensemble_n=ensemble_n if ensemble_n >= 2 else None,
        seed=seed,
        # compare v as the odometry reports it, like the fit above (before and after alike)
        odom_v_window="auto",
        report_path=out / "report.html",
        command_line=f"sim2real demo --out {out} --engine {engine} --ensemble {ensemble_n} "
        f"--seed {seed}",
        title="sim2real demo: TurtleBot3 Burger, spec defaults vs sysid fit",
    )
    before, after = (r.agreement for r in outcome.runs)
    summary: dict[str, Any] = {
        "robot": spec.name,
        "engine": engine,
        "train_log": str(train),
        "validate_log": str(validate),
        "params_file": str(params_path),
        "report": str(out / "report.html"),
        "defaults": before.to_dict(),
        "sysid": after.to_dict(),
        "improvement_points": _points(after.agreement - before.agreement),
        "odom_v_window_s": after.odom_v_window_s,
        "coverage": None,
        "ensemble_n": ensemble_n if outcome.ensemble is not None else 0,
        "seed": seed,
        "fit_s": round(fit_s, 2),
        "elapsed_s": round(time.perf_counter() - start, 2),
    }
    if outcome.ensemble is not None and math.isfinite(outcome.ensemble.coverage):
        summary["coverage"] = outcome.ensemble.coverage
    write_json(out / "summary.json", summary)
    print(summary_table(outcome.runs, outcome.ensemble))
    print(
        f"agreement on the validation log: {_pct(before.agreement)} with spec defaults -> "
        f"{_pct(after.agreement)} with the sysid fit ({summary['elapsed_s']:.0f} s)"
    )
    print(f"wrote {params_path}, {out / 'report.html'}, {out / 'summary.json'}")
    return summary


def _points(x: float) -> float | None:
    return round(100.0 * x, 2) if math.isfinite(x) else None


def _pct(x: float) -> str:
    return f"{100 * x:.1f} %" if math.isfinite(x) else "n/a"


def _handle(args: argparse.Namespace) -> int:
    run_demo(
        args.out, engine=args.engine, ensemble_n=args.ensemble, seed=args.seed, data_dir=args.data
    )
    return 0
