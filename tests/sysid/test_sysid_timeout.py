"""The command timeout is read from the logs (held vs timed-out commands), not assumed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robots.reduced import simulate
from robots.spec import load_spec
from sysid._logs import LogArrays
from sysid._timeout import fit_cmd_timeout

SPEC = load_spec("turtlebot3_burger")


def _log(truth_timeout_s: float, bursts: list[tuple[float, float, float, float]]) -> LogArrays:
    """Commands republished at 10 Hz during each burst (start, end, v, w), silent between."""
    t = np.concatenate([np.arange(a, b, 0.1) for a, b, _, _ in bursts])
    v = np.concatenate([np.full(np.arange(a, b, 0.1).size, lv) for a, b, lv, _ in bursts])
    w = np.concatenate([np.full(np.arange(a, b, 0.1).size, lw) for a, b, _, lw in bursts])
    mt = np.arange(0.0, bursts[-1][1] + 3.0, 1 / 30)
    truth = SPEC.drive.replace(cmd_timeout_s=truth_timeout_s)
    r = simulate(truth, SPEC.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, t_out_s=mt)
    return LogArrays(cmd_t_s=t, cmd_v=v, cmd_w=w, meas_t_s=mt, meas_v=r.v, meas_w=r.w)


BURSTS = [
    (0.0, 1.0, 0.15, 0.0),
    (4.0, 5.0, 0.0, 1.0),
    (8.0, 9.0, -0.1, 0.5),
    (12.0, 12.5, 0.0, 0.0),
]


def test_held_commands_give_no_timeout() -> None:
    params, notes = fit_cmd_timeout([_log(math.inf, BURSTS)], SPEC.drive)
    assert math.isinf(params.cmd_timeout_s)
    assert len(notes) == 1 and "holds the last command: none (inf) (spec: 0.5 s)" in notes[0]


@pytest.mark.parametrize("truth", [0.3, 0.8, 1.5])
def test_a_timeout_is_measured(truth: float) -> None:
    params, notes = fit_cmd_timeout([_log(truth, BURSTS)], SPEC.drive.replace(cmd_timeout_s=10.0))
    # the stop is seen when the base has slowed below 30 % of the command: a little later
    assert truth - 0.05 <= params.cmd_timeout_s <= truth + 0.25, params.cmd_timeout_s
    assert "the base stopped" in notes[0]


def test_continuous_commands_say_nothing() -> None:
    log = _log(0.5, [(0.0, 12.0, 0.15, 0.3), (12.0, 12.5, 0.0, 0.0)])  # stopped by a zero
    params, notes = fit_cmd_timeout([log], SPEC.drive)
    assert params == SPEC.drive and notes == []


def test_fit_drive_reports_it() -> None:
    from sysid.fit import fit_drive

    res = fit_drive(
        [_log(math.inf, BURSTS)], geometry=SPEC.geometry, base_params=SPEC.drive, robot="x"
    )
    assert math.isinf(res.params.cmd_timeout_s)
    assert any(w.startswith("cmd_timeout_s fitted from the logs") for w in res.warnings)
