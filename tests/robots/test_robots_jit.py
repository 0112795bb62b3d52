"""Kernels compiled on first use (robots._jit): a short one-off simulation never loads numba
and gives the compiled numbers bit for bit; past the budget, or once compiled, numba runs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robots import _jit, _kernel, load_spec, simulate
from robots import reduced as reduced_mod

REPO = Path(__file__).resolve().parents[2]

_CHILD = """
import json, sys
import numpy as np
from robots import load_spec, reduced
spec = load_spec("turtlebot3_burger")
rng = np.random.default_rng(3)
t = 0.1 * np.arange(300)
kw = dict(cmd_t_s=t, cmd_v=rng.uniform(-0.3, 0.3, 300), cmd_w=rng.uniform(-3, 3, 300),
          t_out_s=np.arange(0.0, 30.0, 1 / 30), v0=0.05, w0=-0.2)
params = spec.drive.replace(wheel_torque_max_nm=0.03, accel_lim_v_mps2=1.5, delay_s=0.07)
auto = reduced.simulate(params, spec.geometry, python=None, **kw)
loaded_after_auto = "numba" in sys.modules
compiled = reduced.simulate(params, spec.geometry, **kw)
print(json.dumps({
    "numba_after_auto": loaded_after_auto,
    "numba_after_compiled": "numba" in sys.modules,
    "same_v": bool(np.array_equal(auto.v, compiled.v)),
    "same_w": bool(np.array_equal(auto.w, compiled.w)),
    "moves": float(np.ptp(auto.v)),
}))
"""


def test_short_one_off_simulation_runs_without_numba_and_equals_compiled_bit_for_bit() -> None:
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD], capture_output=True, text=True, check=True, cwd=REPO
    )
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    assert got == {**got, "numba_after_auto": False, "numba_after_compiled": True}
    assert got["same_v"] and got["same_w"] and got["moves"] > 0.1


def test_auto_mode_compiles_past_the_budget_or_once_compiled() -> None:
    spec = load_spec("turtlebot3_burger")
    t = np.arange(0.0, 5.0, 0.1)
    kw = {"cmd_t_s": t, "cmd_v": np.full(t.size, 0.2), "cmd_w": np.zeros(t.size), "t_out_s": t}
    simulate(spec.drive, spec.geometry, **kw)  # compiled in this process now
    assert _jit.compiled()
    assert not reduced_mod._within_interpret_budget(10)
    # every module-level name that held a kernel is the numba dispatcher now
    assert not isinstance(_kernel.drive_step, _jit.Kernel)
    assert not isinstance(reduced_mod.drive_step, _jit.Kernel)
    assert hasattr(_kernel.drive_step, "signatures")


def test_interpreted_block_runs_an_uncompiled_kernel_as_python() -> None:
    calls: list[float] = []

    def double(x: float) -> float:
        calls.append(x)
        return 2.0 * x

    kernel = _jit.Kernel(double, {})  # not registered: never compiled
    with _jit.interpreted():
        assert kernel(1.5) == 3.0
    assert calls == [1.5]
    assert "not compiled yet" in repr(kernel)


def test_a_kernel_compiles_without_the_disk_cache_when_numba_has_no_cache_folder(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import numba

    real = numba.njit

    def no_cache_folder(**options: Any) -> Any:
        if options.get("cache"):
            raise RuntimeError("cannot cache function 'twice': no locator available for file 'x'")
        return real(**options)

    monkeypatch.setattr(numba, "njit", no_cache_folder)
    kernel = _jit.Kernel(lambda x: 2.0 * x, {"cache": True})
    compiled = _jit._dispatcher(numba, kernel)
    assert compiled(1.5) == 3.0
    assert hasattr(compiled, "signatures")
    other = _jit.Kernel(lambda x: x, {"cache": True})
    monkeypatch.setattr(numba, "njit", lambda **o: (_ for _ in ()).throw(RuntimeError("boom")))
    with pytest.raises(RuntimeError, match="boom"):
        _jit._dispatcher(numba, other)


_INNER = """
from robots._jit import njit

@njit(cache=True)
def inner(x):
    return x + {add}
"""

_OUTER = """
from robots._jit import njit
from tests.kmod_inner import inner

@njit(cache=True)
def outer(x):
    return inner(x) * 2.0
"""


def test_editing_a_called_kernel_invalidates_the_callers_disk_cache(tmp_path: Path) -> None:
    """numba keys a cached kernel by its own file only: a caller in another file would keep
    the old callee's machine code. _jit keys the cache on the sources' digest instead."""
    pkg = tmp_path / "tests"  # a package _jit rebinds kernel names in
    pkg.mkdir()
    (pkg / "kmod_outer.py").write_text(_OUTER)
    run = [sys.executable, "-c", "from tests.kmod_outer import outer; print(outer(1.0))"]

    def outer_of_one(add: float) -> float:
        (pkg / "kmod_inner.py").write_text(_INNER.format(add=add))
        proc = subprocess.run(run, capture_output=True, text=True, check=True, cwd=tmp_path)
        return float(proc.stdout.strip())

    assert outer_of_one(1.0) == 4.0
    cache = pkg / "__pycache__"
    assert any(p.suffix == ".nbi" and p.name.startswith("kmod_outer.") for p in cache.iterdir())
    assert outer_of_one(2.0) == 6.0  # numba alone would load outer's stale code: 4.0
    assert outer_of_one(2.0) == 6.0  # and from the cache again


def test_a_stale_folder_loses_only_its_kernel_modules_cache_files(tmp_path: Path) -> None:
    names = ["reduced._run-99.py311.nbi", "reduced._run-99.py311.1.nbc", "other.f-1.py311.nbi"]
    for name in names:
        (tmp_path / name).write_bytes(b"x")
    assert _jit.invalidate_folder(tmp_path, {"reduced", "_kernel"}, "abc")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["other.f-1.py311.nbi", _jit.STAMP_NAME]
    assert (tmp_path / _jit.STAMP_NAME).read_text().strip() == "abc"
    (tmp_path / names[0]).write_bytes(b"x")
    assert not _jit.invalidate_folder(tmp_path, {"reduced"}, "abc")  # stamp matches: kept
    assert (tmp_path / names[0]).exists()
    assert _jit.sources_digest({tmp_path / names[0]}) != _jit.sources_digest(set())


_PLAIN_INNER = """
import numba

@numba.njit(cache=True)
def inner(x):
    return x + {add}
"""

_PLAIN_OUTER = """
from pathlib import Path

import numba

from robots import _jit
from plainmods import plain_inner
from plainmods.plain_inner import inner

@numba.njit(cache=True)
def outer(x):
    return inner(x) * 2.0

_jit.key_cache(outer, {Path(__file__), Path(plain_inner.__file__)})
"""


def test_key_cache_keys_a_plain_numba_module_on_the_sources_it_calls(tmp_path: Path) -> None:
    """A plain numba.njit(cache=True) module (sim2real.envs._vecnav) calling kernels of other
    files: key_cache drops its cached code when one of those files changes."""
    pkg = tmp_path / "plainmods"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "plain_outer.py").write_text(_PLAIN_OUTER)
    run = [sys.executable, "-c", "from plainmods.plain_outer import outer; print(outer(1.0))"]

    def outer_of_one(add: float) -> float:
        (pkg / "plain_inner.py").write_text(_PLAIN_INNER.format(add=add))
        proc = subprocess.run(run, capture_output=True, text=True, check=True, cwd=tmp_path)
        return float(proc.stdout.strip())

    assert outer_of_one(1.0) == 4.0
    cache = pkg / "__pycache__"
    assert any(p.name.startswith("plain_outer.") and p.suffix == ".nbi" for p in cache.iterdir())
    assert (cache / "plain_outer-sources.sha256").exists()
    assert outer_of_one(2.0) == 6.0  # numba alone would load outer's stale code: 4.0
    assert outer_of_one(2.0) == 6.0  # and from the cache again
