"""The ``mechkin`` command: one module per subcommand (DESIGN.md: cli/)."""

from __future__ import annotations

import json

import typer

from mechkin import __version__
from mechkin.cli.check import check_cli
from mechkin.cli.fk import fk_cli
from mechkin.cli.info import info_cli

app = typer.Typer(
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    help="Kinematics of open, closed and complex-chain robot mechanisms described in YAML.",
)
app.command("fk")(fk_cli)
app.command("info")(info_cli)
app.command("check")(check_cli)


def _register_optional() -> None:
    """Subcommands whose modules may not exist yet in a partial build."""
    import importlib

    for verb in ("ik", "track", "workspace"):
        try:
            mod = importlib.import_module(f"mechkin.cli.{verb}")
        except ModuleNotFoundError as exc:
            if exc.name != f"mechkin.cli.{verb}":
                raise
            continue
        app.command(verb)(getattr(mod, f"{verb}_cli"))


_register_optional()


@app.command("schema")
def schema_cli(
    kind: str = typer.Argument(..., help="mechanism or scenario"),
) -> None:
    """Print the JSON Schema of mechanism or scenario files (for editor validation)."""
    from mechkin.config.scenario import scenario_json_schema
    from mechkin.config.schema import MechanismSpec

    if kind == "mechanism":
        schema = MechanismSpec.model_json_schema()
    elif kind == "scenario":
        schema = scenario_json_schema()
    else:
        typer.echo(f"error: schema: expected 'mechanism' or 'scenario', got {kind!r}", err=True)
        raise typer.Exit(2)
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    typer.echo(json.dumps(schema, indent=2))


@app.command("version")
def version_cli() -> None:
    """Print the version."""
    typer.echo(__version__)


def main() -> None:
    app()


