"""The typer app of ``mechkin`` (the one argument reader): one module per subcommand (DESIGN.md:
cli/).

Start-up is cheap: :func:`build_app` registers only the subcommand a call names (``mechkin ik
...`` imports and converts the ``ik`` command alone; ``--help`` and unknown names get them all),
typer's rich help is off unless ``MECHKIN_RICH_HELP=1`` (rich costs ~0.1 s to import), and the
subcommand modules import typer and ``mechkin.cli.common`` only: numpy, the model, the solvers,
plotting and MCAP code are imported inside the commands that use them, so ``mechkin --help``,
``mechkin --version`` and ``mechkin schema`` import none of them. ``app`` (every command, for
tests and typer's runner) is built on first use.
"""

from __future__ import annotations

import importlib
import os
from typing import Any

import typer

from mechkin import __version__
from mechkin.errors import EXIT_CODES

#: subcommand -> (module, function), registered in this order
COMMANDS: dict[str, tuple[str, str]] = {
    "fk": ("mechkin.cli.fk", "fk_cli"),
    "ik": ("mechkin.cli.ik", "ik_cli"),
    "track": ("mechkin.cli.track", "track_cli"),
    "workspace": ("mechkin.cli.workspace", "workspace_cli"),
    "run": ("mechkin.cli.run", "run_cli"),
    "info": ("mechkin.cli.info", "info_cli"),
    "check": ("mechkin.cli.check", "check_cli"),
    "import": ("mechkin.cli.import_export", "import_cli"),
    "export": ("mechkin.cli.import_export", "export_cli"),
    "warmup": ("mechkin.cli.warmup", "warmup_cli"),
    "schema": ("mechkin.cli.commands", "schema_cli"),
    "version": ("mechkin.cli.commands", "version_cli"),
}
HELP = "Kinematics of open, closed and complex-chain robot mechanisms described in YAML."
EPILOG = "Exit codes: " + "; ".join(f"{c} {what}" for c, what in EXIT_CODES.items()) + "."


def _version(value: bool) -> None:
    if value:
        typer.echo(__version__)
        raise typer.Exit()


def _main(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                 help="Print the version and exit."),
) -> None:
    """Kinematics of open, closed and complex-chain robot mechanisms described in YAML."""


def build_app(only: str | None = None) -> typer.Typer:
    """The typer app with every subcommand, or with subcommand ``only`` alone (the one a call
    runs: nothing else is imported or converted)."""
    rich = os.environ.get("MECHKIN_RICH_HELP", "") not in ("", "0")
    app = typer.Typer(no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
                      rich_markup_mode="rich" if rich else None, help=HELP, epilog=EPILOG)
    app.callback()(_main)
    for name in COMMANDS if only is None else [only]:
        module, attr = COMMANDS[name]
        app.command(name)(getattr(importlib.import_module(module), attr))
    return app


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


def version_cli() -> None:
    """Print the version."""
    typer.echo(__version__)


def run_app(argv: list[str] | None = None) -> None:
    """Run the typer app on ``argv`` (default ``sys.argv[1:]``), built with the named
    subcommand only when there is one; a bad option or argument (``--workers 0``) is one line
    ``mechkin fk: error: ... (see --help)`` (exit 2); Ctrl-C outside a command: one line, exit
    130. Leaves with SystemExit(code)."""
    import sys

    try:  # typer >= 0.22 carries its own copy of click
        from typer._click import exceptions as click_exc
    except ImportError:  # pragma: no cover - older typer: click itself
        from click import exceptions as click_exc

    args = sys.argv[1:] if argv is None else argv
    name = args[0] if args and args[0] in COMMANDS else None
    try:
        code = build_app(name)(args=args, standalone_mode=False)
    except click_exc.NoArgsIsHelpError as exc:  # plain `mechkin`: the help
        exc.show()
        raise SystemExit(exc.exit_code) from None
    except click_exc.UsageError as exc:
        ctx = exc.ctx
        where = ctx.command_path if ctx is not None else "mechkin"
        msg = " ".join(str(exc.format_message()).split())
        msg = msg if len(msg) <= 200 else msg[:197] + "..."
        sys.stderr.write(f"{where}: error: {msg} (see --help)\n")
        raise SystemExit(exc.exit_code) from None
    except click_exc.ClickException as exc:
        exc.show()
        raise SystemExit(exc.exit_code) from None
    except typer.Abort:
        typer.echo("Aborted!", err=True)
        raise SystemExit(1) from None
    except KeyboardInterrupt:  # outside a command's own handler (argument parsing, start-up)
        typer.echo("mechkin: interrupted (SIGINT); no output was changed", err=True)
        raise SystemExit(130) from None
    raise SystemExit(code if isinstance(code, int) else 0)


_APP: list[typer.Typer] = []


def __getattr__(name: str) -> Any:
    if name == "app":  # every command (tests, typer's runner), built once on first use
        if not _APP:
            _APP.append(build_app())
        return _APP[0]
    raise AttributeError(f"module 'mechkin.cli.commands' has no attribute {name!r}")
