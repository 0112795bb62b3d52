"""Safe output: write to a temporary file beside the target, then rename over it.

:func:`atomic_write` writes one file (through :func:`robots.files.atomic_write`, the one atomic
write); :func:`output_set` writes several files as a set: they are staged in a temporary folder
beside their destination and moved in together at the end, so a run that fails or is killed
before the end leaves the previous outputs untouched. Files get the user's umask (``0666 & ~umask``, 0644 by default), like any file a program creates.

Temp names carry the writer's process id; a later run removes the leftovers of runs that were
killed (and finishes the moves of a set that was killed while moving in, so the folder ends
with the complete new set, never a mix).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import IO

from robots import files
from sim2real.errors import Sim2RealFileNotFoundError, Sim2RealValueError

__all__ = [
    "OutputSet",
    "atomic_write",
    "check_not_an_input",
    "check_output_path",
    "clean_orphans",
    "output_set",
]

_SET_PREFIX = ".sim2real-out-"
_COMMIT = ".commit"
_SET_RE = re.compile(r"^\.sim2real-out-(\d+)-")


def check_output_path(path: str | Path, *, what: str = "output file") -> Path:
    """Return ``path`` as a Path after checking its folder exists (clear error otherwise)."""
    problem = files.output_problem(path, what=what)
    if problem is not None:
        raise Sim2RealFileNotFoundError(problem)
    return Path(path)


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


def _finish_set(folder: Path) -> None:
    """Move a committed staging folder's files into its parent (roll forward), then drop it."""
    for item in sorted(folder.iterdir()):
        if item.name != _COMMIT and item.is_file():
            os.replace(item, folder.parent / item.name)
    shutil.rmtree(folder, ignore_errors=True)


def clean_orphans(folder: str | Path) -> None:
    """Remove the temp files and staging folders that killed runs left in ``folder``.

    A staging folder whose set was already committed (killed while moving in) is finished
    instead, so ``folder`` ends with the whole new set.
    """
    base = Path(folder)
    files.clean_orphans(base)
    with contextlib.suppress(OSError):
        for item in base.iterdir():
            m = _SET_RE.match(item.name) if item.is_dir() else None
            if m is None or files.process_alive(int(m.group(1))):
                continue
            if (item / _COMMIT).exists():
                _finish_set(item)
            else:
                shutil.rmtree(item, ignore_errors=True)


@contextlib.contextmanager
def atomic_write(path: str | Path, mode: str = "wb", *, what: str = "output file") -> Iterator[IO]:  # type: ignore[type-arg]
    """Open a temp file next to ``path``; on success rename it to ``path``, else delete it.

    Nothing is left at ``path`` when the body raises, so a failed run loses no earlier output.
    The file gets the mode ``0666 & ~umask`` (0644 under the usual umask 022).

    Examples
    --------
    >>> with atomic_write("out.txt", "w") as fh:  # doctest: +SKIP
    ...     fh.write("hello")
    """
    target = check_output_path(path, what=what)
    clean_orphans(target.parent if str(target.parent) else Path("."))
    with files.atomic_write(target, mode) as fh:
        yield fh


class OutputSet:
    """The staged paths of an :func:`output_set`: write each output to ``staged(dest)``."""

    def __init__(self, staged: dict[Path, Path]) -> None:
        self._staged = staged

    def staged(self, dest: str | Path) -> Path:
        """Where to write the output whose destination is ``dest`` (inside the staging folder).

        Extra files written beside it (e.g. a report's PNGs) move in with the set.
        """
        return self._staged[Path(dest).resolve()]

    @property
    def destinations(self) -> tuple[Path, ...]:
        """The destinations, as given (resolved)."""
        return tuple(self._staged)


@contextlib.contextmanager
def output_set(
    paths: Sequence[str | Path | None], *, what: str = "output file"
) -> Iterator[OutputSet]:
    """Write several outputs as a set: all of them move in at the end, or none does.

    Each destination's folder gets one staging folder ``.sim2real-out-<pid>-*``; the body writes
    into :meth:`OutputSet.staged` paths; on success every file of each staging folder moves to
    its destination folder (``os.replace``, after a commit marker is written so a run killed
    while moving in is finished by the next one). When the body raises, the staging folders are
    removed and the previous outputs stay as they were. ``None`` entries are skipped.

    Examples
    --------
    >>> with output_set(["a.json", "report.html"]) as out:  # doctest: +SKIP
    ...     out.staged("a.json").write_text("{}")
    ...     out.staged("report.html").write_text("<html></html>")
    """
    dests = [check_output_path(p, what=what).resolve() for p in paths if p is not None]
    for k, d in enumerate(dests):
        if d in dests[:k]:
            raise Sim2RealValueError(f"{what} '{d}' is given twice; give each output its own path")
    folders: dict[Path, Path] = {}
    try:
        for d in dests:
            if d.parent not in folders:
                clean_orphans(d.parent)
                folders[d.parent] = Path(
                    tempfile.mkdtemp(prefix=f"{_SET_PREFIX}{os.getpid()}-", dir=d.parent)
                )
        yield OutputSet({d: folders[d.parent] / d.name for d in dests})
    except BaseException:
        for folder in folders.values():
            shutil.rmtree(folder, ignore_errors=True)
        raise
    for folder in folders.values():
        (folder / _COMMIT).touch()
    for folder in folders.values():
        _finish_set(folder)
