"""``mechkin check FILE...``: validate mechanism and scenario files, reporting every problem."""

from __future__ import annotations

from pathlib import Path

import typer

from mechkin.config.load import read_yaml
from mechkin.errors import MechkinError


def check_cli(
    files: list[Path] = typer.Argument(..., help="Mechanism or scenario YAML files"),
) -> None:
    """Validate mechanism and scenario files; one line per problem, exit 2 if any."""
    n_bad = 0
    for f in files:
        problems = check_file(f)
        if problems:
            n_bad += 1
            for p in problems:
                typer.echo(p, err=True)
        else:
            typer.echo(f"{f}: ok")
    raise typer.Exit(2 if n_bad else 0)


def check_file(path: Path) -> list[str]:
    """Problems of one file (empty if valid). Scenario files are recognised by ``task:``; their
    mechanism file is checked too."""
    from mechkin.config.scenario import load_scenario
    from mechkin.model import load_mechanism

    try:
        doc = read_yaml(path)
        if isinstance(doc.data, dict) and "task" in doc.data:
            sc = load_scenario(path)
            if sc.mechanism_path is not None:
                load_mechanism(sc.mechanism_path)
        else:
            load_mechanism(path)
    except MechkinError as exc:
        return str(exc).splitlines()
    return []
