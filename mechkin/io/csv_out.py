"""CSV tables with units in the headers (``t_s, q1_rad, x_m``); a table never holds NaN.

Floats are printed with ``repr`` (the shortest text that parses back to the same float64), so
``float(cell) == value`` exactly. String columns (e.g. ``status``) are quoted only when needed
(RFC 4180: a comma, a quote or a line break in the cell).
"""

from __future__ import annotations

import enum
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mechkin.errors import OutputError
from mechkin.io.atomic import atomic_write_text

__all__ = ["format_csv", "read_csv", "write_csv"]

_NEEDS_QUOTES = (",", '"', "\n", "\r")


def _quote(cell: str) -> str:
    if any(c in cell for c in _NEEDS_QUOTES) or cell != cell.strip():
        return '"' + cell.replace('"', '""') + '"'
    return cell


def _column_cells(name: str, values: np.ndarray | Sequence[Any]) -> list[str]:
    if isinstance(values, np.ndarray):
        arr = values
    else:
        arr = np.empty(len(values), dtype=object)
        for i, v in enumerate(values):
            arr[i] = v
    if arr.ndim != 1:
        raise OutputError(f"CSV column {name!r}: expected a 1-D column, got shape {arr.shape}")
    kind = arr.dtype.kind
    if kind == "f":
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise OutputError(
                f"CSV column {name!r}: expected finite numbers, got {arr[bad[0]]!r} "
                f"at row {int(bad[0])} ({bad.size} non-finite value(s))"
            )
        return [repr(v) for v in arr.astype(np.float64).tolist()]
    if kind == "b":
        return ["1" if v else "0" for v in arr.tolist()]
    if kind in "iu":
        return [str(v) for v in arr.tolist()]
    if kind in "US":
        return [_quote(str(v)) for v in arr.astype(str).tolist()]
    if kind == "O":
        vals = arr.tolist()
        if all(type(v) is str for v in vals):  # labels (status, class): quote each value once
            memo = {v: _quote(v) for v in set(vals)}
            return [memo[v] for v in vals]
        cells = []
        for i, v in enumerate(vals):
            if isinstance(v, enum.Enum):
                v = v.value
            if isinstance(v, (bool, np.bool_)):
                cells.append("1" if v else "0")
            elif isinstance(v, (int, np.integer)):
                cells.append(str(int(v)))
            elif isinstance(v, (float, np.floating)):
                if not np.isfinite(v):
                    raise OutputError(
                        f"CSV column {name!r}: expected finite numbers, got {v!r} at row {i}"
                    )
                cells.append(repr(float(v)))
            elif isinstance(v, str):
                cells.append(_quote(v))
            else:
                raise OutputError(
                    f"CSV column {name!r}: expected numbers or strings, got "
                    f"{type(v).__name__} at row {i}"
                )
        return cells
    raise OutputError(f"CSV column {name!r}: expected numbers or strings, got dtype {arr.dtype}")


def format_csv(columns: Mapping[str, np.ndarray | Sequence[Any]]) -> str:
    """Format equal-length columns as CSV text (header line, ``\\n`` line ends).

    Parameters
    ----------
    columns : mapping of str to array, shape (m,), or sequence of length m
        Column name (with its unit, e.g. ``"q1_rad"``) -> values. Floats, integers, booleans
        (written ``1``/``0``), strings and enums (written as their ``.value``) are accepted.

    Returns
    -------
    str
        The CSV text; floats are written with ``repr`` so they round-trip exactly.

    Raises
    ------
    OutputError
        No columns, an empty or duplicate name, columns of different lengths, a non-1-D
        column, or a NaN/inf value (the message names the column and the row).
    """
    if not columns:
        raise OutputError("CSV table: expected at least one column, got none")
    names = list(columns)
    for name in names:
        if not isinstance(name, str) or not name.strip():
            raise OutputError(f"CSV table: expected non-empty string column names, got {name!r}")
    cells = [_column_cells(name, columns[name]) for name in names]
    lengths = {name: len(c) for name, c in zip(names, cells, strict=False)}
    if len(set(lengths.values())) > 1:
        raise OutputError(f"CSV table: expected columns of equal length, got {lengths}")
    lines = [",".join(_quote(n) for n in names)]
    lines.extend(",".join(row) for row in zip(*cells, strict=False))
    return "\n".join(lines) + "\n"


def write_csv(
    path: str | os.PathLike[str], columns: Mapping[str, np.ndarray | Sequence[Any]]
) -> Path:
    """Write :func:`format_csv` of ``columns`` to ``path`` atomically; return the path.

    Examples
    --------
    >>> write_csv(out / "joints.csv", {"t_s": t, "q1_rad": q[:, 0], "status": st})  # doctest: +SKIP
    """
    return atomic_write_text(path, format_csv(columns))


def read_csv(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Read a table written by :func:`write_csv` back into columns.

    Columns whose cells all parse as numbers become float64 arrays (integers included);
    the others stay arrays of ``str``.

    Parameters
    ----------
    path : path-like
        The CSV file.

    Returns
    -------
    dict of str to array, shape (m,)
        Columns in file order.

    Raises
    ------
    ValueError
        An empty file or a row whose cell count differs from the header's (with its line).
    OSError
        The file cannot be read.
    """
    import csv

    with open(path, newline="", encoding="utf-8") as f:
        rows = [(n, r) for n, r in enumerate(csv.reader(f), start=1) if r]
    if not rows:
        raise ValueError("expected a CSV header line, got an empty file")
    header, body = rows[0][1], [r for _, r in rows[1:]]
    for n, r in rows[1:]:
        if len(r) != len(header):
            raise ValueError(f"line {n}: expected {len(header)} cells, got {len(r)}")
    out: dict[str, np.ndarray] = {}
    for j, name in enumerate(header):
        col = [r[j] for r in body]
        try:
            out[name] = np.array([float(c) for c in col], dtype=np.float64)
        except ValueError:
            out[name] = np.array(col, dtype=str)
    return out
