"""Timing helpers shared by the benchmarks: alternate the contenders, same repeat count, report
min/median/max, and time whole commands as a user runs them (cold and warm).

Not a public module (benchmarks are scripts); imported as ``from _timing import ...`` with the
``benchmarks/`` folder on ``sys.path`` (the scripts run from there).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

__all__ = [
    "CPU_S",
    "QUICK",
    "Stats",
    "alternate",
    "bench_arguments",
    "command_times",
    "fmt_ratio",
    "machine",
    "paired_ratios",
    "record",
    "timed_run",
]

REPO = Path(__file__).resolve().parents[1]
#: Where :func:`record` appends headline figures (``results_page.py`` turns them into
#: ``docs/benchmarks.md``).
#: CPU seconds (user + system) of every command run by :func:`command_times`, by command line:
#: on a loaded machine the wall time mostly measures the queue, the CPU time the work.
CPU_S: dict[str, list[float]] = {}
RESULTS = Path(os.environ.get("SIM2REAL_BENCH_RESULTS", REPO / "benchmarks" / ".results.jsonl"))
#: ``BENCH_QUICK=1`` (``make bench BENCH_QUICK=1``): fewer repeats and shorter runs, for checking
#: that every benchmark runs; the figures are then noisier (``docs/benchmarks.md`` says so).
QUICK = os.environ.get("BENCH_QUICK", "") not in ("", "0")


def bench_arguments(
    doc: str | None, *, fewer: str, parts: Sequence[str], only_help: str, repeatable: bool = True
) -> argparse.ArgumentParser:
    """The arguments the benchmarks with parts share: ``--quick`` (``fewer`` of something, or
    ``BENCH_QUICK=1``) and ``--only`` one of the ``parts`` (``repeatable``: a list of them)."""
    parser = argparse.ArgumentParser(description=(doc or "").splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=f"fewer {fewer} (or BENCH_QUICK=1)")
    action = "append" if repeatable else "store"
    parser.add_argument("--only", action=action, choices=parts, help=only_help)
    return parser


@dataclass(frozen=True, kw_only=True)
class Stats:
    """Wall-clock seconds of the repeats of one contender (and their CPU seconds).

    ``cpu_s`` is the process CPU time (user + system, :func:`time.process_time`) of each
    repeat, when measured: on a shared machine the wall time also counts the queue, the CPU
    time only this process's work (see :meth:`cpu`).
    """

    times_s: tuple[float, ...]
    cpu_s: tuple[float, ...] = ()

    def cpu(self) -> Stats:
        """The same repeats by CPU time (``times_s`` = ``cpu_s``)."""
        if not self.cpu_s:
            raise ValueError("no CPU times were measured for these repeats")
        return Stats(times_s=self.cpu_s, cpu_s=self.cpu_s)

    @property
    def min(self) -> float:
        return min(self.times_s)

    @property
    def median(self) -> float:
        return statistics.median(self.times_s)

    @property
    def max(self) -> float:
        return max(self.times_s)

    def fmt(self, scale: float = 1e3, unit: str = "ms") -> str:
        """``min/median/max`` in ``unit`` (``scale`` converts from seconds)."""
        return (
            f"{self.min * scale:.3g}/{self.median * scale:.3g}/{self.max * scale:.3g} {unit} "
            "(min/median/max)"
        )

    def rate(self, count: float) -> tuple[float, float, float]:
        """``count`` per second at (slowest, median, fastest) repeat."""
        return count / self.max, count / self.median, count / self.min


def alternate(
    contenders: Mapping[str, Callable[[], object]], repeats: int, *, warmup: bool = True
) -> dict[str, Stats]:
    """Time each contender ``repeats`` times, interleaved (a, b, a, b, ...) in one process.

    Wall and CPU time of each repeat (:class:`Stats`); the order flips every round, so neither
    contender always runs right after the other.
    """
    names = list(contenders)
    if warmup:
        for name in names:
            contenders[name]()
    times: dict[str, list[float]] = {name: [] for name in names}
    cpu: dict[str, list[float]] = {name: [] for name in names}
    for i in range(repeats):
        order = names if i % 2 == 0 else names[::-1]
        for name in order:
            c0, t0 = time.process_time(), time.perf_counter()
            contenders[name]()
            times[name].append(time.perf_counter() - t0)
            cpu[name].append(time.process_time() - c0)
    return {name: Stats(times_s=tuple(times[name]), cpu_s=tuple(cpu[name])) for name in names}


def fmt_ratio(num: Stats, den: Stats) -> str:
    """Per-repeat ratios num/den (paired by repeat): min/median/max."""
    ratios = [a / b for a, b in zip(num.times_s, den.times_s, strict=True)]
    return f"{min(ratios):.3g}/{statistics.median(ratios):.3g}/{max(ratios):.3g} (min/median/max)"


def paired_ratios(num: Stats, den: Stats) -> tuple[float, float, float]:
    """(min, median, max) of the per-repeat ratios num/den."""
    ratios = [a / b for a, b in zip(num.times_s, den.times_s, strict=True)]
    return min(ratios), statistics.median(ratios), max(ratios)


def timed_run(argv: Sequence[str], env: Mapping[str, str] | None = None) -> tuple[float, float]:
    """Wall-clock and CPU seconds (the child's user + system time) of one run of the command
    ``argv`` from the repository root; a non-zero exit raises."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    run_env = None if env is None else dict(env)
    subprocess.run(argv, check=True, capture_output=True, env=run_env, cwd=REPO)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime


def command_times(
    commands: Mapping[str, Sequence[str]], repeats: int
) -> dict[str, tuple[float, Stats]]:
    """Whole-process wall time of each command as a user runs it: (cold, warm stats).

    "Cold": the first run with empty bytecode and numba caches (``PYTHONPYCACHEPREFIX`` and
    ``NUMBA_CACHE_DIR`` pointed at fresh folders, so every module is compiled and every numba
    kernel built again; the OS file cache is not dropped). "Warm": ``repeats`` runs with the
    normal caches after one unmeasured run, the commands alternated (wall and CPU time of
    each, the CPU time being the child's user + system time).
    """
    import tempfile

    base_env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    # a user's installed package has its bytecode cached; PYTHONDONTWRITEBYTECODE (set in some
    # shells and CI) would make every "warm" run compile our editable sources again (~26 ms
    # for read_trace's 17 modules), while the peers' site-packages were byte-compiled at install
    base_env.pop("PYTHONDONTWRITEBYTECODE", None)

    def run(argv: Sequence[str], env: Mapping[str, str]) -> tuple[float, float]:
        wall, cpu = timed_run(argv, env)
        CPU_S.setdefault(" ".join(argv), []).append(cpu)
        return wall, cpu

    cold: dict[str, float] = {}
    for name, argv in commands.items():
        with tempfile.TemporaryDirectory() as pyc, tempfile.TemporaryDirectory() as nb:
            env = {**base_env, "PYTHONPYCACHEPREFIX": pyc, "NUMBA_CACHE_DIR": nb}
            cold[name] = run(argv, env)[0]
        run(argv, base_env)  # fill the normal caches
    warm: dict[str, list[tuple[float, float]]] = {name: [] for name in commands}
    names = list(commands)
    for i in range(repeats):
        for name in names if i % 2 == 0 else names[::-1]:
            warm[name].append(run(commands[name], base_env))
    return {
        name: (
            cold[name],
            Stats(times_s=tuple(w for w, _ in warm[name]), cpu_s=tuple(c for _, c in warm[name])),
        )
        for name in names
    }


def machine() -> str:
    """One line naming the machine: CPU model, cores, Python."""
    cpu = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {sys.version.split()[0]}"


def record(bench: str, figure: str, value: str, target: str, met: bool | None) -> None:
    """Append one headline figure to :data:`RESULTS` (one JSON object per line), with the
    name of the script that records it."""
    import json

    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    script = Path(sys.argv[0]).name
    row = {"bench": bench, "figure": figure, "value": value, "target": target, "met": met}
    row["script"] = script
    with RESULTS.open("a", encoding="utf-8") as fh:
        fh.write(json.dumps(row) + "\n")
