"""`sim2real demo` commands (not written yet)."""

from __future__ import annotations

import argparse

__all__ = ["register"]


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register the `demo` command group (placeholder until its issue lands)."""
