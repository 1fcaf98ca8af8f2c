"""The work of ``mechkin check FILE...``: validate mechanism and scenario files, reporting every
problem (no typer: :mod:`mechkin.cli.check` is the typer command).

A scenario gets every validation its run does short of solving: the scenario schema, its
mechanism file (parsed and built), and :func:`mechkin.tasks.validate.validate_scenario` (the
task section against the mechanism, the ``expect:`` keys against the summary). Each file is
parsed once. Exit 0 all ok, 2 bad input, 3 an internal error (one line, never a traceback).
"""

from __future__ import annotations

import logging
import warnings
from pathlib import Path

from mechkin.cli.shell import echo
from mechkin.errors import MechkinError


def run_check(files: list[Path]) -> int:
    """Check every file, print one line per problem (stderr) or ``FILE: ok`` (stdout, with the
    run's estimated time for a scenario); the exit code (0 all ok, 2 bad input, 3 an internal
    error)."""
    from mechkin.tasks.budget import human_time, time_budget

    code = 0
    for f in files:
        with time_budget(None) as found:  # the run's time estimates (tasks.estimates)
            problems, internal = check_file_status(f)
        if problems:
            code = max(code, 3 if internal else 2)
            for p in problems:
                echo(p, err=True)
        elif found:
            secs = sum(e["seconds"] for e in found)
            echo(f"{f}: ok (the run is estimated to take about {human_time(secs)})")
        else:
            echo(f"{f}: ok")
    return code


def check_file(path: Path) -> list[str]:
    """Problems of one file (empty if valid). Scenario files are recognised by ``task:``; their
    mechanism file is checked too, and the scenario against it."""
    return check_file_status(path)[0]


def check_file_status(path: Path) -> tuple[list[str], bool]:
    """(problems, internal): the problems of one file; internal is True when an unexpected
    exception (a bug, reported as one line) stopped the check."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a numpy warning is a problem, not stderr noise
            return _problems(Path(path)), False
    except MechkinError as exc:
        lines = str(exc).splitlines() or [type(exc).__name__]
        return [ln if ln.startswith(str(path)) or ".yaml" in ln.split(": ", 1)[0]
                else f"{path}: {ln}" for ln in lines], False
    except RecursionError:
        return [f"{path}: internal error: RecursionError (nesting too deep)"], True
    except Exception as exc:  # noqa: BLE001 - check must never show a traceback
        logging.getLogger("mechkin").debug("internal error", exc_info=True)
        from mechkin.config.load import short_str

        return [f"{path}: internal error: {type(exc).__name__}: {short_str(exc, 200)}"], True


def _problems(path: Path) -> list[str]:
    from mechkin.config.load import read_yaml
    from mechkin.config.mechanism_file import is_robot_file, read_mechanism_spec
    from mechkin.config.scenario import load_scenario
    from mechkin.model.build import build_mechanism
    from mechkin.tasks.validate import validate_scenario

    if is_robot_file(path):  # URDF / MJCF: import and build
        spec, mdoc = read_mechanism_spec(path)
        build_mechanism(spec, mdoc)
        return []
    doc = read_yaml(path)
    if isinstance(doc.data, dict) and "task" in doc.data:
        sc = load_scenario(path, doc=doc)
        mech = None
        if sc.mechanism_path is not None:
            spec, mdoc = read_mechanism_spec(sc.mechanism_path)
            mech = build_mechanism(spec, mdoc)
        validate_scenario(sc, mech)
        from mechkin.tasks import check_budget

        check_budget(sc)  # the run's memory budget, before any work
    else:
        spec, mdoc = read_mechanism_spec(path, doc=doc)
        build_mechanism(spec, mdoc)
    return []
