"""Report records -> files: one entry point for every task (DESIGN.md: io).

:func:`prepare_output` checks the output folder before any work (usable, not another
scenario's results unless ``force``, not being written by another run: a lock file with the
holder's pid). :func:`write_report` stages every file of a run in one
:class:`~mechkin.io.output_dir.OutputDir`, hands the report's task record to its writer module
``mechkin.io.<writer>_out`` (function ``write(od, report, plots)``), writes summary.json with
``out_dir`` and ``files``, and removes the previous run's files that this run did not write.

Imports: records (types only), io.output_dir and the writer modules (loaded by name).
"""

from __future__ import annotations

import contextlib
import importlib
import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mechkin.errors import OutputDirError
from mechkin.io.output_dir import OutputDir, _pid_alive, forget_cleanup, register_cleanup
from mechkin.records import Report

LOCK_NAME = ".mechkin.lock"


def _previous(out_dir: Path) -> dict[str, Any] | None:
    """The previous run's summary.json in ``out_dir`` (None if absent or unreadable)."""
    p = out_dir / "summary.json"
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _short(text: str, n: int = 80) -> str:
    return text if len(text) <= n else "..." + text[-(n - 3):]


def check_output_dir(out_dir: str | Path, scenario: str, *, force: bool = False) -> None:
    """Refuse an unusable output folder before any work (OutputDirError, exit 2)."""
    out = Path(out_dir)
    where = _short(str(out))
    for part in out.absolute().parts:
        if len(part.encode("utf-8", "surrogateescape")) > 255:
            raise OutputDirError(f"--out {where}: a folder name of {len(part)} characters is "
                                 "longer than file systems allow (255 bytes)")
    try:
        if out.exists() and not out.is_dir():
            raise OutputDirError(f"--out {where}: expected a folder, got an existing file")
        anc = out.absolute()
        while not anc.exists():
            anc = anc.parent
    except OSError as exc:
        raise OutputDirError(f"--out {where}: {exc.strerror or exc}") from None
    if not anc.is_dir():
        raise OutputDirError(f"--out {where}: {_short(str(anc))} is a file, not a folder")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise OutputDirError(f"--out {where}: {_short(str(anc))} is not writable")
    if out.is_dir() and not force:
        prev = _previous(out)
        visible = [p.name for p in out.iterdir() if not p.name.startswith(".")]
        if prev is not None and prev.get("scenario") not in (None, scenario):
            raise OutputDirError(
                f"--out {where}: holds the results of scenario {str(prev.get('scenario'))!r}, "
                f"not {scenario!r} (use another --out, or --force to replace them)")
        if prev is None and visible:
            raise OutputDirError(
                f"--out {where}: not empty and not a mechkin output folder ({len(visible)} "
                f"entries, e.g. {visible[0]!r}); use an empty folder, or --force")


@contextlib.contextmanager
def prepare_output(out_dir: str | Path, scenario: str, *, force: bool = False) -> Iterator[Path]:
    """Check ``out_dir`` and hold its lock for the whole run (``with``); a folder created here
    and left empty (the run failed before writing) is removed again."""
    out = Path(out_dir)
    check_output_dir(out, scenario, force=force)
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputDirError(f"--out {_short(str(out))}: cannot create: "
                             f"{exc.strerror or exc}") from None
    lock = out / LOCK_NAME

    def _release() -> None:
        with contextlib.suppress(OSError):
            lock.unlink()
        if created:
            with contextlib.suppress(OSError):
                out.rmdir()  # only if empty

    key = 0
    try:
        _take_lock(lock)
        key = register_cleanup(_release)
        yield out
    finally:
        forget_cleanup(key)
        _release()


def _take_lock(lock: Path) -> None:
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                pid = int(lock.read_text().strip() or "0")
            except (OSError, ValueError):
                pid = 0
            if pid and pid != os.getpid() and _pid_alive(pid):
                raise OutputDirError(f"--out {_short(str(lock.parent))}: being written by "
                                     f"another mechkin run (pid {pid}); wait for it or use "
                                     "another --out") from None
            with contextlib.suppress(OSError):
                lock.unlink()  # stale: its process is gone
            continue
        except OSError as exc:
            raise OutputDirError(f"--out {_short(str(lock.parent))}: cannot write: "
                                 f"{exc.strerror or exc}") from None
        with os.fdopen(fd, "w") as f:
            f.write(f"{os.getpid()}\n")
        return
    raise OutputDirError(f"--out {_short(str(lock.parent))}: cannot take the lock {LOCK_NAME}")


def write_report(report: Report, out_dir: str | Path, *, plots: bool = True) -> dict[str, Any]:
    """Write every output of ``report`` into ``out_dir`` atomically; return the final summary.

    ``plots=False`` (``--no-plots``) skips the PNGs even when the scenario asks for them. The
    previous run's files (its summary.json ``files``) that this run does not write are
    removed, so the folder holds exactly this run's outputs.
    """
    out_dir = Path(out_dir)
    writer = importlib.import_module(f"mechkin.io.{report.writer}_out")
    summary = dict(report.summary)
    summary["out_dir"] = str(out_dir)
    prev = _previous(out_dir) if out_dir.is_dir() else None
    old = [f for f in (prev or {}).get("files", []) if isinstance(f, str)]
    with OutputDir(out_dir, replaces=old) as od:
        od.table_format = getattr(report.outputs, "table", "csv")
        writer.write(od, report, plots)
        summary["files"] = od.files + ["summary.json"]
        od.write_json("summary.json", summary)
    return summary
