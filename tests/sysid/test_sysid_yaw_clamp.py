"""A clamp on the commanded yaw rate is freed only when a log shows one, and fitted.

A driver that clamps the commanded yaw rate (Clearpath's do) leaves the forward speed to its
command; a wheel-speed cap scales both wheels together and slows v and w alike. The fit frees
``speed_lim_w_radps`` (no spec value) only on the first kind of log and starts it at the
fastest measured yaw rate.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robots.params import DriveParams
from sysid._excitation import analyse
from sysid._logs import LogArrays
from sysid.fit import fit_drive
from sysid.synthetic import WAFFLE_LIKE_GEOMETRY, step_commands, synthetic_log

GEO = WAFFLE_LIKE_GEOMETRY
#: The spec defaults a fit starts from: no clamp, no wheel-speed cap.
BASE = DriveParams(motor_gain_nms_per_rad=0.01)
CLAMP_RADPS = 1.0


def _log(truth: DriveParams, seed: int = 3) -> LogArrays:
    t, v, w = step_commands(60.0, seed=seed, v_max_mps=0.2, w_max_radps=1.8, hold_s=(2.0, 3.5))
    return synthetic_log(truth, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed, spike_mps=None)


def _truth(**changes: float) -> DriveParams:
    return BASE.replace(delay_s=0.1, speed_loop_ki_per_s=10.0, **changes)


def test_a_yaw_clamp_is_freed_with_a_note() -> None:
    exc = analyse([_log(_truth(speed_lim_w_radps=CLAMP_RADPS))], GEO, BASE, "auto")
    assert "speed_lim_w_radps" in exc.free
    (note,) = [n for n in exc.warnings if "clamp on the commanded yaw rate" in n]
    assert "stops near 1" in note and "forward speed keeps" in note


@pytest.mark.parametrize(
    "truth",
    [_truth(), _truth(wheel_speed_max_radps=0.22 / GEO.wheel_radius_m)],
    ids=["nothing saturates", "a wheel-speed cap scales both wheels"],
)
def test_no_clamp_is_freed_without_one(truth: DriveParams) -> None:
    exc = analyse([_log(truth)], GEO, BASE, "auto")
    assert "speed_lim_w_radps" not in exc.free
    assert not [n for n in exc.warnings if "clamp on the commanded yaw rate" in n]


def test_a_spec_clamp_is_not_refitted() -> None:
    base = BASE.replace(speed_lim_w_radps=1.5)
    exc = analyse([_log(_truth(speed_lim_w_radps=CLAMP_RADPS))], GEO, base, "auto")
    assert "speed_lim_w_radps" not in exc.free


@pytest.mark.slow
def test_the_fit_recovers_the_clamp() -> None:
    truth = _truth(speed_lim_w_radps=CLAMP_RADPS)
    res = fit_drive([_log(truth)], geometry=GEO, base_params=BASE)
    fitted = res.params.speed_lim_w_radps
    assert math.isfinite(fitted)
    assert fitted == pytest.approx(CLAMP_RADPS, rel=0.03)
    assert res.scores_fit[0].agreement_w > 0.9
    assert np.isfinite(res.estimate("speed_lim_w_radps").std)
