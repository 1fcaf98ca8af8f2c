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
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mechkin.errors import OutputDirError
from mechkin.io.output_dir import COMMIT_MARKER, OutputDir, forget_cleanup, register_cleanup
from mechkin.records import Report

LOCK_NAME = ".mechkin.lock"


#: The largest previous summary.json (or commit marker) read from an output folder.
MAX_SUMMARY_BYTES = 64 * 1024 * 1024


def _read_owned(p: Path) -> dict[str, Any] | None:
    """A JSON object from ``p`` if it is a regular file (never a symlink, FIFO or device: not
    followed, not waited on) of at most :data:`MAX_SUMMARY_BYTES`; else None."""
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(p, flags)
    except OSError:
        return None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_size > MAX_SUMMARY_BYTES:
            return None
        raw = os.read(fd, MAX_SUMMARY_BYTES + 1)
        data = json.loads(raw) if len(raw) <= MAX_SUMMARY_BYTES else None
    except (OSError, ValueError, RecursionError):
        return None
    finally:
        os.close(fd)
    return data if isinstance(data, dict) else None


def _previous(out_dir: Path) -> dict[str, Any] | None:
    """The previous run's summary.json in ``out_dir`` (None if absent or unreadable)."""
    return _read_owned(out_dir / "summary.json")


def _interrupted(out_dir: Path) -> dict[str, Any] | None:
    """The commit marker of a run killed while it moved its files into ``out_dir`` (None if
    the folder is whole)."""
    return _read_owned(out_dir / COMMIT_MARKER)


def _names(doc: dict[str, Any] | None, key: str) -> list[str]:
    got = (doc or {}).get(key, [])
    return [f for f in got if isinstance(f, str)] if isinstance(got, list) else []


def previous_files(out_dir: Path) -> list[str]:
    """Every file an earlier mechkin run wrote into ``out_dir``: the previous summary's list,
    and those of an interrupted commit (its marker); the next commit replaces them all."""
    mark = _interrupted(out_dir)
    names = _names(_previous(out_dir), "files") + _names(mark, "files") + _names(mark,
                                                                                 "replaces")
    return list(dict.fromkeys(names))


def _short(text: str, n: int = 80) -> str:
    return text if len(text) <= n else "..." + text[-(n - 3):]


def check_output_dir(out_dir: str | Path, scenario: str, *, force: bool = False) -> None:
    """Refuse an unusable output folder before any work (OutputDirError, exit 2)."""
    out = Path(out_dir)
    where = _short(str(out))
    if not out.is_absolute():
        try:
            os.getcwd()
        except OSError:
            raise OutputDirError(f"--out {where}: the working directory no longer exists; "
                                 "give an absolute --out") from None
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
        prev = _previous(out) or _interrupted(out)
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
    and left empty (the run failed before writing) is removed again. A refused run never
    touches the lock it did not take."""
    out = Path(out_dir)
    check_output_dir(out, scenario, force=force)
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputDirError(f"--out {_short(str(out))}: cannot create: "
                             f"{exc.strerror or exc}") from None
    try:
        lock = _take_lock(out / LOCK_NAME)
    except BaseException:
        if created:
            with contextlib.suppress(OSError):
                out.rmdir()  # only if empty
        raise

    def _release() -> None:
        lock.release()
        if created:
            with contextlib.suppress(OSError):
                out.rmdir()  # only if empty

    key = register_cleanup(_release)
    try:
        yield out
    finally:
        forget_cleanup(key)
        _release()


class _Lock:
    """``.mechkin.lock`` held with ``flock`` on an open descriptor: the kernel drops the lock
    when its process dies (a SIGKILL too), so a stale file is taken over, and only the holder
    removes the file."""

    def __init__(self, path: Path, fd: int) -> None:
        self.path, self.fd = path, fd

    def release(self) -> None:
        if self.fd < 0:
            return
        with contextlib.suppress(OSError):
            if _same_file(self.path, self.fd):
                self.path.unlink()  # still ours: unlink while holding it
        with contextlib.suppress(OSError):
            os.close(self.fd)  # drops the flock
        self.fd = -1


def _same_file(path: Path, fd: int) -> bool:
    try:
        a, b = os.stat(path, follow_symlinks=False), os.fstat(fd)
    except OSError:
        return False
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def _holder(lock: Path) -> str:
    try:
        return f" (pid {int(lock.read_text(encoding='ascii')[:20].strip() or '0')})"
    except (OSError, ValueError):
        return ""


def _take_lock(lock: Path) -> _Lock:
    import fcntl

    where = _short(str(lock.parent))
    for _ in range(20):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_RDWR | getattr(os, "O_NOFOLLOW", 0)
                         | getattr(os, "O_NONBLOCK", 0), 0o644)
        except OSError as exc:
            raise OutputDirError(f"--out {where}: cannot take the lock {LOCK_NAME}: "
                                 f"{exc.strerror or exc}") from None
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise OutputDirError(f"--out {where}: {LOCK_NAME} is not a regular file")
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise OutputDirError(f"--out {where}: being written by another mechkin run"
                                     f"{_holder(lock)}; wait for it or use another "
                                     "--out") from None
            if not _same_file(lock, fd):
                os.close(fd)  # its holder removed it between our open and our flock: again
                continue
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
        except BaseException:
            with contextlib.suppress(OSError):
                os.close(fd)
            raise
        return _Lock(lock, fd)
    raise OutputDirError(f"--out {where}: cannot take the lock {LOCK_NAME}")


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
    old = previous_files(out_dir) if out_dir.is_dir() else []
    with OutputDir(out_dir, replaces=old, scenario=summary.get("scenario")) as od:
        od.table_format = getattr(report.outputs, "table", "csv")
        writer.write(od, report, plots)
        summary["files"] = od.files + ["summary.json"]
        od.write_json("summary.json", summary)
    return summary
