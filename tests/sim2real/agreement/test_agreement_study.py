"""The agreement study as a library call (``sim2real.agreement.study``), and the thin CLI over it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from _agreement_fixtures import HIDDEN, ROBOT, write_log, write_params

from sim2real.agreement.figures import AGREEMENT_KEYS
from sim2real.agreement.latency import REFERENCE_KEYS
from sim2real.agreement.study import StudyConfig, run_study
from sim2real.cli import main
from sim2real.errors import Sim2RealValueError


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("study")
    return write_log(root / "val.mcap", duration_s=20.0), write_params(root / "p.yaml", HIDDEN)


def test_run_study_returns_the_figures_the_cli_writes(
    files: tuple[Path, Path], tmp_path: Path
) -> None:
    log, params = files
    out = tmp_path / "lib.json"
    result = run_study(
        StudyConfig(log=log, robot=ROBOT, params_path=params, engine="reduced", json_path=out)
    )
    assert [r.label for r in result.runs] == ["spec defaults", "sysid params"]
    assert result.main is result.runs[-1].agreement
    assert result.written == (out,)
    assert tuple(result.figures) == (*AGREEMENT_KEYS, *REFERENCE_KEYS, "notes")
    assert json.loads(out.read_text()) == result.figures
    cli_out = tmp_path / "cli.json"
    argv = ["agree", str(log), "--robot", ROBOT, "--engine", "reduced"]
    assert main([*argv, "--params", str(params), "--json", str(cli_out)]) == 0
    assert json.loads(cli_out.read_text()) == result.figures
    assert result.figures["agreement"] > 0.95


def test_band_level_sets_the_quantiles_of_the_band(files: tuple[Path, Path]) -> None:
    log, params = files
    kw = dict(log=log, robot=ROBOT, params_path=params, engine="reduced", ensemble_n=8)
    wide = run_study(StudyConfig(**kw, band_level=0.9)).ensemble  # type: ignore[arg-type]
    narrow = run_study(StudyConfig(**kw, band_level=0.5)).ensemble  # type: ignore[arg-type]
    assert wide is not None and narrow is not None
    assert wide.band_level == 0.9 and narrow.band_level == 0.5
    assert np.all(narrow.hi_v - narrow.lo_v <= wide.hi_v - wide.lo_v + 1e-12)
    assert np.sum(wide.hi_v - wide.lo_v) > np.sum(narrow.hi_v - narrow.lo_v)


@pytest.mark.parametrize("level", [0.0, 1.0, -0.2, 1.5, float("nan"), float("inf")])
def test_band_level_outside_0_1_is_refused(files: tuple[Path, Path], level: float) -> None:
    log, params = files
    config = StudyConfig(
        log=log, robot=ROBOT, params_path=params, engine="reduced", ensemble_n=3, band_level=level
    )
    with pytest.raises(Sim2RealValueError, match="--band-level"):
        run_study(config)


def test_agree_parses_the_params_file_once(
    files: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the point replay, the ensemble, the verdict's envelope and the report's parameter table
    # all use the params file: one command reads and parses it once
    log, params = files
    reads: list[Path] = []
    read_text = Path.read_text

    def counting(self: Path, *args: object, **kwargs: object) -> str:
        if self.resolve() == params.resolve():
            reads.append(self)
        return read_text(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(Path, "read_text", counting)
    argv = ["agree", str(log), "--robot", ROBOT, "--engine", "reduced", "--params", str(params)]
    report = tmp_path / "r.html"
    assert main([*argv, "--ensemble", "4", "--report", str(report)]) == 0
    assert report.is_file()
    assert len(reads) == 1
