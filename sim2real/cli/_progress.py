"""The CLI's progress bar: on a terminal a transient bar, in a pipe nothing at all.

:mod:`rich` is imported when a bar is made, not when this module is, so a command that may
show a bar (``agree`` with ``--ensemble``) costs nothing at start-up when it shows none.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator

__all__ = ["Update", "progress_bar"]

#: ``update(completed, description=None)``: move the bar (and relabel it).
Update = Callable[..., None]


@contextlib.contextmanager
def progress_bar(
    label: str, total: float, *, counted: bool = False, stdout: bool = False
) -> Iterator[Update]:
    """A transient progress bar shown while the body runs; yields its ``update`` function.

    Parameters
    ----------
    label : str
        The bar's text (rich markup), e.g. ``"[bold]agree[/] ensemble"``; ``{description}``
        in it is replaced by the latest ``description=`` given to ``update``.
    total : float
        The value of ``completed`` at the end.
    counted : bool
        Show ``done/total`` beside the bar.
    stdout : bool
        Draw on stdout (a command whose table follows the bar there) instead of stderr.

    Examples
    --------
    >>> with progress_bar("[bold]sysid[/] {description}", 1.0) as update:
    ...     update(0.5, description="fitting")
    """
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    console = Console(stderr=not stdout)
    columns = [
        TextColumn(label.replace("{description}", "{task.description:<18}")),
        BarColumn(),
        *([MofNCompleteColumn()] if counted else []),
        TimeElapsedColumn(),
    ]
    # disabled off a terminal: rich would print an empty line to a pipe
    with Progress(
        *columns, console=console, transient=True, disable=not console.is_terminal
    ) as bar:
        task = bar.add_task("starting", total=total)

        def update(completed: float, description: str | None = None) -> None:
            if description is None:
                bar.update(task, completed=completed)
            else:
                bar.update(task, completed=completed, description=description)

        yield update
