"""`sysid sensors` on two real recordings of one Neato unit (its XV-11 lidar)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from sim2real.cli import main
from sim2real.sensor_id import identify_sensor, read_sensor_logs
from sysid.sensors import PoseArrays, ScanArrays, SensorEstimate, still_stretches

pytestmark = [pytest.mark.realdata]

LOGS = (
    "neato_ksoltan_bag-file-name_2018-09-15-10-16-08.mcap",
    "neato_ksoltan_testdrive_2018-09-18-20-17-54.mcap",
)


def _overlap(a: tuple[float, float], b: tuple[float, float]) -> bool:
    return max(a[0], b[0]) <= min(a[1], b[1])


@pytest.fixture(scope="module")
def spec(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("neato") / "neato.yaml"
    argv = ["robots", "new", "neato", "--wheel-separation", "0.248", "--max-speed", "0.3"]
    assert main([*argv, "-o", str(path)]) == 0
    return path


Logs = tuple[list[ScanArrays], list[PoseArrays]]


@pytest.fixture(scope="module")
def identified(realdata_dir: Path, spec: Path) -> dict[str, tuple[Logs, SensorEstimate]]:
    """Per recording of :data:`LOGS`: its scans and odometry, and its identification (both
    tests judge the same one)."""
    out = {}
    for name in LOGS:
        logs = read_sensor_logs([realdata_dir / name])
        out[name] = (logs, identify_sensor([realdata_dir / name], robot=spec, logs=logs))
    return out


def test_two_recordings_of_one_unit_agree(
    identified: dict[str, tuple[Logs, SensorEstimate]],
) -> None:
    a, b = (identified[name][1] for name in LOGS)
    for est in (a, b):
        assert est.beams == 361 and est.range_max_m == pytest.approx(5.0)
        assert est.still_scans >= 10
        # a triangulation sensor: the noise grows with the square of range, 1-2 mm per m^2
        assert 0.001 < est.noise_std_per_m2 < 0.002
        assert est.noise_std_0_m < 0.002 and est.noise_std_per_m < 0.001
        assert 0.01 < est.dropout < 0.08
    # Konolige et al. (2008), the design of the XV-11's laser distance sensor: "3 cm accuracy
    # out to 6 m"; the upper 95 % bound of the identified std stays under it at every range
    # bin of both recordings (the farthest bins lie near 4 m)
    for est in (a, b):
        assert max(est.noise_std_hi_m) < 0.03
    assert _overlap(a.noise_std_per_m2_ci, b.noise_std_per_m2_ci)
    assert _overlap(a.dropout_ci, b.dropout_ci)
    assert _overlap(a.time_offset_ci, b.time_offset_ci)
    # the scans are stamped when a revolution ends: 0.1-0.3 s after odometry's clock says
    assert -0.30 < a.time_offset_s < -0.10 and -0.30 < b.time_offset_s < -0.10
    # this driver's scan x axis points backwards: a mounting yaw of 180 degrees
    for est in (a, b):
        lo, hi = est.mounting_yaw_ci
        off = math.remainder(est.mounting_yaw_rad - math.pi, 2 * math.pi)
        assert abs(off) < math.radians(2.0)
        assert lo - 0.01 <= est.mounting_yaw_rad <= hi + 0.01
    gap = math.remainder(a.mounting_yaw_rad - b.mounting_yaw_rad, 2 * math.pi)
    half = 0.5 * (
        a.mounting_yaw_ci[1] - a.mounting_yaw_ci[0] + b.mounting_yaw_ci[1] - b.mounting_yaw_ci[0]
    )
    assert abs(gap) <= half  # the two intervals overlap


def test_moving_scans_check_the_still_noise(
    realdata_dir: Path, spec: Path, identified: dict[str, tuple[Logs, SensorEstimate]]
) -> None:
    for name in LOGS:
        (scans, odoms), full = identified[name]
        assert full.noise_source == "still" and full.moving_residuals > 4000
        # motion only adds to the spread (the XV-11 turns at 5 Hz and its scans are not
        # deskewed): the moving scans' noise is 1-1.5 times the still noise from 1 m out
        for r, still, moving in zip(
            full.noise_range_m, full.noise_std_m, full.moving_noise_std_m, strict=True
        ):
            if r >= 1.0:
                assert still <= moving <= 1.5 * still, (name, r, still, moving)
        # the same recording with its still scans cut out: the noise from moving scans alone
        s = scans[0]
        keep = np.ones(s.t_s.size, dtype=bool)
        for a, b in still_stretches(s, odoms[0]):
            keep[a:b] = False
        cut = dataclasses.replace(s, t_s=s.t_s[keep], ranges_m=s.ranges_m[keep])
        est = identify_sensor([realdata_dir / name], robot=spec, logs=([cut], odoms), n_boot=100)
        assert est.still_scans == 0 and est.noise_source == "moving"
        for r, std, lo, hi in zip(
            est.noise_range_m, est.noise_std_m, est.noise_std_lo_m, est.noise_std_hi_m, strict=True
        ):
            assert lo < std < hi
            if r >= 1.0:
                assert full.noise_std_at(r) <= std <= 1.5 * full.noise_std_at(r), (name, r, std)
