"""Where the long jobs of a run execute, and their progress bar (scheduling only).

Every long job of a task is split into independent **jobs** by its solver (ik: chunks of
targets; workspace: design values, task-space chunks, joint-sweep subtrees, lee maps; track:
the grids of a grid study; fk: chunks of a long trajectory with overlapping warm starts) and
run by :func:`mechkin.solvers.workspace.sweeps.run_jobs` in this process, on ``--workers N`` local
processes or on a Dask cluster (``--scheduler ADDRESS``). The results come back in job order,
so the executor never changes them (see each task for what is bitwise identical).

The command line sets the run's :class:`Execution` with :func:`execution` (a context
variable, like the memory budget of :mod:`mechkin.tasks.budget`); the tasks read it with
:func:`current`, and functions that take the options themselves (``workspace.run(workers=)``)
override it. Defaults: one process (the tasks solve as they always did) and a progress bar
only when stderr is a terminal.

Imports: the standard library, tasks.budget, tasks.progress; solvers.sweeps inside.
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Any

from mechkin.errors import ConfigError


@dataclass(frozen=True)
class Execution:
    """The run's execution options.

    Attributes
    ----------
    workers : int or None
        Local worker processes (None: the task's default, one process for ik, fk, track and
        joint sweeps; min(cpu count, jobs) for design and task-space sweeps).
    address : str or None
        Dask scheduler address (``tcp://host:port``); overrides ``workers``.
    progress : bool or None
        Progress bar on stderr: True forces it, False turns it off, None: when stderr is a
        terminal.
    where : str
        Where ``workers`` / ``address`` came from (for error lines).
    """

    workers: int | None = None
    address: str | None = None
    progress: bool | None = None
    where: str = "--workers"

    @property
    def split(self) -> bool:
        """True when the jobs run anywhere but in this process alone."""
        return self.address is not None or (self.workers is not None and self.workers > 1)

    def n_workers(self, default: int = 1) -> int | None:
        """Local processes for :func:`~mechkin.solvers.workspace.sweeps.run_jobs` (None on Dask)."""
        if self.address is not None:
            return None
        return int(self.workers) if self.workers is not None else int(default)

    def describe(self, jobs: int, default: int = 1) -> dict[str, Any]:
        """The ``execution`` block of summary.json."""
        n = self.n_workers(default)
        return {"executor": "dask" if self.address is not None else "process",
                "workers": None if n is None else max(1, min(n, max(jobs, 1))),
                "jobs": int(jobs)}


_EXECUTION: contextvars.ContextVar[Execution | None] = contextvars.ContextVar(
    "mechkin_execution", default=None)


def current() -> Execution:
    """The execution options in force (:func:`execution`; outside one, the defaults)."""
    return _EXECUTION.get() or Execution()


@contextlib.contextmanager
def execution(workers: int | None = None, scheduler: str | None = None,
              progress: bool | None = None) -> Iterator[Execution]:
    """Run the block with these execution options (the command line's ``--workers``,
    ``--scheduler``, ``--progress``); checks them first (:func:`check`)."""
    ex = Execution(workers=workers, address=scheduler, progress=progress)
    check(ex)
    token = _EXECUTION.set(ex)
    try:
        yield ex
    finally:
        _EXECUTION.reset(token)


def resolve(workers: int | None = None, scheduler: str | None = None,
            progress: bool | None = None) -> Execution:
    """:func:`current` with the explicitly given options replacing its fields."""
    ex = current()
    if workers is not None:
        ex = replace(ex, workers=workers)
    if scheduler is not None:
        ex = replace(ex, address=scheduler, where="--scheduler")
    if progress is not None:
        ex = replace(ex, progress=progress)
    return ex


def check(ex: Execution) -> None:
    """Bad options are bad input (exit 2) before any work: a worker count the machine cannot
    hold (:func:`mechkin.tasks.budget.check_workers`), a scheduler without the dask extra or
    that does not answer, has no workers or workers without this mechkin version
    (:func:`mechkin.solvers.workspace.sweeps.connect_cluster`)."""
    if ex.address is not None:
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise ConfigError("--scheduler: running on a Dask cluster needs the optional extra "
                              "(pip install 'mechkin[dask]')") from None
        from mechkin.solvers.workspace.sweeps import connect_cluster

        # fail fast, before the output folder or any work: a wrong address, no workers,
        # workers without this mechkin (ClusterError, one line, exit 2)
        connect_cluster(ex.address).close()
    elif ex.workers is not None:
        if ex.workers < 1:
            raise ConfigError(f"{ex.where}: expected at least 1 worker, got {ex.workers}")
        from mechkin.tasks import budget

        budget.check_workers(ex.where, int(ex.workers))


def map_jobs(fn: Callable[[Any], Any], jobs: Sequence[Any], description: str,
             ex: Execution | None = None, *, default_workers: int = 1,
             progress: Callable[[int, int], None] | None = None,
             partial: bool = False) -> list[Any]:
    """``[fn(job) for job in jobs]`` on the run's executor, with a progress bar of the jobs
    (stderr; :mod:`mechkin.tasks.progress`) unless ``progress`` is given.

    Parameters
    ----------
    fn : callable
        A module-level (picklable) function.
    jobs : sequence
        One picklable argument per job.
    description : str
        The bar's label.
    ex : Execution, optional
        Default :func:`current`.
    default_workers : int
        Local processes when ``ex.workers`` is None.
    partial : bool
        The caller keeps a prefix of the results: once the run's ``--max-time`` is used no
        further job starts and the results so far are returned
        (:func:`mechkin.tasks.budget.overrun`); else the run stops with nothing written.
    """
    from mechkin.solvers.workspace.sweeps import run_jobs
    from mechkin.tasks.budget import check_deadline, overrun, time_limit
    from mechkin.tasks.progress import progress_bar

    ex = current() if ex is None else ex
    workers = ex.n_workers(default_workers)

    def timed(update: Callable[[int, int], None] | None) -> Callable[[int, int], None]:
        def call(done: int, total: int) -> None:
            if not partial:
                check_deadline()  # --max-time: stop between two jobs
            if update is not None:
                update(done, total)
        return call

    stop = overrun if partial and time_limit() is not None else None
    if progress is not None:
        return run_jobs(fn, jobs, workers=workers, address=ex.address, progress=timed(progress),
                        stop=stop)
    with progress_bar(ex.progress, description, deadline=not partial) as update:
        return run_jobs(fn, jobs, workers=workers, address=ex.address, progress=timed(update),
                        stop=stop)


def call(job: tuple[Callable[..., Any], tuple[Any, ...]]) -> Any:
    """A job ``(function, arguments)``: ``function(*arguments)`` (module-level functions
    pickle by name, so any task function with picklable arguments can be a job)."""
    fn, args = job
    return fn(*args)
