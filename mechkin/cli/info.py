"""``mechkin info MECH.yaml``: coordinates, cuts, equations, degrees of freedom, mobility."""

from __future__ import annotations

from pathlib import Path

import typer

from mechkin.cli.common import handle_errors
from mechkin.cli.info_report import (  # noqa: F401 - the names callers import from here
    _SPATIAL_EQ,
    absolute_counts,
    mechanism_info,
    run_info,
    show_info,
)


def info_cli(
    mechanism: Path = typer.Argument(..., help="Mechanism YAML"),
    json_out: bool = typer.Option(False, "--json", help="Print JSON instead of text"),
) -> None:
    """Joint coordinates, cuts, constraint equations, degrees of freedom and mobility."""
    handle_errors(show_info)(mechanism, json_out)
