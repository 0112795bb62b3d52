"""sim2real: close the sim-to-real gap of mobile-robot navigation policies.

The distribution installs four import packages:

- :mod:`sysid` fits the drive-model parameters (friction, inertia, delay, limits) to logs;
- :mod:`robots` builds pybullet models of real bases from spec files and runs the drive model;
- :mod:`randomizers` holds gymnasium wrappers for domain randomisation;
- :mod:`sim2real` (this package) reads and writes MCAP logs, replays logs in simulation,
  measures sim-vs-real agreement, writes the report, and provides the CLI and reference envs.
"""

from __future__ import annotations

from typing import Any

__all__ = ["__version__"]


def __getattr__(name: str) -> Any:
    # importlib.metadata costs tens of ms at start-up: looked up only when asked for (PEP 562)
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("sim2real")
        except PackageNotFoundError:  # pragma: no cover - running from a source tree
            value = "0.0.0+unknown"
        globals()["__version__"] = value
        return value
    raise AttributeError(f"module 'sim2real' has no attribute {name!r}")
