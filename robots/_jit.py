"""Numba kernels that are compiled on first use, so a process that never runs one never imports
numba (about 0.5 s of CPU: the import and its first-call set-up).

``@njit(**options)`` marks a kernel (numba's ``njit`` options: ``cache``, ``inline``, ...). The
first call of any kernel from Python compiles (or loads from numba's cache; without a writable
cache folder it just compiles) all of them at once
(:func:`compile_all`) and rebinds every module-level name in the ``robots`` package that held a
kernel to its numba dispatcher, so compiled kernels call and inline each other as plain numba
functions. Inside :func:`interpreted`, a kernel that is not compiled yet runs as plain Python
(its ``py_func``) instead, calling the other kernels the same way: the same arithmetic without
numba, for one short run where compiling would cost more than it saves
(:func:`robots.reduced.simulate` with ``python=None``).

numba's on-disk cache (``cache=True``) is keyed by each kernel's own source file, but a
compiled kernel holds the kernels it calls from other files too (``robots.reduced`` inlines the
drive step of ``robots._kernel``): editing one file would leave the others' cached machine code
stale. :func:`compile_all` therefore keys the cache on a hash of the sources of every kernel
module (:func:`sources_digest`): when the hash stored beside a cache folder differs, that
folder's cached kernels of these modules are deleted before anything loads them.

Examples
--------
>>> @njit(cache=False)
... def twice(x):
...     return 2.0 * x
>>> with interpreted():
...     twice(1.5)  # plain Python while nothing is compiled
3.0
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from robots.files import write_text_atomic

__all__ = [
    "Kernel",
    "compile_all",
    "compiled",
    "interpreted",
    "key_cache",
    "njit",
    "sources_digest",
]

_KERNELS: list[Kernel] = []
_LOCK = threading.RLock()
_LOCAL = threading.local()
#: Packages whose module-level names are rebound to the dispatchers by :func:`compile_all`.
_PACKAGES = ("robots", "sysid", "randomizers", "sim2real", "tests")
#: File beside numba's cache files holding the sources digest they were compiled from.
STAMP_NAME = "robots-jit-sources.sha256"


class Kernel:
    """A numba kernel before it is compiled: calls compile it (or interpret it, see module).

    Attributes
    ----------
    py_func : callable
        The plain-Python function.
    options : dict
        The options for ``numba.njit``.
    dispatcher : numba dispatcher or None
        The compiled kernel once :func:`compile_all` ran.
    """

    def __init__(self, py_func: Callable[..., Any], options: dict[str, Any]) -> None:
        self.py_func = py_func
        self.options = options
        self.dispatcher: Any = None
        functools.update_wrapper(self, py_func)

    def __call__(self, *args: Any) -> Any:
        if self.dispatcher is not None:
            return self.dispatcher(*args)
        if getattr(_LOCAL, "interpreting", 0):
            return self.py_func(*args)
        compile_all()
        dispatcher: Any = self.dispatcher
        return dispatcher(*args)

    def __repr__(self) -> str:
        state = "compiled" if self.dispatcher is not None else "not compiled yet"
        return f"<robots kernel {self.py_func.__qualname__} ({state})>"


def njit(**options: Any) -> Any:
    """Decorator: a :class:`Kernel` compiled with ``numba.njit(**options)`` on first use."""

    def mark(py_func: Callable[..., Any]) -> Kernel:
        kernel = Kernel(py_func, options)
        with _LOCK:
            _KERNELS.append(kernel)
        return kernel

    return mark


def compiled() -> bool:
    """Whether the kernels are compiled (numba imported) in this process."""
    return bool(_KERNELS) and all(k.dispatcher is not None for k in _KERNELS)


def compile_all() -> None:
    """Compile every kernel (lazily, per numba: on its first call or from its cache) and rebind
    the module-level names that held them to the numba dispatchers."""
    with _LOCK:
        if compiled():
            return
        import numba

        swap: dict[int, Any] = {}
        fresh = [k for k in _KERNELS if k.dispatcher is None]
        for kernel in fresh:
            kernel.dispatcher = _dispatcher(numba, kernel)
        _drop_stale_caches(fresh)
        for kernel in _KERNELS:
            swap[id(kernel)] = kernel.dispatcher
        for name, module in list(sys.modules.items()):
            if module is None or name.split(".")[0] not in _PACKAGES:
                continue
            namespace = vars(module)
            for attr, value in list(namespace.items()):
                if isinstance(value, Kernel):
                    namespace[attr] = swap[id(value)]


def _dispatcher(numba: Any, kernel: Kernel) -> Any:
    """``numba.njit(**options)(py_func)``; without the on-disk cache if numba finds no writable
    cache folder (neither beside the source nor ``NUMBA_CACHE_DIR`` / the user cache)."""
    try:
        return numba.njit(**kernel.options)(kernel.py_func)
    except RuntimeError as exc:
        if not kernel.options.get("cache") or "cannot cache" not in str(exc):
            raise
        return numba.njit(**{**kernel.options, "cache": False})(kernel.py_func)


def _source_file(kernel: Kernel) -> Path | None:
    module = sys.modules.get(kernel.py_func.__module__)
    name = getattr(module, "__file__", None)
    return Path(name) if name else None


def sources_digest(files: set[Path]) -> str:
    """SHA-256 of ``files`` (names and contents, in sorted order)."""
    digest = hashlib.sha256()
    for path in sorted(files):
        digest.update(path.name.encode() + b"\0")
        with contextlib.suppress(OSError):  # an unreadable source: its name still counts
            digest.update(path.read_bytes())
    return digest.hexdigest()


def _drop_stale_caches(kernels: list[Kernel]) -> None:
    """Delete the cached machine code of ``kernels``' modules in each cache folder whose stamp
    is not the digest of its sources (before numba loads any of it), then stamp the folder.

    A folder's sources are its own kernel modules plus every kernel module of ``robots`` (the
    bottom of the import order, which every kernel may call), so the digest is the same in
    every process that uses the folder.
    """
    folders: dict[Path, set[Path]] = {}
    base: set[Path] = set()
    for kernel in (k for k in kernels if k.options.get("cache")):
        folder = getattr(getattr(kernel.dispatcher, "_cache", None), "_cache_path", None)
        source = _source_file(kernel)
        if not (folder and source):
            continue
        folders.setdefault(Path(folder), set()).add(source)
        if kernel.py_func.__module__.split(".")[0] == "robots":
            base.add(source)
    for folder, sources in folders.items():
        invalidate_folder(folder, {f.stem for f in sources}, sources_digest(sources | base))


def invalidate_folder(
    folder: Path, stems: set[str], digest: str, stamp_name: str = STAMP_NAME
) -> bool:
    """Delete ``folder``'s numba cache files (``.nbi``, ``.nbc``) of the modules ``stems``
    unless its stamp (file ``stamp_name``) says ``digest``; write the stamp. Returns whether
    files were deleted.

    Folders that cannot be read or written are left alone (numba then compiles anew).
    """
    stamp = folder / stamp_name
    try:
        if stamp.read_text(encoding="ascii").strip() == digest:
            return False
    except OSError:
        pass
    dropped = False
    try:
        for path in folder.iterdir():
            if path.suffix in (".nbi", ".nbc") and path.name.split(".")[0] in stems:
                path.unlink(missing_ok=True)
                dropped = True
        write_text_atomic(stamp, digest + "\n", encoding="ascii")
    except OSError:
        pass
    return dropped


def key_cache(dispatcher: Any, sources: set[Path]) -> bool:
    """Key the on-disk cache of a plain ``numba.njit(cache=True)`` module on ``sources``.

    numba keys a cached kernel on its own file only; a kernel that calls kernels of other
    files (``sources``: list them all, the kernel's own file included) keeps stale machine code
    when one of those changes. Call this at import, after the module's kernels are defined and
    before any runs: if the digest of ``sources`` differs from the one stamped in the cache
    folder of ``dispatcher`` (any kernel of the module), the module's cached kernels there are
    deleted. Returns whether files were deleted.
    """
    folder = getattr(getattr(dispatcher, "_cache", None), "_cache_path", None)
    module = sys.modules.get(getattr(dispatcher, "py_func", dispatcher).__module__)
    name = getattr(module, "__file__", None)
    if not (folder and name):
        return False
    stem = Path(name).stem
    return invalidate_folder(
        Path(folder), {stem}, sources_digest(sources), f"{stem}-sources.sha256"
    )


@contextmanager
def interpreted() -> Iterator[None]:
    """Run kernels that are not compiled yet as plain Python inside this block (this thread)."""
    _LOCAL.interpreting = getattr(_LOCAL, "interpreting", 0) + 1
    try:
        yield
    finally:
        _LOCAL.interpreting -= 1
