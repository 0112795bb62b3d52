"""The SHA-256 of a log file, computed only when someone reads it (private).

Reading a log needs none of its digest; only the commands that write it (a fit result's
``data`` list, agree's ``log_sha256``, a calibration's validation list) do. So
:attr:`~sim2real.logs.TraceMeta.sha256` and :attr:`~sim2real.logs.LogInfo.sha256` hold a
:class:`FileDigest` until their first access, which hashes the file then (1 MiB blocks, no
copy of the whole file in memory) and keeps the hex string. The file's size and modification
time are recorded when it is read: a file that changed in between is an error, not a digest
of other bytes than the ones read.

Examples
--------
>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Meta:
...     sha256: LazyText = LazyText()
>>> Meta(sha256=lambda: "ab" * 32).sha256[:4]
'abab'
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import overload

from sim2real.errors import LogFormatError

__all__ = ["FileDigest", "LazyText", "lazy_value"]

_BLOCK = 1 << 20


class FileDigest:
    """Hex SHA-256 of the concatenated bytes of ``paths``, computed when called.

    ``paths`` is one file, or for a rosbag2 folder its ``metadata.yaml`` then its storage
    files. Picklable (sent to worker processes with a Trace).
    """

    def __init__(self, paths: Sequence[Path], *, name: str) -> None:
        self.paths = tuple(Path(p) for p in paths)
        self.name = name
        self.stamps = tuple(_stamp(p) for p in self.paths)

    def __call__(self) -> str:
        import hashlib  # only where a digest is asked for (not on the read path)

        h = hashlib.sha256()
        for path, stamp in zip(self.paths, self.stamps, strict=True):
            if _stamp(path) != stamp:
                raise LogFormatError(
                    f"log file '{self.name}' changed since it was read ('{path}' has another "
                    "size or modification time), so its SHA-256 would not describe the data "
                    "read; read the log again"
                )
            with path.open("rb") as fh:
                while block := fh.read(_BLOCK):
                    h.update(block)
        return h.hexdigest()


def _stamp(path: Path) -> tuple[int, int]:
    st = os.stat(path)
    return st.st_size, st.st_mtime_ns


class LazyText:
    """A str dataclass field that may be given as a callable, called on first access.

    Assigning a ``str`` stores it; assigning a callable stores it until the attribute is
    first read, then its result replaces it. The class-level default is ``""``.
    """

    def __set_name__(self, owner: type, name: str) -> None:
        self._slot = "_lazy_" + name

    @overload
    def __get__(self, obj: None, objtype: type | None = None) -> str: ...

    @overload
    def __get__(self, obj: object, objtype: type | None = None) -> str: ...

    def __get__(self, obj: object | None, objtype: type | None = None) -> str:
        if obj is None:
            return ""
        value = obj.__dict__.get(self._slot, "")
        if callable(value):
            value = str(value())
            obj.__dict__[self._slot] = value
        return str(value)

    def __set__(self, obj: object, value: str | Callable[[], str]) -> None:
        obj.__dict__[self._slot] = value


def lazy_value(obj: object, name: str) -> str | Callable[[], str]:
    """The stored value of :class:`LazyText` field ``name`` without computing it.

    Pass it on in ``dataclasses.replace(obj, name=lazy_value(obj, name))`` so that a copy does
    not compute the value.
    """
    value: str | Callable[[], str] = obj.__dict__.get("_lazy_" + name, "")
    return value
