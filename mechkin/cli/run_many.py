"""The work of ``mechkin run PATH...``: every scenario under the given files and folders, the task
taken from each file's ``task:``, one line per scenario, a final count, and optionally a JUnit
XML file and an aggregate JSON summary for CI (no typer; :mod:`mechkin.cli.commands` registers
the command).

Each scenario runs exactly as ``mechkin <task> FILE`` would (load, validate, lock the output
folder, solve, write) into ``outputs/<scenario name>/`` or ``--out DIR/<scenario name>/``.
With ``--workers N`` the scenarios run on N local processes (each scenario then runs its own
jobs in its process). The exit code is the most serious of the scenarios' codes in the order
3 (internal error), 4 (output error), 2 (bad input), 5 (expect failed), 1 (solver), 0.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from mechkin.cli.shell import echo
from mechkin.errors import ConfigError

#: the most serious code wins, in this order (lowest index first)
SEVERITY = (3, 4, 2, 5, 1, 0)
_TASK_LINE = re.compile(r"^task\s*:", re.MULTILINE)


def find_scenarios(paths: Iterable[Path]) -> tuple[list[Path], int]:
    """(scenario files, skipped): each file as given; each folder's ``*.yaml``/``*.yml`` files,
    recursively and sorted, that have a top-level ``task:`` (other YAML files, such as
    mechanism files, are skipped and counted). A missing path is bad input."""
    found: list[Path] = []
    problems: list[str] = []
    skipped = 0
    for p in paths:
        p = Path(p)
        if p.is_dir():
            files = sorted(f for f in p.rglob("*") if f.suffix in (".yaml", ".yml")
                           and f.is_file() and not any(part.startswith(".")
                                                       for part in f.relative_to(p).parts))
            for f in files:
                try:
                    text = f.read_text(encoding="utf-8", errors="replace")
                except OSError:
                    text = "task:"  # let the run report why it cannot be read
                if _TASK_LINE.search(text):
                    found.append(f)
                else:
                    skipped += 1
        elif p.exists():
            found.append(p)
        else:
            problems.append(f"{p}: no such file or folder")
    if problems:
        raise ConfigError(problems)
    unique = list(dict.fromkeys(found))
    if not unique:
        raise ConfigError(f"{', '.join(str(p) for p in paths)}: no scenario files (YAML files "
                          "with a task: key) found")
    return unique, skipped


def run_one(path: Path, out_base: Path | None, plots: bool, force: bool,
            workers: int | None, max_time: float | None = None,
            policy: str | None = None) -> dict[str, Any]:
    """Run one scenario as its task command would (``max_time`` [s] and ``policy``: its
    ``--max-time`` and ``--max-time-policy``); a plain record (picklable) of the outcome:
    path, name, task, code, status, line, time_s, estimated_time_s (None when the task made
    no estimate), out_dir, checks, errors (the problem lines of a refused or crashed run),
    messages (the run's own stderr lines)."""
    from mechkin.tasks.budget import time_budget

    rec: dict[str, Any] = {"path": str(path), "name": path.stem, "task": None, "code": 3,
                           "status": None, "line": "", "time_s": 0.0,
                           "estimated_time_s": None, "out_dir": None,
                           "checks": [], "errors": [], "messages": []}
    t0 = time.perf_counter()
    with time_budget(max_time, policy) as estimates:
        _run_into(rec, path, out_base, plots, force, workers, estimates)
    rec["time_s"] = time.perf_counter() - t0
    return rec


def _run_into(rec: dict[str, Any], path: Path, out_base: Path | None, plots: bool,
              force: bool, workers: int | None, estimates: list[dict[str, Any]]) -> None:
    import logging
    import warnings

    from mechkin.cli.lines import LINES
    from mechkin.config.load import short_str
    from mechkin.errors import MechkinError
    from mechkin.tasks.budget import record_estimate

    try:
        from mechkin.config.scenario import load_scenario
        from mechkin.io.report import prepare_output
        from mechkin.tasks import run
        from mechkin.tasks.distributed import execution

        sc = load_scenario(Path(path))
        rec["name"], rec["task"] = sc.name, sc.spec.task
        out = (out_base / sc.name) if out_base is not None else Path("outputs") / sc.name
        with execution(workers, None, False), prepare_output(out, sc.name,
                                                             force=force) as out_dir:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                rep = run(sc)
            rec["estimated_time_s"] = record_estimate(rep.summary, estimates)
            summary = rep.write(out_dir, plots=plots)
        rec.update(code=rep.exit_code, status=rep.status, out_dir=str(out_dir),
                   checks=_plain(rep.checks), messages=list(rep.messages))
        task = "ik" if rep.task == "biped" else rep.task
        try:
            rec["line"] = LINES[task](summary) if task in LINES else rep.status
        except (KeyError, TypeError, ValueError):
            rec["line"] = f"{sc.name}: {rep.status}"
    except MechkinError as exc:
        lines = str(exc).splitlines() or [type(exc).__name__]
        rec.update(code=exc.exit_code, status="refused" if exc.exit_code == 2 else "error",
                   errors=[ln if str(path) in ln or ".yaml" in ln.split(": ", 1)[0]
                           else f"{path}: {ln}" for ln in lines])
    except Exception as exc:  # noqa: BLE001 - one line per scenario, never a traceback
        logging.getLogger("mechkin").debug("internal error", exc_info=True)
        rec.update(code=3, status="internal error",
                   errors=[f"{path}: internal error: {type(exc).__name__}: "
                           f"{short_str(exc, 200)}"])


def _plain(checks: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The expect results as JSON-ready values (numpy scalars and arrays to lists)."""
    import numpy as np

    def conv(v: Any) -> Any:
        if isinstance(v, np.ndarray):
            return v.tolist()
        if isinstance(v, np.generic):
            return v.item()
        if isinstance(v, (list, tuple)):
            return [conv(x) for x in v]
        return v

    return [{k: conv(v) for k, v in c.items()} for c in checks]


def overall_code(codes: Iterable[int]) -> int:
    """The most serious exit code (order :data:`SEVERITY`; a signal code wins over all)."""
    codes = list(codes)
    for c in codes:
        if c not in SEVERITY:
            return c
    return min(codes, key=SEVERITY.index) if codes else 0


def run_paths(paths: list[Path], *, workers: int | None = None, out: Path | None = None,
              junit: Path | None = None, summary: Path | None = None, plots: bool = True,
              force: bool = False, runner: Callable[..., dict[str, Any]] | None = None,
              max_time: str | None = None, max_time_policy: str | None = None) -> int:
    """``mechkin run``: run every scenario under ``paths``, print one line each and a final
    count, write the JUnit and JSON files; the exit code (:func:`overall_code`).
    ``max_time`` / ``max_time_policy``: each scenario's ``--max-time`` (a duration) and
    ``--max-time-policy``, checked before any work."""
    import functools

    from mechkin.io.batch_out import check_target, write_junit, write_summary
    from mechkin.tasks import budget

    try:
        seconds = budget.parse_duration(max_time) if max_time is not None else None
    except ValueError:
        raise ConfigError(f"--max-time: expected a duration like 90s, 5m or 2h, got "
                          f"{max_time[:40]!r}") from None
    policy = budget.parse_policy(max_time_policy) if max_time_policy is not None else None
    if seconds is None:
        budget.time_limit()  # a bad MECHKIN_MAX_TIME: one line before any work
    if policy is None:
        budget.time_policy()  # a bad MECHKIN_MAX_TIME_POLICY too
    if runner is None and (seconds is not None or policy is not None):
        runner = functools.partial(run_one, max_time=seconds, policy=policy)
    files, skipped = find_scenarios(paths)
    for target, opt in ((junit, "--junit"), (summary, "--summary")):
        if target is not None:
            check_target(Path(target), opt)  # before any work: exit 2, nothing written
    _refuse_shared_folders(files, out)
    runner = runner or run_one
    t0 = time.perf_counter()
    results: list[dict[str, Any]] = []
    if workers is None or workers <= 1 or len(files) == 1:
        for f in files:
            results.append(_report(runner(f, out, plots, force, None)))
    else:
        results = _run_pool(files, workers, out, plots, force, runner)
    total = time.perf_counter() - t0
    code = overall_code(r["code"] for r in results)
    echo(final_line(results, skipped, total))
    try:
        if junit is not None:
            write_junit(Path(junit), results, total)
        if summary is not None:
            write_summary(Path(summary), results, total, code)
    except OSError as exc:
        echo(f"error: cannot write the run's report: {exc.strerror or exc}", err=True)
        return overall_code([code, 4])
    return code


def _run_pool(files: list[Path], workers: int, out: Path | None, plots: bool, force: bool,
              runner: Callable[..., dict[str, Any]]) -> list[dict[str, Any]]:
    import multiprocessing
    import sys
    from concurrent.futures import ProcessPoolExecutor, as_completed

    method = ("forkserver" if sys.platform != "win32"
              and "forkserver" in multiprocessing.get_all_start_methods() else "spawn")
    ctx = multiprocessing.get_context(method)  # no fork of a parent with threads
    results: dict[int, dict[str, Any]] = {}
    with ProcessPoolExecutor(max_workers=min(workers, len(files)),
                             mp_context=ctx) as pool:
        futs = {pool.submit(runner, f, out, plots, force, 1): i for i, f in enumerate(files)}
        for fut in as_completed(futs):
            i = futs[fut]
            try:
                results[i] = _report(fut.result())
            except Exception as exc:  # noqa: BLE001 - a worker that died: that scenario's error
                results[i] = _report({"path": str(files[i]), "name": files[i].stem,
                                      "task": None, "code": 3, "status": "internal error",
                                      "line": "", "time_s": 0.0, "estimated_time_s": None,
                                      "out_dir": None, "checks": [],
                                      "messages": [],
                                      "errors": [f"{files[i]}: internal error: worker process "
                                                 f"failed: {type(exc).__name__}"]})
    return [results[i] for i in range(len(files))]


def _refuse_shared_folders(files: list[Path], out: Path | None) -> None:
    """Two scenarios of one name would write one output folder: bad input before any work."""
    from mechkin.config.load import read_yaml

    seen: dict[str, Path] = {}
    problems = []
    for f in files:
        try:
            data = read_yaml(f).data
        except Exception:  # noqa: BLE001 - the scenario's own run reports it
            continue
        name = data.get("name") if isinstance(data, dict) else None
        if not isinstance(name, str):
            continue
        if name in seen:
            where = (out or Path("outputs")) / name
            problems.append(f"{f}: name: {name!r} is also the name of {seen[name]}; both "
                            f"would write {where} (rename one)")
        else:
            seen[name] = f
    if problems:
        raise ConfigError(problems)


_WORD = {0: "PASS", 1: "FAIL", 2: "BAD INPUT", 3: "ERROR", 4: "OUTPUT ERROR", 5: "FAIL"}


def _report(rec: dict[str, Any]) -> dict[str, Any]:
    """Print the scenario's line (and its problem or message lines on stderr)."""
    word = _WORD.get(rec["code"], "STOPPED")
    held = sum(1 for c in rec["checks"] if c.get("ok"))
    exp = f", {held}/{len(rec['checks'])} expects" if rec["checks"] else ""
    what = rec["line"] or (rec["errors"][0] if rec["errors"] else rec["status"])
    echo(f"{word:<4} [exit {rec['code']}] {rec['path']} ({rec['time_s']:.2f} s{exp}): {what}")
    for ln in rec["errors"][1:] if not rec["line"] else rec["errors"]:
        echo(ln, err=True)
    for ln in rec["messages"]:
        echo(ln, err=True)
    return rec


def final_line(results: list[dict[str, Any]], skipped: int, total: float) -> str:
    """``59 scenarios: 58 passed, 1 failed (exit 5: 1); 428/429 expects held; 75.3 s``."""
    n = len(results)
    passed = sum(r["code"] == 0 for r in results)
    by: dict[int, int] = {}
    for r in results:
        if r["code"]:
            by[r["code"]] = by.get(r["code"], 0) + 1
    checks = [c for r in results for c in r["checks"]]
    held = sum(1 for c in checks if c.get("ok"))
    fails = ""
    if by:
        fails = f", {n - passed} not passed (" + ", ".join(
            f"exit {c}: {k}" for c, k in sorted(by.items())) + ")"
    skip = f"; {skipped} non-scenario YAML files skipped" if skipped else ""
    return (f"{n} scenario{'s' if n != 1 else ''}: {passed} passed{fails}; {held}/{len(checks)}"
            f" expects held; {total:.1f} s{skip}")
