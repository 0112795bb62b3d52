"""`sysid calibrate` names the basis of every noise factor it prints: the note's widening and
the summary's noise scale are one figure on one basis (the identified std)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml


@pytest.mark.slow
def test_the_demo_calibration_says_one_factor_on_one_basis(demo_run: Path) -> None:
    # the demo's step 2 is `sysid calibrate` as the tour types it; its lines up to step 3
    printed = (demo_run / "stdout.txt").read_text(encoding="utf-8")
    text = printed.split("\n2/3 sim2real sysid calibrate ", 1)[1].split("\n3/3 sim2real ", 1)[0]
    # the demo's w band misses by more than any spread: the noise is widened on every sample
    widened = re.search(r"widened on every sample, on w to x([0-9.]+) the identified std", text)
    summary = re.search(r"90 % band, w: .*\(noise x([0-9.]+) the identified std\)", text)
    assert widened and summary, text
    assert widened.group(1) == summary.group(1)  # measured x1.2-1.3 in both
    block = yaml.safe_load((demo_run / "out" / "calibrated.yaml").read_text())["calibration"]
    assert f"{block['noise_scale_w']:.3g}" == summary.group(1)
    line = re.search(r"odometry noise w +([0-9.e-]+) rad/s x([0-9.]+) the file's", text)
    assert line and f"{block['noise_factor_w']:.3g}" == line.group(2)
