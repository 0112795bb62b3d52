"""Run by ``test_cluster_lost.py`` as a script: map_tasks on a Ray cluster that dies mid-run.

Argv: the head's ``HOST:PORT`` and a file whose appearance tells the test to kill the head.
Prints one JSON line: the results, the warnings, the wall time.
"""

from __future__ import annotations

import json
import os
import sys
import time
import warnings
from pathlib import Path

from sim2real.cluster import map_tasks

DRIVER = os.getpid()
N = 400


def item(x: tuple[int, str]) -> int:
    """``i * i``. A Ray task holds its batch (60 s), so the cluster dies holding it; this
    process starts only once a Ray task runs (the test kills the head then), so that it cannot
    finish every item before Ray connects."""
    i, flag = x
    if os.getpid() != DRIVER:
        Path(flag).touch()
        time.sleep(60.0)
    deadline = time.monotonic() + 120.0
    while not Path(flag).exists() and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.002)
    return i * i


def main() -> None:
    address, flag = sys.argv[1], sys.argv[2]
    t0 = time.monotonic()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = map_tasks(item, [(i, flag) for i in range(N)], address=address)
    import ray

    out = {
        "ok": got == [i * i for i in range(N)],
        "warnings": [f"{w.category.__name__}: {w.message}" for w in caught],
        "ray_initialized": ray.is_initialized(),
        "wall_s": time.monotonic() - t0,
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
