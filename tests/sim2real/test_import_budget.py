"""Each CLI command imports only what it uses (issue 16): a light command never pays for
matplotlib, scipy, pybullet, python-control, filterpy or numba."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
DEMO_LOG = REPO / "data" / "demo_train.mcap"

#: Top-level packages a light command must not import.
HEAVY = ("matplotlib", "scipy", "pybullet", "control", "filterpy", "numba", "gymnasium", "mcap")


def _imported(*argv: str) -> set[str]:
    """The top-level module names ``python -X importtime -m sim2real ARGV`` imports."""
    proc = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "sim2real", *argv],
        capture_output=True,
        text=True,
        check=False,
        cwd=REPO,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    names = re.findall(r"^import time:\s+\d+ \|\s+\d+ \|\s*(\S+)$", proc.stderr, re.MULTILINE)
    assert len(names) > 20, "importtime printed nothing: is -X importtime honoured?"
    return {name.split(".")[0] for name in names}


@pytest.mark.parametrize(
    "argv",
    [("robots", "list"), ("logs", "info", str(DEMO_LOG)), ("--help",)],
    ids=["robots-list", "logs-info", "help"],
)
def test_light_commands_import_no_heavy_package(argv: tuple[str, ...]) -> None:
    imported = _imported(*argv)
    assert "sim2real" in imported
    assert sorted(imported & set(HEAVY)) == []


def test_help_imports_no_numpy() -> None:
    # the parsers quote score definitions (sysid.definitions) without the code computing them
    assert "numpy" not in _imported("--help")


def test_agree_reduced_without_report_imports_no_plotting_or_fitting() -> None:
    # a 150 s log: one replay interprets the drive kernel (robots.reduced.INTERPRET_BUDGET_STEPS)
    # rather than loading numba for it; no ensemble, so no progress bar (rich) either
    imported = _imported(
        "agree", str(DEMO_LOG), "--robot", "turtlebot3_burger", "--engine", "reduced"
    )
    assert "robots" in imported
    heavy = {"matplotlib", "pybullet", "control", "filterpy", "numba", "scipy", "rich"}
    assert sorted(imported & heavy) == []


def test_lazy_package_attributes_still_resolve() -> None:
    import randomizers
    import robots
    import sysid

    assert callable(robots.simulate)
    assert callable(sysid.fit_drive)
    assert randomizers.DepthNoise.__module__ == "randomizers"
    assert "DepthNoise" in dir(randomizers)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = robots.nope  # type: ignore[attr-defined]


def test_sysid_show_imports_no_fitting_code(tmp_path: Path) -> None:
    from robots.params import DriveParams
    from sysid import SysidResult

    params = tmp_path / "params.yaml"
    result = SysidResult(
        robot="turtlebot3_burger",
        params=DriveParams(),
        estimates=(),
        identifiable=(),
        correlation_names=(),
        correlation=(),
    )
    params.write_text(result.to_yaml(), encoding="utf-8")
    imported = _imported("sysid", "show", str(params))
    assert "sysid" in imported and "rich" in imported
    heavy = {"scipy", "numba", "matplotlib", "pybullet", "control", "filterpy", "mcap"}
    assert sorted(imported & heavy) == []
