"""Do the fit's 95 % intervals hold the truth on plants drawn from the priors?

Each plant is a ``turtlebot3_burger`` drive drawn from its spec's priors
(:class:`robots.randomization.DriveDistribution`), driven by a 20 s random step sequence and
fitted (``sysid.fit_drive``, the spec's priors) from that one synthetic log. Per fitted field it
prints how many of the 95 % intervals hold the truth, per plant seed and pooled over all
plants, with a Wilson 95 % interval of the pooled share, and the pooled share over every field.
Seeds 29 and 47 were looked at while the fit's starts were designed; 61 and 73 were not.

``tests/sysid/test_sysid_calibration.py`` runs the plants of one seed (its comment argues the
size and the thresholds); this script runs all of them (120 plants, about 420 s of CPU).

Run: ``.venv/bin/python benchmarks/bench_sysid_coverage.py [--seeds 29:24,47:48,61:24,73:24]``
(``BENCH_QUICK=1``: seed 61 alone)
"""

from __future__ import annotations

import argparse
import collections
import importlib
import math
import resource
import sys
import time
from pathlib import Path
from typing import Any

from _timing import QUICK, record


def _tests(name: str) -> Any:
    """A module of the repository's ``tests`` package (not installed: the checkout's)."""
    root = str(Path(__file__).resolve().parents[1])
    if root not in sys.path:
        sys.path.insert(0, root)
    return importlib.import_module(name)


def wilson(hits: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval of a binomial share (``z`` 1.96: 95 %)."""
    if n == 0:
        return (0.0, 1.0)
    p = hits / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (centre - half, centre + half)


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument(
        "--seeds",
        default=None,
        help="plant seeds and counts, SEED:N,... (default: 29:24,47:48,61:24,73:24)",
    )
    args = parser.parse_args()
    diagnostic = _tests("tests.sysid.test_sysid_calibration")
    map_in_processes = _tests("tests.processes").map_in_processes
    if args.seeds:
        seeds = tuple(
            (int(s), int(n)) for s, n in (item.split(":") for item in args.seeds.split(","))
        )
    else:
        seeds = ((61, 24),) if QUICK else diagnostic.ALL_PLANT_SEEDS
    start = time.process_time()
    t0 = time.perf_counter()
    per_seed = []
    for seed, n in seeds:
        per_seed.append(
            (seed, map_in_processes(diagnostic.fit_plant, diagnostic.plant_cases(((seed, n),))))
        )
    hits: dict[int, collections.Counter[str]] = {}
    fits: dict[int, collections.Counter[str]] = {}
    spurious = collections.Counter[int]()
    for seed, results in per_seed:
        hits[seed], fits[seed] = collections.Counter(), collections.Counter()
        for _, fitted in results:
            for name, truth, low, high in fitted:
                if math.isinf(truth):
                    spurious[seed] += 1
                    continue
                fits[seed][name] += 1
                hits[seed][name] += low is not None and high is not None and low <= truth <= high
    names = sorted(set().union(*(f.keys() for f in fits.values())))
    head = "".join(f"{seed:>10}" for seed, _ in seeds)
    print(f"{'field':<26}{head}{'pooled':>10}  Wilson 95 %")
    total_hits = total_n = 0
    lowest = (1.0, "")
    for name in names:
        cells, h_all, n_all = "", 0, 0
        for seed, _ in seeds:
            h, n = hits[seed][name], fits[seed][name]
            cells += f"{h:>4}/{n:<5}" if n else f"{'-':>10}"
            h_all, n_all = h_all + h, n_all + n
        lo, hi = wilson(h_all, n_all)
        share = h_all / n_all
        lowest = min(lowest, (share, name))
        total_hits, total_n = total_hits + h_all, total_n + n_all
        print(f"{name:<26}{cells}{share:>10.3f}  {lo:.3f}-{hi:.3f}")
    lo, hi = wilson(total_hits, total_n)
    print(
        f"{'every field':<26}{'':>{10 * len(seeds)}}{total_hits / total_n:>10.3f}"
        f"  {lo:.3f}-{hi:.3f}"
    )
    n_plants = sum(n for _, n in seeds)
    print(
        f"spurious acceleration limits: {sum(spurious.values())} of {2 * n_plants} (per seed "
        + ", ".join(f"{seed}: {spurious[seed]}" for seed, _ in seeds)
        + ")"
    )
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = time.process_time() - start + children.ru_utime + children.ru_stime
    print(
        f"{n_plants} plants, {time.perf_counter() - t0:.0f} s wall, {cpu:.0f} s CPU"
        " (this process and its worker processes)"
    )
    record(
        "sysid coverage",
        f"lowest field's 95 % interval coverage ({n_plants} plants)",
        f"{lowest[1]} {lowest[0]:.3f}",
        f">= {diagnostic.COVERAGE_FIELD}",
        lowest[0] >= diagnostic.COVERAGE_FIELD,
    )


if __name__ == "__main__":
    main()
