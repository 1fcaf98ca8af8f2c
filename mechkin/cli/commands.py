"""The typer app of ``mechkin``: one module per subcommand (DESIGN.md: cli/).

Start-up is cheap: the subcommand modules import typer and ``mechkin.cli.common`` only; numpy,
the model, the solvers, plotting and MCAP code are imported inside the commands that use them,
so ``mechkin --help``, ``mechkin --version`` and ``mechkin schema`` import none of them. The
entry point is :func:`mechkin.cli.app.main`, which runs the plain run commands without
building this app (:mod:`mechkin.cli.fast`).
"""

from __future__ import annotations

import typer

from mechkin import __version__
from mechkin.cli.check import check_cli
from mechkin.cli.fk import fk_cli
from mechkin.cli.ik import ik_cli
from mechkin.cli.import_export import export_cli, import_cli
from mechkin.cli.info import info_cli
from mechkin.cli.track import track_cli
from mechkin.cli.warmup import warmup_cli
from mechkin.cli.workspace import workspace_cli

app = typer.Typer(
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    help="Kinematics of open, closed and complex-chain robot mechanisms described in YAML.",
)


def _version(value: bool) -> None:
    if value:
        typer.echo(__version__)
        raise typer.Exit()


@app.callback()
def _main(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                 help="Print the version and exit."),
) -> None:
    """Kinematics of open, closed and complex-chain robot mechanisms described in YAML."""


app.command("fk")(fk_cli)
app.command("ik")(ik_cli)
app.command("track")(track_cli)
app.command("workspace")(workspace_cli)
app.command("info")(info_cli)
app.command("check")(check_cli)
app.command("import")(import_cli)
app.command("export")(export_cli)
app.command("warmup")(warmup_cli)


@app.command("schema")
def schema_cli(
    kind: str = typer.Argument(None, help="mechanism or scenario (omit with --write)"),
    write: str = typer.Option(None, "--write", metavar="DIR",
                              help="Write mechanism.schema.json and scenario.schema.json into "
                                   "DIR instead of printing one."),
) -> None:
    """Print the JSON Schema of mechanism or scenario files (for editor validation)."""
    from mechkin.config.schema_files import schema_text
    from mechkin.config.schema_files import write as write_schemas

    if write is not None:
        if kind is not None:
            typer.echo("error: schema: give a kind or --write DIR, not both", err=True)
            raise typer.Exit(2)
        try:
            paths = write_schemas(write, fresh=False)
        except OSError as exc:
            typer.echo(f"error: schema: cannot write into {write}: {exc.strerror or exc}",
                       err=True)
            raise typer.Exit(1) from None
        for p in paths:
            typer.echo(str(p))
        return
    if kind not in ("mechanism", "scenario"):
        typer.echo(f"error: schema: expected 'mechanism' or 'scenario', got {kind!r}", err=True)
        raise typer.Exit(2)
    typer.echo(schema_text(kind), nl=False)


@app.command("version")
def version_cli() -> None:
    """Print the version."""
    typer.echo(__version__)


def run_app() -> None:
    """Run the typer app on ``sys.argv`` (Ctrl-C outside a command: one line, exit 130)."""
    _one_line_usage_errors()
    try:
        app()
    except KeyboardInterrupt:  # outside a command's own handler (argument parsing, start-up)
        typer.echo("mechkin: interrupted (SIGINT); no output was changed", err=True)
        raise SystemExit(130) from None


def _one_line_usage_errors() -> None:
    """A bad option or argument (``--workers 0``): one line ``mechkin fk: error: ...`` on
    stderr instead of typer's usage text and box (exit 2 as before)."""
    import sys

    try:
        from typer import rich_utils
    except ImportError:  # pragma: no cover - typer without rich: click's plain lines
        return
    original = rich_utils.rich_format_error
    if getattr(original, "_mechkin", False):
        return

    def one_line(exc: object) -> None:
        if type(exc).__name__ == "NoArgsIsHelpError":  # plain `mechkin`: the help
            original(exc)
            return
        ctx = getattr(exc, "ctx", None)
        where = ctx.command_path if ctx is not None else "mechkin"
        msg = " ".join(str(exc.format_message()).split())  # type: ignore[attr-defined]
        msg = msg if len(msg) <= 200 else msg[:197] + "..."
        sys.stderr.write(f"{where}: error: {msg} (see --help)\n")

    one_line._mechkin = True  # type: ignore[attr-defined]
    rich_utils.rich_format_error = one_line
