"""A whole run's output folder: files are staged in a hidden sibling directory and moved into
the output folder only when the ``with`` block ends without an exception.

Imports: io.atomic, io.csv_out, io.summary, errors.
"""

from __future__ import annotations

import logging
import os
import shutil
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


def _check_relative(name: str | os.PathLike[str]) -> str:
    rel = PurePosixPath(Path(name).as_posix())
    if rel.is_absolute() or not rel.parts or any(p in ("..", ".", "") for p in rel.parts):
        raise OutputError(f"output file name {str(name)!r}: expected a relative path without '..'")
    return rel.as_posix()


class OutputDir:
    """Stage the files of one run and move them into ``path`` only if the run succeeds.

    Files are written under a hidden staging directory created beside ``path`` (same
    filesystem, so the final moves are ``os.replace`` renames). On normal exit of the ``with``
    block ``path`` is created if needed and each staged file is renamed into place; files of
    ``path`` not written in this run are left alone. On an exception the staging directory is
    removed and nothing appears in ``path``.

    Parameters
    ----------
    path : path-like
        The output folder, e.g. ``outputs/<scenario name>``.
    fsync : bool
        Flush every staged file to disk before it is moved into place.

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

    def __init__(self, path: str | os.PathLike[str], *, fsync: bool = True) -> None:
        self.path = Path(path)
        self._fsync = fsync
        self._staging: Path | None = None
        self._files: list[str] = []

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
        parent = self.path.absolute().parent
        try:
            parent.mkdir(parents=True, exist_ok=True)
            self._staging = Path(
                tempfile.mkdtemp(prefix=f"{_STAGING_PREFIX}{self.path.name}-", dir=parent)
            )
        except OSError as e:
            raise OutputError(f"{self.path}: cannot create a staging directory: {e}") from e
        self._files = []
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        staging = self.staging
        try:
            if exc_type is None:
                self._commit(staging)
        finally:
            shutil.rmtree(staging, ignore_errors=True)
            self._staging = None

    def _commit(self, staging: Path) -> None:
        missing = [n for n in self._files if not (staging / n).is_file()]
        if missing:
            raise OutputError(f"{self.path}: files requested but never written: {missing}")
        try:
            self.path.mkdir(parents=True, exist_ok=True)
            for name in self._files:
                src = staging / name
                if self._fsync:
                    _fsync_file(src)
                dst = self.path / name
                dst.parent.mkdir(parents=True, exist_ok=True)
                os.replace(src, dst)
        except OSError as e:
            raise OutputError(f"{self.path}: cannot move outputs into place: {e}") from e
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
