"""Pieces every typer subcommand shares: the options of the run commands, the run-command
factory, error handling (DESIGN.md: cli).

Typer only: nothing here imports numpy, the solvers, plotting or MCAP code at module level, so
``mechkin --help`` starts instantly. The work itself is :mod:`mechkin.cli.shell` (no typer);
this module turns its :class:`~mechkin.cli.shell.Exit` into ``typer.Exit``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer

from mechkin.cli import shell
from mechkin.cli.shell import (  # noqa: F401 - the names the subcommands import from here
    _SIGNALLED,
    _has_location,
    _stop_children,
    default_out_dir,
    dump,
    echo_json,
    report,
    terminate_cleanly,
)

F = TypeVar("F", bound=Callable[..., Any])

# the options every run command shares
OutOption = Annotated[Path | None, typer.Option(
    "--out", "-o", help="Output folder [default: outputs/<scenario name>]")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print summary.json to stdout too")]
PlotsOption = Annotated[bool, typer.Option("--plots/--no-plots", help="Write PNG plots")]
MaxMemoryOption = Annotated[str | None, typer.Option(
    "--max-memory", metavar="SIZE",
    help="Memory budget of the job, e.g. 8G or 512M [default: MECHKIN_MAX_MEMORY, else half "
         "of this machine's memory]")]
MaxTimeOption = Annotated[str | None, typer.Option(
    "--max-time", metavar="DURATION",
    help="Refuse a job estimated to take longer (e.g. 90s, 5m, 2h) and stop one that runs "
         "longer at its next safe point: the finished rows are written, status 'stopped: "
         "max-time', exit 1 [default: MECHKIN_MAX_TIME, else no limit]")]
ProgressOption = Annotated[bool | None, typer.Option(
    "--progress/--no-progress",
    help="Progress bar on stderr for long runs [default: when stderr is a terminal]")]
ForceOption = Annotated[bool, typer.Option(
    "--force", help="Replace an output folder that holds another scenario's results")]
WorkersOption = Annotated[int | None, typer.Option(
    "--workers", "-j", min=1,
    help="Run the long jobs of this run (ik target chunks, sweeps, lee maps, grid studies, fk "
         "chunks) on N local processes (default: one process; workspace sweeps: workers: of "
         "the scenario, else min(cpu count, jobs))")]
SchedulerOption = Annotated[str | None, typer.Option(
    "--scheduler", metavar="ADDRESS",
    help="Dask scheduler address (tcp://host:port): run the long jobs on that cluster (needs "
         "the dask extra; every worker must run this mechkin version)")]


def run_command(task: str, doc: str, line: Callable[[dict[str, Any]], str]
                ) -> Callable[..., None]:
    """The typer command ``mechkin <task> SCENARIO [--out] [--json] [--plots]``: load the
    scenario, run ``mechkin.tasks.<task>``, write the report, print ``line(summary)`` (or the
    summary with ``--json``) and the report's messages, exit with its code."""

    def command(
        scenario: Path = typer.Argument(..., help=f"Scenario YAML (task: {task})"),
        out: OutOption = None,
        json_out: JsonOption = False,
        plots: PlotsOption = True,
        force: ForceOption = False,
        max_memory: MaxMemoryOption = None,
        max_time: MaxTimeOption = None,
        progress: ProgressOption = None,
        workers: WorkersOption = None,
        scheduler: SchedulerOption = None,
    ) -> None:
        raise typer.Exit(execute(task, scenario, out, json_out, plots, line, force=force,
                                 max_memory=max_memory, max_time=max_time, progress=progress,
                                 workers=workers, scheduler=scheduler))

    command.__doc__ = doc
    command.__name__ = f"{task}_cli"
    return command


def execute(task: str, scenario: Path, out: Path | None, json_out: bool, plots: bool,
            line: Callable[[dict[str, Any]], str], *, force: bool = False,
            max_memory: str | None = None, **options: Any) -> int:
    """:func:`mechkin.cli.shell.execute` for a typer command (its exits as ``typer.Exit``)."""
    try:
        return shell.execute(task, scenario, out, json_out, plots, line, force=force,
                             max_memory=max_memory, **options)
    except shell.Exit as exc:
        raise typer.Exit(code=exc.code) from None


def handle_errors(fn: F) -> F:
    """Turn MechkinError into one line per problem on stderr and its exit code (never a
    traceback); unexpected exceptions exit 3 with a one-line message
    (:func:`mechkin.cli.shell.handle_errors`, leaving as ``typer.Exit``)."""
    inner = shell.handle_errors(fn)

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return inner(*args, **kwargs)
        except shell.Exit as exc:
            raise typer.Exit(code=exc.code) from None

    return wrapper  # type: ignore[return-value]
