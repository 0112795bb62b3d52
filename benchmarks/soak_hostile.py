"""Soak run of the hostile-log suite: many random mixes of structured faults through the CLI.

The CI suite (``tests/sim2real/test_hostile_logs.py``) runs a few dozen derandomised examples
in-process; this soak run draws many more (seeded ``numpy.random.Generator``), runs each
command in a fresh subprocess under an address-space limit, and reports the exit codes, the
peak RSS (min/median/max) and every run that broke a rule: an exit code other than 0/2, a
traceback, an exit 2 that is not one ``sim2real: error:`` line, a non-finite figure on exit 0,
or a peak RSS above 0.5 GB.

Usage::

    .venv/bin/python benchmarks/soak_hostile.py --runs 200 --seed 0
    .venv/bin/python benchmarks/soak_hostile.py --runs 30 --fit-every 5   # also sysid fit
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "sim2real"))

from hostile_logs import ROBOT, Fault, base_arrays, figures_finite, write_faulty

KINDS = (
    "stamp_outlier",
    "gap",
    "backwards",
    "duplicate",
    "nan",
    "inf",
    "absurd",
    "clock_offset",
    "cmd_outlier",
    "truncate",
    "no_crc",
    "unknown_channel",
)
LIMIT_AS = 6 * 2**30
PEAK_LIMIT_MB = 500.0
_CHILD = (
    "import sys; from sim2real.cli import main; rc = main(sys.argv[1:]); "
    "sys.stdout.flush(); "
    # VmHWM is this process's own peak; ru_maxrss would also count the forked parent's
    # pages from before exec (the whole pytest process, ~0.5 GB late in a suite run)
    "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0]; "
    "print('PEAK_KB', int(hwm.split()[1]), file=sys.stderr); "
    "sys.exit(rc)"
)


def _limit() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT_AS, LIMIT_AS))


def _faults(rng: np.random.Generator) -> list[Fault]:
    extras = ({}, {"key": "meas_w"}, {"key": "cmd_v"})
    return [
        Fault(
            str(rng.choice(KINDS)),
            at=float(rng.uniform()),
            size=float(rng.uniform(0, 2)),
            extra=extras[int(rng.integers(3))],
        )
        for _ in range(int(rng.integers(1, 4)))
    ]


def _run(argv: list[str], cwd: Path) -> tuple[int, str, str, float, float]:
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, *argv],
        capture_output=True,
        text=True,
        cwd=cwd,
        preexec_fn=_limit,
        check=False,
        timeout=900,
    )
    elapsed = time.perf_counter() - start
    peak = [ln for ln in proc.stderr.splitlines() if ln.startswith("PEAK_KB")]
    peak_mb = int(peak[-1].split()[1]) / 1024 if peak else float("inf")
    err = "\n".join(ln for ln in proc.stderr.splitlines() if not ln.startswith("PEAK_KB"))
    return proc.returncode, proc.stdout, err, peak_mb, elapsed


def _problems(code: int, out: str, err: str, peak_mb: float, json_path: Path | None) -> list[str]:
    found = []
    if code not in (0, 2):
        found.append(f"exit {code}")
    if "Traceback" in out + err:
        found.append("traceback")
    if code == 2:
        lines = [ln for ln in err.splitlines() if ln.startswith("sim2real: error:")]
        if len(lines) != 1:
            found.append("exit 2 without exactly one error line")
    if code == 0 and json_path is not None:
        bad = figures_finite(json.loads(json_path.read_text()))
        if bad:
            found.append(f"non-finite figures {bad}")
    if peak_mb > PEAK_LIMIT_MB:
        found.append(f"peak RSS {peak_mb:.0f} MB")
    return found


def main() -> int:
    """Run the soak and print its summary; exit 1 when any run broke a rule."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=100, help="number of faulty logs")
    parser.add_argument("--seed", type=int, default=0, help="seed of the fault draws")
    parser.add_argument("--fit-every", type=int, default=10, help="also sysid fit every k-th log")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    base = base_arrays(duration_s=30.0, seed=args.seed)
    codes: dict[str, dict[int, int]] = {}
    peaks: list[float] = []
    times: list[float] = []
    failures: list[str] = []
    with tempfile.TemporaryDirectory(prefix="soak-") as tmp:
        folder = Path(tmp)
        for k in range(args.runs):
            faults = _faults(rng)
            log = write_faulty(folder / f"log{k}.mcap", faults, base)
            commands = {
                "logs info": (["logs", "info", log.name], None),
                "agree": (
                    [
                        "agree",
                        log.name,
                        "--robot",
                        ROBOT,
                        "--engine",
                        "reduced",
                        "--json",
                        f"a{k}.json",
                    ],
                    folder / f"a{k}.json",
                ),
            }
            if args.fit_every and k % args.fit_every == 0:
                commands["sysid fit"] = (
                    ["sysid", "fit", log.name, "--robot", ROBOT, "-o", f"p{k}.yaml"],
                    None,
                )
            for name, (argv, json_path) in commands.items():
                code, out, err, peak_mb, elapsed = _run(argv, folder)
                codes.setdefault(name, {}).setdefault(code, 0)
                codes[name][code] += 1
                peaks.append(peak_mb)
                times.append(elapsed)
                for problem in _problems(code, out, err, peak_mb, json_path):
                    failures.append(f"run {k} {name} {[f.kind for f in faults]}: {problem}")
    print(f"soak: {args.runs} faulty logs, seed {args.seed}")
    for name, by_code in codes.items():
        print(f"  {name:<10} exit codes {dict(sorted(by_code.items()))}")
    print(
        f"  peak RSS MB  min {min(peaks):.0f}  median {statistics.median(peaks):.0f}  "
        f"max {max(peaks):.0f}  (limit {PEAK_LIMIT_MB:.0f})"
    )
    print(
        f"  wall s/run   min {min(times):.2f}  median {statistics.median(times):.2f}  "
        f"max {max(times):.2f}"
    )
    for failure in failures:
        print(f"  FAIL {failure}")
    print("  all runs kept the rules" if not failures else f"  {len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
