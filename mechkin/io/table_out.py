"""Tables of a run in the format ``outputs.table`` asks for: ``csv`` (text, :mod:`mechkin.io.
csv_out`), ``npz`` (numpy) or ``parquet`` (pyarrow, optional).

Design
------
A table is the same mapping of columns in every format (names with their units, ``t_s``,
``q1_rad``, ``ee_x_m``, ..., ``status``), so a binary table holds exactly the CSV's values
without the cost of their text (a 100k-step fk table is 4.1M floats: 70 MB of CSV, about 1-2 s
of formatting even on the fast path, against 33 MB of npz written in a few tens of ms):

- ``npz``: ``numpy.savez`` (uncompressed), one array per column under the CSV header's name;
  float columns float64 (bit for bit), integers int64, booleans bool, strings numpy unicode.
  ``numpy.load(path)[name]`` reads a column back.
- ``parquet``: one pyarrow column per CSV column with the same names and types (float64,
  int64, bool, string), snappy-compressed (pyarrow's default), dictionary-encoded for the
  string columns only (on float columns, where every value differs, a dictionary costs 6x the
  write time and grows the file); ``pyarrow.parquet.read_table``
  or ``pandas.read_parquet`` read it. pyarrow is an optional extra (``pip install
  "mechkin[parquet]"``); the scenario check refuses ``table: parquet`` without it before any
  work.

Values are checked as for the CSV (finite floats, 1-D columns of equal length: the messages of
:func:`mechkin.io.csv_out.format_csv`), so every format refuses what the CSV refuses.

Imports: io.csv_out, io.output_dir (types), errors.
"""

from __future__ import annotations

import enum
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mechkin.errors import OutputError
from mechkin.io.csv_out import _column_cells, _float_column, _is_float_column

__all__ = ["TABLE_FORMATS", "table_arrays", "table_name", "write_table", "write_table_file"]

#: The formats of ``outputs.table`` and their file suffixes.
TABLE_FORMATS = {"csv": ".csv", "npz": ".npz", "parquet": ".parquet"}

PARQUET_HINT = 'pip install "mechkin[parquet]"'


def table_name(stem: str, fmt: str) -> str:
    """File name of table ``stem`` in format ``fmt`` (``fk`` -> ``fk.csv``, ``fk.npz``)."""
    if fmt not in TABLE_FORMATS:
        raise OutputError(f"table format: expected one of {', '.join(TABLE_FORMATS)}, got "
                          f"{fmt!r}")
    return stem + TABLE_FORMATS[fmt]


def _object_column(name: str, values: Sequence[Any]) -> np.ndarray:
    """A list / object column as a typed array: strings (enums as their value), booleans,
    integers or floats (finite), as the CSV writes them; anything mixed as its CSV text."""
    vals = [v.value if isinstance(v, enum.Enum) else v for v in values]
    if all(type(v) is str for v in vals):
        return np.array(vals, dtype=str) if vals else np.zeros(0, dtype=str)
    if all(isinstance(v, (bool, np.bool_)) for v in vals):
        return np.array(vals, dtype=bool)
    if all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
           for v in vals):
        return np.array(vals, dtype=np.int64)
    if all(isinstance(v, (int, float, np.integer, np.floating))
           and not isinstance(v, (bool, np.bool_)) for v in vals):
        return _float_column(name, np.array(vals, dtype=np.float64))
    cells = _column_cells(name, values)  # validates (names the bad row) and gives the text
    return np.array([c[1:-1].replace('""', '"') if c.startswith('"') else c for c in cells],
                    dtype=str)


def table_arrays(columns: Mapping[str, np.ndarray | Sequence[Any]]) -> dict[str, np.ndarray]:
    """The columns of a table as 1-D typed arrays (float64, int64, bool, str), checked as
    :func:`mechkin.io.csv_out.format_csv` checks them.

    Raises
    ------
    OutputError
        No columns, a bad name, columns of different lengths, a non-1-D column, NaN/inf.
    """
    if not columns:
        raise OutputError("table: expected at least one column, got none")
    out: dict[str, np.ndarray] = {}
    for name, v in columns.items():
        if not isinstance(name, str) or not name.strip():
            raise OutputError(f"table: expected non-empty string column names, got {name!r}")
        if _is_float_column(v):
            out[name] = _float_column(name, v)
            continue
        if isinstance(v, np.ndarray) and v.dtype != object:
            if v.ndim != 1:
                raise OutputError(f"CSV column {name!r}: expected a 1-D column, got shape "
                                  f"{v.shape}")
            kind = v.dtype.kind
            if kind == "b":
                out[name] = v.astype(bool)
            elif kind in "iu":
                out[name] = v.astype(np.int64)
            elif kind in "US":
                out[name] = v.astype(str)
            else:
                _column_cells(name, v)  # raises with the CSV's message
                raise OutputError(f"CSV column {name!r}: unsupported dtype {v.dtype}")
            continue
        arr = np.asarray(v, dtype=object) if not isinstance(v, np.ndarray) else v
        if arr.ndim != 1:
            _column_cells(name, v)  # the CSV's message for a non-1-D column
        out[name] = _object_column(name, list(v))
    lengths = {k: len(a) for k, a in out.items()}
    if len(set(lengths.values())) > 1:
        raise OutputError(f"CSV table: expected columns of equal length, got {lengths}")
    return out


def _write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    with open(path, "wb") as f:  # a file object: numpy adds no second ".npz"
        np.savez(f, **arrays)


def _write_parquet(path: Path, arrays: dict[str, np.ndarray]) -> None:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise OutputError(f"parquet tables need pyarrow, which is not installed: "
                          f"{PARQUET_HINT}") from None
    table = pa.table({k: pa.array(a) for k, a in arrays.items()})
    # dictionary pages for the label columns only: tried on 100k distinct floats per column
    # they cost 6x the write time and make the file larger
    labels = [k for k, a in arrays.items() if a.dtype.kind == "U"]
    pq.write_table(table, path, use_dictionary=labels)


def write_table_file(path: str | os.PathLike[str], columns: Mapping[str, Any],
                     fmt: str) -> Path:
    """Write ``columns`` to ``path`` as ``fmt`` (csv, npz, parquet); return the path."""
    path = Path(path)
    if fmt == "csv":
        from mechkin.io.csv_out import write_csv

        return write_csv(path, columns)
    arrays = table_arrays(columns)
    if fmt == "npz":
        _write_npz(path, arrays)
    elif fmt == "parquet":
        _write_parquet(path, arrays)
    else:
        table_name("table", fmt)  # raises: unknown format
    return path


def write_table(od: Any, stem: str, columns: Mapping[str, Any], fmt: str = "csv") -> Path:
    """Stage table ``stem`` in the output folder ``od`` (:class:`mechkin.io.output_dir.
    OutputDir`) as ``fmt``: ``<stem>.csv`` through ``od.write_csv``, ``<stem>.npz`` or
    ``<stem>.parquet`` at ``od.path_for``; return the staged path."""
    name = table_name(stem, fmt)
    if fmt == "csv":
        return od.write_csv(name, columns)
    arrays = table_arrays(columns)
    path = od.path_for(name)
    if fmt == "npz":
        _write_npz(path, arrays)
    else:
        _write_parquet(path, arrays)
    return path
