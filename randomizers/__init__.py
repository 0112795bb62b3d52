"""Gymnasium wrappers for domain randomisation (sensor noise, delays, camera pose, dynamics)."""

from __future__ import annotations

__all__: list[str] = []
