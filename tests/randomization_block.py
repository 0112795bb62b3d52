"""Test helper: a ``randomization:`` block (sim2real.randomization/2) around given parameters.

The block varies every field the robot spec gives an informative prior, centred on the given
parameter values, with the prior covariance times ``rel**2``; the other fields are fixed at the
given values. Real params files get this block from ``sim2real sysid fit``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml

from robots.params import SCHEMA, BaseGeometry, DriveParams
from robots.randomization import DriveDistribution, ObservationNoise
from robots.spec import load_spec

__all__ = ["distribution_around", "write_params_file"]


def distribution_around(
    params: DriveParams,
    robot: str,
    *,
    rel: float = 0.3,
    noise_v: float = 0.003,
    noise_w: float = 0.02,
) -> DriveDistribution:
    """A distribution centred on ``params`` (spec prior covariance x ``rel**2``).

    A term that ``params`` switch off (a ``lin`` field at 0 on its lower bound, e.g. the P loop's
    ``speed_loop_ki_per_s = 0``) is fixed: a spread centred on the bound only draws one side.
    """
    spec = load_spec(robot)
    prior = DriveDistribution.from_priors(spec.name, spec.geometry, spec.priors, session=False)
    off = {
        n
        for n in prior.names
        if not SCHEMA[n].coord.startswith("log")
        and float(getattr(params, n)) == SCHEMA[n].lower == 0.0
    }
    keep = [i for i, n in enumerate(prior.names) if n not in off]
    names = tuple(prior.names[i] for i in keep)
    mean = tuple(_coord(params, n, spec.geometry) for n in names)
    cov = prior.covariance_array[np.ix_(keep, keep)] * rel**2
    return DriveDistribution(
        robot=spec.name,
        geometry=spec.geometry,
        names=names,
        mean=mean,
        covariance=tuple(tuple(float(c) for c in row) for row in np.atleast_2d(cov)),
        fixed={n: float(getattr(params, n)) for n in DriveParams.names() if n not in names},
        noise=ObservationNoise(std_v_mps=noise_v, std_w_radps=noise_w),
    )


def _coord(params: DriveParams, name: str, geometry: BaseGeometry) -> float:
    """``name``'s coordinate at ``params`` (a friction per unit of ``params``' own total)."""
    f = SCHEMA[name]
    total = None if f.per_field is None else f.total_of(geometry, getattr(params, f.per_field))
    return f.to_coord(float(getattr(params, name)), geometry, total)


def write_params_file(
    path: Path,
    params: DriveParams,
    robot: str,
    *,
    fitted: dict[str, float] | None = None,
    rel: float = 0.3,
    noise_v: float = 0.003,
    noise_w: float = 0.02,
    extra: dict[str, Any] | None = None,
) -> Path:
    """A params file: ``fitted`` values (5 % std) under ``parameters`` plus the block."""
    values = fitted if fitted is not None else {}
    doc: dict[str, Any] = {
        "format": "sim2real.sysid/1",
        "robot": robot,
        "tool_version": "test",
        "parameters": {
            k: {"value": float(v), "std": 0.05 * abs(float(v)), "ci95": None, "status": "fitted"}
            for k, v in values.items()
        },
        "randomization": distribution_around(
            params, robot, rel=rel, noise_v=noise_v, noise_w=noise_w
        ).to_dict(),
        **(extra or {}),
    }
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    return path
