"""The note on odometry spikes says how far a spike sits off its neighbours."""

from __future__ import annotations

import numpy as np

from sysid._initial import _spike_notes
from sysid._logs import LogArrays


def _log(meas_v: np.ndarray) -> LogArrays:
    t = np.arange(meas_v.size) * 0.05
    return LogArrays(
        cmd_t_s=t, cmd_v=np.full(t.size, 0.3), cmd_w=np.zeros(t.size), meas_t_s=t,
        meas_v=meas_v, meas_w=np.zeros(t.size), name="drive.mcap",
    )  # fmt: skip


def test_a_dropout_is_measured_from_its_neighbours() -> None:
    v = np.full(40, 0.3)
    v[20] = 0.0  # one sample of the driver's zero in the middle of a 0.3 m/s run
    [note] = _spike_notes([_log(v)])
    assert note.startswith("drive.mcap: 1 v and 0 w odometry spike(s)")
    assert "(the largest at 0.00 m/s, 0.30 m/s off its neighbours)" in note


def test_a_burst_is_measured_from_its_neighbours() -> None:
    v = np.full(40, 0.2)
    v[10] = 1.35
    [note] = _spike_notes([_log(v)])
    assert "(the largest at 1.35 m/s, 1.15 m/s off its neighbours)" in note


def test_a_clean_log_has_no_note() -> None:
    assert _spike_notes([_log(np.full(40, 0.3))]) == []
