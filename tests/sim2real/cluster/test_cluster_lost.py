"""A Ray cluster that dies mid-run: the work it held runs in this process, with a warning."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import pytest

from sim2real.cli import _warnings_as_lines
from sim2real.cluster import _cluster_file, _Shared, write_synthetic_fleet
from sim2real.errors import ClusterLostWarning
from tests.processes import descendants

HERE = Path(__file__).resolve().parent


def test_items_given_back_go_to_this_process_first_and_only() -> None:
    shared = _Shared(10, None)
    batch = shared.take(2)  # guided batch for Ray: 0..2
    assert batch == range(0, 3)
    shared.give_back(batch)
    assert shared.take(2) == range(3, 5)  # Ray never gets given-back items
    assert [shared.take() for _ in range(4)] == [range(i, i + 1) for i in (0, 1, 2, 5)]
    shared.give_back(range(8, 9))
    shared.halt()  # a failure elsewhere: nothing more, given back or not
    assert not shared.take()


def test_cli_prints_the_packages_warnings_as_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    with _warnings_as_lines():
        for _ in range(2):  # every time, not once per place
            warnings.warn(ClusterLostWarning("Ray failed\n  during the run"), stacklevel=1)
    assert (
        capsys.readouterr().err.splitlines() == ["sim2real: warning: Ray failed during the run"] * 2
    )


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


#: Ray 2.60 starts a head with token authentication; a driver given the head's address uses
#: it only when told (Ray enables it by itself for ``auto`` alone).
TOKEN_ENV = {**os.environ, "RAY_AUTH_MODE": "token"}


@contextlib.contextmanager
def _ray_head() -> Iterator[int]:
    """A Ray head of its own (``ray start --head --block``, token auth) on a free port; every
    process of it is killed (SIGKILL) on the way out. Yields the port."""
    port = _free_port()
    head = subprocess.Popen(
        [str(Path(sys.executable).with_name("ray")), "start", "--head", "--block",
         f"--port={port}", "--num-cpus=1", "--include-dashboard=false", "--disable-usage-stats"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
        env=TOKEN_ENV,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            time.sleep(0.1)
        else:
            pytest.fail("the Ray head did not open its port within 60 s")
        yield port
    finally:
        _kill_tree(head.pid)
        head.wait(timeout=30)
        # `ray start` recorded this head as the machine's cluster; a record of a dead head
        # makes a later plain ray.init(num_cpus=...) refuse ("connecting to an existing
        # cluster", the RLlib test in CI), so it goes with the head
        record = _cluster_file()
        with contextlib.suppress(OSError):
            if record.read_text(encoding="utf-8").strip().endswith(f":{port}"):
                record.unlink()


def _kill_tree(root: int) -> None:
    for pid in [*descendants(root), root]:
        with contextlib.suppress(ProcessLookupError):  # gone already
            os.kill(pid, signal.SIGKILL)


@pytest.mark.cluster
@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads Linux /proc")
def test_map_tasks_survives_a_cluster_that_dies_mid_run(tmp_path: Path) -> None:
    """A head started here is killed (SIGKILL, every process of it) while a Ray task holds a
    batch: the driver gets the items back, finishes all 400 in order, warns once in one
    sentence, and lets go of the dead cluster."""
    flag = tmp_path / "ray_task_running"
    with _ray_head() as port:
        driver = subprocess.Popen(
            [sys.executable, str(HERE / "_lost_driver.py"), f"127.0.0.1:{port}", str(flag)],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=TOKEN_ENV,
        )  # fmt: skip
        deadline = time.monotonic() + 120.0
        while not flag.exists() and driver.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        if not flag.exists():
            driver.kill()
            pytest.fail(f"no Ray task ever ran: {driver.communicate()}")
        # the with block's exit kills the head; a Ray task still holds its batch
    out, err = driver.communicate(timeout=180)
    assert driver.returncode == 0, err[-3000:]
    result = json.loads(out.strip().splitlines()[-1])
    assert result["ok"]  # every item, in order, the same values
    assert result["ray_initialized"] is False  # not left tied to the dead cluster
    (warning,) = result["warnings"]
    assert warning.startswith(f"ClusterLostWarning: Ray (--ray 127.0.0.1:{port}) failed during")
    assert "item(s) it held and the rest ran in this process" in warning
    assert "\n" not in warning
    assert result["wall_s"] < 60  # the held batch was not waited out (its tasks sleep 60 s)


@pytest.mark.cluster
@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads Linux /proc")
def test_explicit_address_without_token_mode_says_how_to_connect(tmp_path: Path) -> None:
    """``--ray HOST:PORT`` to a token-auth head without RAY_AUTH_MODE: exit 2, one sentence
    that names the fix; with RAY_AUTH_MODE=token the same command runs on that head."""
    # what is checked is the connection, not the figures: two short sessions (10 s each, the
    # bundled demo log is 148 s) keep the joined run's per-log work small
    logs = write_synthetic_fleet(tmp_path, 2, duration_s=10.0, seed=3)
    no_mode = {k: v for k, v in os.environ.items() if k != "RAY_AUTH_MODE"}
    with _ray_head() as port:
        argv = [sys.executable, "-m", "sim2real", "agree", *map(str, logs),
                "--robot", "turtlebot3_burger", "--engine", "reduced", "--ray", f"127.0.0.1:{port}"]  # fmt: skip
        refused = subprocess.run(argv, capture_output=True, text=True, env=no_mode, timeout=120)
        joined = subprocess.run(argv, capture_output=True, text=True, env=TOKEN_ENV, timeout=300)
    assert refused.returncode == 2, refused.stderr[-2000:]
    (line,) = [x for x in refused.stderr.splitlines() if x.startswith("sim2real: error:")]
    assert f"--ray 127.0.0.1:{port}: cannot connect" in line
    assert "set RAY_AUTH_MODE=token" in line and "Traceback" not in refused.stderr
    assert joined.returncode == 0, joined.stderr[-2000:]
    assert "2 logs: robot turtlebot3_burger, engine reduced, Ray (127.0.0.1:" in joined.stdout
