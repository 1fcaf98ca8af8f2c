"""Atomic file output: every file is written to a hidden temp name and renamed into place.

A reader (or a crash, or an exception half-way through a writer) never sees half a file: the
final name either holds the previous content or the complete new one. ``os.replace`` is atomic
on POSIX and Windows when source and target are on the same filesystem, so temp files always
live in the target's own directory.

:class:`mechkin.io.output_dir.OutputDir` extends this to a whole run.
"""

from __future__ import annotations

import contextlib
import logging
import os
import secrets
import stat
from collections.abc import Iterator
from pathlib import Path

from mechkin.errors import OutputDirError, OutputError

__all__ = [
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
]

log = logging.getLogger(__name__)

_STAGING_PREFIX = ".mechkin-staging-"


def _temp_name(path: Path) -> Path:
    # Keep the final suffix last: matplotlib and others pick the format from the extension.
    return path.with_name(f".{path.name}.{secrets.token_hex(4)}.part{path.suffix}")


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def refuse_special(final: Path) -> None:
    """OutputDirError (exit 2, nothing written) when ``final`` exists and is not a regular
    file: a device (``-o /dev/null``), FIFO, socket, folder or symlink is never replaced."""
    try:
        st = os.lstat(final)
    except FileNotFoundError:
        return
    except OSError as e:
        raise OutputDirError(f"{final}: cannot write: {e.strerror or e}") from None
    if stat.S_ISREG(st.st_mode):
        return
    kind = ("a symlink" if stat.S_ISLNK(st.st_mode) else "a folder" if stat.S_ISDIR(st.st_mode)
            else "a FIFO" if stat.S_ISFIFO(st.st_mode) else "a socket" if stat.S_ISSOCK(
                st.st_mode) else "a device")
    raise OutputDirError(f"{final}: exists and is {kind}; mechkin replaces only regular files "
                         "(nothing written)")


def _remove_quietly(path: Path) -> None:
    with contextlib.suppress(FileNotFoundError):
        path.unlink()


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], *, fsync: bool = True) -> Iterator[Path]:
    """Yield a temp path beside ``path``; rename it to ``path`` when the block succeeds.

    The temp file is created empty (with the usual umask permissions) in the same directory,
    named ``.<name>.<random>.part<suffix>``. The caller (or a library such as matplotlib)
    writes the complete content to it. On normal exit the temp file is flushed to disk and
    ``os.replace``'d onto ``path``; on an exception it is removed and the exception propagates,
    so ``path`` keeps its previous content (or stays absent).

    Parameters
    ----------
    path : path-like
        Final file name. Missing parent directories are created.
    fsync : bool
        Flush the temp file to disk before the rename (crash safety).

    Yields
    ------
    Path
        The temp path to write to.

    Raises
    ------
    OutputDirError
        ``path`` exists and is not a regular file (a device, FIFO, folder or symlink).
    OutputError
        The directory cannot be created or the rename fails.

    Examples
    --------
    >>> with atomic_path(out / "q.png") as tmp:   # doctest: +SKIP
    ...     fig.savefig(tmp)
    """
    final = Path(path)
    refuse_special(final)
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        tmp = _temp_name(final)
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    except OSError as e:
        raise OutputError(f"{final}: cannot create a temp file: {e.strerror or e}") from e
    try:
        yield tmp
        if not tmp.exists():
            raise OutputError(f"{final}: the writer removed its temp file {tmp.name}")
        if fsync:
            _fsync_file(tmp)
        os.replace(tmp, final)
    except BaseException as e:
        _remove_quietly(tmp)
        if isinstance(e, OSError):
            raise OutputError(f"{final}: cannot write: {e.strerror or e}") from e
        raise
    log.debug("wrote %s", final)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes, *, fsync: bool = True) -> Path:
    """Write ``data`` to ``path`` atomically (temp file + ``os.replace``); return the path."""
    final = Path(path)
    with atomic_path(final, fsync=fsync) as tmp, open(tmp, "wb") as f:
        f.write(data)
    return final


def atomic_write_text(path: str | os.PathLike[str], text: str, *, fsync: bool = True) -> Path:
    """Write ``text`` as UTF-8 (``\\n`` line ends) to ``path`` atomically; return the path."""
    return atomic_write_bytes(path, text.encode("utf-8"), fsync=fsync)
