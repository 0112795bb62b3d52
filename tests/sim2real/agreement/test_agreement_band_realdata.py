"""The calibrated band on real Neato recordings the fit and the calibration never used: coverage
80-99 % and a narrow width (issue 28's targets), on rows the calibration statistics fix."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import yaml

from sim2real.cli import main

pytestmark = [pytest.mark.realdata, pytest.mark.slow]

TOP_V, TOP_W = 0.3, 2 * 0.3 / 0.248  # the spec's top speed and yaw rate


@pytest.fixture(scope="module")
def calibrated(neato_calibrated: Path) -> tuple[Path, Path]:
    """The Neato's spec file and its fit of the test drive calibrated on the obstacle avoidance
    (the run the calibration-noise tests check too)."""
    return neato_calibrated / "neato.yaml", neato_calibrated / "calibrated.yaml"


def test_the_calibration_keeps_the_noise_and_narrows_the_v_spread(
    calibrated: tuple[Path, Path],
) -> None:
    block = yaml.safe_load(calibrated[1].read_text())["calibration"]
    # the obstacle avoidance commands 2-3 m/s to a 0.3 m/s base: on the clipped command a
    # quarter of its samples are steady (none on the raw one)
    assert block["validation_steady_share_v"] > 0.2
    # it has no steady stretch to show its noise: the fit's is kept (main narrowed it x0.1)
    assert block["noise_factor_v"] == pytest.approx(1.0) == block["noise_factor_w"]
    # the band over-covered it by its dynamics spread: the parameters that move v narrowed
    assert block["spread_narrowing"]["wheel_speed_max_radps"] < 0.5
    assert 0.9 <= block["validation_coverage_v"] <= 0.96


# The band's members replay each session with the drive model; pybullet integrates the same
# model, so both engines give the band the same figures (measured on these four rows: coverage
# to 0.001, median widths to 0.0001 m/s and rad/s; benchmarks/bench_real.py prints both engines
# on every base). The reduced engine replays a row in 1-3 CPU-s, pybullet in 14-30: one row
# keeps pybullet (the default engine a user's `agree` runs), the others use the reduced one.
@pytest.mark.parametrize(
    ("log", "engine"),
    [
        # main: w 76.4 %, v 0.078 m/s
        ("neato_ksoltan_bag-file-name_2018-09-15-10-16-08.mcap", "reduced"),
        # main: w 79.6 %
        ("neato_paulruvolo-pr2_drive_square_bag_2017-01-29-18-30-40.mcap", "pybullet"),
        # the band's noise is the log's own source's: olin's 7 Hz w (0.032 rad/s, twice the
        # fit log's) and pr2's 2017 twist v (0.0005 m/s, 1/25 of the fit log's)
        ("neato_olin2018_teleop.mcap", "reduced"),  # file's noise: w 65.8 %
        # file's: v 100 %
        ("neato_paulruvolo-pr2_finite_state_bag_2017-02-06-00-10-00.mcap", "reduced"),
    ],
)
def test_the_band_covers_another_session_narrowly(
    calibrated: tuple[Path, Path], realdata_dir: Path, tmp_path: Path, log: str, engine: str
) -> None:
    robot, params = calibrated
    out = tmp_path / "agree.json"
    main(["agree", str(realdata_dir / log), "--robot", str(robot), "--params", str(params),
          "--ensemble", "30", "--seed", "0", "--json", str(out), "--engine", engine])  # fmt: skip
    r = json.loads(out.read_text())
    assert 0.8 <= r["coverage_v"] <= 0.99 and 0.8 <= r["coverage_w"] <= 0.99
    assert r["band_width_v_mps"] <= max(0.2 * TOP_V, 1.25 * r["noise_band_width_v_mps"])
    assert r["band_width_w_radps"] <= max(0.2 * TOP_W, 1.25 * r["noise_band_width_w_radps"])


def test_a_slower_unit_is_the_headline_when_the_fit_does_worse_than_the_defaults(
    calibrated: tuple[Path, Path], realdata_dir: Path, tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:  # fmt: skip
    """The yycho unit holds ~0.28-0.29 m/s where the fitted ksoltan unit holds ~0.30-0.31: the
    fit is under the defaults, and the headline names the cause with its next step. The gap
    sits near v's tolerance (0.02 m/s; 0.026 on one CPU, 0.019 on another), so the cause is
    this unit's top speed or, under the tolerance, the 13.9 % of the log outside the envelope
    the fit saw; either way the next step is the one for that cause."""
    robot, params = calibrated
    out = tmp_path / "agree.json"
    main(["agree", str(realdata_dir / "neato_yycho0108_test_drive.mcap"), "--robot", str(robot),
          "--params", str(params), "--ensemble", "30", "--seed", "0", "--json", str(out)])  # fmt: skip
    lines = capsys.readouterr().out.splitlines()
    headline = next(x for x in lines if x.startswith("verdict"))
    step = next(x for x in lines if x.startswith("next step"))
    assert json.loads(out.read_text())["agreement"] < 0.48  # the spec defaults reach 48.1 %
    assert "The fit does worse than the spec defaults" in headline
    held = re.search(r"this robot holds ([\d.]+) m/s in v where the fitted model holds ([\d.]+)",
                     headline)  # fmt: skip
    if held is not None:
        assert 0.26 < float(held[1]) < 0.29 < float(held[2]) < 0.32
        assert "this unit is slower than the fit log's (another unit's top speed" in headline
        assert step.startswith("next step: fit on a log of this unit, or on logs of several")
    else:
        assert "likely cause: this log drives outside what the fit log saw" in headline
        assert step.startswith("next step: refit on a log that drives like this one")


def test_a_slower_unit_is_a_reason_when_the_fit_beats_the_defaults(
    calibrated: tuple[Path, Path], realdata_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The olin unit holds ~0.27 m/s on its straights (the fitted unit ~0.30); the fit beats the
    defaults there, so the slower unit is a reason, not the headline."""
    robot, params = calibrated
    main(["agree", str(realdata_dir / "neato_olin2018_teleop.mcap"), "--robot", str(robot),
          "--params", str(params), "--engine", "reduced"])  # fmt: skip
    out = capsys.readouterr().out.splitlines()
    assert not any("this unit is slower" in x for x in out if x.startswith("verdict"))
    said = [x for x in out if x.startswith("  - this robot holds")]
    assert len(said) == 1 and "this unit is slower than the fit log's" in said[0]
    held = re.search(r"holds ([\d.]+) m/s in v where the fitted model holds ([\d.]+)", said[0])
    assert held is not None and 0.25 < float(held[1]) < 0.28 < float(held[2]) < 0.31


def test_the_fit_records_its_logs_own_measurement_noise(calibrated: tuple[Path, Path]) -> None:
    # the ksoltan test drive runs steady for 87 samples: 7 Hz pose-derived odometry
    noise = yaml.safe_load(calibrated[1].read_text())["settings"]["measurement_noise"]
    assert noise["samples"] >= 30
    assert noise["std_v_mps"] == pytest.approx(0.0123, rel=0.05)
    assert noise["std_w_radps"] == pytest.approx(0.0146, rel=0.05)
