"""`agree` says when the checked log leaves the envelope the fit saw (or that it is unknown)."""

from __future__ import annotations

import html
from pathlib import Path

import pytest
import yaml
from _agreement_fixtures import HIDDEN, ROBOT, write_log, write_params

from sim2real.cli import main


def _with_envelope(src: Path, dst: Path, **values: float) -> Path:
    doc = yaml.safe_load(src.read_text())
    doc["envelope"] = {"v_mps": 0.0, "w_radps": 1.5, "vw": 0.0, "dv_mps2": 0.5, "dw_radps2": 8.0}
    doc["envelope"].update(values)
    dst.write_text(yaml.safe_dump(doc))
    return dst


def test_a_spin_fit_checked_on_driving_says_where_it_extrapolates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = write_log(tmp_path / "drive.mcap", duration_s=20.0)
    plain = write_params(tmp_path / "p.yaml", HIDDEN)
    spin = _with_envelope(plain, tmp_path / "spin.yaml")  # as a spin-in-place fit writes it
    report = tmp_path / "r.html"
    argv = ["agree", str(log), "--robot", ROBOT, "--engine", "reduced", "--params", str(spin)]
    assert main([*argv, "--report", str(report)]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if "leaves the envelope the fit saw" in ln)
    assert "|v| up to" in line and "where the fit saw 0" in line
    assert "|v w| (turning while driving)" in line and "speed_lim_v_mps" in line
    assert line[4:] in html.unescape(report.read_text())  # the report says it too
    wide = _with_envelope(plain, tmp_path / "wide.yaml", v_mps=1.0, vw=5.0, dv_mps2=9.0)
    argv[-1] = str(wide)
    assert main(argv) == 0
    assert "envelope" not in capsys.readouterr().out  # inside: nothing to say
    argv[-1] = str(plain)
    assert main(argv) == 0
    assert "the envelope the fit saw is unknown (params file" in capsys.readouterr().out
