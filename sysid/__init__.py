"""System identification of a differential-drive base's drive-model parameters."""

from __future__ import annotations

__all__: list[str] = []
