"""Fixtures of the documentation tests: the demo run the sim2real tests check too (one run)."""

from __future__ import annotations

from tests.sim2real.shared_runs import demo_run

__all__ = ["demo_run"]
