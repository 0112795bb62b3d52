"""Fixtures shared by the whole test suite."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

# pytest (prepend import mode) puts tests/ on sys.path, where tests/sim2real, tests/robots, ...
# would shadow the real packages as empty namespace packages (their __init__ never runs and
# submodule lookups can hit the test folders). Drop tests/ and import the real packages first.
_TESTS_DIR = str(Path(__file__).resolve().parent)
sys.path[:] = [p for p in sys.path if str(Path(p or ".").resolve()) != _TESTS_DIR]
for _name in ("sim2real", "robots", "sysid", "randomizers"):
    if _name in sys.modules and getattr(sys.modules[_name], "__file__", None) is None:
        del sys.modules[_name]
    __import__(_name)

#: ``../shared/realdata`` beside the checkout: real third-party logs, never copied into the repo.
REALDATA_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"


@pytest.fixture(scope="session")
def realdata_dir() -> Path:
    """The folder of real robot logs; skips the test when it is absent."""
    if not REALDATA_DIR.is_dir():
        pytest.skip(f"real robot logs not found at {REALDATA_DIR} (shared/ is not beside the repo)")
    return REALDATA_DIR


@pytest.fixture(scope="session")
def drexel_log(realdata_dir: Path) -> Path:
    """TurtleBot3 Waffle Pi go-to-goal log (real, ROS 2 CDR MCAP)."""
    path = realdata_dir / "tb3wp_drexel_goal.mcap"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    return path


@pytest.fixture(scope="session")
def neato_log(realdata_dir: Path) -> Path:
    """Neato teleop log (real, ROS 2 CDR MCAP)."""
    path = realdata_dir / "neato_olin2018_teleop.mcap"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    return path
