"""``mechkin workspace SCENARIO.yaml``: isotropy and workspace maps (lee Figs. 2-5), design,
joint and task-space sweeps (:mod:`mechkin.tasks.workspace`). Stdout carries only the result
line or JSON; a progress bar goes to stderr."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from mechkin.cli.common import (
    ForceOption,
    JsonOption,
    MaxMemoryOption,
    OutOption,
    PlotsOption,
    ProgressOption,
    SchedulerOption,
    WorkersOption,
    execute,
)


def _line(s: dict[str, Any]) -> str:
    if "design" in s:
        d = s["design"]
        parts = []
        for v in d["per_value"]:
            fr = [f"{k} {e['volume_fraction']:.3f}" for k, e in v.get("isotropy", {}).items()]
            if "gamma_range" in v:
                fr.append(f"gamma range {v['gamma_range']['defined_fraction']:.3f}")
            parts.append(f"{d['parameter']} = {v['value']:g}: {', '.join(fr)}")
        body = "volume fractions " + "; ".join(parts)
    elif s.get("kind") == "task_space":
        body = (f"{s['n_reachable']}/{s['n_poses']} poses reached, isotropy median "
                f"{s['isotropy'].get('median', 0.0):.3f}")
    elif s.get("kind") == "lee_spherical":
        parts = [f"{name}: volume fraction {e['volume_fraction']:.3f}"
                 for name, e in s.get("isotropy", {}).items()]
        if "gamma_range" in s:
            parts.append(f"gamma range defined on {s['gamma_range']['defined_fraction']:.3f}")
        body = "; ".join(parts)
    else:
        body = (f"{s['n_reachable']}/{s['n_samples']} samples reachable, voxel volume "
                f"{s['volume']['voxel_m3']:.4g} m^3")
    failed = [c["key"] for c in s.get("expect", []) if not c["ok"]]
    tail = f"; expect failed: {', '.join(failed)}" if failed else ""
    return f"{s['scenario']}: {s['status']} ({body}){tail}; wrote {s['out_dir']}"


def workspace_cli(
    scenario: Path = typer.Argument(..., help="Scenario YAML (task: workspace)"),
    out: OutOption = None,
    json_out: JsonOption = False,
    plots: PlotsOption = True,
    force: ForceOption = False,
    max_memory: MaxMemoryOption = None,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    progress: ProgressOption = None,
) -> None:
    """Workspace and isotropy maps (lee's spherical mechanism), design sweeps, joint and
    task-space sweeps of any mechanism."""
    raise typer.Exit(execute("workspace", scenario, out, json_out, plots, _line, force=force,
                             max_memory=max_memory, workers=workers, scheduler=scheduler,
                             progress=progress))
