"""`sim2real logs` commands (not written yet)."""

from __future__ import annotations

import argparse

__all__ = ["register"]


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register the `logs` command group (placeholder until its issue lands)."""
