"""``mechkin run PATH...``: every scenario under the given files and folders, for CI (the work is
:mod:`mechkin.cli.run_many`)."""

from __future__ import annotations

from pathlib import Path

import typer

from mechkin.cli.common import (
    ForceOption,
    MaxTimeOption,
    MaxTimePolicyOption,
    OutOption,
    PlotsOption,
    handle_errors,
)


def run_cli(
    paths: list[Path] = typer.Argument(..., help="Scenario files and folders (searched "
                                                 "recursively for YAML files with a task: key)"),
    out: OutOption = None,
    plots: PlotsOption = True,
    force: ForceOption = False,
    workers: int = typer.Option(1, "--workers", "-j", min=1,
                                help="Run N scenarios at a time on local processes"),
    junit: Path = typer.Option(None, "--junit", metavar="FILE",
                               help="Write a JUnit XML report: one testcase per scenario and "
                                    "one per expect: entry"),
    summary: Path = typer.Option(None, "--summary", metavar="FILE",
                                 help="Write an aggregate JSON summary of the run"),
    max_time: MaxTimeOption = None,
    max_time_policy: MaxTimePolicyOption = None,
) -> None:
    """Run every scenario (task from each file's task:); one line each, a final count.

    Output folders: outputs/<scenario name>, or OUT/<scenario name> with --out. Exit code: the
    most serious of the scenarios' codes, in the order 3, 4, 2, 5, 1, 0. --max-time and
    --max-time-policy apply to each scenario (its estimate is kept in --summary and --junit).
    """
    from mechkin.cli.run_many import run_paths
    from mechkin.cli.shell import terminate_cleanly

    with terminate_cleanly():
        code = handle_errors(run_paths)(paths, workers=workers, out=out, junit=junit,
                                        summary=summary, plots=plots, force=force,
                                        max_time=max_time, max_time_policy=max_time_policy)
    raise typer.Exit(code)
