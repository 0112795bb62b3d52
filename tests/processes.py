"""Run a test's independent expensive cases (fits) in worker processes, one per core.

The suite runs in one pytest process, which leaves the second core of a two-core CI machine
idle; a test made of many independent fits (120 in the coverage diagnostic) hands them to
worker processes instead. The results are the same as in process: each case is a pure
function of its arguments (seeded), and they come back in order.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")


def cores() -> int:
    """The CPUs this process may run on (its affinity mask, not the machine's count)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def map_in_processes(fn: Callable[[T], R], items: Sequence[T]) -> list[R]:
    """``[fn(x) for x in items]``, in up to :func:`cores` fresh worker processes.

    Parameters
    ----------
    fn : callable
        A module-level function (it is pickled by name); it must not depend on state the test
        set up in this process (monkeypatches do not reach the workers).
    items : sequence
        Its arguments, picklable.

    Returns
    -------
    list
        ``fn(x)`` for each item, in the items' order. With one core (or one item) the items
        run here, in order, as a plain loop would.

    Notes
    -----
    The workers are spawned, not forked: a fork of a process that holds threads (numba,
    pybullet, a BLAS pool) may deadlock. A worker's exception is re-raised here.
    """
    workers = min(cores(), len(items))
    if workers <= 1:
        return [fn(x) for x in items]
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        return list(pool.map(fn, items))


def process_table() -> dict[int, tuple[int, str]]:
    """pid -> (parent pid, command line with spaces) of every process (Linux ``/proc``; empty
    elsewhere). Processes that exit while it is read are left out."""
    table: dict[int, tuple[int, str]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
            cmd = (stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        table[int(stat.parent.name)] = (int(text[text.rindex(")") + 2 :].split()[1]), cmd)
    return table


def descendants(root: int, table: Mapping[int, tuple[int, str]] | None = None) -> list[int]:
    """The pids below ``root`` in ``table`` (default: :func:`process_table` now), sorted."""
    table = process_table() if table is None else table
    ours, grew = {root}, True
    while grew:
        new = {pid for pid, (pp, _) in table.items() if pp in ours} - ours
        grew, ours = bool(new), ours | new
    return sorted(ours - {root})
