"""The workspace task: isotropy and workspace maps (lee Figs. 2-5), design, joint and task-space
sweeps. A validated ``workspace:`` scenario -> :class:`mechkin.records.Report`; writes nothing.

Kinds of section (:mod:`mechkin.config.workspace_spec`):

* ``lee_spherical``: :func:`mechkin.solvers.workspace.maps.lee_workspace` with the design taken
  from the mechanism file (R, r, P, stroke) and overridden by ``parameters``: sigma_KI maps
  per named gamma set and gamma_min/gamma_max (Fig. 2). With ``design: {parameter, values}``
  the maps are computed once per value (:func:`mechkin.solvers.workspace.sweeps.lee_design_sweep`)
  with a comparison table.
* ``joint_sweep``: the independent joints on a grid or at random (seeded); for a closed chain
  the loop closure (kim1995 §5.1) is solved for every sample, continued from a solved
  neighbour so the sweep keeps one assembly mode
  (:func:`mechkin.solvers.workspace.joint_sweep.joint_sweep`; mode changes and closure
  failures are counted): reachable positions of a frame, bounding box, voxel and convex-hull
  volumes, statistics of Yoshikawa's manipulability and of the isotropy of the reduced frame
  Jacobian.
* ``task_space``: a grid (or seeded random set) of task-space poses through the batched ik
  (:func:`mechkin.solvers.workspace.sweeps.task_space_sweep`): reachability and dexterity.

Every kind runs as jobs on ``workers`` local processes or on a Dask cluster (``scheduler`` /
``executor: {kind: dask, address}``, or the run's :mod:`mechkin.tasks.distributed` options):
design values, task-space chunks, joint-sweep subtrees and blocks, the maps of a single lee
scenario; the record is the one of a single process. A progress bar (jobs, map sets or samples)
is drawn on stderr when asked (``progress=True``; None: when stderr is a terminal).

The kinds live in :mod:`~mechkin.tasks.workspace_lee` and :mod:`~mechkin.tasks.workspace_sweeps`
(what they share: :mod:`~mechkin.tasks.workspace_common`); this module dispatches, checks the
budget and resolves the execution options.

Imports: config, model, solvers, spatial, records, tasks.common, tasks.workspace_* (never io/ or
cli/).
"""

from __future__ import annotations

import sys
from typing import Any

from mechkin.config.scenario import Scenario
from mechkin.errors import ConfigError
from mechkin.records import Report
from mechkin.tasks.workspace_lee import _run_lee, _run_lee_design
from mechkin.tasks.workspace_sweeps import _run_joint_sweep, _run_task_space


def run(scenario: Scenario, workers: int | None = None, scheduler: str | None = None,
        progress: bool | None = False) -> Report:
    """Run a workspace scenario.

    Parameters
    ----------
    scenario : Scenario
    workers : int, optional
        Local worker processes (overrides ``workers:`` and the run's --workers).
    scheduler : str, optional
        Dask scheduler address (overrides ``executor:``).
    progress : bool, optional
        Progress bar on stderr; None: when stderr is a terminal.

    Returns
    -------
    Report
        Writer ``workspace`` (:mod:`mechkin.io.workspace_out`); exit code 1 when an expect
        failed.
    """
    ex = _execution(scenario, workers, scheduler, progress)
    check_workspace_budget(scenario, ex)
    kind = scenario.section.kind
    if kind == "lee_spherical":
        if scenario.section.design is not None:
            return _run_lee_design(scenario, ex)
        return _run_lee(scenario, ex)
    if kind == "task_space":
        return _run_task_space(scenario, ex)
    return _run_joint_sweep(scenario, ex)


def check_budget(scenario: Scenario) -> None:
    """The run's budget checks (memory, worker count) with the scenario's own execution
    settings, without solving."""
    check_workspace_budget(scenario, _execution(scenario, None, None, False))


def _grid_size(axes: list[Any]) -> int:
    n = 1
    for a in axes:
        n *= max(int(getattr(a, "n", None) or 1), 1)
    return n


def check_workspace_budget(sc: Scenario, ex: dict[str, Any]) -> None:
    """Estimate the sweep's peak memory from the scenario (grid sizes x joints and frames,
    samples, poses) and refuse it beyond the budget, before any work (mechkin.tasks.budget)."""
    from mechkin.tasks import budget, estimates

    spec = sc.section
    doc = sc.doc
    if ex.get("workers") is not None and not ex.get("address"):
        budget.check_workers(doc.where(("workspace", "workers")), int(ex["workers"]))
    if spec.kind == "lee_spherical":
        cells = (_grid_size([spec.alpha, spec.beta]) if spec.alpha and spec.beta else 91 * 91)
        gammas = sum(len(v) for v in (spec.isotropy_maps or {}).values())
        est = 8.0 * 60 * cells * max(gammas, 1)
        if spec.gamma_range is not None:
            g = spec.gamma_range
            est += 8.0 * 30 * g.n * g.n_alpha * g.n_beta
        est += 8.0 * 20 * len(spec.poses or [])
        budget.check(doc.where(("workspace",)), est, f"a lee map of {cells} alpha-beta cells "
                     f"x {max(gammas, 1)} gammas")
        return
    from mechkin.model import load_mechanism

    mech = load_mechanism(sc.mechanism_path)
    per = 8.0 * (6 * mech.n + 16 * (mech.n_links + len(mech.frame_names)) + 6 * mech.n * 4)
    if spec.kind == "joint_sweep":
        if spec.method == "monte_carlo" or spec.samples is not None:
            m = int(spec.samples or 0)
        else:
            m = _grid_size(list((spec.joints or {}).values()))
        budget.check(doc.where(("workspace",)), 2.0 * per * m,
                     f"a joint sweep of {m} samples of {mech.name} ({mech.n} joints)")
        budget.estimate_time(doc.where(("workspace",)), estimates.joint_sweep_seconds(mech, m),
                             f"a joint sweep of {m} samples of {mech.name}")
    else:
        axes = [a for a in (getattr(spec, "positions", None) or {}).values()] if isinstance(
            getattr(spec, "positions", None), dict) else []
        m = int(spec.samples or 0) or _grid_size(axes) + len(spec.poses or [])
        budget.check(doc.where(("workspace",)), 3.0 * per * m,
                     f"a task-space sweep of {m} poses of {mech.name} ({mech.n} joints)")
        starts = 1 + int(getattr(spec, "restarts", 0) or 0)
        budget.estimate_time(doc.where(("workspace",)), estimates.task_space_seconds(m, starts),
                             f"a task-space sweep of {m} poses x {starts} starts")


def _execution(sc: Scenario, workers: int | None, scheduler: str | None,
               progress: bool | None) -> dict[str, Any]:
    """workers / dask address / progress flag from the options, else the scenario."""
    from mechkin.tasks.distributed import Execution, resolve

    spec = sc.section
    ctx = resolve(workers, scheduler, None)
    address = ctx.address
    from_file = False
    if address is None and spec.executor is not None and spec.executor.kind == "dask":
        address, from_file = spec.executor.address, True
    if address is not None:
        try:
            import distributed  # noqa: F401
        except ImportError:
            where = sc.doc.where(("workspace", "executor")) if from_file else "--scheduler"
            raise ConfigError(f"{where}: running on a Dask cluster needs the optional extra "
                              "(pip install 'mechkin[dask]')") from None
    n = ctx.workers if ctx.workers is not None else spec.workers
    if progress is None:
        progress = ctx.progress
    ex = Execution(workers=n, address=address, progress=progress,
                   where="--workers" if ctx.workers is not None else
                   sc.doc.where(("workspace", "workers")))
    show = sys.stderr.isatty() if progress is None else bool(progress)
    return {"workers": n, "address": address, "progress": show,
            "force_terminal": progress is True, "ex": ex}
