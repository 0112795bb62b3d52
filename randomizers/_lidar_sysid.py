"""The per-episode lidar noise distribution of a ``sim2real sysid sensors`` result (private).

The result file (``format: sim2real.sysid.sensors/1``) gives the noise model
:math:`\\sigma(r) = \\sigma_0 + \\sigma_1 r` and the invalid-return rate, each with a 95 %
interval. :class:`SensorNoiseDistribution` reads each as a normal with the estimate as mean and
the interval's half width over 1.96 as standard deviation, and draws one value per episode:
``spread`` (1 = as identified) multiplies the standard deviations, like the dynamics; draws
are clipped to ``>= 0`` (the rate to ``[0, 1]``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import yaml

from randomizers.errors import RandomizerConfigError

__all__ = [
    "SENSORS_FORMAT",
    "FromSensors",
    "SensorNoiseDistribution",
    "load_sensor_noise",
    "scan_latency_s",
]

#: The ``format`` key of a ``sim2real sysid sensors`` result.
SENSORS_FORMAT = "sim2real.sysid.sensors/1"
_Z95 = 1.959963984540054


@dataclass(frozen=True, kw_only=True)
class SensorNoiseDistribution:
    """Means and standard deviations of ``std_m`` (m), ``std_per_m`` (m/m) and ``dropout``."""

    std_m: tuple[float, float]
    std_per_m: tuple[float, float]
    std_per_m2: tuple[float, float]
    dropout: tuple[float, float]
    range_min_m: float
    range_max_m: float

    def sample(self, rng: np.random.Generator, spread: float) -> tuple[float, float, float, float]:
        """One episode's ``(std_m, std_per_m, std_per_m2, dropout)``.

        Examples
        --------
        >>> d = SensorNoiseDistribution(std_m=(0.0, 0.0), std_per_m=(0.005, 0.001),
        ...                             std_per_m2=(0.0, 0.0), dropout=(0.05, 0.01),
        ...                             range_min_m=0.02, range_max_m=5.0)
        >>> s0, s1, s2, p = d.sample(np.random.default_rng(0), 1.0)
        >>> bool(s0 == 0.0 and 0.0 < s1 < 0.01 and 0.0 < p < 0.1)
        True
        """
        z = rng.standard_normal(4)
        s0 = max(0.0, self.std_m[0] + spread * self.std_m[1] * z[0])
        s1 = max(0.0, self.std_per_m[0] + spread * self.std_per_m[1] * z[1])
        s2 = max(0.0, self.std_per_m2[0] + spread * self.std_per_m2[1] * z[2])
        p = min(1.0, max(0.0, self.dropout[0] + spread * self.dropout[1] * z[3]))
        return s0, s1, s2, p


def _field(data: dict[str, Any], key: str, path: Path) -> tuple[float, float]:
    value = data.get(key)
    ci = data.get(key.removesuffix("_m") + "_ci" if key == "noise_std_0_m" else key + "_ci")
    if value is None or not isinstance(ci, list) or len(ci) != 2 or None in ci:
        raise RandomizerConfigError(
            f"sensor file '{path}' has no identified '{key}' (the recording could not identify "
            "it: see its 'unidentified' notes); record a still stretch and identify again, or "
            "give LidarNoise std_m and dropout by hand"
        )
    mean = float(value)
    sd = (float(ci[1]) - float(ci[0])) / (2.0 * _Z95)
    if not (math.isfinite(mean) and math.isfinite(sd)):
        raise RandomizerConfigError(f"sensor file '{path}' key '{key}' is not finite: {value!r}")
    return mean, max(sd, 0.0)


def scan_latency_s(path: str | Path) -> tuple[float, float]:
    """The scan's latency against odometry as a ``[low, high]`` delay range, s.

    ``time_offset_s`` is added to scan stamps to reach the odometry's clock, so a negative
    offset means the scan is older than its stamp says: the delay range is the negated 95 %
    interval of the offset, clipped to >= 0.
    """
    p = Path(path)
    data = _read(p)
    ci = data.get("time_offset_ci")
    if data.get("time_offset_s") is None or not isinstance(ci, list) or None in ci:
        raise RandomizerConfigError(
            f"sensor file '{p}' has no identified 'time_offset_s' (see its 'unidentified' "
            "notes); record turns that start and stop and identify again, or give delay_s by hand"
        )
    return max(0.0, -float(ci[1])), max(0.0, -float(ci[0]))


def _read(p: Path) -> dict[str, Any]:
    """The mapping of a sensor result file (format checked)."""
    try:
        data = yaml.safe_load(p.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        raise RandomizerConfigError(
            f"sensor file '{p}' cannot be read as YAML ({exc}); give the file written by "
            "`sim2real sysid sensors`"
        ) from None
    if not isinstance(data, dict) or data.get("format") != SENSORS_FORMAT:
        raise RandomizerConfigError(
            f"sensor file '{p}' is not a '{SENSORS_FORMAT}' file; write one with "
            "`sim2real sysid sensors`"
        )
    return data


def load_sensor_noise(path: str | Path, section: str | None = None) -> SensorNoiseDistribution:
    """Read the noise distribution of a ``sim2real sysid sensors`` result file: the lidar's,
    or with ``section="depth"`` the depth camera's (depth limits 0 and infinity)."""
    p = Path(path)
    data = _read(p)
    if section is not None:
        part = data.get(section)
        if not isinstance(part, dict):
            raise RandomizerConfigError(
                f"sensor file '{p}' has no '{section}' section (its recordings had no depth "
                "image topic with still frames); identify with a depth topic recorded "
                "(--depth-topic) or give DepthNoise std_m by hand"
            )
        data = {"range_min_m": 0.0, "range_max_m": math.inf, **part}
    return SensorNoiseDistribution(
        std_m=_field(data, "noise_std_0_m", p),
        std_per_m=_field(data, "noise_std_per_m", p),
        std_per_m2=_field(data, "noise_std_per_m2", p),
        dropout=_field(data, "dropout", p),
        range_min_m=float(data["range_min_m"]),
        range_max_m=float(data["range_max_m"]),
    )


class FromSensors:
    """``from_sysid`` and the per-episode draw of a noise randomizer built from a ``sim2real
    sysid sensors`` result (the lidar's noise, or with ``_SECTION = "depth"`` the camera's)."""

    _SECTION: ClassVar[str | None] = None
    _dist: SensorNoiseDistribution | None
    _spread: float
    rng: np.random.Generator
    std_m: float
    std_per_m: float
    std_per_m2: float
    dropout: float

    @classmethod
    def from_sysid(
        cls,
        path: str | Path,
        *,
        env: Any = None,
        spread: float = 1.0,
        **kwargs: Any,
    ) -> Any:
        """Noise drawn per episode from a ``sim2real sysid sensors`` result.

        Each episode draws ``std_m``, ``std_per_m``, ``std_per_m2`` and ``dropout`` from
        normals centred on the identified values with the standard deviations of their 95 %
        intervals times ``spread`` (1 = as identified), clipped to >= 0; the curriculum
        ``scale`` then multiplies the noise and dropout as usual. Other keyword arguments
        (``key``, ``index``, the sensor's limits, ``scale``, ``name``) pass through. Without
        ``env`` it returns a picklable ``env -> wrapper`` callable.

        Examples
        --------
        >>> from randomizers import LidarNoise
        >>> make = LidarNoise.from_sysid("sensors.yaml", spread=2.0)  # doctest: +SKIP
        >>> env = make(base_env)  # doctest: +SKIP
        """
        load_sensor_noise(path, section=cls._SECTION)  # fail here, not in a worker
        make: Any = cls  # a randomizer class: (env, sysid=..., spread=..., **kwargs)
        factory: Any = functools.partial(make, sysid=str(path), spread=spread, **kwargs)
        return factory if env is None else factory(env)

    def _keep_model(
        self,
        model: tuple[float, float, float, float],
        dist: SensorNoiseDistribution | None,
        spread: float,
    ) -> None:
        """Keep the noise model ``(std_m, std_per_m, std_per_m2, dropout)`` in force and the
        identified distribution each episode draws it from (None: the model stays)."""
        self.std_m, self.std_per_m, self.std_per_m2, self.dropout = model
        self._dist = dist
        self._spread = spread

    def sample_episode(self) -> None:
        """Draw this episode's noise from the identified distribution (with ``sysid``)."""
        if self._dist is not None:
            draw = self._dist.sample(self.rng, self._spread)
            self.std_m, self.std_per_m, self.std_per_m2, self.dropout = draw
