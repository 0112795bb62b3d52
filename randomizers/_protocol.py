"""Check that an env implements the protocol a physics-level randomizer needs.

The protocols (docs/ARCHITECTURE.md, "Env protocols") are methods on ``env.unwrapped``:

- camera: ``get_camera_pose() -> (xyz m, rpy rad)`` in the base frame,
  ``set_camera_pose(xyz, rpy)`` and ``get_camera_view_matrix() -> 16 floats``;
- drive: ``get_drive_params() -> robots.params.DriveParams`` and ``set_drive_params(params)``.

A pose or parameter set must survive the env's ``reset`` (randomizers set it just before the
reset, so the episode's first observation already uses it).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from randomizers.errors import MissingProtocolError

__all__ = ["CAMERA_PROTOCOL", "DRIVE_PROTOCOL", "require_protocol"]

CAMERA_PROTOCOL = ("get_camera_pose", "set_camera_pose", "get_camera_view_matrix")
DRIVE_PROTOCOL = ("get_drive_params", "set_drive_params")


def require_protocol(env: gym.Env[Any, Any], methods: tuple[str, ...], wrapper: str) -> Any:
    """Return ``env.unwrapped`` after checking it has every method in ``methods``."""
    base = env.unwrapped
    missing = [m for m in methods if not callable(getattr(base, m, None))]
    if missing:
        raise MissingProtocolError(
            f"{wrapper} needs env.unwrapped.{missing[0]}() (missing: {missing}), which "
            f"{type(base).__module__}.{type(base).__name__} does not have; implement "
            f"{list(methods)} on the env (see docs/ARCHITECTURE.md, 'Env protocols') or "
            "remove this wrapper"
        )
    return base
