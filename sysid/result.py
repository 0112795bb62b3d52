"""Results of a drive-model fit and their YAML file (``format: sim2real.sysid/1``).

The file layout is the one documented in ``docs/ARCHITECTURE.md``; ``robots.params``
reads it (``read_params_file`` / ``load_drive_params``) without importing sysid.

Examples
--------
>>> from sysid.result import SysidResult
>>> res = SysidResult.load("params.yaml")  # doctest: +SKIP
>>> res.estimate("delay_s").value  # doctest: +SKIP
0.118
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import yaml

from robots.errors import ParamsFileError
from robots.files import output_problem, plain_data, write_text_atomic
from robots.params import PARAMS_FILE_FORMAT, DriveParams, load_params_document
from robots.randomization import DriveDistribution
from sysid.envelope import Envelope
from sysid.errors import ResultFileError, SysidFileError

__all__ = ["STATUSES", "DataFile", "FitScores", "ParameterEstimate", "SysidResult"]

#: Allowed values of :attr:`ParameterEstimate.status`.
STATUSES = ("fitted", "prior", "fixed", "tied", "derived")


@dataclass(frozen=True, kw_only=True)
class ParameterEstimate:
    """One parameter (or identifiable combination) with its uncertainty.

    Attributes
    ----------
    name : str
        DriveParams field or identifiable combination name.
    value : float
        Estimate (spec prior when ``status == "fixed"``), in ``unit``.
    std : float or None
        Standard error (None for fixed parameters).
    ci95_low, ci95_high : float or None
        95 % confidence interval (None for fixed parameters).
    unit : str
        SI unit.
    status : str
        ``fitted`` (a MAP estimate the log informed), ``prior`` (not fitted: the log does not
        inform it, its posterior is its prior), ``fixed`` (known exactly or "no limit": no
        spread), ``tied`` (set equal to another parameter) or ``derived`` (an identifiable
        combination computed from the fitted ones).
    coord : str or None
        Coordinate kind of the field (:data:`robots.params.SCHEMA`), None for combinations.
    coord_std : float or None
        Posterior standard deviation in that coordinate.
    prior_sd : float or None
        Prior standard deviation in that coordinate (None: no prior).
    """

    name: str
    value: float
    std: float | None
    ci95_low: float | None
    ci95_high: float | None
    unit: str
    status: str
    coord: str | None = None
    coord_std: float | None = None
    prior_sd: float | None = None

    @property
    def sd_ratio(self) -> float | None:
        """Posterior / prior sd in coordinates: ~1 = the data did not inform it, << 1 = they
        did; None without a prior."""
        if self.coord_std is None or not self.prior_sd:
            return None
        return self.coord_std / self.prior_sd

    def to_yaml_dict(self) -> dict[str, Any]:
        """The mapping written under this parameter's name in the result file."""
        ci = None if self.ci95_low is None else [_num(self.ci95_low), _num(self.ci95_high)]
        out: dict[str, Any] = {
            "value": _num(self.value),
            "std": None if self.std is None else _num(self.std),
            "ci95": ci,
            "unit": self.unit,
            "status": self.status,
        }
        if self.coord is not None:
            ratio = self.sd_ratio
            out |= {
                "coord": self.coord,
                "coord_std": None if self.coord_std is None else _num(self.coord_std),
                "prior_sd": None if self.prior_sd is None else _num(self.prior_sd),
                "sd_ratio": None if ratio is None else round(_num(ratio), 4),
            }
        return out

    @classmethod
    def from_yaml_dict(cls, name: str, entry: Mapping[str, Any]) -> ParameterEstimate:
        """Inverse of :meth:`to_yaml_dict`."""
        ci = entry.get("ci95")
        return cls(
            name=name,
            value=float(entry["value"]),
            std=_opt(entry.get("std")),
            ci95_low=None if ci is None else float(ci[0]),
            ci95_high=None if ci is None else float(ci[1]),
            unit=str(entry.get("unit", "")),
            status=str(entry.get("status", "fixed")),
            coord=None if entry.get("coord") is None else str(entry["coord"]),
            coord_std=_opt(entry.get("coord_std")),
            prior_sd=_opt(entry.get("prior_sd")),
        )


@dataclass(frozen=True, kw_only=True)
class FitScores:
    """How well the fitted model reproduces one log (see :mod:`sysid.metrics`).

    Attributes
    ----------
    log : str
        Log name (file path, with ``[start:end]`` when cropped).
    n_samples, n_active : int
        Measurement samples, and those active in the agreement sense.
    fit_percent_v, fit_percent_w : float
        MATLAB ``compare`` FIT % per channel (NaN when the channel is constant).
    agreement, agreement_v, agreement_w : float
        Share of active samples within tolerance on both / each channel.
    rmse_v, rmse_w : float
        Root-mean-square error, m/s and rad/s.
    """

    log: str
    n_samples: int
    n_active: int
    fit_percent_v: float
    fit_percent_w: float
    agreement: float
    agreement_v: float
    agreement_w: float
    rmse_v: float
    rmse_w: float


@dataclass(frozen=True, kw_only=True)
class DataFile:
    """A log the result was computed from: name, sha256 (None if unknown) and role."""

    file: str
    sha256: str | None
    role: str  # "fit" or "validation"


@dataclass(frozen=True, kw_only=True)
class SysidResult:
    """Outcome of :func:`sysid.fit_drive`.

    Attributes
    ----------
    robot : str
        Robot (spec) name the parameters belong to.
    params : DriveParams
        The fitted drive parameters (ready for ``robots`` and the randomisers).
    estimates : tuple of ParameterEstimate
        Every DriveParams field with status and uncertainty.
    identifiable : tuple of ParameterEstimate
        Combinations the data identify independently of the motor-gain prior.
    correlation_names : tuple of str
        Fit coordinates (DriveParams fields) ordering :attr:`correlation`.
    correlation : tuple of tuple of float
        Correlation matrix of the fit coordinates (normalised, see :mod:`sysid._coords`).
    linear : dict
        Linearised first-order-plus-delay model per axis (python-control): transfer function,
        rise time, settling time, bandwidth.
    scores_fit, scores_validation : tuple of FitScores
        Scores on the fitting logs and on the validation logs.
    data : tuple of DataFile
        Files used, with sha256.
    tool_version : str
        Version of the sim2real distribution that produced the result.
    warnings : tuple of str
        Plain sentences about what the data could not identify or what was odd.
    settings : dict
        Fit settings (loss, dt, scales, free parameters, evaluations, cost).
    bootstrap_std : dict
        Block-bootstrap standard deviation of each fitted parameter (empty without bootstrap).
    randomization : DriveDistribution or None
        The calibrated distribution (``randomization`` block of the file): posterior (one log)
        or population (several logs) plus between-session spread, priors of the fields the
        logs did not inform, and the odometry noise model.
    sessions : tuple of dict
        Per-log estimates when several logs were fitted: ``{"log": name, "parameters":
        {field: {"value": .., "coord_std": ..}}}``.
    priors : dict
        ``{field: {"nominal", "sd", "session_sd", "coord", "source"}}``: the priors used.
    envelope : Envelope or None
        Where the fitting logs drove the robot (:mod:`sysid.envelope`); None when the file
        was written without one.
    """

    robot: str
    params: DriveParams
    estimates: tuple[ParameterEstimate, ...]
    identifiable: tuple[ParameterEstimate, ...]
    correlation_names: tuple[str, ...]
    correlation: tuple[tuple[float, ...], ...]
    linear: dict[str, Any] = field(default_factory=dict)
    scores_fit: tuple[FitScores, ...] = ()
    scores_validation: tuple[FitScores, ...] = ()
    data: tuple[DataFile, ...] = ()
    tool_version: str = "unknown"
    warnings: tuple[str, ...] = ()
    settings: dict[str, Any] = field(default_factory=dict)
    bootstrap_std: dict[str, float] = field(default_factory=dict)
    randomization: DriveDistribution | None = None
    sessions: tuple[dict[str, Any], ...] = ()
    priors: dict[str, dict[str, Any]] = field(default_factory=dict)
    envelope: Envelope | None = None

    @property
    def converged(self) -> bool:
        """False when the optimiser stopped at its evaluation limit (see :attr:`warnings`)."""
        return bool(self.settings.get("converged", True))

    def estimate(self, name: str) -> ParameterEstimate:
        """The estimate of DriveParams field or identifiable combination ``name``."""
        for est in (*self.estimates, *self.identifiable):
            if est.name == name:
                return est
        known = [e.name for e in (*self.estimates, *self.identifiable)]
        raise KeyError(f"no estimate named '{name}'; known: {known}")

    def to_dict(self) -> dict[str, Any]:
        """Plain nested mapping in the result-file layout."""
        return {
            "format": PARAMS_FILE_FORMAT,
            "robot": self.robot,
            "tool_version": self.tool_version,
            "parameters": {e.name: e.to_yaml_dict() for e in self.estimates},
            "identifiable": {e.name: e.to_yaml_dict() for e in self.identifiable},
            "correlation": {
                "names": list(self.correlation_names),
                "matrix": [[round(_num(c), 4) for c in row] for row in self.correlation],
            },
            "linear": plain_data(self.linear),
            "scores": {
                "fit": [plain_data(asdict(s)) for s in self.scores_fit],
                "validation": [plain_data(asdict(s)) for s in self.scores_validation],
            },
            "data": [asdict(d) for d in self.data],
            "warnings": list(self.warnings),
            "settings": plain_data(self.settings),
            "bootstrap_std": plain_data(self.bootstrap_std),
            "priors": plain_data(self.priors),
            "sessions": plain_data(list(self.sessions)),
            "randomization": None if self.randomization is None else self.randomization.to_dict(),
            "envelope": None if self.envelope is None else self.envelope.to_dict(),
        }

    def to_yaml(self) -> str:
        """The result file's text (YAML, ``.inf`` for 'no limit')."""
        return str(yaml.safe_dump(self.to_dict(), sort_keys=False, width=100))

    def save(self, path: str | Path) -> Path:
        """Write :meth:`to_yaml` to ``path`` atomically (:func:`robots.files.atomic_write`).

        Raises :class:`~sysid.errors.SysidFileError` when the folder does not exist or ``path``
        is a folder; nothing is left behind on failure.
        """
        problem = output_problem(path)
        if problem is not None:
            raise SysidFileError(problem)
        return write_text_atomic(path, self.to_yaml())

    @classmethod
    def load(cls, path: str | Path) -> SysidResult:
        """Read a result file written by :meth:`save`.

        Raises :class:`~sysid.errors.ResultFileError` for missing, unreadable or foreign files.
        """
        p = Path(path)
        try:
            doc = load_params_document(p)
        except ParamsFileError as exc:
            raise ResultFileError(str(exc)) from None
        if not isinstance(doc, dict) or doc.get("format") != PARAMS_FILE_FORMAT:
            if isinstance(doc, dict):
                got = repr(doc.get("format"))
            elif doc is None:
                got = "absent (the file is empty)"
            else:
                got = f"absent (the file holds a YAML {type(doc).__name__}, not a mapping)"
            raise ResultFileError(
                f"file '{p}' is not a sysid result: 'format' is {got}, expected "
                f"'{PARAMS_FILE_FORMAT}'; give a file written by 'sim2real sysid fit'"
            )
        try:
            return cls._from_doc(doc, p)
        except ParamsFileError as exc:
            raise ResultFileError(str(exc)) from None
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise ResultFileError(
                f"sysid result file '{p}' is malformed ({type(exc).__name__}: {exc}); "
                "regenerate it with 'sim2real sysid fit'"
            ) from None

    @classmethod
    def _from_doc(cls, doc: Mapping[str, Any], path: Path) -> SysidResult:
        estimates = tuple(
            ParameterEstimate.from_yaml_dict(k, v) for k, v in doc["parameters"].items()
        )
        params = DriveParams().replace(**{e.name: e.value for e in estimates})
        corr = doc.get("correlation") or {}
        scores = doc.get("scores") or {}
        return cls(
            robot=str(doc["robot"]),
            params=params,
            estimates=estimates,
            identifiable=tuple(
                ParameterEstimate.from_yaml_dict(k, v)
                for k, v in (doc.get("identifiable") or {}).items()
            ),
            correlation_names=tuple(corr.get("names") or ()),
            correlation=tuple(tuple(float(c) for c in row) for row in corr.get("matrix") or ()),
            linear=dict(doc.get("linear") or {}),
            scores_fit=tuple(FitScores(**s) for s in scores.get("fit") or ()),
            scores_validation=tuple(FitScores(**s) for s in scores.get("validation") or ()),
            data=tuple(DataFile(**d) for d in doc.get("data") or ()),
            tool_version=str(doc.get("tool_version", "unknown")),
            warnings=tuple(str(w) for w in doc.get("warnings") or ()),
            settings=dict(doc.get("settings") or {}),
            bootstrap_std={str(k): float(v) for k, v in (doc.get("bootstrap_std") or {}).items()},
            randomization=(
                None
                if doc.get("randomization") is None
                else DriveDistribution.from_dict(
                    doc["randomization"], robot=str(doc["robot"]), source=f"{path}: randomization"
                )
            ),
            sessions=tuple(dict(s) for s in doc.get("sessions") or ()),
            priors={str(k): dict(v) for k, v in (doc.get("priors") or {}).items()},
            envelope=Envelope.from_dict(doc.get("envelope") or {}),
        )


def _opt(x: Any) -> float | None:
    return None if x is None else float(x)


def _num(x: float | None) -> float:
    """A float YAML can hold (numpy scalars to float; inf/nan kept)."""
    return math.nan if x is None else float(x)
