"""The ``mechkin`` command (entry point :func:`main`): one module per subcommand (DESIGN.md:
cli/); the typer app itself, the one argument reader, is :mod:`mechkin.cli.commands`
(``mechkin.cli.app.app`` loads it).

Start-up is cheap: this module imports nothing; :func:`mechkin.cli.commands.run_app` registers
only the subcommand a call names. Numpy, the model, the solvers, plotting and MCAP code are
imported inside the commands that use them, so ``mechkin --help``, ``mechkin --version`` and
``mechkin schema`` import none of them.
"""

from __future__ import annotations

import sys
from typing import Any, NoReturn


def main() -> None:
    """``mechkin ...`` through the typer app; then :func:`leave`."""
    try:
        from mechkin.cli.commands import run_app
    except KeyboardInterrupt:  # before the command's own handler took over
        sys.stderr.write("mechkin: interrupted (SIGINT); no output was changed\n")
        raise SystemExit(130) from None
    try:
        run_app()
        code = 0
    except SystemExit as exc:
        if exc.code is not None and not isinstance(exc.code, int):
            raise  # a message to print: Python's own exit
        code = exc.code or 0
    leave(code)


def leave(code: int) -> NoReturn:
    """Exit with ``code`` once the command is done, skipping the interpreter's teardown.

    Freeing the modules of a numerical run takes 0.1-0.9 s at exit (numba's and LLVM's
    objects above all), after every file is written and closed. So, as after a signal
    (:func:`mechkin.cli.shell.terminate_cleanly`), the process leaves with ``os._exit``, but
    only after the ``atexit`` handlers (logging, ``weakref.finalize``, multiprocessing, numba)
    have run and stdout and stderr are flushed. Python exits as usual with other threads still
    running, under a profiler or tracer (``python -m cProfile -m mechkin ...`` writes its
    profile after the program), when a flush fails (a closed pipe) or with
    ``MECHKIN_FAST_EXIT=0``.
    """
    import atexit
    import os
    import threading

    run_exitfuncs = getattr(atexit, "_run_exitfuncs", None)
    if (threading.active_count() > 1 or run_exitfuncs is None
            or sys.getprofile() is not None or sys.gettrace() is not None  # cProfile, coverage
            or os.environ.get("MECHKIN_FAST_EXIT", "1") == "0"):
        raise SystemExit(code)
    run_exitfuncs()
    try:
        for f in (sys.stdout, sys.stderr):
            if f is not None:
                f.flush()
    except Exception:  # noqa: BLE001 - Python's exit reports it (exit 120)
        raise SystemExit(code) from None
    os._exit(code)


def __getattr__(name: str) -> Any:
    # ``from mechkin.cli.app import app`` (tests, typer's runner) and the command functions
    if name.startswith("__"):
        raise AttributeError(name)
    from mechkin.cli import commands

    try:
        return getattr(commands, name)
    except AttributeError:
        raise AttributeError(f"module 'mechkin.cli.app' has no attribute {name!r}") from None
