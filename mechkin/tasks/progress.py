"""Progress of long runs on stderr (never stdout), shared by the tasks.

:func:`progress_bar` yields a callback ``update(done, total)`` (or None when disabled): a rich
progress bar when ``enabled`` is True, or None (the default: only when stderr is a terminal).

With a time limit (``--max-time``, :mod:`mechkin.tasks.budget`) the callback also stops the run
between two jobs once the limit is used (bar or not).

Imports: the standard library, tasks.budget; rich inside.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterator


def resolve(progress: bool | None) -> tuple[bool, bool]:
    """(show, force_terminal): ``None`` shows a bar only when stderr is a terminal."""
    if progress is None:
        return bool(getattr(sys.stderr, "isatty", lambda: False)()), False
    return bool(progress), bool(progress)


@contextlib.contextmanager
def progress_bar(progress: bool | None, description: str, deadline: bool = True
                 ) -> Iterator[Callable[[int, int], None] | None]:
    """A rich progress bar on stderr as a callback ``update(done, total)``; None when off.
    ``deadline=False``: the caller stops at its own safe points (budget.overrun) and keeps
    the finished rows, so the callback never raises."""
    from mechkin.tasks.budget import check_deadline, time_limit

    show, force = resolve(progress)
    if not show:
        # with a --max-time the callback still runs: it stops the run between two jobs
        yield ((lambda done, total: check_deadline()) if time_limit() is not None and deadline
               else None)
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    console = Console(stderr=True, force_terminal=force or None)
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=console, transient=False) as bar:
        task = bar.add_task(description, total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)
            if deadline:
                check_deadline()

        yield update
