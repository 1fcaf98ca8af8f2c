"""Tasks: a validated scenario -> a :class:`mechkin.records.Report` (DESIGN.md: tasks).

One module per task: :mod:`~mechkin.tasks.fk`, :mod:`~mechkin.tasks.ik`,
:mod:`~mechkin.tasks.track`, :mod:`~mechkin.tasks.workspace` and :mod:`~mechkin.tasks.biped`
(an ``ik`` scenario with a ``biped:`` section). Each has ``run(scenario, **options) -> Report``
and writes no file; ``Report.write`` does that, through the writer this package installs
(:mod:`mechkin.tasks.write`, the task layer's one door to io).

Imports: config, model, solvers, spatial, records; io only through :mod:`mechkin.tasks.write`;
never cli/.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

from mechkin.records import Report, set_report_writer
from mechkin.tasks.write import write_report

set_report_writer(write_report)

TASKS = ("fk", "ik", "track", "workspace")


def task_module_name(scenario: Any) -> str:
    """The task module that runs ``scenario`` (``biped`` for an ik scenario with ``biped:``)."""
    if scenario.spec.task == "ik" and scenario.section_name == "biped":
        return "biped"
    return str(scenario.spec.task)


def run(scenario: Any, **options: Any) -> Report:
    """Run a loaded scenario (:func:`mechkin.config.scenario.load_scenario`) to a report.

    ``options`` are the task's own run options (workspace: ``workers``, ``scheduler``,
    ``progress``).
    """
    from mechkin.solvers.result import stop_when
    from mechkin.tasks import budget
    from mechkin.tasks.prepare import prepare

    # load and validate (everything short of solving, as `mechkin check` does), keeping what
    # the checks computed that the run needs (the mechanism, its closed form, biped legs)
    prepared = prepare(scenario)
    mod = importlib.import_module(f"mechkin.tasks.{task_module_name(scenario)}")
    import inspect

    accepted = inspect.signature(mod.run).parameters
    if "prepared" in accepted:
        options = {**options, "prepared": prepared}
    # --max-time: the task stops at its next safe point once the time is used, keeps the
    # finished rows, and the report says so (budget.mark_stopped: exit 1)
    with stop_when(budget.overrun if budget.time_limit() is not None else None):
        rep = mod.run(scenario, **{k: v for k, v in options.items() if k in accepted})
    return budget.mark_stopped(rep, scenario.path)


def run_file(path: str | Path, task: str | None = None, **options: Any) -> Report:
    """Load the scenario file ``path`` (checking it is a ``task`` scenario when given) and
    run it."""
    if task is None:
        from mechkin.config.scenario import load_scenario

        sc = load_scenario(Path(path))
    else:
        from mechkin.tasks.common import load_task_scenario

        sc = load_task_scenario(path, task)
    return run(sc, **options)


def check_budget(scenario: Any) -> None:
    """The memory-budget checks the run makes before any work (``mechkin check`` calls them,
    so a file that checks ok is not refused by the run's budget on this machine)."""
    mod = importlib.import_module(f"mechkin.tasks.{task_module_name(scenario)}")
    fn = getattr(mod, "check_budget", None)
    if fn is not None:
        fn(scenario)
