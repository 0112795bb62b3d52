"""Recordings that excite one axis, and fleets with a bad log: every defined figure, no null."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from _agreement_fixtures import HIDDEN, ROBOT, write_log, write_params

from sim2real.cli import main


def _agree(*args: str | Path) -> int:
    return main(["agree", *map(str, args), "--robot", ROBOT, "--engine", "reduced"])


@pytest.mark.parametrize(("axes", "gone"), [("w", "v"), ("v", "w")])
def test_a_one_axis_log_gives_every_defined_figure_and_names_the_rest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], axes: str, gone: str
) -> None:
    log = write_log(tmp_path / f"only_{axes}.mcap", duration_s=20.0, axes=axes)
    out = tmp_path / "agree.json"
    assert _agree(log, "--json", out) == 0
    figures = json.loads(out.read_text())
    assert None not in [v for k, v in figures.items() if k != "params_file"]
    for key in (f"fit_percent_{gone}", f"lag_s_{gone}"):
        assert key not in figures
        assert any(f"figure '{key}' is left out" in n for n in figures["notes"])
    assert f"fit_percent_{axes}" in figures and f"lag_s_{axes}" in figures
    assert 0.0 <= figures["agreement"] <= 1.0 and figures[f"agreement_{gone}"] > 0.9
    stdout = capsys.readouterr().out
    assert f"note: figure 'fit_percent_{gone}' is left out: the measured {gone} is constant" in (
        stdout
    )


def test_a_log_without_measured_motion_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = write_log(tmp_path / "still.mcap", duration_s=20.0, axes="")
    assert _agree(log) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "no sample is active" in err or "constant on both axes" in err


def test_a_fleet_goes_on_past_one_axis_and_corrupt_logs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """10 logs, 2 spinning in place and 1 corrupt: exit 0, 9 rows of figures, 1 saying why."""
    logs = [
        write_log(tmp_path / f"s{k}.mcap", duration_s=12.0, seed=k, axes="w" if k < 2 else "vw")
        for k in range(9)
    ]
    corrupt = tmp_path / "s9.mcap"
    corrupt.write_bytes(b"\x89MCAP0\r\n" + b"not an mcap at all" * 50)
    params = write_params(tmp_path / "p.yaml", HIDDEN)
    out = tmp_path / "fleet.json"
    code = _agree(*logs, corrupt, "--params", params, "--json", out)
    stdout = capsys.readouterr().out
    assert code == 0
    rows = [ln for ln in stdout.splitlines() if ln.startswith("s") and ".mcap" in ln]
    assert len(rows) == 10
    assert sum("left out:" in r for r in rows) == 1 and "s9.mcap  left out:" in stdout
    assert sum("%" in r for r in rows) == 9
    doc = json.loads(out.read_text())
    assert len(doc["logs"]) == 10 and doc["summary"]["n_logs"] == 9
    assert doc["summary"]["n_left_out"] == 1 and "error" in doc["logs"][9]
    spin = doc["logs"][0]
    assert "lag_s_v" not in spin and "fit_percent_v" not in spin and spin["agreement"] > 0.5


def test_a_fleet_with_no_usable_log_exits_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = []
    for k in range(2):
        bad.append(tmp_path / f"bad{k}.mcap")
        bad[-1].write_bytes(b"junk" * 100)
    assert _agree(*bad) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "none of the 2 logs could be used" in err


def test_sysid_fit_goes_on_past_a_bad_log(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A spin-in-place session and a good one are fitted; the corrupt log's note says why."""
    spin = write_log(tmp_path / "spin.mcap", duration_s=15.0, axes="w")
    good = write_log(tmp_path / "good.mcap", duration_s=15.0, seed=3)
    corrupt = tmp_path / "corrupt.mcap"
    corrupt.write_bytes(b"junk" * 100)
    out = tmp_path / "p.yaml"
    argv = ["sysid", "fit", str(spin), str(good), str(corrupt), "--robot", ROBOT, "-o", str(out)]
    assert main(argv) == 0 and out.is_file()
    stdout = " ".join(capsys.readouterr().out.split())
    assert "note: left out: log file" in stdout and "corrupt.mcap" in stdout
    assert "note: FIT % v is undefined on spin.mcap: its measured v is constant" in stdout
    assert " nan " not in stdout
    other = tmp_path / "corrupt2.mcap"
    other.write_bytes(b"junk" * 99)
    assert main(["sysid", "fit", str(corrupt), str(other), "--robot", ROBOT, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "none of the 2 logs could be used" in err and err.count("\n") == 1
