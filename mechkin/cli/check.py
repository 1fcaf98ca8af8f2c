"""``mechkin check FILE...``: validate mechanism and scenario files, reporting every problem.

A scenario gets every validation its run does short of solving: the scenario schema, its
mechanism file (parsed and built), and :func:`mechkin.tasks.validate.validate_scenario` (the
task section against the mechanism, the ``expect:`` keys against the summary). Each file is
parsed once. Exit 0 all ok, 2 bad input, 3 an internal error (one line, never a traceback).
"""

from __future__ import annotations

from pathlib import Path

import typer

from mechkin.cli.check_files import (  # noqa: F401 - the names callers import from here
    _problems,
    check_file,
    check_file_status,
    run_check,
)
from mechkin.cli.common import MaxTimeOption, MaxTimePolicyOption, handle_errors


def check_cli(
    files: list[Path] = typer.Argument(..., help="Mechanism or scenario YAML files"),
    max_time: MaxTimeOption = None,
    max_time_policy: MaxTimePolicyOption = None,
) -> None:
    """Validate mechanism and scenario files; one line per problem, exit 2 if any. With
    --max-time, a scenario whose run would be refused for its estimate is refused too."""
    raise typer.Exit(handle_errors(run_check)(files, max_time=max_time,
                                              max_time_policy=max_time_policy))
