"""Pieces every subcommand shares: error handling, output folders, expect checks, MCAP logs."""

from __future__ import annotations

import functools
import json
import logging
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

import numpy as np
import typer

from mechkin.errors import MechkinError

F = TypeVar("F", bound=Callable[..., Any])
UNIT_TO_SI = {"rad": 1.0, "deg": np.pi / 180.0, "m": 1.0, "mm": 1e-3, "s": 1.0, "1": 1.0}


# the options every run command shares
OutOption = Annotated[Path | None, typer.Option(
    "--out", "-o", help="Output folder [default: outputs/<scenario name>]")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print summary.json to stdout too")]
PlotsOption = Annotated[bool, typer.Option("--plots/--no-plots", help="Write PNG plots")]


def run_command(task: str, doc: str, run: Callable[[Path, Path | None, bool, bool], int]
                ) -> Callable[..., None]:
    """The typer command ``mechkin <task> SCENARIO [--out] [--json] [--plots]`` around
    ``run(scenario, out, json_out, plots) -> exit code`` (fk, ik and track share it)."""

    def command(
        scenario: Path = typer.Argument(..., help=f"Scenario YAML (task: {task})"),
        out: OutOption = None,
        json_out: JsonOption = False,
        plots: PlotsOption = True,
    ) -> None:
        raise typer.Exit(run(scenario, out, json_out, plots))

    command.__doc__ = doc
    command.__name__ = f"{task}_cli"
    return command


def load_task_scenario(path: Path, task: str) -> Any:
    """Load a scenario for ``mechkin <task>``; a scenario of another task is bad input."""
    from mechkin.config.scenario import load_scenario
    from mechkin.errors import ConfigError

    sc = load_scenario(path)
    if sc.spec.task != task:
        raise ConfigError(f"{sc.doc.where(('task',))}: expected task {task} for 'mechkin "
                          f"{task}', got {sc.spec.task} (use 'mechkin {sc.spec.task}')")
    return sc


def handle_errors(fn: F) -> F:
    """Turn MechkinError into one line per problem on stderr and its exit code (never a
    traceback); unexpected exceptions exit 3 with a one-line message."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except MechkinError as exc:
            for line in str(exc).splitlines() or [type(exc).__name__]:
                typer.echo(f"error: {line}" if not _has_location(line) else line, err=True)
            raise typer.Exit(code=exc.exit_code) from None
        except (typer.Exit, typer.Abort, KeyboardInterrupt):
            raise
        except Exception as exc:  # noqa: BLE001 - the CLI must never show a traceback
            logging.getLogger("mechkin").debug("internal error", exc_info=True)
            typer.echo(f"mechkin: internal error: {type(exc).__name__}: {exc} (run with "
                       "MECHKIN_DEBUG=1 for details)", err=True)
            if _debug():
                raise
            raise typer.Exit(code=3) from None

    return wrapper  # type: ignore[return-value]


def _has_location(line: str) -> bool:
    head = line.split(": ", 1)[0]
    return ".yaml" in head or ".yml" in head or ".csv" in head or ":" in head


def _debug() -> bool:
    import os

    return os.environ.get("MECHKIN_DEBUG", "") not in ("", "0")


def joint_factor(mech: Any, j: int, units: Any) -> float:
    """SI factor of joint j's values in a file's units: length for prismatic, angle for
    revolute joints."""
    from mechkin.config.units import angle_factor, length_factor

    return length_factor(units.length) if mech.s[j] == 1 else angle_factor(units.angle)


def default_out_dir(name: str, out: Path | None) -> Path:
    """``--out`` if given, else ``outputs/<scenario name>/`` under the working directory."""
    return Path(out) if out is not None else Path("outputs") / name


def lookup(obj: Any, key: str) -> Any:
    """Value at a dot path (``targets.0.q_v.q1``) of nested dicts and lists; KeyError if absent."""
    cur = obj
    for part in key.split("."):
        if isinstance(cur, dict):
            if part not in cur:
                raise KeyError(part)
            cur = cur[part]
        elif isinstance(cur, (list, tuple)):
            try:
                cur = cur[int(part)]
            except (ValueError, IndexError):
                raise KeyError(part) from None
        else:
            raise KeyError(part)
    return cur


def evaluate_expect(summary: dict[str, Any], expects: list[Any]) -> list[dict[str, Any]]:
    """Check each ``expect:`` entry against the summary; values compared in SI."""
    out = []
    for e in expects:
        f = UNIT_TO_SI[e.unit] if e.unit else 1.0
        rec: dict[str, Any] = {"key": e.key, "unit": e.unit or "SI"}
        if e.value is not None:
            rec.update(expected=e.value, tol=e.tol)
            ref = np.atleast_1d(np.asarray(e.value, dtype=float)) * f
            lo, hi = ref - e.tol * f, ref + e.tol * f
        else:
            rec.update(min=e.min, max=e.max)
            lo = np.atleast_1d(-np.inf if e.min is None else e.min * f)
            hi = np.atleast_1d(np.inf if e.max is None else e.max * f)
            ref = None
        if e.source:
            rec["source"] = e.source
        try:
            actual = lookup(summary, e.key)
            if actual is None:
                raise KeyError(e.key)
            act = np.atleast_1d(np.asarray(actual, dtype=float))
            if not np.all(np.isfinite(act)):
                raise ValueError(e.key)
            if ref is not None and act.shape != ref.shape:
                rec.update(ok=False, actual=actual, message=f"shape {act.shape} != {ref.shape}")
            else:
                ok = bool(np.all(np.isfinite(act)) and np.all(act >= lo) and np.all(act <= hi))
                shown = (act / f).tolist()
                rec.update(ok=ok, actual=shown[0] if len(shown) == 1 else shown)
                if ref is not None:
                    rec["error"] = float(np.max(np.abs(act - ref))) / f if act.size else 0.0
        except (KeyError, TypeError, ValueError):
            rec.update(ok=False, actual=None,
                       message=f"no finite value at {e.key!r} in the summary")
        out.append(rec)
    return out


def report_expect(checks: list[dict[str, Any]], scenario_path: Path) -> None:
    for c in checks:
        if not c["ok"]:
            want = (f"{c['expected']} +- {c['tol']}" if "expected" in c
                    else f"in [{c.get('min')}, {c.get('max')}]")
            msg = c.get("message") or f"expected {want} ({c['unit']}), got {c['actual']}"
            typer.echo(f"{scenario_path}: expect {c['key']}: {msg}", err=True)


def report(summary: dict[str, Any], json_out: bool, line: str) -> None:
    """End of a run command: summary.json on stdout with ``--json``, else one summary line."""
    if json_out:
        echo_json(summary)
    else:
        typer.echo(line)


def echo_json(summary: dict[str, Any]) -> None:
    from mechkin.io.summary import summary_json

    sys.stdout.write(summary_json(summary))


def dump(obj: Any) -> str:
    return json.dumps(obj, indent=2)
