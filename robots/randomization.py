r"""The one distribution of drive parameters (and odometry noise) that every sampler draws from.

A :class:`DriveDistribution` is a Gaussian in the fit coordinates of
:data:`robots.params.SCHEMA` (``lin`` for delay and friction, ``log`` for gains and limits,
``log_total_mass`` / ``log_total_inertia`` for the payload), plus fixed values for every other
field and an :class:`ObservationNoise` model. ``sim2real sysid fit`` writes it to the
``randomization:`` block of a params file; ``agree --ensemble``,
``DynamicsRandomizer.from_sysid`` and the envs draw from it with :meth:`DriveDistribution.sample`
-- same seed, same draws everywhere.

Sampling: :math:`z = \mu + s\,\Sigma^{1/2}\,\mathrm{clip}(e, \pm c)` with :math:`\Sigma^{1/2}`
the symmetric (principal) square root of the covariance, :math:`e \sim \mathcal N(0, I)`
truncated at :math:`c` = :data:`TRUNCATE_SIGMA` per component and :math:`s` the ``spread``. The
principal root is a continuous function of :math:`\Sigma` (an eigenvector basis is not: with two
equal variances a 1e-16 change rotates it, and every draw with it), so a params file that
changes in its last digit draws nearly the same robots. Each coordinate is
then kept inside the schema's plausible range and mapped back to a value. Total mass and yaw
inertia are :math:`e^z > 0` and limits :math:`e^z > 0` by construction, so every draw is a
physical robot.

The block (``format: sim2real.randomization/2``; a format-1 block, whose friction coordinates
were the values themselves, is read and converted)::

    randomization:
      format: sim2real.randomization/2
      robot: turtlebot3_burger
      geometry: {mass_kg: .., yaw_inertia_kgm2: .., wheel_radius_m: .., wheel_separation_m: ..}
      names: [delay_s, added_mass_kg, ...]     # fields that vary
      coords: [lin, log_total_mass, per_total_mass, ...]   # their coordinate kinds (the schema's)
      mean: [...]                              # in coordinates
      covariance: [[...], ...]                 # in coordinates
      fixed: {cmd_timeout_s: 0.5, accel_lim_v_mps2: .inf, ...}   # every other field
      noise: {v: {std_mps: .., quantum_mps: ..}, w: {std_radps: .., quantum_radps: ..}}

Examples
--------
>>> import numpy as np
>>> from robots.spec import load_spec
>>> spec = load_spec("turtlebot3_burger")
>>> dist = DriveDistribution.from_priors(spec.name, spec.geometry, spec.priors)
>>> draws = dist.sample(np.random.default_rng(0), 3)
>>> all(p.total_mass_kg(spec.geometry) > 0 for p in draws)
True
>>> draws == dist.sample(np.random.default_rng(0), 3)  # same generator state, same robots
True
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from statistics import NormalDist
from typing import Any

import numpy as np

from robots.arrays import FloatArray
from robots.errors import ParamsFileError, RobotsValueError
from robots.params import (
    SCHEMA,
    BaseGeometry,
    DriveParams,
    ParamsFile,
    Prior,
    coords_to_values,
    params_file_for,
)

__all__ = [
    "RANDOMIZATION_FORMAT",
    "TRUNCATE_SIGMA",
    "DriveDistribution",
    "ObservationNoise",
    "apply_noise",
    "cap_spread",
    "spread_limit",
]


_NORMAL = NormalDist()
#: the smallest upper-tail probability a truncated draw maps to (a bound ~37 sd out)
_TINY = 1e-300

#: ``format:`` key of the ``randomization`` block.
RANDOMIZATION_FORMAT = "sim2real.randomization/2"
#: The earlier format, read and converted: its friction coordinates were the values (``lin``),
#: where format 2 has them per unit of the total mass or yaw inertia (``per_total_*``).
_FORMAT_1 = "sim2real.randomization/1"
#: Draws are truncated at this many standard deviations per component (keeps 99.99 %
#: of the mass, the variance shrinks by 0.1 %, and no draw is an absurd robot).
TRUNCATE_SIGMA = 4.0
#: Largest odometry noise accepted from a file (m/s, rad/s): beyond it the "noise" is the
#: signal, and the file is wrong.
_MAX_NOISE = {"v": 1.0, "w": 5.0}


def spread_limit(name: str, geometry: BaseGeometry) -> float:
    """Largest standard deviation of field ``name`` that a ``randomization`` block accepts, in
    its schema coordinate: ``absurd_sd`` (times the prior sd for a ``lin`` or ``per_total_*``
    coordinate).

    Examples
    --------
    >>> from robots.params import BaseGeometry
    >>> geo = BaseGeometry(wheel_radius_m=0.033, wheel_separation_m=0.16, mass_kg=1.0,
    ...                    yaw_inertia_kgm2=0.01)
    >>> spread_limit("accel_lim_v_mps2", geo)  # a log coordinate: a factor e**3
    3.0
    """
    field = SCHEMA[name]
    limit = field.absurd_sd
    if not field.coord.startswith("log"):  # lin, per_total_*: relative to the prior's spread
        limit *= max(field.prior_sd(geometry), 1e-12)
    return float(limit)


def cap_spread(
    cov: FloatArray, names: Sequence[str], geometry: BaseGeometry, *, share: float = 0.99
) -> FloatArray:
    """``cov`` with every field's sd held at or below ``share`` x :func:`spread_limit`
    (correlations kept: rows and columns are scaled together, so the result stays PSD).

    A field the logs barely inform (an acceleration limit that almost never acted) can come
    out of a fit or a calibration with a posterior wider than any robot of its kind; it is
    capped rather than refused.

    Examples
    --------
    >>> import numpy as np
    >>> from robots.params import BaseGeometry
    >>> geo = BaseGeometry(wheel_radius_m=0.033, wheel_separation_m=0.16, mass_kg=1.0,
    ...                    yaw_inertia_kgm2=0.01)
    >>> capped = cap_spread(np.diag([25.0, 0.04]), ["accel_lim_v_mps2", "delay_s"], geo)
    >>> np.round(np.sqrt(np.diag(capped)), 3).tolist()
    [2.97, 0.2]
    """
    limit = np.array([share * spread_limit(n, geometry) for n in names])
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    shrink = np.minimum(1.0, limit / np.maximum(sd, 1e-300))
    out: FloatArray = np.asarray(cov, dtype=np.float64) * np.outer(shrink, shrink)
    return out


@dataclass(frozen=True, kw_only=True)
class ObservationNoise:
    """Odometry noise model: white noise and quantisation of the reported v and w.

    Attributes
    ----------
    std_v_mps, std_w_radps : float
        Standard deviation of the white noise on v (m/s) and w (rad/s).
    quantum_v_mps, quantum_w_radps : float
        Resolution of the reported values (an encoder tick per odometry period), 0 = none.
    """

    std_v_mps: float = 0.0
    std_w_radps: float = 0.0
    quantum_v_mps: float = 0.0
    quantum_w_radps: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            limit = _MAX_NOISE["v" if "_v_" in f.name else "w"]
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            if not (ok and math.isfinite(value) and 0.0 <= value <= limit):
                raise RobotsValueError(
                    f"observation noise '{f.name}' must be a finite number in [0, {limit}], got "
                    f"{value!r}; refit the params file or fix the value"
                )

    def to_dict(self) -> dict[str, dict[str, float]]:
        """The ``noise`` mapping of the block."""
        return {
            "v": {"std_mps": self.std_v_mps, "quantum_mps": self.quantum_v_mps},
            "w": {"std_radps": self.std_w_radps, "quantum_radps": self.quantum_w_radps},
        }

    @classmethod
    def from_dict(cls, data: Any, *, source: str = "noise") -> ObservationNoise:
        """Inverse of :meth:`to_dict`; ``source`` names the mapping in errors."""
        keys = {"v": ("std_mps", "quantum_mps"), "w": ("std_radps", "quantum_radps")}
        if not isinstance(data, Mapping) or set(data) != set(keys):
            raise ParamsFileError(
                f"{source} must be a mapping with keys 'v' and 'w', got {data!r}; e.g. "
                "{v: {std_mps: 0.004, quantum_mps: 0.0}, w: {std_radps: 0.02, quantum_radps: 0.0}}"
            )
        values: dict[str, Any] = {}
        for axis, (std_key, q_key) in keys.items():
            entry = data[axis]
            if not isinstance(entry, Mapping) or set(entry) != {std_key, q_key}:
                raise ParamsFileError(
                    f"{source}.{axis} must be a mapping with keys '{std_key}' and '{q_key}', "
                    f"got {entry!r}"
                )
            unit = std_key.removeprefix("std_")
            values[f"std_{axis}_{unit}"] = entry[std_key]
            values[f"quantum_{axis}_{unit}"] = entry[q_key]
        try:
            return cls(**values)
        except RobotsValueError as exc:
            raise ParamsFileError(f"{source}: {exc}") from None

    def apply(
        self, rng: np.random.Generator, v: Any, w: Any, *, spread: float = 1.0
    ) -> tuple[FloatArray, FloatArray]:
        """Noisy, quantised copies of ``v`` and ``w`` (v noise drawn first, then w)."""
        return apply_noise(rng, v, w, noise=self, spread=spread)


def apply_noise(
    rng: np.random.Generator, v: Any, w: Any, *, noise: Any, spread: float = 1.0
) -> tuple[FloatArray, FloatArray]:
    """Noisy, quantised copies of ``v`` and ``w``: white noise of sd ``noise.std_v_mps`` and
    ``noise.std_w_radps`` (numbers, or one per sample along the last axis), v drawn first,
    then rounded to ``noise.quantum_v_mps`` and ``noise.quantum_w_radps`` (0 = none).

    Examples
    --------
    >>> n = ObservationNoise(std_v_mps=0.0, std_w_radps=0.0, quantum_v_mps=0.5)
    >>> apply_noise(np.random.default_rng(0), [0.2, 0.3], [0.1, 0.1], noise=n)[0].tolist()
    [0.0, 0.5]
    """
    va = np.asarray(v, dtype=np.float64)
    wa = np.asarray(w, dtype=np.float64)
    nv = va + spread * np.asarray(noise.std_v_mps) * rng.standard_normal(va.shape)
    nw = wa + spread * np.asarray(noise.std_w_radps) * rng.standard_normal(wa.shape)
    if noise.quantum_v_mps > 0:
        nv = np.round(nv / noise.quantum_v_mps) * noise.quantum_v_mps
    if noise.quantum_w_radps > 0:
        nw = np.round(nw / noise.quantum_w_radps) * noise.quantum_w_radps
    return nv, nw


def _principal_root(cov: FloatArray) -> FloatArray:
    """The symmetric PSD square root :math:`R = V \\Lambda^{1/2} V^T` of ``cov`` (:math:`R R = \\Sigma`).

    Unlike the factor :math:`V\\Lambda^{1/2}` it does not depend on which eigenvector basis
    ``eigh`` returns for a repeated eigenvalue, so it moves continuously with ``cov``. Tiny
    negative eigenvalues from rounding count as zero.
    """
    eig, vec = np.linalg.eigh(cov)
    root: FloatArray = (vec * np.sqrt(np.clip(eig, 0.0, None))) @ vec.T
    return root


@dataclass(frozen=True, kw_only=True)
class DriveDistribution:
    """A Gaussian over drive parameters in schema coordinates, fixed values and odometry noise.

    Attributes
    ----------
    robot : str
        Robot (spec) name the distribution belongs to.
    geometry : BaseGeometry
        The spec geometry (the total-mass and total-inertia coordinates are relative to it).
    names : tuple of str
        DriveParams fields that vary, in the order of :attr:`mean`.
    mean : tuple of float
        Mean in coordinates.
    covariance : tuple of tuple of float
        Covariance in coordinates (symmetric, positive semi-definite).
    fixed : dict
        ``{field: value}`` for every other DriveParams field (may be inf for limits).
    noise : ObservationNoise
        Odometry noise model.
    lower : dict
        ``{field: value}``: lower bounds that the fitted logs prove for limits they never
        reached (the log needed this much, so the robot has at least that). Draws of these
        fields (``log`` coordinates only) follow their marginal truncated below the bound
        (see :meth:`sample_coords`); the mean is kept.
    """

    robot: str
    geometry: BaseGeometry
    names: tuple[str, ...]
    mean: tuple[float, ...]
    covariance: tuple[tuple[float, ...], ...]
    fixed: dict[str, float] = field(default_factory=dict)
    noise: ObservationNoise = field(default_factory=ObservationNoise)
    lower: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        _validate(self, "DriveDistribution")
        _validate_lower(self.lower, self.names, "DriveDistribution.lower")

    # --- views -------------------------------------------------------------------------------

    @property
    def coords(self) -> tuple[str, ...]:
        """Coordinate kind of each varying field (from :data:`robots.params.SCHEMA`)."""
        return tuple(SCHEMA[n].coord for n in self.names)

    @property
    def mean_array(self) -> FloatArray:
        """:attr:`mean` as an array."""
        return np.array(self.mean, dtype=np.float64)

    @property
    def covariance_array(self) -> FloatArray:
        """:attr:`covariance` as a (k, k) array."""
        return np.array(self.covariance, dtype=np.float64).reshape(len(self.names), -1)

    def std(self) -> dict[str, float]:
        """Standard deviation of each varying field, in coordinate units."""
        return dict(zip(self.names, np.sqrt(np.diag(self.covariance_array)).tolist(), strict=True))

    def params_at(self, z: Sequence[float]) -> DriveParams:
        """The DriveParams at coordinate vector ``z`` (kept inside the schema's range)."""
        changes = dict(self.fixed)
        changes |= coords_to_values(self.names, z, self.geometry, self.fixed)
        return DriveParams(**changes)

    def mean_params(self) -> DriveParams:
        """The DriveParams at the mean (the representative point estimate)."""
        return self.params_at(self.mean)

    # --- sampling ----------------------------------------------------------------------------

    def sample_coords(self, rng: np.random.Generator, n: int, *, spread: float = 1.0) -> FloatArray:
        r"""``n`` draws in coordinates, shape (n, k) (see the module docstring).

        A field with a lower bound :math:`L` (:attr:`lower`) is then mapped through its
        marginal :math:`N(\mu, \sigma^2)`, :math:`\sigma` = spread x its sd, onto the same
        normal truncated below :math:`L`:
        :math:`z' = \mu + \sigma\,\Phi^{-1}(a + (1 - a)\,\Phi((z - \mu)/\sigma))`,
        :math:`a = \Phi((L - \mu)/\sigma)`. The map is monotone, so the draws keep their
        ranks and correlations, and the same generator state gives the same robots.
        """
        _check_draw_args(rng, n, spread)
        k = len(self.names)
        e = np.clip(rng.standard_normal((n, k)), -TRUNCATE_SIGMA, TRUNCATE_SIGMA)
        out: FloatArray = self.mean_array + spread * e @ _principal_root(self.covariance_array)
        for name, bound in self.lower.items():
            j = self.names.index(name)
            sd = spread * math.sqrt(max(float(self.covariance_array[j, j]), 0.0))
            out[:, j] = _truncated_below(out[:, j], self.mean[j], sd, math.log(bound))
        return out

    def sample(self, rng: np.random.Generator, n: int, *, spread: float = 1.0) -> list[DriveParams]:
        """``n`` physical parameter sets drawn from the distribution.

        ``spread`` multiplies every standard deviation (1 = as fitted). Draws come from
        ``rng.standard_normal((n, k))``: same generator state, same robots (the module's
        example).
        """
        return [self.params_at(z) for z in self.sample_coords(rng, n, spread=spread)]

    def sample_noise(
        self, rng: np.random.Generator, v: Any, w: Any, *, spread: float = 1.0
    ) -> tuple[FloatArray, FloatArray]:
        """Odometry as the robot would report ``v`` and ``w``: noise, then quantisation."""
        _check_draw_args(rng, 1, spread)
        return self.noise.apply(rng, v, w, spread=spread)

    def scaled(self, factor: float) -> DriveDistribution:
        """The same distribution with every standard deviation times ``factor``."""
        if isinstance(factor, bool) or not (
            isinstance(factor, int | float) and math.isfinite(factor) and factor >= 0
        ):
            raise RobotsValueError(
                f"scale factor must be a finite number >= 0, got {factor!r}; e.g. 1.5"
            )
        cov = self.covariance_array * float(factor) ** 2
        return DriveDistribution(
            robot=self.robot,
            geometry=self.geometry,
            names=self.names,
            mean=self.mean,
            covariance=_tuples(cov),
            fixed=dict(self.fixed),
            noise=self.noise,
            lower=dict(self.lower),
        )

    # --- construction and files --------------------------------------------------------------

    @classmethod
    def from_priors(
        cls,
        robot: str,
        geometry: BaseGeometry,
        priors: Mapping[str, Prior],
        *,
        session: bool = True,
        noise: ObservationNoise | None = None,
    ) -> DriveDistribution:
        """The prior predictive distribution: every informative prior varies, with variance
        ``sd**2`` (+ ``session_sd**2`` when ``session``); the others are fixed at their nominal.

        Examples
        --------
        >>> from robots.spec import load_spec
        >>> spec = load_spec("turtlebot3_burger")
        >>> "delay_s" in DriveDistribution.from_priors(spec.name, spec.geometry, spec.priors).names
        True
        """
        names = [n for n in SCHEMA if priors[n].informative]
        var = [priors[n].sd ** 2 + (priors[n].session_sd ** 2 if session else 0.0) for n in names]
        return cls(
            robot=robot,
            geometry=geometry,
            names=tuple(names),
            mean=tuple(priors[n].mean(geometry) for n in names),
            covariance=_tuples(np.diag(var)),
            fixed={n: priors[n].nominal for n in SCHEMA if n not in names},
            noise=noise or ObservationNoise(),
        )

    def to_dict(self) -> dict[str, Any]:
        """The ``randomization`` block (plain YAML types; ``lower`` only when there are bounds)."""
        lower = {"lower": {k: float(v) for k, v in self.lower.items()}} if self.lower else {}
        return {
            "format": RANDOMIZATION_FORMAT,
            "robot": self.robot,
            "geometry": {
                f.name: float(getattr(self.geometry, f.name)) for f in fields(BaseGeometry)
            },
            "names": list(self.names),
            "coords": list(self.coords),
            "mean": [float(x) for x in self.mean],
            "covariance": [[float(c) for c in row] for row in self.covariance],
            "fixed": {k: float(v) for k, v in self.fixed.items()},
            "noise": self.noise.to_dict(),
            **lower,
        }

    @classmethod
    def from_dict(
        cls, block: Any, *, robot: str | None = None, source: str = "randomization"
    ) -> DriveDistribution:
        """Read a ``randomization`` block; ``source`` names it in errors (file and key).

        Raises :class:`~robots.errors.ParamsFileError` (one sentence naming the key, the rule,
        the value and the fix) for another robot's block, missing keys, NaN/inf or absurd
        spreads, a covariance that is not symmetric positive semi-definite, unknown fields.
        """
        return _parse_block(cls, block, robot=robot, source=source)

    @classmethod
    def from_params_file(cls, path: str | Path | ParamsFile, *, robot: str) -> DriveDistribution:
        """The distribution in the ``randomization`` block of a params file for ``robot``.

        ``path`` is the file, or a :class:`~robots.params.ParamsFile` read already.

        Examples
        --------
        >>> dist = DriveDistribution.from_params_file("params.yaml", robot="turtlebot2")
        ... # doctest: +SKIP
        >>> dist.sample(np.random.default_rng(0), 10)  # doctest: +SKIP
        """
        pf = params_file_for(path, robot)
        if "randomization" not in pf.document:
            raise ParamsFileError(
                f"params file '{pf.path}' has no 'randomization' block; refit it with "
                "'sim2real sysid fit' (this version writes one)"
            )
        return cls.from_dict(
            pf.document["randomization"],
            robot=robot,
            source=f"params file '{pf.path}': randomization",
        )


# ----------------------------------------------------------------------------- helpers


def _tuples(matrix: FloatArray) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(c) for c in row) for row in np.atleast_2d(matrix))


def _check_draw_args(rng: Any, n: Any, spread: Any) -> None:
    if not isinstance(rng, np.random.Generator):
        raise RobotsValueError(
            f"rng must be a numpy.random.Generator, got {type(rng).__name__}; "
            "e.g. numpy.random.default_rng(0)"
        )
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
        raise RobotsValueError(f"number of draws n must be an integer >= 1, got {n!r}")
    if isinstance(spread, bool) or not (
        isinstance(spread, int | float) and math.isfinite(spread) and spread >= 0
    ):
        raise RobotsValueError(f"spread must be a finite number >= 0, got {spread!r}; e.g. 1.0")


def _fail(source: str, key: str, rule: str, value: Any, fix: str) -> ParamsFileError:
    return ParamsFileError(f"{source}.{key} {rule}, got {value!r}; {fix}")


@dataclass(frozen=True, kw_only=True)
class _Parts:
    """The fields of a distribution that :func:`_validate` checks."""

    geometry: BaseGeometry
    names: tuple[str, ...]
    mean: tuple[float, ...]
    covariance: tuple[tuple[float, ...], ...]
    fixed: Mapping[str, float]


#: What the validators check: a distribution, or the parts of one read from a file.
_Checked = _Parts | DriveDistribution

_BLOCK_KEYS = frozenset(
    {"format", "robot", "geometry", "names", "coords", "mean", "covariance", "fixed", "noise"}
)
_REFIT = "refit the params file with 'sim2real sysid fit'"


def _validate(dist: _Checked, source: str) -> None:
    """Check a distribution (raises ParamsFileError naming the key and the field)."""
    _validate_names(dist, source)
    _validate_mean(dist, source)
    _validate_covariance(dist, source)
    try:
        values = dict(dist.fixed)
        values |= coords_to_values(dist.names, dist.mean, dist.geometry, dist.fixed)
        DriveParams(**values)
    except RobotsValueError as exc:
        raise ParamsFileError(f"{source}: {exc}; {_REFIT}") from None


def _validate_names(dist: _Checked, source: str) -> None:
    k = len(dist.names)
    if k == 0:
        raise _fail(source, "names", "must list at least one varying field", [], _REFIT)
    unknown = [n for n in dist.names if n not in SCHEMA]
    if unknown or len(set(dist.names)) != k:
        raise _fail(
            source,
            "names",
            f"must be distinct DriveParams fields ({list(SCHEMA)})",
            list(dist.names),
            _REFIT,
        )
    missing = [n for n in SCHEMA if n not in dist.names and n not in dist.fixed]
    extra = [n for n in dist.fixed if n not in SCHEMA or n in dist.names]
    if missing or extra:
        raise _fail(
            source,
            "fixed",
            f"must give every field not in names exactly once (missing {missing}, extra {extra})",
            sorted(dist.fixed),
            _REFIT,
        )


def _validate_mean(dist: _Checked, source: str) -> None:
    k = len(dist.names)
    if len(dist.mean) != k:
        raise _fail(source, "mean", f"must be {k} numbers (one per name)", list(dist.mean), _REFIT)
    for name, x in zip(dist.names, dist.mean, strict=True):
        if not (isinstance(x, int | float) and math.isfinite(x)):
            raise _fail(source, "mean", f"entry of '{name}' must be a finite number", x, _REFIT)


def _validate_covariance(dist: _Checked, source: str) -> None:
    k = len(dist.names)
    rows_ok = all(len(row) == k for row in dist.covariance)
    cov = np.array(dist.covariance, dtype=np.float64) if rows_ok else np.zeros((0,))
    if cov.shape != (k, k):
        raise _fail(source, "covariance", f"must be a {k} x {k} matrix", dist.covariance, _REFIT)
    for i, name in enumerate(dist.names):
        _validate_variance(name, float(cov[i, i]), dist.geometry, source)
    bad = np.argwhere(~np.isfinite(cov) | ~np.isclose(cov, cov.T, rtol=1e-6, atol=1e-12))
    if bad.size:
        i, j = (int(a) for a in bad[0])
        raise _fail(
            source,
            "covariance",
            f"must be finite and symmetric; the entry of ('{dist.names[i]}', '{dist.names[j]}')",
            float(cov[i, j]),
            _REFIT,
        )
    eig = np.linalg.eigvalsh(cov)
    if eig[0] < -1e-9 * max(float(eig[-1]), 1e-300):
        raise _fail(
            source,
            "covariance",
            "must be positive semi-definite (smallest eigenvalue)",
            float(eig[0]),
            _REFIT,
        )


def _validate_variance(name: str, var: float, geometry: BaseGeometry, source: str) -> None:
    limit = spread_limit(name, geometry)
    if not (math.isfinite(var) and var >= 0):
        raise _fail(
            source,
            "covariance",
            f"variance of '{name}' must be a finite number >= 0",
            var,
            _REFIT,
        )
    if math.sqrt(var) > limit:
        raise _fail(
            source,
            "covariance",
            f"standard deviation of '{name}' must be <= {limit:.3g} in its "
            f"{SCHEMA[name].coord} coordinate (wider is an absurd spread)",
            math.sqrt(var),
            _REFIT,
        )


def _parse_block(
    cls: type[DriveDistribution], block: Any, *, robot: str | None, source: str
) -> DriveDistribution:
    old = _check_block_head(block, robot=robot, source=source)
    names, coords = block["names"], block["coords"]
    _check_names_coords(names, coords, old=old, source=source)
    parts = _block_parts(block, names, source)
    if old:
        parts = _from_format_1(parts, coords)
    _validate(parts, source)
    return cls(
        robot=str(block["robot"]),
        geometry=parts.geometry,
        names=parts.names,
        mean=parts.mean,
        covariance=parts.covariance,
        fixed=dict(parts.fixed),
        noise=ObservationNoise.from_dict(block["noise"], source=f"{source}.noise"),
        lower=_parse_lower(block.get("lower", {}), parts.names, f"{source}.lower"),
    )


def _check_block_head(block: Any, *, robot: str | None, source: str) -> bool:
    """Refuse a block without its keys, of another format or robot; whether it is format 1."""
    if not isinstance(block, Mapping) or not block:
        raise ParamsFileError(f"{source} must be a non-empty mapping, got {block!r}; {_REFIT}")
    keys = sorted(_BLOCK_KEYS)
    missing = sorted(_BLOCK_KEYS - set(block))
    unknown = sorted(set(block) - _BLOCK_KEYS - {"lower"})  # 'lower' is optional
    if missing or unknown:
        raise _fail(
            source,
            "keys",
            f"must be {keys} (missing {missing}, unknown {unknown})",
            sorted(block),
            _REFIT,
        )
    if block["format"] not in (RANDOMIZATION_FORMAT, _FORMAT_1):
        raise _fail(source, "format", f"must be '{RANDOMIZATION_FORMAT}'", block["format"], _REFIT)
    if robot is not None and block["robot"] != robot:
        raise _fail(
            source,
            "robot",
            f"must be '{robot}' (this block is for another robot)",
            block["robot"],
            f"use the params file of {robot} or pass --robot {block['robot']}",
        )
    return bool(block["format"] == _FORMAT_1)


def _check_names_coords(names: Any, coords: Any, *, old: bool, source: str) -> None:
    """Refuse field names that are not a list of strings, or coordinate kinds off the schema."""
    if not (isinstance(names, list) and all(isinstance(n, str) for n in names)):
        raise _fail(source, "names", "must be a list of DriveParams field names", names, _REFIT)
    if not isinstance(coords, list) or len(coords) != len(names):
        raise _fail(
            source, "coords", f"must be a list of {len(names)} coordinate kinds", coords, _REFIT
        )
    for n, c in zip(names, coords, strict=True):
        if old and n in SCHEMA and SCHEMA[n].per_field is not None and c == "lin":
            continue  # format 1: the value itself, converted below
        if n in SCHEMA and SCHEMA[n].coord != c:
            raise _fail(source, "coords", f"entry of '{n}' must be '{SCHEMA[n].coord}'", c, _REFIT)


def _block_parts(block: Mapping[str, Any], names: list[str], source: str) -> _Parts:
    """The block's geometry, mean, covariance and fixed values, each read as numbers."""
    geometry = _parse_geometry(block["geometry"], f"{source}.geometry")
    fixed = block["fixed"]
    if not isinstance(fixed, Mapping):
        raise _fail(source, "fixed", "must be a mapping of field: value", fixed, _REFIT)
    return _Parts(
        geometry=geometry,
        names=tuple(names),
        mean=tuple(_floats(block["mean"], f"{source}.mean", any_float=True)),
        covariance=tuple(
            tuple(_floats(row, f"{source}.covariance", any_float=True))
            for row in _rows(block["covariance"], source)
        ),
        fixed={
            str(k): _floats([v], f"{source}.fixed.{k}", allow_inf=True)[0] for k, v in fixed.items()
        },
    )


def _parse_lower(value: Any, names: Sequence[str], source: str) -> dict[str, float]:
    if not isinstance(value, Mapping):
        raise _fail(
            source.rpartition(".")[0], "lower", "must be a mapping of field: lower bound", value,
            _REFIT,
        )  # fmt: skip
    out = {str(k): _floats([v], f"{source}.{k}")[0] for k, v in value.items()}
    _validate_lower(out, names, source)
    return out


def _validate_lower(lower: Mapping[str, float], names: Sequence[str], source: str) -> None:
    """Bounds only on varying fields of ``log`` coordinates, each a finite number > 0."""
    for name, bound in lower.items():
        if name not in names or SCHEMA[name].coord != "log":
            raise ParamsFileError(
                f"{source}.{name}: a lower bound needs a varying field with a 'log' coordinate "
                f"(one of {[n for n in names if SCHEMA[n].coord == 'log']}), got {name!r}; "
                "refit the params file with 'sim2real sysid fit'"
            )
        if isinstance(bound, bool) or not (
            isinstance(bound, int | float) and math.isfinite(bound) and bound > 0
        ):
            raise ParamsFileError(
                f"{source}.{name} must be a finite number > 0, got {bound!r}; refit the params "
                "file with 'sim2real sysid fit'"
            )


def _truncated_below(z: FloatArray, mu: float, sd: float, bound: float) -> FloatArray:
    """``z`` drawn from N(mu, sd^2) mapped onto that normal truncated below ``bound``."""
    if sd <= 0.0:
        return np.maximum(z, bound)
    beta = (bound - mu) / sd
    u = [min(max(_NORMAL.cdf((x - mu) / sd), 1e-15), 1.0 - 1e-15) for x in z.tolist()]
    if beta <= 0.0:  # the bound below the mean: Phi^-1(a + (1 - a) u), a = Phi(beta)
        a = _NORMAL.cdf(beta)
        std = [_NORMAL.inv_cdf(a + (1.0 - a) * x) for x in u]
    else:  # above it, from the upper tail, where a rounds to 1: -Phi^-1((1 - u) Phi(-beta))
        # Phi(-beta) from erfc: NormalDist.cdf's 1 + erf(...) cancels to 0 beyond ~8 sd
        tail = 0.5 * math.erfc(beta / math.sqrt(2.0))
        std = [-_NORMAL.inv_cdf(max((1.0 - x) * tail, _TINY)) for x in u]
    return np.maximum(mu + sd * np.array(std, dtype=np.float64), bound)


def _from_format_1(parts: _Parts, coords: Sequence[str]) -> _Parts:
    r"""A format-1 block in format-2 coordinates: each friction's value :math:`F` becomes
    :math:`F/T` (:math:`T` its total mass or yaw inertia, :math:`e^{z_T}` when that varies too,
    else the spec's plus the fixed payload), the covariance mapped with the Jacobian at the mean
    (:math:`\partial(F/T)/\partial F = 1/T`, :math:`\partial(F/T)/\partial z_T = -F/T`). Shapes
    the validation refuses are passed through for it to name."""
    k = len(parts.names)
    cov = np.array(parts.covariance, dtype=np.float64)
    if len(parts.mean) != k or cov.shape != (k, k) or not all(n in SCHEMA for n in parts.names):
        return parts
    mean = np.array(parts.mean, dtype=np.float64)
    jac = np.eye(k)
    for i, (name, coord) in enumerate(zip(parts.names, coords, strict=True)):
        per = SCHEMA[name].per_field
        if per is None or coord != "lin":
            continue
        if per in parts.names:
            j = parts.names.index(per)
            total = math.exp(float(mean[j]))
            jac[i, j] = -float(mean[i]) / total
        else:
            total = SCHEMA[name].total_of(parts.geometry, parts.fixed.get(per, 0.0))
        if not total > 0:
            return parts
        jac[i, i] = 1.0 / total
    new_cov = jac @ cov @ jac.T
    return _Parts(
        geometry=parts.geometry,
        names=parts.names,
        mean=tuple(float(x) for x in np.diag(jac) * mean),
        covariance=tuple(tuple(float(c) for c in row) for row in 0.5 * (new_cov + new_cov.T)),
        fixed=parts.fixed,
    )


def _rows(value: Any, source: str) -> list[Any]:
    if not isinstance(value, list) or not all(isinstance(r, list) for r in value):
        raise _fail(
            source,
            "covariance",
            "must be a list of rows (lists of numbers)",
            value,
            "refit the params file with 'sim2real sysid fit'",
        )
    return value


def _floats(
    values: Any, where: str, *, allow_inf: bool = False, any_float: bool = False
) -> list[float]:
    """Numbers of a YAML list (``any_float``: NaN/inf pass, the caller names the field)."""
    ok = isinstance(values, list) and all(
        isinstance(x, int | float) and not isinstance(x, bool) for x in values
    )
    if ok:
        out = [float(x) for x in values]
        if any_float or all(math.isfinite(x) or (allow_inf and x == math.inf) for x in out):
            return out
    raise ParamsFileError(
        f"{where} must hold {'numbers (.inf allowed)' if allow_inf else 'finite numbers'}, got "
        f"{values!r}; refit the params file with 'sim2real sysid fit'"
    )


def _parse_geometry(value: Any, where: str) -> BaseGeometry:
    names = [f.name for f in fields(BaseGeometry)]
    if not isinstance(value, Mapping) or sorted(value) != sorted(names):
        raise ParamsFileError(
            f"{where} must be a mapping with keys {names}, got {value!r}; refit the params file"
        )
    try:
        return BaseGeometry(**{n: _floats([value[n]], f"{where}.{n}")[0] for n in names})
    except RobotsValueError as exc:
        raise ParamsFileError(f"{where}: {exc}") from None
