"""``python -m sim2real ...`` runs the ``sim2real`` command line."""

from __future__ import annotations

import sys

from sim2real.cli import run

__all__: list[str] = []

if __name__ == "__main__":
    sys.exit(run())
