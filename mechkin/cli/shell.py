"""The shell of every run command: run one scenario, handle errors, report.

No typer and no numpy at module level; :mod:`mechkin.cli.common` wraps these functions for the
typer commands (:class:`Exit` -> ``typer.Exit``). Output goes through :func:`echo`, which
writes what ``typer.echo`` writes (typer's own when typer is loaded).
"""

from __future__ import annotations

import contextlib
import functools
import json
import logging
import sys
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

from mechkin.errors import MechkinError

F = TypeVar("F", bound=Callable[..., Any])


class Exit(Exception):  # noqa: N818 - typer's name, typer.Exit in the typer commands
    """Leave the command with ``code`` (what ``typer.Exit(code)`` does in a typer command)."""

    def __init__(self, code: int = 0) -> None:
        super().__init__(code)
        self.code = code


_ANSI: Any = None


def echo(message: str, err: bool = False) -> None:
    """``echo(message, err=err)``: the line and a newline, ANSI styles removed unless the
    stream is a terminal, flushed. typer's own echo when typer is loaded (the typer commands,
    its test runner); else the same steps."""
    typer = sys.modules.get("typer")
    if typer is not None:
        typer.echo(message, err=err)
        return
    f = sys.stderr if err else sys.stdout
    if f is None:
        return
    out = f"{message}\n"
    if not _isatty(f):
        global _ANSI
        if _ANSI is None:
            import re

            _ANSI = re.compile(r"\033\[[;?0-9]*[a-zA-Z]")  # click's strip_ansi
        out = _ANSI.sub("", out)
    f.write(out)
    f.flush()


def _isatty(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except Exception:  # noqa: BLE001 - as click.isatty
        return False


def execute(task: str, scenario: Path, out: Path | None, json_out: bool, plots: bool,
            line: Callable[[dict[str, Any]], str], *, force: bool = False,
            max_memory: str | None = None, **options: Any) -> int:
    """Run one scenario end to end (the body of every run command); returns the exit code.

    Order: load and validate the scenario, check and lock the output folder (before any
    work), run the task, write the report atomically, print the line and the messages.
    SIGTERM is turned into a clean stop (staging removed, worker processes terminated).
    """
    with terminate_cleanly():
        return handle_errors(_execute)(task, scenario, out, json_out, plots, line, force,
                                       max_memory, **options)


def _execute(task: str, scenario: Path, out: Path | None, json_out: bool, plots: bool,
             line: Callable[[dict[str, Any]], str], force: bool, max_memory: str | None,
             **options: Any) -> int:
    from mechkin.errors import ConfigError
    from mechkin.tasks import budget

    try:
        limit = budget.parse_size(max_memory) if max_memory is not None else None
    except ValueError:
        raise ConfigError(f"--max-memory: expected a size like 8G or 512M, got "
                          f"{max_memory[:40]!r}") from None
    max_time = options.pop("max_time", None)
    try:
        seconds = budget.parse_duration(max_time) if max_time is not None else None
    except ValueError:
        raise ConfigError(f"--max-time: expected a duration like 90s, 5m or 2h, got "
                          f"{max_time[:40]!r}") from None
    with budget.time_budget(seconds) as estimates:
        return _run_scenario(task, scenario, out, json_out, plots, line, force, limit,
                             estimates, **options)


def _run_scenario(task: str, scenario: Path, out: Path | None, json_out: bool, plots: bool,
                  line: Callable[[dict[str, Any]], str], force: bool, limit: int | None,
                  estimates: list[dict[str, Any]], **options: Any) -> int:
    from mechkin.io.report import prepare_output
    from mechkin.tasks import budget, run
    from mechkin.tasks.common import load_task_scenario
    from mechkin.tasks.distributed import execution

    sc = load_task_scenario(scenario, task)
    with budget.memory_budget(limit), execution(
            options.get("workers"), options.get("scheduler"), options.get("progress")
    ), prepare_output(default_out_dir(sc.name, out), sc.name, force=force) as out_dir:
        with warnings.catch_warnings():
            # floating-point warnings of a diverging solve: the statuses and summary say it
            warnings.simplefilter("ignore", RuntimeWarning)
            rep = run(sc, **options)
        if estimates and isinstance(rep.summary, dict):  # the estimate made before the job
            total = sum(e["seconds"] for e in estimates)
            rep.summary["estimated_time_s"] = float(f"{total:.3g}")
        summary = rep.write(out_dir, plots=plots)
    report(summary, json_out, line(summary))
    for msg in rep.messages:
        echo(msg, err=True)
    return rep.exit_code


class _Terminated(BaseException):
    """Raised by the SIGTERM handler (a BaseException, so no ``except Exception`` eats it)."""


@contextlib.contextmanager
def terminate_cleanly() -> Iterator[None]:
    """SIGTERM or SIGINT during a run: stop child processes, unwind (so staging folders and
    locks are removed by their ``finally`` blocks), one line, exit 143 / 130.

    A signal can land while a C extension initialises (numpy, scipy): Python then reports an
    ImportError, and the half-initialised module may abort the interpreter's finalisation. So
    the handlers record the signal, and once the stack has unwound the process leaves with
    ``os._exit`` (no finalisation) whatever exception carried the signal up.
    """
    import os
    import signal

    def on_signal(signum: int, frame: Any) -> None:
        # never raise from here: an exception raised inside a finaliser, a weakref callback or
        # a C-extension import is dropped or aborts the interpreter. Stop the workers, remove
        # this run's staging folders and lock (renames into the output folder run with the
        # signals held, so the folder holds the previous or the complete new files), leave.
        _SIGNALLED.append(signum)
        with contextlib.suppress(BaseException):
            _stop_children()
        # no import here (the main thread may be half-way through importing these modules):
        # nothing to clean up unless the output code is loaded
        mod = sys.modules.get("mechkin.io.output_dir")
        with contextlib.suppress(BaseException):
            if mod is not None and hasattr(mod, "run_cleanups"):
                mod.run_cleanups()
        term = signum == signal.SIGTERM
        with contextlib.suppress(Exception):
            what = "terminated (SIGTERM)" if term else "interrupted (SIGINT)"
            sys.stderr.write(f"mechkin: {what}; no output was changed\n")
            sys.stderr.flush()
        os._exit(143 if term else 130)

    try:
        old = {s: signal.signal(s, on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    except ValueError:  # not the main thread (e.g. inside a test runner thread)
        yield
        return
    try:
        yield
    except BaseException:
        if not _SIGNALLED:
            raise
    finally:
        for s, h in old.items():
            signal.signal(s, h)
    if _SIGNALLED:
        term = _SIGNALLED[0] == signal.SIGTERM
        sys.stderr.write(f"mechkin: {'terminated (SIGTERM)' if term else 'interrupted (SIGINT)'}"
                         "; no output was changed\n")
        sys.stderr.flush()
        sys.stdout.flush()
        os._exit(143 if term else 130)


_SIGNALLED: list[int] = []


def _stop_children() -> None:
    """Stop worker processes with the parent: the forkserver first (SIGKILL, so it cannot print
    a half-served request), then every worker (SIGTERM, then SIGKILL if still alive)."""
    import multiprocessing
    import os
    import signal as sig

    if "multiprocessing.forkserver" in sys.modules:
        fs = getattr(sys.modules["multiprocessing.forkserver"], "_forkserver", None)
        pid = getattr(fs, "_forkserver_pid", None)
        if pid:
            with contextlib.suppress(OSError):
                os.kill(pid, sig.SIGKILL)
    kids = multiprocessing.active_children()
    for p in kids:
        with contextlib.suppress(Exception):
            p.terminate()
    for p in kids:
        with contextlib.suppress(Exception):
            p.join(timeout=2.0)
            if p.is_alive():
                p.kill()


def handle_errors(fn: F) -> F:
    """Turn MechkinError into one line per problem on stderr and its exit code (never a
    traceback); unexpected exceptions exit 3 with a one-line message. The code leaves as
    :class:`Exit` (``typer.Exit`` through :func:`mechkin.cli.common.handle_errors`)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except MechkinError as exc:
            for ln in str(exc).splitlines() or [type(exc).__name__]:
                ln = f"error: {ln}" if not _has_location(ln) else ln
                echo(ln if len(ln) <= 300 else ln[:297] + "...", err=True)  # one short line
            raise Exit(exc.exit_code) from None
        except KeyboardInterrupt:
            _stop_children()
            if _SIGNALLED:
                raise  # terminate_cleanly reports it
            echo("mechkin: interrupted (SIGINT); no output was changed", err=True)
            raise Exit(130) from None
        except Exit:
            raise
        except Exception as exc:  # noqa: BLE001 - the CLI must never show a traceback
            typer = sys.modules.get("typer")
            if typer is not None and isinstance(exc, (typer.Exit, typer.Abort)):
                raise
            if _SIGNALLED:
                raise  # a signal that surfaced as another exception (e.g. during an import)
            logging.getLogger("mechkin").debug("internal error", exc_info=True)
            from mechkin.config.load import short_str

            echo(f"mechkin: internal error: {type(exc).__name__}: {short_str(exc, 200)} "
                 "(run with MECHKIN_DEBUG=1 for details)", err=True)
            if _debug():
                raise
            raise Exit(3) from None

    return wrapper  # type: ignore[return-value]


def _has_location(line: str) -> bool:
    head = line.split(": ", 1)[0]
    return ".yaml" in head or ".yml" in head or ".csv" in head or ":" in head


def _debug() -> bool:
    import os

    return os.environ.get("MECHKIN_DEBUG", "") not in ("", "0")


def default_out_dir(name: str, out: Path | None) -> Path:
    """``--out`` if given, else ``outputs/<scenario name>/`` under the working directory."""
    return Path(out) if out is not None else Path("outputs") / name


def report(summary: dict[str, Any], json_out: bool, line: str) -> None:
    """End of a run command: summary.json on stdout with ``--json``, else one summary line."""
    if json_out:
        echo_json(summary)
    else:
        echo(line)


def echo_json(summary: dict[str, Any]) -> None:
    from mechkin.io.summary import summary_json

    sys.stdout.write(summary_json(summary))


def dump(obj: Any) -> str:
    return json.dumps(obj, indent=2)
