"""sim2real: close the sim-to-real gap of mobile-robot navigation policies.

The distribution installs four import packages:

- :mod:`sysid` fits the drive-model parameters (friction, inertia, delay, limits) to logs;
- :mod:`robots` builds pybullet models of real bases from spec files and runs the drive model;
- :mod:`randomizers` holds gymnasium wrappers for domain randomisation;
- :mod:`sim2real` (this package) reads and writes MCAP logs, replays logs in simulation,
  measures sim-vs-real agreement, writes the report, and provides the CLI and reference envs.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

__all__ = ["__version__"]

try:
    __version__ = version("sim2real")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"
