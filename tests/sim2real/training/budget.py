"""A time budget that judges the code, not the machine: CPU seconds always, wall seconds where
the load average does not exceed the cores."""

from __future__ import annotations

import os
import resource
import time
import warnings
from collections.abc import Iterator
from contextlib import contextmanager


def _cpu_s() -> float:
    """CPU seconds of this process and its reaped children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


@contextmanager
def within_budget(budget_s: float) -> Iterator[None]:
    """Fail when the block takes ``budget_s`` CPU seconds or more; fail on its wall clock only
    where the load average is at most the cores (a busier machine's wall clock measures the
    machine: the run's summary shows a warning instead).

    Examples
    --------
    >>> with within_budget(5.0):
    ...     _ = sum(range(1000))
    """
    cpu0, wall0 = _cpu_s(), time.perf_counter()
    yield
    cpu_s, wall_s = _cpu_s() - cpu0, time.perf_counter() - wall0
    assert cpu_s < budget_s, f"{cpu_s:.1f} CPU-s (budget {budget_s:.0f} s)"
    load = os.getloadavg()[0]
    if load <= (os.cpu_count() or 1):
        assert wall_s < budget_s, (
            f"{wall_s:.1f} s wall, {cpu_s:.1f} CPU-s (budget {budget_s:.0f} s)"
        )
    else:
        warnings.warn(
            f"wall clock not judged: load average {load:.1f} exceeds {os.cpu_count()} cores "
            f"({wall_s:.1f} s wall, {cpu_s:.1f} CPU-s)",
            stacklevel=3,
        )
