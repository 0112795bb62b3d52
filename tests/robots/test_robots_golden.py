"""The drive chain gives the same numbers, bit for bit, as the recorded golden traces
(tests/robots/_golden_drive.py says when each was recorded)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.robots._golden_drive import GOLDEN, record


@pytest.fixture(scope="module")
def now() -> dict[str, np.ndarray]:
    return record()


@pytest.mark.parametrize("what", ["simulate", "reduced_step", "pybullet_replay", "pybullet_step"])
def test_drive_chain_matches_golden_traces(now: dict[str, np.ndarray], what: str) -> None:
    golden = np.load(GOLDEN)
    keys = [k for k in golden.files if k.endswith("/" + what)]
    assert len(keys) == 3
    for key in keys:
        np.testing.assert_array_equal(now[key], golden[key], err_msg=key)
        assert np.ptp(golden[key]) > 0.01, key  # the traces do move
