"""The Makefile's install targets compile the drive kernels once (numba's on-disk cache), so
the first ``sim2real sysid fit`` after an install loads them instead of compiling."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MAKEFILE = REPO / "Makefile"

#: Run in a fresh process after the warm-up: the full fit of the README, then which kernels
#: numba compiled (cache misses) and which it loaded from the cache (hits).
PROBE = """
import json, sys
from sim2real.fitting import fit_logs
from robots import _jit
fit_logs([sys.argv[1]], robot="turtlebot3_burger")
used = [k for k in _jit._KERNELS if k.dispatcher is not None and k.dispatcher.signatures]
print(json.dumps({
    k.py_func.__qualname__: [sum(k.dispatcher.stats.cache_hits.values()),
                             sum(k.dispatcher.stats.cache_misses.values())]
    for k in used
}))
"""


def _warm_argv() -> list[str]:
    """The Makefile's warm-up command, with its sim2real run as ``python -m sim2real``."""
    text = MAKEFILE.read_text(encoding="utf-8").replace("\\\n", " ")
    line = re.search(r"^warm = \$\(1\)/sim2real (.*?) > /dev/null$", text, re.MULTILINE)
    assert line, "the Makefile defines no warm-up"
    return [sys.executable, "-m", "sim2real", *shlex.split(line.group(1))]


def test_every_install_target_warms_the_kernels() -> None:
    text = MAKEFILE.read_text(encoding="utf-8")
    for stamp in ("$(STAMP_RUN):", "$(STAMP_DEV):", "$(STAMP_RLLIB):"):
        recipe = text.split(stamp, 1)[1].split("\n\n", 1)[0]
        assert "$(call warm," in recipe, stamp
        assert recipe.index("pip install") < recipe.index("$(call warm,"), stamp


def _cache_listing(folder: Path) -> list[str]:
    """The numba cache files and stamps under ``folder`` (for a failure's message)."""
    return sorted(
        f"{p.relative_to(folder)} {p.stat().st_size}"
        for p in folder.rglob("*")
        if p.is_file() and p.suffix in (".nbi", ".nbc", ".sha256")
    )


@pytest.mark.slow
@pytest.mark.serial  # numba's cache files must not see another process's load or writes
def test_the_first_fit_after_the_warm_up_compiles_nothing(tmp_path: Path) -> None:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}  # a cold, private cache
    argv = [a.replace("$(1)/..", str(tmp_path)) for a in _warm_argv()]
    warm = subprocess.run(argv, cwd=REPO, env=env, capture_output=True, text=True, check=False)
    assert warm.returncode == 0, warm.stderr[-2000:]
    after_warm = _cache_listing(tmp_path / "numba")
    probe = subprocess.run(
        [sys.executable, "-c", PROBE, str(REPO / "data" / "demo_train.mcap")],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert probe.returncode == 0, probe.stderr[-2000:]
    stats = json.loads(probe.stdout.splitlines()[-1])
    assert "_run_many" in stats  # the fit's kernels ...
    loaded = all(hits >= 1 and misses == 0 for hits, misses in stats.values())  # ... loaded
    assert loaded, (stats, after_warm, _cache_listing(tmp_path / "numba"), probe.stderr[-2000:])
