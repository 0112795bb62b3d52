"""A noise std the validation logs cannot identify keeps the file's estimate."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.agreement.calibration import noise_information_share, shrunk_noise_std
from sim2real.cli import main

stds = st.floats(1e-5, 1.0)


def test_information_share_golden() -> None:
    # members 0 and 1: spread (1 + 1/2) * 0.5 = 0.75; noise 0.25; (0.25 / 1.0)^2 = 0.0625
    members = np.tile([[0.0], [1.0]], (1, 5))
    assert noise_information_share(members, 0.5, 0.0) == pytest.approx(0.0625, rel=1e-12)
    # quantisation adds q^2 / 12 = 0.25 to the variance: (0.25 / 1.25)^2
    assert noise_information_share(members, 0.5, math.sqrt(3.0)) == pytest.approx(0.04, rel=1e-12)
    assert noise_information_share(np.zeros((3, 5)), 0.1, 0.0) == pytest.approx(1.0)


@settings(max_examples=200, deadline=None)
@given(cal=stds, file=stds, share=st.floats(0.0, 1.0))
def test_shrunk_std_lies_between_the_file_and_the_calibration(
    cal: float, file: float, share: float
) -> None:
    got = shrunk_noise_std(cal, file, share)
    assert min(cal, file) * (1 - 1e-12) <= got <= max(cal, file) * (1 + 1e-12)
    more = shrunk_noise_std(cal, file, min(share + 0.1, 1.0))
    assert abs(more - cal) <= abs(got - cal) + 1e-15


@pytest.mark.realdata
@pytest.mark.slow
def test_a_log_the_spread_explains_does_not_drive_the_noise_to_zero(
    realdata_dir: Path, tmp_path: Path
) -> None:
    # a Neato fit on its test drive, calibrated on its obstacle avoidance: the members' spread
    # explains the w residuals and the likelihood's w noise ends at the search floor
    spec, params, out = tmp_path / "neato.yaml", tmp_path / "p.yaml", tmp_path / "c.yaml"
    argv = ["robots", "new", "neato", "--wheel-separation", "0.248", "--max-speed", "0.3"]
    assert main([*argv, "-o", str(spec)]) == 0
    fit = realdata_dir / "neato_ksoltan_testdrive_2018-09-18-20-17-54.mcap"
    cal = realdata_dir / "neato_ksoltan_obstacle_avoid_demo_2018-09-18-20-30-36.mcap"
    assert main(["sysid", "fit", str(fit), "--robot", str(spec), "-o", str(params)]) == 0
    argv = ["sysid", "calibrate", str(params), str(cal), "--robot", str(spec), "-o", str(out)]
    assert main(argv) == 0
    block = yaml.safe_load(out.read_text())["calibration"]
    # w: the file's 0.0164 rad/s narrowed x0.23 to bring the coverage to 95 % (the likelihood
    # alone gives 1e-5 rad/s, the search floor)
    assert 0.15 <= block["noise_factor_w"] <= 2.0
    assert 0.9 <= block["validation_coverage_w"] <= 0.955
