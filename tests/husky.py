"""The Husky A200 spec as ``robots new husky`` writes it from Clearpath's published numbers.

Several test modules build the same skid steer; they write it through :func:`husky_spec`.
"""

from __future__ import annotations

from pathlib import Path

from robots.spec import RobotSpec, load_spec
from robots.template import spec_text


def husky_spec(folder: Path, *, drive: str = "skid", max_speed_mps: float = 1.0) -> RobotSpec:
    """``robots new husky --drive DRIVE`` from the A200 datasheet (track 0.555 m, wheel radius
    0.165 m, 50 kg, 1.0 m/s unless ``max_speed_mps`` says otherwise), written to
    ``folder / f"husky_{drive}.yaml"`` and loaded."""
    path = folder / f"husky_{drive}.yaml"
    path.write_text(
        spec_text(
            "husky",
            wheel_separation_m=0.555,
            wheel_radius_m=0.165,
            mass_kg=50.0,
            max_speed_mps=max_speed_mps,
            drive=drive,
        )
    )
    return load_spec(path)
