"""``sim2real.fitting.fit_logs``: the one fit behind ``sim2real sysid fit`` and the Python API."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from robots.spec import load_spec
from sim2real.cli import main
from sim2real.fitting import fit_logs, read_fit_logs

REPO = Path(__file__).resolve().parents[2]
DEMO_TRAIN = REPO / "data" / "demo_train.mcap"


@pytest.mark.slow
def test_cli_and_library_give_the_same_fit(tmp_path: Path) -> None:
    out = tmp_path / "params.yaml"
    assert (
        main(["sysid", "fit", str(DEMO_TRAIN), "--robot", "turtlebot3_burger", "-o", str(out)]) == 0
    )
    fit = fit_logs([DEMO_TRAIN], robot="turtlebot3_burger")
    from_cli = yaml.safe_load(out.read_text(encoding="utf-8"))
    from_library = yaml.safe_load(fit.result.to_yaml())
    for doc in (from_cli, from_library):
        doc["settings"].pop("seconds")  # the fit's wall time
    assert from_cli == from_library  # every number: values, intervals, scores, randomisation
    # the spec's defaults reach the fit: its priors and the encoder's odometry window
    spec = load_spec("turtlebot3_burger")
    assert fit.result.settings["odom_v_window_s"] == pytest.approx(spec.odometry.v_window_s)
    assert fit.result.priors["delay_s"]["sd"] == pytest.approx(spec.priors["delay_s"].sd)
    delay = from_cli["parameters"]["delay_s"]["value"]
    assert 0.04 < delay < 0.12
    assert any("time source auto" in note for note in fit.notes)


def test_window_crops_and_pauses_split(tmp_path: Path) -> None:
    spec = load_spec("turtlebot3_burger")
    whole = read_fit_logs([DEMO_TRAIN], spec=spec)
    part = read_fit_logs([DEMO_TRAIN], spec=spec, window=(0.0, 20.0))
    span = sum(float(p.meas_t_s[-1] - p.meas_t_s[0]) for p in part)
    assert 15.0 < span <= 20.0
    assert sum(p.meas_t_s.size for p in part) < sum(p.meas_t_s.size for p in whole)
