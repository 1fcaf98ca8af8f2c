"""Numeric input tables (an fk motion ``csv:``): parsed strictly, every problem as one line
``file:line: column N ('name'): message`` (bad input, never an internal error).

The file goes through the guarded reader's checks (a regular file of at most
:data:`~mechkin.config.guarded_read.MAX_TABLE_BYTES`, ``MECHKIN_MAX_TABLE_MB``) and is parsed
row by row into one float64 buffer (8 bytes a cell; no list of rows), so memory stays near the
size of the numbers. Cell contents are never echoed in a message (a file given by mistake,
e.g. ``/etc/passwd``, is not printed): a header is named only when it looks like a column name.

Imports: the standard library, config.guarded_read and errors only (numpy inside).
"""

from __future__ import annotations

import csv
import math
import os
import re
import stat
from array import array
from pathlib import Path
from typing import Any

from mechkin.config.guarded_read import MAX_TABLE_BYTES, check_file, env_mib
from mechkin.errors import ConfigError

MAX_BYTES = MAX_TABLE_BYTES  # a motion table larger than this is refused (bad input)

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]{0,39}\Z")


def _column(header: list[str], j: int) -> str:
    h = header[j] if j < len(header) else ""
    return f"column {j + 1} ({h!r})" if _NAME.match(h) else f"column {j + 1}"


def read_numeric_csv(path: str | Path, *, max_bytes: int | None = None) -> dict[str, Any]:
    """Columns of a CSV table whose every cell is a finite number (float64 arrays).

    Raises
    ------
    ConfigError
        Not a regular file, too large, empty, no data rows, a ragged row, a duplicate column,
        or a cell that is not a finite number (naming its
        line and column, never its text).
    """
    import numpy as np

    p = Path(path)
    limit = env_mib("MECHKIN_MAX_TABLE_MB", MAX_BYTES) if max_bytes is None else max_bytes
    check_file(p, what="input table", limit=limit, hint="MECHKIN_MAX_TABLE_MB raises it")
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read the input table: {exc.strerror or exc}") from None
    values = array("d")
    header: list[str] | None = None
    rows = 0
    try:
        with open(fd, newline="", encoding="utf-8") as f:
            if not stat.S_ISREG(os.fstat(fd).st_mode):  # swapped after the check
                raise ConfigError(f"{p}: the input table is not a regular file")
            for n, r in enumerate(csv.reader(f), start=1):
                if not r:
                    continue
                if header is None:
                    header = [h.strip() for h in r]
                    _check_header(p, header)
                    continue
                if len(r) != len(header):
                    raise ConfigError(f"{p}:{n}: expected {len(header)} cells, got {len(r)}")
                for j, cell in enumerate(r):
                    try:
                        v = float(cell)
                    except ValueError:
                        raise ConfigError(f"{p}:{n}: {_column(header, j)}: expected a "
                                          "number") from None
                    if not math.isfinite(v):
                        raise ConfigError(f"{p}:{n}: {_column(header, j)}: expected a finite "
                                          "number")
                    values.append(v)
                rows += 1
                if len(values) * 8 > 4 * limit:  # grew while read
                    raise ConfigError(f"{p}: the input table grew past the limit of {limit} "
                                      "bytes while read")
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        what = "not UTF-8 text" if isinstance(exc, UnicodeDecodeError) else "cannot read CSV"
        raise ConfigError(f"{p}:1: {what} ({type(exc).__name__})") from None
    if header is None:
        raise ConfigError(f"{p}:1: expected a header line, got an empty file")
    if rows == 0:
        raise ConfigError(f"{p}:2: expected at least one data row after the header")
    data = np.frombuffer(values, dtype=np.float64).reshape(rows, len(header))
    return {h: data[:, j].copy() for j, h in enumerate(header)}


def _check_header(p: Path, header: list[str]) -> None:
    seen = set()
    for j, h in enumerate(header):
        if h in seen:
            raise ConfigError(f"{p}:1: {_column(header, j)} appears twice")
        seen.add(h)
