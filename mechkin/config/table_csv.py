"""Numeric input tables (an fk motion ``csv:``): parsed strictly, every problem as one line
``file:line: column 'name': message`` (bad input, never an internal error).

Imports: the standard library and errors only (numpy inside).
"""

from __future__ import annotations

import csv
import math
import os
import stat
from pathlib import Path
from typing import Any

from mechkin.errors import ConfigError

MAX_BYTES = 256 * 1024 * 1024  # a motion table larger than this is refused (bad input)


def _short(text: str, n: int = 40) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."


def read_numeric_csv(path: str | Path, *, max_bytes: int = MAX_BYTES) -> dict[str, Any]:
    """Columns of a CSV table whose every cell is a finite number (float64 arrays).

    Raises
    ------
    ConfigError
        Not a regular file, too large, empty, no data rows, a ragged row, a duplicate column,
        or a cell that is not a finite number (naming its line and column).
    """
    import numpy as np

    p = Path(path)
    try:
        st = os.stat(p)
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"{p}: expected a regular file")
    if st.st_size > max_bytes:
        raise ConfigError(f"{p}: {st.st_size} bytes is more than the {max_bytes}-byte limit "
                          "of an input table")
    try:
        with open(p, newline="", encoding="utf-8") as f:
            rows = [(n, r) for n, r in enumerate(csv.reader(f), start=1) if r]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ConfigError(f"{p}:1: cannot read CSV: {_short(str(exc), 80)}") from None
    if not rows:
        raise ConfigError(f"{p}:1: expected a header line, got an empty file")
    header = [h.strip() for h in rows[0][1]]
    seen = set()
    for h in header:
        if h in seen:
            raise ConfigError(f"{p}:1: column {_short(h)!r} appears twice")
        seen.add(h)
    if len(rows) == 1:
        raise ConfigError(f"{p}:2: expected at least one data row after the header")
    data = np.empty((len(rows) - 1, len(header)))
    for i, (n, r) in enumerate(rows[1:]):
        if len(r) != len(header):
            raise ConfigError(f"{p}:{n}: expected {len(header)} cells, got {len(r)}")
        for j, cell in enumerate(r):
            try:
                v = float(cell)
            except ValueError:
                raise ConfigError(f"{p}:{n}: column {_short(header[j])!r}: expected a number, "
                                  f"got {_short(cell)!r}") from None
            if not math.isfinite(v):
                raise ConfigError(f"{p}:{n}: column {_short(header[j])!r}: expected a finite "
                                  f"number, got {_short(cell)!r}")
            data[i, j] = v
    return {h: data[:, j] for j, h in enumerate(header)}
