"""``mechkin workspace SCENARIO.yaml``: isotropy and workspace maps (lee Figs. 2-5), design,
joint and task-space sweeps (:mod:`mechkin.tasks.workspace`). Stdout carries only the result
line or JSON; a progress bar goes to stderr."""

from __future__ import annotations

from pathlib import Path

import typer

from mechkin.cli.common import (
    ForceOption,
    JsonOption,
    MaxMemoryOption,
    MaxTimeOption,
    MaxTimePolicyOption,
    OutOption,
    PlotsOption,
    ProgressOption,
    SchedulerOption,
    WorkersOption,
    execute,
)
from mechkin.cli.lines import workspace_line as _line


def workspace_cli(
    scenario: Path = typer.Argument(..., help="Scenario YAML (task: workspace)"),
    out: OutOption = None,
    json_out: JsonOption = False,
    plots: PlotsOption = True,
    force: ForceOption = False,
    max_memory: MaxMemoryOption = None,
    max_time: MaxTimeOption = None,
    max_time_policy: MaxTimePolicyOption = None,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    progress: ProgressOption = None,
) -> None:
    """Workspace and isotropy maps (lee's spherical mechanism), design sweeps, joint and
    task-space sweeps of any mechanism."""
    raise typer.Exit(execute("workspace", scenario, out, json_out, plots, _line, force=force,
                             max_memory=max_memory, max_time=max_time,
                             max_time_policy=max_time_policy, workers=workers,
                             scheduler=scheduler,
                             progress=progress))
