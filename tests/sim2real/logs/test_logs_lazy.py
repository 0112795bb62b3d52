"""The read path imports only what reading needs (issue 16.3, whole-process decode time)."""

from __future__ import annotations

import ast
import subprocess
import sys

import pytest

import sim2real.logs

#: Modules a CDR MCAP read never needs: writers, ``logs info``, digests, YAML, the console,
#: the generic decoders (mcap, mcap_ros2) and their standard-library imports.
_NOT_ON_READ_PATH = (
    "sim2real.logs._writer",
    "sim2real.logs._info",
    "sim2real.logs._bagwrite",
    "sim2real.logs._csv",
    "sim2real._io",
    "yaml",
    "rich",
    "mcap",
    "mcap_ros2",
    "rosbags",
    "tempfile",
    "shutil",
    "lzma",
    "hashlib",
    "difflib",
    "json",
)


def test_read_trace_imports_only_the_read_path(tmp_path) -> None:
    import numpy as np

    from sim2real.logs import write_velocity_log

    t = 1_700_000_000 * 10**9 + np.arange(50, dtype=np.int64) * 20_000_000
    path = write_velocity_log(
        tmp_path / "run.mcap",
        cmd_t_ns=t,
        cmd_v=np.full(50, 0.1),
        cmd_w=np.zeros(50),
        meas_t_ns=t,
        meas_v=np.full(50, 0.1),
        meas_w=np.zeros(50),
    )
    prog = (
        "import sys\n"
        "before = set(sys.modules)\n"
        "from sim2real.logs import read_trace\n"
        f"tr = read_trace({str(path)!r})\n"
        "print(repr([int(tr.meas_t_ns.size), sorted(set(sys.modules) - before)]))\n"
    )
    out = subprocess.run([sys.executable, "-c", prog], capture_output=True, text=True, check=True)
    count, loaded = ast.literal_eval(out.stdout.strip().splitlines()[-1])
    assert count == 50
    assert "sim2real.logs._reader" in loaded
    unwanted = [m for m in _NOT_ON_READ_PATH if m in loaded]
    assert unwanted == [], f"read_trace imported {unwanted}"


def test_lazy_names_resolve_and_unknown_names_fail() -> None:
    for name in sim2real.logs.__all__:
        assert getattr(sim2real.logs, name) is not None
    assert set(sim2real.logs.__all__) <= set(dir(sim2real.logs))
    with pytest.raises(AttributeError, match="no_such_thing"):
        _ = sim2real.logs.no_such_thing  # type: ignore[attr-defined]
