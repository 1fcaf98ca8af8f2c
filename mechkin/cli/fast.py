"""The run commands' arguments read without typer: ``mechkin fk|ik|track|workspace SCENARIO``
with the options of :mod:`mechkin.cli.common`, ``mechkin info MECH [--json]`` and ``mechkin
check FILE...``, the common cases of a short call.

Importing typer, building the command tree and its per-option pydantic adapters costs 0.1-0.2
s of a call that should take well under a second (issue 15). :func:`main` reads the plain
forms of the run commands' arguments itself and runs :func:`mechkin.cli.shell.execute` with
exactly the values the typer command would pass; anything else (``--help``, an unknown or
repeated option, a value that looks like an option, ``--``, a bad ``--workers``, the other
commands, shell completion, an ASCII-encoded terminal) returns None and the typer app runs
the command as before, with its own messages. tests/cli/test_fast_args.py checks the two
readings agree argument for argument.
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path
from typing import Any

RUN_TASKS = ("fk", "ik", "track", "workspace")

# option -> (keyword, value): a str value means "takes the next argument"; else the flag's value
_FLAGS: dict[str, tuple[str, Any]] = {
    "--json": ("json_out", True),
    "--plots": ("plots", True),
    "--no-plots": ("plots", False),
    "--force": ("force", True),
    "--progress": ("progress", True),
    "--no-progress": ("progress", False),
}
_VALUED = {"--out": "out", "-o": "out", "--max-memory": "max_memory", "--max-time": "max_time",
           "--workers": "workers", "-j": "workers", "--scheduler": "scheduler"}
_DEFAULTS: dict[str, Any] = {"out": None, "json_out": False, "plots": True, "force": False,
                             "max_memory": None, "max_time": None, "progress": None,
                             "workers": None,
                             "scheduler": None}
_WORKERS = re.compile(r"[1-9][0-9]{0,8}")


def parse_run_args(argv: list[str]) -> tuple[str, dict[str, Any]] | None:
    """``(task, keywords of execute)`` for ``argv`` (without the program name), or None when
    the typer app must read it (see the module docstring)."""
    if not argv or argv[0] not in RUN_TASKS:
        return None
    task, rest = argv[0], argv[1:]
    kw: dict[str, Any] = {}
    scenario: str | None = None
    i = 0
    while i < len(rest):
        tok = rest[i]
        i += 1
        if tok.startswith("-"):
            name, eq, value = tok.partition("=")
            if name in _FLAGS and not eq:
                key, val = _FLAGS[name]
            elif name in _VALUED:
                if eq and not name.startswith("--"):  # -o=x: click reads the value "=x"
                    return None
                if not eq:
                    if i == len(rest):
                        return None
                    value = rest[i]
                    i += 1
                if not value or value.startswith("-"):
                    return None
                key = _VALUED[name]
                if key == "workers":
                    if not _WORKERS.fullmatch(value):
                        return None
                    val = int(value)
                elif key == "out":
                    val = Path(value)
                else:
                    val = value
            else:
                return None
            if key in kw:  # a repeated option: typer's rules
                return None
            kw[key] = val
        else:
            if scenario is not None:
                return None
            scenario = tok
    if scenario is None:
        return None
    return task, {"scenario": Path(scenario), **_DEFAULTS, **kw}


def parse_file_args(argv: list[str]) -> tuple[str, dict[str, Any]] | None:
    """``mechkin info MECH [--json]`` -> ``("info", {"mechanism", "json_out"})`` and
    ``mechkin check FILE...`` -> ``("check", {"files"})``; None for anything else."""
    if not argv or argv[0] not in ("info", "check"):
        return None
    cmd, rest = argv[0], argv[1:]
    if cmd == "check":
        if not rest or any(t.startswith("-") for t in rest):
            return None
        return cmd, {"files": [Path(t) for t in rest]}
    json_out = "--json" in rest
    pos = [t for t in rest if t != "--json"]
    if len(pos) != 1 or pos[0].startswith("-") or rest.count("--json") > 1:
        return None
    return cmd, {"mechanism": Path(pos[0]), "json_out": json_out}


def _streams_ok() -> bool:
    """Text streams typer's echo would write to unchanged (not ASCII, not missing)."""
    import codecs

    for f in (sys.stdout, sys.stderr):
        enc = getattr(f, "encoding", None)
        if f is None or not enc:
            return False
        try:
            if codecs.lookup(enc).name == "ascii":
                return False
        except LookupError:
            return False
    return True


def main(argv: list[str]) -> int | None:
    """Run ``argv`` (without the program name) if it is a plain run command; its exit code, or
    None (nothing done) when the typer app must take it."""
    if os.environ.get("MECHKIN_FAST_CLI", "1") == "0" or not _streams_ok():
        return None
    if any(k.startswith("_") and k.endswith("_COMPLETE") for k in os.environ):
        return None  # a shell-completion request: typer's
    from mechkin.cli import shell

    files = parse_file_args(argv)
    if files is not None:
        cmd, kw = files
        try:
            if cmd == "check":
                from mechkin.cli.check_files import run_check

                return shell.handle_errors(run_check)(kw["files"])
            from mechkin.cli.info_report import show_info

            shell.handle_errors(show_info)(kw["mechanism"], kw["json_out"])
            return 0
        except shell.Exit as exc:
            return exc.code
    parsed = parse_run_args(argv)
    if parsed is None:
        return None
    task, kw = parsed
    from mechkin.cli.lines import LINES

    scenario = kw.pop("scenario")
    out, json_out, plots = kw.pop("out"), kw.pop("json_out"), kw.pop("plots")
    try:
        return shell.execute(task, scenario, out, json_out, plots, LINES[task], **kw)
    except shell.Exit as exc:
        return exc.code
