"""``sim2real demo`` (what ``make demo`` runs): the README tour's three commands, in-process.

The bundled logs are three sessions of one base (a foreign plant, :mod:`sim2real.plants.diff_drive`):

1. ``sim2real sysid fit data/demo_train.mcap --robot turtlebot3_burger --validate
   data/demo_validate.mcap -o OUT/params.yaml``: fit the drive model to the first session
   (the validation log is only scored);
2. ``sim2real sysid calibrate OUT/params.yaml data/demo_calibrate.mcap --robot
   turtlebot3_burger -o OUT/calibrated.yaml``: fit the spread of the randomisation to a second
   session the fit did not see;
3. ``sim2real agree data/demo_validate.mcap --robot turtlebot3_burger --params
   OUT/calibrated.yaml --report OUT/report.html --json OUT/agreement.json --ensemble 10``:
   replay a third session (another kind of driving, 37 ms more latency than the first, more
   payload, a lower battery) in pybullet with the spec defaults and with the fit, measure both
   and the coverage of the calibrated band;
4. write ``OUT/summary.json`` and print a short table.

Every other option is at its default (:func:`tour_commands`), so the tour gives the same
figures. The sample logs come from a foreign plant (:mod:`sim2real.plants.diff_drive`), not from the
model that is fitted (see ``data/README.md``); they are looked up in
``$SIM2REAL_DATA``, then in ``data/`` of the source checkout, then in
``<prefix>/share/sim2real/data`` of an installed package.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import math
import os
import shlex
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from sim2real._io import output_set
from sim2real.agreement.figures import check_ensemble_size
from sim2real.agreement.study import run_study, summary_table, write_json
from sim2real.cli import build_parser
from sim2real.cli._agree import study_config
from sim2real.cli._calibrate import handle_calibrate
from sim2real.cli._parsers.demo import DEFAULT_OUT
from sim2real.cli._sysid import handle_fit
from sim2real.errors import Sim2RealFileNotFoundError, Sim2RealValueError
from sim2real.logs import read_trace

__all__ = ["find_data_dir", "handle_demo", "run_demo", "tour_commands"]

TRAIN_LOG = "demo_train.mcap"
CALIBRATE_LOG = "demo_calibrate.mcap"
VALIDATE_LOG = "demo_validate.mcap"
_LOGS = (TRAIN_LOG, CALIBRATE_LOG, VALIDATE_LOG)
DEMO_ROBOT = "turtlebot3_burger"


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
    candidates = [Path(explicit)] if explicit is not None else _candidates()
    for folder in candidates:
        if all((folder / name).is_file() for name in _LOGS):
            return folder
    tried = ", ".join(f"'{c}'" for c in candidates)
    raise Sim2RealFileNotFoundError(
        f"the demo's sample logs {', '.join(_LOGS)} were not found in {tried}; "
        "run the demo from a source checkout, set SIM2REAL_DATA or pass --data DIR "
        "(regenerate them with 'python -m sim2real._samples data')"
    )


def tour_commands(
    out_dir: str | Path,
    data_dir: str | Path,
    *,
    engine: str = "pybullet",
    ensemble_n: int = 10,
    seed: int = 0,
) -> tuple[list[str], list[str], list[str]]:
    """The README tour's ``sysid fit``, ``sysid calibrate`` and ``agree`` command lines.

    Each is the argument list after ``sim2real``. The demo runs exactly these, with every
    other option at its default, so a user who types the tour gets the demo's figures.
    ``--engine`` and ``--seed`` appear only when they differ from their defaults.

    Examples
    --------
    >>> fit, calibrate, agree = tour_commands("o", "data")
    >>> " ".join(calibrate)
    'sysid calibrate o/params.yaml data/demo_calibrate.mcap --robot turtlebot3_burger -o o/calibrated.yaml'
    """
    data, out = Path(data_dir), Path(out_dir)
    train, validate = str(data / TRAIN_LOG), str(data / VALIDATE_LOG)
    params, calibrated = str(out / "params.yaml"), str(out / "calibrated.yaml")
    fit = ["sysid", "fit", train, "--robot", DEMO_ROBOT, "--validate", validate, "-o", params]
    calibrate = ["sysid", "calibrate", params, str(data / CALIBRATE_LOG)]
    calibrate += ["--robot", DEMO_ROBOT, "-o", calibrated]
    agree = ["agree", validate, "--robot", DEMO_ROBOT, "--params", calibrated]
    agree += ["--report", str(out / "report.html"), "--json", str(out / "agreement.json")]
    if ensemble_n >= 2:
        agree += ["--ensemble", str(ensemble_n)]
        if seed != 0:
            agree += ["--seed", str(seed)]
    if engine != "pybullet":
        agree += ["--engine", engine]
    return fit, calibrate, agree


def _check_out(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise Sim2RealValueError(f"--out '{out}' exists and is not a folder; choose a folder")
    for parent in out.parents:  # the nearest existing parent must be a folder to create OUT in
        if parent.exists():
            if not parent.is_dir():
                raise Sim2RealValueError(
                    f"--out '{out}' cannot be created: its parent '{parent}' is a file, not a "
                    f"folder; choose an --out path under a folder, e.g. --out {DEFAULT_OUT}"
                )
            break


def _outputs(out: Path) -> list[Path]:
    """Every file the demo writes in OUT (one set)."""
    names = ("params.yaml", "calibrated.yaml", "report.html", "agreement.json", "summary.json")
    return [out / name for name in names]


@contextlib.contextmanager
def _showing(stage: Path, out: Path) -> Iterator[None]:
    """Print what the body prints with the staging folder named as OUT (where it moves to)."""
    buffer = io.StringIO()
    try:
        with contextlib.redirect_stdout(buffer):
            yield
    finally:
        sys.stdout.write(buffer.getvalue().replace(str(stage), str(out)))
        sys.stdout.flush()


def run_demo(
    out_dir: str | Path,
    *,
    engine: str = "pybullet",
    ensemble_n: int = 10,
    seed: int = 0,
    data_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Run the demo (the README tour's commands); returns ``OUT/summary.json``'s content.

    All outputs are one set (:func:`sim2real._io.output_set`): the tour runs in a staging
    folder inside OUT and its files move in together at the end, so a failed or killed run
    leaves the previous demo's outputs as they were (and the next run removes its leftovers).
    """
    start = time.perf_counter()
    data = find_data_dir(data_dir)
    out = Path(out_dir)
    _check_inputs(out, data, ensemble_n)
    shown = tour_commands(out, data, engine=engine, ensemble_n=ensemble_n, seed=seed)
    parser = build_parser()
    out.mkdir(parents=True, exist_ok=True)
    with output_set(_outputs(out), what="demo output") as staged:
        stage = staged.staged(out / "summary.json").parent
        fit_argv, calibrate_argv, agree_argv = tour_commands(
            stage, data, engine=engine, ensemble_n=ensemble_n, seed=seed
        )
        print(f"1/3 sim2real {shlex.join(shown[0])}", flush=True)
        with _showing(stage, out):
            handle_fit(parser.parse_args(fit_argv))
        fit_s = time.perf_counter() - start
        print(f"2/3 sim2real {shlex.join(shown[1])}", flush=True)
        with _showing(stage, out):
            handle_calibrate(parser.parse_args(calibrate_argv))
        print(f"3/3 sim2real {shlex.join(shown[2])}", flush=True)
        config = dataclasses.replace(
            study_config(parser.parse_args(agree_argv)),
            title="sim2real demo: TurtleBot3 Burger (foreign plant), spec defaults vs calibrated "
            "sysid fit",
            command_line=f"sim2real {shlex.join(shown[2])}",
            params_shown=str(out / "calibrated.yaml"),
        )
        outcome = run_study(config)
        summary = _summary(outcome, list(shown), data, out)
        summary["fit_s"] = round(fit_s, 2)
        summary["elapsed_s"] = round(time.perf_counter() - start, 2)
        write_json(staged.staged(out / "summary.json"), summary)
    _print_outcome(outcome, summary, out)
    return summary


def _check_inputs(out: Path, data: Path, ensemble_n: int) -> None:
    """Refuse a bad OUT, ensemble size or sample log before OUT is created or written."""
    _check_out(out)
    if ensemble_n >= 2:  # a bad size fails here, not after the fit
        check_ensemble_size(ensemble_n)
    for name in _LOGS:
        read_trace(data / name)


def _print_outcome(outcome: Any, summary: dict[str, Any], out: Path) -> None:
    """The agreement table, the verdict, the before/after line and the files written."""
    print(summary_table(outcome.runs, outcome.ensemble))
    if outcome.verdict is not None:  # the report's verdict, in the same words
        print("\n".join(outcome.verdict.lines()))
    before, after = summary["defaults"]["agreement"], summary["sysid"]["agreement"]
    cov = summary["coverage"]
    print(
        f"validation log: agreement {_pct(before)} with spec defaults -> {_pct(after)} with the "
        f"sysid fit; band coverage {_pct(cov)} ({summary['elapsed_s']:.0f} s)"
    )
    print(
        f"wrote {out / 'params.yaml'}, {out / 'calibrated.yaml'}, {out / 'report.html'}, "
        f"{out / 'agreement.json'}, {out / 'summary.json'}"
    )


def _summary(outcome: Any, argvs: list[list[str]], data: Path, out: Path) -> dict[str, Any]:
    before, after = (r.agreement for r in outcome.runs)
    ens = outcome.ensemble
    coverage = ens.coverage if ens is not None and math.isfinite(ens.coverage) else None
    return {
        "robot": DEMO_ROBOT,
        "engine": outcome.runs[-1].replay.engine,
        "train_log": str(data / TRAIN_LOG),
        "calibrate_log": str(data / CALIBRATE_LOG),
        "validate_log": str(data / VALIDATE_LOG),
        "params_file": str(out / "params.yaml"),
        "calibrated_file": str(out / "calibrated.yaml"),
        "report": str(out / "report.html"),
        "commands": ["sim2real " + shlex.join(argv) for argv in argvs],
        "defaults": before.to_dict(),
        "sysid": after.to_dict(),
        "improvement_points": _points(after.agreement - before.agreement),
        "odom_v_window_s": after.odom_v_window_s,
        "coverage": coverage,
        "ensemble_n": ens.n if ens is not None else 0,
        "coverage_v": ens.coverage_v if ens is not None else None,
        "coverage_w": ens.coverage_w if ens is not None else None,
        "band_width_v_mps": ens.band_width_v_mps if ens is not None else None,
        "band_width_w_radps": ens.band_width_w_radps if ens is not None else None,
        "seed": _seed(argvs[-1]),
    }


def _seed(agree_argv: list[str]) -> int:
    return int(agree_argv[agree_argv.index("--seed") + 1]) if "--seed" in agree_argv else 0


def _points(x: float) -> float | None:
    return round(100.0 * x, 2) if math.isfinite(x) else None


def _pct(x: float) -> str:
    return f"{100 * x:.1f} %" if math.isfinite(x) else "n/a"


def handle_demo(args: argparse.Namespace) -> int:
    """``demo``: the README tour on the bundled logs, into ``--out``."""
    run_demo(
        args.out, engine=args.engine, ensemble_n=args.ensemble, seed=args.seed, data_dir=args.data
    )
    return 0
