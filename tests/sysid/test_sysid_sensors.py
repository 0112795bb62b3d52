"""sysid.sensors on scans with known truth (the project's ray caster in a static room)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sysid.errors import ExcitationError, ResultFileError, SysidValueError
from sysid.sensors import PoseArrays, ScanArrays, estimate_sensor, load_sensor
from tests.sysid.sensor_truth import MOUNT_XY_M, Truth, draw_truth, synthetic_recording


def _errors(truth: Truth, seed: int) -> dict[str, tuple[bool, bool]]:
    """Per quantity: (within the issue's target, 95 % interval holds the truth)."""
    scans, odom = synthetic_recording(truth, seed)
    est = estimate_sensor(scans, odom, mount_xy_m=MOUNT_XY_M, seed=seed)
    out = {}
    mid = len(est.noise_range_m) // 2
    for name, i in (("std_near", 0), ("std_mid", mid), ("std_far", -1)):
        true_std = truth.std_at(est.noise_range_m[i])
        out[name] = (
            abs(est.noise_std_m[i] / true_std - 1.0) <= 0.15,
            est.noise_std_lo_m[i] <= true_std <= est.noise_std_hi_m[i],
        )
    lo, hi = est.dropout_ci
    out["dropout"] = (abs(est.dropout - truth.dropout) <= 0.015, lo <= truth.dropout <= hi)
    lo, hi = est.time_offset_ci
    out["offset"] = (abs(est.time_offset_s - truth.offset_s) <= 0.010, lo <= truth.offset_s <= hi)
    lo, hi = est.mounting_yaw_ci
    out["yaw"] = (
        abs(est.mounting_yaw_rad - truth.yaw_rad) <= math.radians(0.5),
        lo <= truth.yaw_rad <= hi,
    )
    return out


def test_one_recording_meets_the_targets() -> None:
    truth = draw_truth(np.random.default_rng(7))
    errors = _errors(truth, 7)
    assert all(ok for ok, _ in errors.values()), errors


#: Seeds of the coverage draws (``benchmarks/bench_sensors.py`` runs 20 others, 1000-1019).
DRAW_SEEDS = tuple(range(100, 110))
#: Each quantity's 95 % interval must hold the truth on at least this many of the draws. With
#: 10 independent draws (binomial): a false alarm at the nominal 95 % coverage 1.2 % (7 % at
#: 90 %); a quantity whose intervals are half as wide as they should be (coverage ~2/3 for a
#: normal error) fails with probability 0.69, one covering half the time 0.95. Measured: the
#: still noise std at the middle range 8 of 10, every other quantity 9 or 10; with every
#: interval halved about its centre the still test's five quantities other than the yaw fail
#: (3-7 of 10), the moving test's near range (4 of 10); the moving middle and far intervals
#: still hold all ten then (they are wide: half the time would be enough).
MIN_COVERED = 8


@pytest.mark.slow
def test_intervals_cover_the_truth_over_10_draws() -> None:
    draws = [_errors(draw_truth(np.random.default_rng(seed)), seed) for seed in DRAW_SEEDS]
    for name in draws[0]:
        within = sum(d[name][0] for d in draws)
        covered = sum(d[name][1] for d in draws)
        assert within == len(DRAW_SEEDS), (name, within)
        assert covered >= MIN_COVERED, (name, covered)


def _moving_only(seed: int) -> dict[str, tuple[float, bool]]:
    """A recording whose base never stands still: per range bin (near, middle, far) the
    relative error of the noise std and whether its 95 % interval holds the truth."""
    truth = draw_truth(np.random.default_rng(seed))
    scans, odom = synthetic_recording(truth, seed, stops=False)
    est = estimate_sensor(scans, odom, mount_xy_m=MOUNT_XY_M, seed=seed)
    assert est.still_scans == 0 and est.noise_source == "moving"
    assert math.isnan(est.dropout) and est.moving_residuals > 10_000
    out = {}
    for name, i in (("near", 0), ("mid", len(est.noise_range_m) // 2), ("far", -1)):
        true_std = truth.std_at(est.noise_range_m[i])
        out[name] = (
            est.noise_std_m[i] / true_std - 1.0,
            est.noise_std_lo_m[i] <= true_std <= est.noise_std_hi_m[i],
        )
    return out


def test_moving_scans_give_the_noise_without_a_still_stretch() -> None:
    errors = _moving_only(3)
    assert all(abs(err) <= 0.15 for err, _ in errors.values()), errors
    assert errors["mid"][1], errors


@pytest.mark.slow
def test_moving_scans_intervals_cover_the_truth_over_10_draws() -> None:
    draws = [_moving_only(seed) for seed in DRAW_SEEDS]
    for name in draws[0]:
        assert all(abs(d[name][0]) <= 0.15 for d in draws), name
        assert sum(d[name][1] for d in draws) >= MIN_COVERED, name


def test_moving_scans_check_the_still_stretches() -> None:
    truth = draw_truth(np.random.default_rng(7))
    scans, odom = synthetic_recording(truth, 7)
    est = estimate_sensor(scans, odom, mount_xy_m=MOUNT_XY_M, n_boot=50)
    assert est.noise_source == "still"
    for still, moving, r in zip(
        est.noise_std_m, est.moving_noise_std_m, est.noise_range_m, strict=True
    ):
        assert moving == pytest.approx(truth.std_at(r), rel=0.08)
        assert moving == pytest.approx(still, rel=0.08)


def test_estimate_round_trips_through_yaml(tmp_path: Path) -> None:
    truth = draw_truth(np.random.default_rng(3))
    scans, odom = synthetic_recording(truth, 3, duration_s=20.0)
    est = estimate_sensor(scans, odom, mount_xy_m=MOUNT_XY_M, n_boot=20)
    est.save(tmp_path / "sensors.yaml")
    back = load_sensor(tmp_path / "sensors.yaml")
    assert back.beams == 360
    assert back.noise_std_per_m == pytest.approx(est.noise_std_per_m)
    assert back.dropout_ci == pytest.approx(est.dropout_ci)
    assert len(back.dropout_by_beam) == 360
    assert back.unidentified == est.unidentified
    assert back.moving_noise_std_m == pytest.approx(est.moving_noise_std_m)
    assert back.moving_residuals == est.moving_residuals > 0
    # a file written before the moving-scan check loads, without it
    text = (tmp_path / "sensors.yaml").read_text().split("\nnoise_source:")[0] + "\n"
    (tmp_path / "old.yaml").write_text(text)
    old = load_sensor(tmp_path / "old.yaml")
    assert old.moving_noise_std_m == () and old.noise_std_0_m == back.noise_std_0_m


def test_load_rejects_other_files(tmp_path: Path) -> None:
    path = tmp_path / "x.yaml"
    path.write_text("format: sim2real.sysid/1\n")
    with pytest.raises(ResultFileError, match=r"is not a 'sim2real\.sysid\.sensors/1' file"):
        load_sensor(path)


def _scans(n: int, beams: int, t0: float = 0.0) -> ScanArrays:
    return ScanArrays(
        t_s=t0 + 0.2 * np.arange(n),
        ranges_m=np.full((n, beams), 2.0),
        angle_min_rad=-math.pi,
        angle_increment_rad=2 * math.pi / beams,
        range_min_m=0.06,
        range_max_m=5.0,
    )


def _odom(t0: float, n: int) -> PoseArrays:
    z = np.zeros(n)
    return PoseArrays(t_s=t0 + 0.1 * np.arange(n), x_m=z, y_m=z, yaw_rad=z)


def test_changing_beam_count_is_refused() -> None:
    with pytest.raises(SysidValueError, match="360 beams and those of 'a' 180"):
        estimate_sensor([_scans(30, 180), _scans(30, 360)], [_odom(0, 80)] * 2, names=["a", "b"])


def test_no_still_stretch_and_no_motion_is_refused() -> None:
    # the odometry lies on another clock: no scan falls inside it
    with pytest.raises(ExcitationError, match="no still stretch"):
        estimate_sensor(_scans(30, 360), _odom(1000.0, 80))


def test_still_only_recording_names_what_it_cannot_identify() -> None:
    rng = np.random.default_rng(1)
    scans = _scans(40, 360)
    noisy = ScanArrays(
        t_s=scans.t_s,
        ranges_m=2.0 + 0.5 * np.cos(4 * scans.angles_rad) + rng.normal(0, 0.02, (40, 360)),
        angle_min_rad=scans.angle_min_rad,
        angle_increment_rad=scans.angle_increment_rad,
        range_min_m=0.06,
        range_max_m=5.0,
    )
    est = estimate_sensor(noisy, _odom(-1.0, 110), n_boot=30)
    assert est.noise_std_at(2.0) == pytest.approx(0.02, rel=0.1)
    assert math.isnan(est.time_offset_s) and math.isnan(est.mounting_yaw_rad)
    assert len(est.unidentified) == 2
