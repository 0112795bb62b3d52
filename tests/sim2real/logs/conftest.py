"""Fixtures of the log I/O tests: small synthetic velocity logs written by our writer."""

from __future__ import annotations

from pathlib import Path

import pytest
from logs_helpers import Arrays, make_arrays

from sim2real.logs import write_velocity_log


@pytest.fixture
def arrays() -> Arrays:
    return make_arrays()


@pytest.fixture
def small_log(tmp_path: Path, arrays: Arrays) -> Path:
    """A valid CDR log (Twist + Odometry) of the ``arrays`` fixture."""
    return write_velocity_log(tmp_path / "small.mcap", **arrays.kwargs())
