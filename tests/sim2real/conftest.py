"""Fixtures of the sim2real tests: runs several modules check, computed once per test run."""

from __future__ import annotations

from tests.sim2real.shared_runs import demo_run

__all__ = ["demo_run"]
