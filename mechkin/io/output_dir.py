"""A whole run's output folder: files are staged in a hidden folder inside it (the same file
system, even when the folder is a mount point) and moved into place only when the ``with``
block ends without an exception; the moves run with SIGINT/SIGTERM held, so a signal leaves
either the previous files or the complete new set.

Imports: io.atomic, io.csv_out, io.summary, errors.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import shutil
import signal
import stat
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path, PurePosixPath
from types import TracebackType
from typing import Any

import numpy as np

from mechkin.errors import OutputDirError, OutputError
from mechkin.io.atomic import _STAGING_PREFIX, _fsync_file
from mechkin.io.csv_out import format_csv
from mechkin.io.summary import summary_json

__all__ = ["OutputDir"]

log = logging.getLogger(__name__)

_HELD = {signal.SIGINT, signal.SIGTERM}

#: Cleanups of the runs in progress (staging folders, locks), run by a signal handler that
#: leaves the process at once (mechkin.cli.common.terminate_cleanly).
_CLEANUPS: dict[int, Any] = {}
_NEXT_KEY = [0]

#: Written into the output folder before the first rename of a commit and removed after the
#: last (summary.json is renamed last): a folder holding it and no summary.json is an
#: interrupted commit; the next run reads it to know which files mechkin wrote there.
COMMIT_MARKER = ".mechkin-commit.json"


def register_cleanup(fn: Any) -> int:
    """Keep ``fn`` to run if the process is stopped by a signal; returns a key to forget it.
    Keys grow with each registration, so :func:`run_cleanups` runs the newest first."""
    _NEXT_KEY[0] += 1
    key = _NEXT_KEY[0]
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


class _DirFd:
    """The output folder opened once; every path under it is reached component by component
    with ``O_NOFOLLOW`` from that descriptor, so no symlink inside it is ever followed."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.fd = -1

    def __enter__(self) -> _DirFd:
        self.fd = os.open(self.path, os.O_RDONLY | os.O_DIRECTORY)
        return self

    def __exit__(self, *exc: object) -> None:
        os.close(self.fd)

    def _parent(self, rel: str, create: bool) -> tuple[int, str] | None:
        """(descriptor of rel's folder, base name); None if a folder on the way is missing
        (and not ``create``). Raises OSError (ELOOP, ENOTDIR) on a symlink or a file."""
        parts = rel.split("/")
        fd = os.dup(self.fd)
        try:
            for part in parts[:-1]:
                if create:
                    with contextlib.suppress(FileExistsError):
                        os.mkdir(part, 0o777, dir_fd=fd)
                try:
                    nfd = os.open(part, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW,
                                  dir_fd=fd)
                except FileNotFoundError:
                    os.close(fd)
                    return None
                os.close(fd)
                fd = nfd
        except BaseException:
            os.close(fd)
            raise
        return fd, parts[-1]

    def foreign(self, rel: str) -> str | None:
        """Why ``rel`` cannot be written by mechkin (a symlink or a file on the way, or a
        destination that is not a regular file), or None."""
        try:
            got = self._parent(rel, create=False)
        except OSError:
            return f"{rel!r} goes through a symlink or a file"
        if got is None:
            return None
        fd, base = got
        try:
            st = os.stat(base, dir_fd=fd, follow_symlinks=False)
        except FileNotFoundError:
            return None
        finally:
            os.close(fd)
        if not stat.S_ISREG(st.st_mode):
            what = "a symlink" if stat.S_ISLNK(st.st_mode) else "not a regular file"
            return f"{rel!r} exists and is {what}"
        return None

    def move_in(self, src: Path, rel: str) -> None:
        got = self._parent(rel, create=True)
        assert got is not None
        fd, base = got
        try:
            os.replace(src, base, dst_dir_fd=fd)
        finally:
            os.close(fd)

    def remove_owned(self, rel: str) -> bool:
        """Remove ``rel`` if it is a regular file reached through real folders (never a
        symlink, a folder or a special file, never outside the folder); True if removed."""
        try:
            rel = _check_relative(rel)
            got = self._parent(rel, create=False)
        except (OSError, OutputError):
            return False
        if got is None:
            return False
        fd, base = got
        try:
            st = os.stat(base, dir_fd=fd, follow_symlinks=False)
            if stat.S_ISREG(st.st_mode):
                os.unlink(base, dir_fd=fd)
                return True
        except OSError:
            pass
        finally:
            os.close(fd)
        return False

    def sync(self) -> None:
        with contextlib.suppress(OSError):
            os.fsync(self.fd)


#: OSErrors of a writer that are bugs, not the disk's answer
_NOT_IO = (FileNotFoundError, IsADirectoryError, NotADirectoryError)


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
                 replaces: Sequence[str] = (), scenario: str | None = None) -> None:
        self.path = Path(path)
        self.scenario = scenario
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
            elif isinstance(exc, OSError) and not isinstance(exc, _NOT_IO):
                # a writer hit a full disk or an I/O error while staging: exit 4, not a bug
                raise OutputError(f"{self.path}: cannot write the outputs: "
                                  f"{exc.strerror or exc}; the folder keeps its previous "
                                  "contents") from exc
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
        """Move the staged files into place: the commit protocol.

        With SIGINT/SIGTERM held: every destination is checked first (a folder on the way
        that is a symlink or a file, a destination that is not a regular file: refused, nothing
        moved); :data:`COMMIT_MARKER` (this run's file list and the previous run's) is renamed
        into the folder; the previous summary.json is removed, then the files are renamed
        into place, the previous run's files that this run did not write are removed, and
        summary.json comes last; then the marker goes. Killed at any moment (SIGKILL), the
        folder holds the previous run whole, or this run whole, or no summary.json and the
        marker: a folder every reader sees as incomplete and the next run cleans up.
        """
        missing = [n for n in self._files if not (staging / n).is_file()]
        if missing:
            raise OutputError(f"{self.path}: files requested but never written: {missing}")
        names = [n for n in self._files if n != "summary.json"]
        last = ["summary.json"] if "summary.json" in self._files else []
        try:
            if self._fsync:
                for name in self._files:
                    _fsync_file(staging / name)
            marker = staging / COMMIT_MARKER
            marker.write_text(json.dumps({
                "pid": os.getpid(), "scenario": self.scenario, "files": names + last,
                "replaces": [n for n in self._replaces if isinstance(n, str)]}) + "\n",
                encoding="utf-8")
            if self._fsync:
                _fsync_file(marker)
            with signals_held(), _DirFd(self.path) as root:
                for name in names + last:
                    problem = root.foreign(name)
                    if problem:
                        marker.unlink()
                        raise OutputDirError(f"--out {self.path}: {problem}; mechkin does not "
                                             "replace what it did not create (nothing written)")
                os.replace(marker, self.path / COMMIT_MARKER)
                root.sync()
                if last:
                    root.remove_owned("summary.json")
                for name in names:
                    root.move_in(staging / name, name)
                for name in self._replaces:
                    if name not in self._files:
                        root.remove_owned(name)
                for name in last:
                    root.move_in(staging / name, name)
                root.sync()
                root.remove_owned(COMMIT_MARKER)
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
