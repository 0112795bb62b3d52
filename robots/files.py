"""Atomic file writes: write to a temporary file beside the target, then rename over it; and
the plain data a YAML file is written from (:func:`plain_data`).

The one atomic write of the project (:mod:`sim2real`, :mod:`sysid`, :mod:`randomizers` and
:mod:`robots` write files through it). A reader of the target sees the old file or the new one,
never a half-written one, and a writer that fails leaves the old file as it was.

Temp names are ``.<name>.<pid>.<random>.tmp`` beside the target; :func:`clean_orphans` removes
those whose writer process is gone (a run that was killed). Files get the user's umask
(``0666 & ~umask``, 0644 by default), like any file a program creates.

Examples
--------
>>> import tempfile
>>> from pathlib import Path
>>> folder = Path(tempfile.mkdtemp())
>>> write_text_atomic(folder / "a.txt", "hello").read_text()
'hello'
>>> sorted(p.name for p in folder.iterdir())  # no temp file left
['a.txt']
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import IO, Any

__all__ = [
    "atomic_write",
    "clean_orphans",
    "file_mode",
    "output_problem",
    "plain_data",
    "process_alive",
    "write_text_atomic",
]

_TEMP_RE = re.compile(r"^\..+\.(\d+)\.[^.]+\.tmp$")


def file_mode() -> int:
    """The mode a new file gets under the user's umask: ``0666 & ~umask`` (0o644 under 022)."""
    mask = os.umask(0o022)  # the only portable way to read it is to set it and set it back
    os.umask(mask)
    return 0o666 & ~mask


def process_alive(pid: int) -> bool:
    """Whether a process with id ``pid`` exists (this one, or one owned by anyone)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def output_problem(path: str | Path, *, what: str = "output file") -> str | None:
    """Why ``path`` cannot be written as a file (one sentence naming it), or None.

    Its folder must exist and it must not be a folder itself. Each package raises its own error
    with the sentence.

    Examples
    --------
    >>> output_problem("/nonexistent-folder/a.yaml", what="params file")
    "params file '/nonexistent-folder/a.yaml' is in folder '/nonexistent-folder', which does not exist; create it first or choose another path"
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        return (
            f"{what} '{target}' is in folder '{folder}', which does not exist; create it first "
            "or choose another path"
        )
    if target.is_dir():
        return f"{what} '{target}' is a folder; give a file name"
    return None


def clean_orphans(folder: str | Path) -> None:
    """Remove the temp files of :func:`atomic_write` in ``folder`` whose writer is gone.

    Files of live processes (and a folder that cannot be read) are left alone.
    """
    with contextlib.suppress(OSError):
        for item in Path(folder).iterdir():
            found = _TEMP_RE.match(item.name)
            if found and not item.is_dir() and not process_alive(int(found.group(1))):
                item.unlink(missing_ok=True)


@contextlib.contextmanager
def atomic_write(
    path: str | Path, mode: str = "wb", *, encoding: str | None = None
) -> Iterator[IO]:  # type: ignore[type-arg]
    """Open a temp file next to ``path``; on success rename it to ``path``, else delete it.

    Nothing is left at ``path`` when the body raises, so a failed write loses no earlier file.
    The temp files of killed writers in the same folder are removed first
    (:func:`clean_orphans`). The folder must exist (``FileNotFoundError`` otherwise).

    Parameters
    ----------
    path : str or Path
        The file to write.
    mode : str
        ``"wb"`` or ``"w"`` (text).
    encoding : str, optional
        The text encoding (text mode only).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> target = Path(tempfile.mkdtemp()) / "b.bin"
    >>> with atomic_write(target) as fh:
    ...     _ = fh.write(b"\\x00\\x01")
    >>> target.read_bytes()
    b'\\x00\\x01'
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    clean_orphans(folder)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}.", suffix=".tmp", dir=folder)
    os.chmod(tmp, file_mode())  # mkstemp makes 0600 files
    try:
        with os.fdopen(fd, mode, encoding=encoding) as fh:
            yield fh
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def write_text_atomic(path: str | Path, text: str, *, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` with :func:`atomic_write`; return ``path`` as a Path.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> write_text_atomic(Path(tempfile.mkdtemp()) / "c.txt", "x").name
    'c.txt'
    """
    with atomic_write(path, "w", encoding=encoding) as fh:
        fh.write(text)
    return Path(path)


def plain_data(value: Any) -> Any:
    """``value`` as the plain Python data ``yaml.safe_dump`` writes: mappings as dicts with
    string keys, tuples and lists as lists, numpy scalars and arrays as Python numbers and
    lists, paths as strings; anything else as it is.

    Examples
    --------
    >>> import numpy as np
    >>> plain_data({"a": (np.float64(0.5), np.arange(2)), 3: Path("x.yaml")})
    {'a': [0.5, [0, 1]], '3': 'x.yaml'}
    """
    if isinstance(value, Mapping):
        return {str(k): plain_data(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [plain_data(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "tolist"):  # a numpy scalar or array
        return plain_data(value.tolist())
    return value
