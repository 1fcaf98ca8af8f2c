"""A whole run's output folder: files are staged in a hidden folder inside it (the same file
system, even when the folder is a mount point) and moved into place only when the ``with``
block ends without an exception; the moves run with SIGINT/SIGTERM held, so a signal leaves
either the previous files or the complete new set.

Imports: io.atomic, io.csv_out, io.summary, errors.
"""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import signal
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path, PurePosixPath
from types import TracebackType
from typing import Any

import numpy as np

from mechkin.errors import OutputError
from mechkin.io.atomic import _STAGING_PREFIX, _fsync_file
from mechkin.io.csv_out import format_csv
from mechkin.io.summary import summary_json

__all__ = ["OutputDir"]

log = logging.getLogger(__name__)

_HELD = {signal.SIGINT, signal.SIGTERM}

#: Cleanups of the runs in progress (staging folders, locks), run by a signal handler that
#: leaves the process at once (mechkin.cli.common.terminate_cleanly).
_CLEANUPS: dict[int, Any] = {}


def register_cleanup(fn: Any) -> int:
    """Keep ``fn`` to run if the process is stopped by a signal; returns a key to forget it."""
    key = id(fn)
    _CLEANUPS[key] = fn
    return key


def forget_cleanup(key: int) -> None:
    _CLEANUPS.pop(key, None)


def run_cleanups() -> None:
    """Run every registered cleanup, newest first, ignoring errors."""
    for key in sorted(_CLEANUPS, reverse=True):
        fn = _CLEANUPS.pop(key, None)
        if fn is not None:
            with contextlib.suppress(Exception):
                fn()


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def sweep_stale_staging(folder: Path) -> list[Path]:
    """Remove staging folders in ``folder`` left by runs whose process is gone."""
    removed = []
    with contextlib.suppress(OSError):
        for d in folder.glob(f"{_STAGING_PREFIX}*"):
            parts = d.name[len(_STAGING_PREFIX):].split("-")
            pid = int(parts[0]) if parts and parts[0].isdigit() else None
            if d.is_dir() and (pid is None or (pid != os.getpid() and not _pid_alive(pid))):
                shutil.rmtree(d, ignore_errors=True)
                removed.append(d)
    return removed


@contextlib.contextmanager
def signals_held():
    """Hold SIGINT and SIGTERM (delivered when the block ends): for the renames of a commit."""
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - not POSIX
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _check_relative(name: str | os.PathLike[str]) -> str:
    rel = PurePosixPath(Path(name).as_posix())
    if rel.is_absolute() or not rel.parts or any(p in ("..", ".", "") for p in rel.parts):
        raise OutputError(f"output file name {str(name)!r}: expected a relative path without '..'")
    return rel.as_posix()


class OutputDir:
    """Stage the files of one run and move them into ``path`` only if the run succeeds.

    Files are written under a hidden staging folder ``path/.mechkin-staging-<pid>-*`` (the
    same file system as the final files, so the moves are ``os.replace`` renames even when
    ``path`` is a mount point). On normal exit of the ``with`` block each staged file is
    renamed into place with SIGINT/SIGTERM held, then the files of ``replaces`` (the previous
    run's list) that this run did not write are removed. On an exception (a signal included)
    the staging folder is removed, the folder keeps its previous content, and a folder this
    run created is removed again. Staging folders of dead runs are swept on entry.

    Parameters
    ----------
    path : path-like
        The output folder, e.g. ``outputs/<scenario name>``.
    fsync : bool
        Flush every staged file to disk before it is moved into place.
    replaces : list of str, optional
        Relative names written by the previous run into ``path``; those not written again are
        removed after a successful commit (a ``--no-plots`` rerun leaves no old PNG behind).

    Attributes
    ----------
    path : Path
        The final output folder.
    files : list of str
        Relative (POSIX) names of the files written so far, in first-write order; the
        ``"files"`` list of summary.json.

    Examples
    --------
    >>> with OutputDir("outputs/demo") as od:          # doctest: +SKIP
    ...     od.write_csv("joints.csv", {"t_s": t, "q1_rad": q[:, 0]})
    ...     od.write_json("summary.json", {"status": "ok", "files": od.files})
    """

    def __init__(self, path: str | os.PathLike[str], *, fsync: bool = True,
                 replaces: Sequence[str] = ()) -> None:
        self.path = Path(path)
        self._fsync = fsync
        self._staging: Path | None = None
        self._files: list[str] = []
        self._replaces = list(replaces)
        self._created = False

    @property
    def files(self) -> list[str]:
        """Relative names of the files written so far (a copy)."""
        return list(self._files)

    @property
    def staging(self) -> Path:
        """The hidden staging directory (only inside the ``with`` block)."""
        if self._staging is None:
            raise OutputError(f"{self.path}: OutputDir used outside its 'with' block")
        return self._staging

    def __enter__(self) -> OutputDir:
        if self._staging is not None:
            raise OutputError(f"{self.path}: OutputDir entered twice")
        if self.path.exists() and not self.path.is_dir():
            raise OutputError(f"{self.path}: expected a directory, got an existing file")
        try:
            self._created = not self.path.exists()
            self.path.mkdir(parents=True, exist_ok=True)
            sweep_stale_staging(self.path)
            self._staging = Path(tempfile.mkdtemp(
                prefix=f"{_STAGING_PREFIX}{os.getpid()}-", dir=self.path))
            staging = self._staging

            def _drop() -> None:
                shutil.rmtree(staging, ignore_errors=True)
                self._remove_if_created()

            self._cleanup = register_cleanup(_drop)
        except OSError as e:
            self._remove_if_created()
            raise OutputError(f"{self.path}: cannot create a staging directory: "
                              f"{e.strerror or e}") from e
        self._files = []
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        staging = self.staging
        ok = False
        try:
            if exc_type is None:
                self._commit(staging)
                ok = True
        finally:
            shutil.rmtree(staging, ignore_errors=True)
            self._staging = None
            forget_cleanup(getattr(self, "_cleanup", 0))
            if not ok:
                self._remove_if_created()

    def _remove_if_created(self) -> None:
        if self._created:
            with contextlib.suppress(OSError):
                self.path.rmdir()  # only if empty

    def _commit(self, staging: Path) -> None:
        missing = [n for n in self._files if not (staging / n).is_file()]
        if missing:
            raise OutputError(f"{self.path}: files requested but never written: {missing}")
        try:
            if self._fsync:
                for name in self._files:
                    _fsync_file(staging / name)
            with signals_held():
                for name in self._files:
                    dst = self.path / name
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    os.replace(staging / name, dst)
                for name in self._replaces:
                    if name not in self._files:
                        with contextlib.suppress(OSError, OutputError):
                            (self.path / _check_relative(name)).unlink()
        except OSError as e:
            raise OutputError(f"{self.path}: cannot move outputs into place: "
                              f"{e.strerror or e}") from e
        log.info("wrote %d file(s) to %s", len(self._files), self.path)

    def path_for(self, name: str | os.PathLike[str]) -> Path:
        """Register ``name`` (relative, may contain sub-folders) and return its staged path.

        The caller writes the complete file there; it is moved to ``self.path / name`` when the
        ``with`` block succeeds. Registering the same name twice returns the same path.
        """
        rel = _check_relative(name)
        staged = self.staging / rel
        staged.parent.mkdir(parents=True, exist_ok=True)
        if rel not in self._files:
            self._files.append(rel)
        return staged

    def final_path(self, name: str | os.PathLike[str]) -> Path:
        """Where ``name`` will be after a successful exit: ``self.path / name``."""
        return self.path / _check_relative(name)

    def write_bytes(self, name: str | os.PathLike[str], data: bytes) -> Path:
        """Stage ``data`` as ``name``; return the staged path."""
        staged = self.path_for(name)
        staged.write_bytes(data)
        return staged

    def write_text(self, name: str | os.PathLike[str], text: str) -> Path:
        """Stage ``text`` (UTF-8) as ``name``; return the staged path."""
        return self.write_bytes(name, text.encode("utf-8"))

    def write_json(self, name: str | os.PathLike[str], obj: Any) -> Path:
        """Stage ``obj`` as JSON via :func:`mechkin.io.summary.summary_json` (NaN refused)."""
        return self.write_text(name, summary_json(obj))

    def write_csv(
        self,
        name: str | os.PathLike[str],
        columns: Mapping[str, np.ndarray | Sequence[Any]],
    ) -> Path:
        """Stage a CSV table via :func:`mechkin.io.csv_out.format_csv` (NaN refused)."""
        return self.write_text(name, format_csv(columns))

    #: The format of :meth:`write_table`'s tables (``outputs.table``: csv, npz, parquet); set
    #: by :func:`mechkin.io.report.write_report` from the report's output flags.
    table_format: str = "csv"

    def write_table(self, stem: str, columns: Mapping[str, np.ndarray | Sequence[Any]]) -> Path:
        """Stage table ``stem`` as ``<stem>.csv``, ``.npz`` or ``.parquet``
        (:attr:`table_format`, :func:`mechkin.io.table_out.write_table`)."""
        from mechkin.io.table_out import write_table

        return write_table(self, stem, columns, self.table_format)
