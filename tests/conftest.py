"""Fixtures shared by the whole test suite."""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from tests.processes import descendants, process_table

# No per-example deadline: the first example of a property test may compile numba kernels, and
# CI machines are loaded. In CI (CI=true) the examples are derandomised, so a run is repeatable.
# A test's own @settings inherits these, except a list it gives: suppress_health_check=[...]
# replaces the profile's, so such a list names HealthCheck.too_slow again.
settings.register_profile("dev", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile(
    "ci", deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile("ci" if os.environ.get("CI") else "dev")

#: ``../shared/realdata`` beside the checkout: real third-party logs, never copied into the repo.
REALDATA_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"


@pytest.fixture
def umask() -> Iterator[None]:
    """Restore the process umask after a test that sets it."""
    old = os.umask(0o022)
    os.umask(old)
    yield
    os.umask(old)


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


#: Markers of tests that need an optional extra, and the modules that extra installs.
_EXTRAS = {"train": ("torch", "stable_baselines3"), "cluster": ("ray",), "mujoco": ("mujoco",)}
#: Where each extra's tests run.
_RUN_BY = {"train": "run `make test-train`", "cluster": "run `make test-train`"}


def _foreign_ray_gcs() -> list[int]:
    """Pids of Ray GCS servers on this machine that this process did not start (Linux /proc).

    ``ray.init(address="auto")`` (``--ray auto``, :func:`sim2real.cluster.connect`) joins any
    Ray running on the machine, found by its ``gcs_server`` process: a shared machine where
    another user's Ray is up would make the tests of a local start fail for that reason.
    """
    table = process_table()
    ours = set(descendants(os.getpid(), table))
    return [
        pid
        for pid, (_, cmd) in table.items()
        if cmd.split(" ")[0].endswith("/gcs_server") and pid not in ours
    ]


def pytest_runtest_setup(item: pytest.Item) -> None:
    """Skip a `cluster` test while another Ray runs on this machine (it would be joined)."""
    if item.get_closest_marker("cluster") is not None and (pids := _foreign_ray_gcs()):
        pytest.skip(
            f"another Ray runs on this machine (gcs_server pid {pids[0]}): "
            "--ray auto would join it instead of starting this test's own"
        )


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Skip tests of an optional extra (`train`, `cluster`, `mujoco`) when it is not installed.

    `make test` installs [mujoco] and runs without the others; `make test-train` installs
    them and runs their tests.
    """
    for marker, modules in _EXTRAS.items():
        missing = [m for m in modules if importlib.util.find_spec(m) is None]
        if not missing:
            continue
        skip = pytest.mark.skip(
            reason=f"needs the [{marker}] extra ({', '.join(missing)} missing): "
            + _RUN_BY.get(marker, f"pip install -e '.[{marker}]'")
        )
        for item in items:
            if item.get_closest_marker(marker) is not None:
                item.add_marker(skip)
