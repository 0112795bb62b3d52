"""Safe output: write to a temporary file beside the target, then rename over it."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO

from sim2real.errors import Sim2RealFileNotFoundError, Sim2RealValueError

__all__ = ["atomic_write", "check_not_an_input", "check_output_path"]


def check_output_path(path: str | Path, *, what: str = "output file") -> Path:
    """Return ``path`` as a Path after checking its folder exists (clear error otherwise)."""
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise Sim2RealFileNotFoundError(
            f"{what} '{p}' is in folder '{parent}', which does not exist; create it first or "
            "choose another path"
        )
    if p.is_dir():
        raise Sim2RealFileNotFoundError(f"{what} '{p}' is a folder; give a file name")
    return p


def check_not_an_input(
    path: str | Path | None, inputs: Iterable[str | Path | None], *, what: str
) -> None:
    """Refuse an output ``path`` that is one of the ``inputs`` (it would overwrite that file)."""
    if path is None:
        return
    out = Path(path).resolve()
    for given in inputs:
        if given is not None and Path(given).resolve() == out:
            raise Sim2RealValueError(
                f"{what} '{path}' is also an input file ('{given}') and would be overwritten; "
                "choose another output path"
            )


@contextlib.contextmanager
def atomic_write(path: str | Path, mode: str = "wb", *, what: str = "output file") -> Iterator[IO]:  # type: ignore[type-arg]
    """Open a temp file next to ``path``; on success rename it to ``path``, else delete it.

    Nothing is left at ``path`` when the body raises, so a failed run loses no earlier output.

    Examples
    --------
    >>> with atomic_write("out.txt", "w") as fh:  # doctest: +SKIP
    ...     fh.write("hello")
    """
    target = check_output_path(path, what=what)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent or ".")
    umask = os.umask(0o022)  # mkstemp makes 0600 files; give the usual 0666 & ~umask instead
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    try:
        with os.fdopen(fd, mode) as fh:
            yield fh
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
