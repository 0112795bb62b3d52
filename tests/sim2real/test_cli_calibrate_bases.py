"""`sysid calibrate` names the basis of every noise factor it prints: the note's widening and
the summary's noise scale are one figure on one basis (the identified std)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

from sim2real.cli import main

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.mark.slow
def test_the_demo_calibration_says_one_factor_on_one_basis(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    params, out = tmp_path / "params.yaml", tmp_path / "calibrated.yaml"
    robot = ["--robot", "turtlebot3_burger"]
    assert main(["sysid", "fit", str(DATA / "demo_train.mcap"), *robot, "-o", str(params)]) == 0
    capsys.readouterr()
    code = main(["sysid", "calibrate", str(params), str(DATA / "demo_calibrate.mcap"), *robot,
                 "-o", str(out)])  # fmt: skip
    text = capsys.readouterr().out
    assert code == 0
    # the demo's w band misses by more than any spread: the noise is widened on every sample
    widened = re.search(r"widened on every sample, on w to x([0-9.]+) the identified std", text)
    summary = re.search(r"90 % band, w: .*\(noise x([0-9.]+) the identified std\)", text)
    assert widened and summary, text
    assert widened.group(1) == summary.group(1)  # measured x1.21 in both
    block = yaml.safe_load(out.read_text())["calibration"]
    assert f"{block['noise_scale_w']:.3g}" == summary.group(1)
    line = re.search(r"odometry noise w +([0-9.e-]+) rad/s x([0-9.]+) the file's", text)
    assert line and f"{block['noise_factor_w']:.3g}" == line.group(2)
