"""Episode metrics: golden numbers for path, time, |dv|, |dw| and jerk."""

from __future__ import annotations

import math

import pytest

from sim2real.envs.metrics import MetricsTracker
from sim2real.errors import Sim2RealValueError


def test_golden_smoothness_numbers() -> None:
    tr = MetricsTracker(control_dt_s=0.5)
    tr.reset(1.0, 1.0)
    # v: 0 -> 1 -> 1 -> 0 ; w: 0 -> 0 -> 2 -> 2 (one record per step)
    for (x, y), v, w in zip(
        [(2.0, 1.0), (2.0, 2.0), (2.0, 2.0)], [1, 1, 0], [0, 2, 2], strict=True
    ):
        tr.record(x=x, y=y, v=v, w=w)
    m = tr.finish("timeout")
    assert m.steps == 3 and m.episode_time_s == pytest.approx(1.5)
    assert m.path_length_m == pytest.approx(2.0)
    assert math.isnan(m.time_to_goal_s) and m.timeout and not m.success
    # dv = [1, 0, -1] -> 2/3 ; dw = [0, 2, 0] -> 2/3
    assert m.mean_abs_dv_mps == pytest.approx(2 / 3)
    assert m.mean_abs_dw_radps == pytest.approx(2 / 3)
    # second differences: v [-1, -1] -> 1 / 0.25 = 4 ; w [2, -2] -> 2 / 0.25 = 8
    assert m.mean_abs_jerk_v_mps3 == pytest.approx(4.0)
    assert m.mean_abs_jerk_w_radps3 == pytest.approx(8.0)


def test_success_has_time_to_goal_and_bad_outcome_is_refused() -> None:
    tr = MetricsTracker(control_dt_s=0.1)
    tr.reset(0.0, 0.0)
    tr.record(x=0.1, y=0.0, v=1.0, w=0.0)
    m = tr.finish("success")
    assert m.time_to_goal_s == pytest.approx(0.1) and m.to_dict()["outcome"] == "success"
    over = tr.finish("overshoot")
    assert over.overshoot and not (over.success or over.collision or over.timeout)
    assert math.isnan(over.time_to_goal_s)
    with pytest.raises(Sim2RealValueError, match="outcome"):
        tr.finish("won")
