"""Fixtures of the agreement tests: runs several modules check, computed once per test run."""

from __future__ import annotations

from pathlib import Path

import pytest
from _agreement_fixtures import NEATO_CALIBRATE, NEATO_FIT

from sim2real.cli import main
from tests.sim2real.shared_runs import run_once


@pytest.fixture(scope="session")
def neato_calibrated(realdata_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder of ``neato.yaml`` (its ``robots new`` spec: wheels 0.248 m apart, 0.3 m/s),
    ``params.yaml`` (``sysid fit`` of the test drive, every option at its default) and
    ``calibrated.yaml`` (``sysid calibrate`` on the obstacle avoidance). Read only."""

    def compute(folder: Path) -> None:
        robot, params = folder / "neato.yaml", folder / "params.yaml"
        assert main(["robots", "new", "neato", "--wheel-separation", "0.248",
                     "--max-speed", "0.3", "-o", str(robot)]) == 0  # fmt: skip
        assert main(["sysid", "fit", str(realdata_dir / NEATO_FIT), "--robot", str(robot),
                     "-o", str(params)]) == 0  # fmt: skip
        assert main(["sysid", "calibrate", str(params), str(realdata_dir / NEATO_CALIBRATE),
                     "--robot", str(robot), "-o", str(folder / "calibrated.yaml")]) == 0  # fmt: skip

    return run_once(tmp_path_factory, "neato_calibrated", compute)
