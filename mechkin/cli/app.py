"""The ``mechkin`` command (entry point :func:`main`): one module per subcommand (DESIGN.md:
cli/); the typer app itself is :mod:`mechkin.cli.commands` (``mechkin.cli.app.app`` loads it).

Start-up is cheap: this module imports nothing; a plain run command (``mechkin ik
SCENARIO.yaml --no-plots``) is read by :mod:`mechkin.cli.fast` and runs without importing
typer, every other call goes through the typer app. Numpy, the model, the solvers, plotting
and MCAP code are imported inside the commands that use them, so ``mechkin --help``,
``mechkin --version`` and ``mechkin schema`` import none of them.
"""

from __future__ import annotations

import sys
from typing import Any


def main() -> None:
    """``mechkin ...``: a plain run command directly, anything else through the typer app."""
    try:
        from mechkin.cli import fast

        code = fast.main(sys.argv[1:])
    except KeyboardInterrupt:  # before the command's own handler took over
        sys.stderr.write("mechkin: interrupted (SIGINT); no output was changed\n")
        raise SystemExit(130) from None
    if code is not None:
        raise SystemExit(code)
    from mechkin.cli.commands import run_app

    run_app()


def __getattr__(name: str) -> Any:
    # ``from mechkin.cli.app import app`` (tests, typer's runner) and the command functions
    if name.startswith("__"):
        raise AttributeError(name)
    from mechkin.cli import commands

    try:
        return getattr(commands, name)
    except AttributeError:
        raise AttributeError(f"module 'mechkin.cli.app' has no attribute {name!r}") from None
