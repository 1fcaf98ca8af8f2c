"""CSV tables with units in the headers (``t_s, q1_rad, x_m``); a table never holds NaN.

Floats are printed with ``repr`` (the shortest text that parses back to the same float64), so
``float(cell) == value`` exactly. String columns (e.g. ``status``) are quoted only when needed
(RFC 4180: a comma, a quote or a line break in the cell).

Design
------
The text of a long table is almost all float cells, and CPython's ``repr`` of a float
(``_Py_dg_dtoa``, about 1 us per 17-digit value) is the cost: 4.1M cells of a 100k-step fk run
take 4-6 s. :func:`format_csv` therefore formats runs of adjacent float columns as one block
(m, k), in chunks of :data:`CHUNK_ROWS` rows, with no per-cell Python work:

- with ``orjson`` installed (optional, ``pip install "mechkin[fastcsv]"``), the block is
  serialised by ``orjson`` (Ryu, the same shortest round-trip digits as ``repr``) and only the
  cells ``repr`` writes in exponent form (``0 < |x| < 1e-4`` or ``|x| >= 1e16``, where orjson's
  exponent style differs: ``1e-6`` / ``1e16`` for ``1e-06`` / ``1e+16``, and ``0.00005`` for
  ``5e-05``) are written again with ``repr`` (their rows, or their columns when they are
  many); a self-check against ``repr`` on boundary values runs once per process and turns the
  path off if this orjson formats differently;
- without it, ``repr`` mapped over each column and the rows joined, from C (``map``): the
  text of today's writer without its per-cell Python loop.

Either way the bytes are those of ``",".join(repr(v) ...)`` row by row (tests/io/
test_csv_fast.py compares them with the reference writer); string, integer and boolean columns
are cells as before, joined to the float blocks row by row in C (``map(",".join, zip(...))``).
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


#: Rows per chunk of the text of a long table (bounds the temporary lists).
CHUNK_ROWS = 20_000

#: Fewest float cells for the orjson path (below, its import and self-check do not pay).
FAST_MIN_CELLS = 20_000


def _is_float_column(values: Any) -> bool:
    return isinstance(values, np.ndarray) and values.ndim == 1 and values.dtype.kind == "f"


def _float_column(name: str, arr: np.ndarray) -> np.ndarray:
    """A float column checked finite (the message of :func:`_column_cells`), as float64."""
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise OutputError(
            f"CSV column {name!r}: expected finite numbers, got {arr[bad[0]]!r} "
            f"at row {int(bad[0])} ({bad.size} non-finite value(s))"
        )
    return arr.astype(np.float64, copy=False)


def _repr_block_text(B: np.ndarray) -> str:
    """Rows of the float block B (r, k), cells ``repr`` joined by ``,``, rows by ``\\n``:
    ``map(repr, ...)`` per column and ``map(",".join, zip(...))`` per row, all called from C
    (measured faster than ``str`` of the nested list with its punctuation replaced)."""
    cells = [list(map(repr, c)) for c in B.T.tolist()]
    return "\n".join(map(",".join, zip(*cells, strict=True)))


_ORJSON: Any = None  # the orjson module once checked, False when absent or not exact


def _needs_exponent(B: np.ndarray) -> np.ndarray:
    """Cells that ``repr`` writes in exponent form (``0 < |x| < 1e-4`` or ``|x| >= 1e16``)."""
    a = np.abs(B)
    return ((a < 1e-4) & (a > 0.0)) | (a >= 1e16)


def _orjson_text(oj: Any, B: np.ndarray) -> str:
    """orjson's text of the block B (r, k) in CSV layout, before the exponent cells are
    fixed."""
    raw = oj.dumps(np.ascontiguousarray(B), option=oj.OPT_SERIALIZE_NUMPY)
    return raw[2:-2].replace(b"],[", b"\n").decode("ascii")


def _fast_block_text(oj: Any, B: np.ndarray) -> str:
    """The text of :func:`_repr_block_text` through orjson, cells in exponent form re-done
    with ``repr`` (their rows when few, else the whole columns that hold them)."""
    exp = _needs_exponent(B)
    if not exp.any():
        return _orjson_text(oj, B)
    rows = np.flatnonzero(exp.any(axis=1))
    if len(rows) * 16 <= len(B):
        lines = _orjson_text(oj, B).split("\n")
        for r, line in zip(rows.tolist(), B[rows].tolist(), strict=True):
            lines[r] = ",".join(map(repr, line))
        return "\n".join(lines)
    dirty = exp.any(axis=0)
    parts: list[list[str]] = []
    j = 0
    k = B.shape[1]
    while j < k:  # runs of clean columns by orjson, columns with exponent cells by repr
        e = j
        while e < k and dirty[e] == dirty[j]:
            e += 1
        sub = B[:, j:e]
        text = _repr_block_text(sub) if dirty[j] else _orjson_text(oj, sub)
        parts.append(text.split("\n"))
        j = e
    return "\n".join(map(",".join, zip(*parts, strict=True)))


#: Values whose repr the orjson path must reproduce (the exponent / positional boundaries of
#: both writers, powers of ten and two, subnormals, the extremes, signed zeros).
def _probe_values() -> np.ndarray:
    e = np.arange(-325, 309, dtype=float)
    mant = np.array([1.0, 1.5, 2.5, 3.141592653589793, 9.999999999999998, 7.0000000000000001])
    edges = np.array([1e-5, 1e-4, 1e16, 1e15, 1e17, 1e21, 1e22, 2.0 ** 53, 2.0 ** 63,
                      2.0 ** 64, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308])
    with np.errstate(over="ignore"):
        v = (mant[None, :] * 10.0 ** e[:, None]).ravel()
        near = np.concatenate([np.nextafter(edges, 0.0), edges, np.nextafter(edges, np.inf)])
    rng = np.random.default_rng(1234)
    rnd = rng.standard_normal(2000) * 10.0 ** rng.integers(-30, 30, 2000)
    out = np.concatenate([v, near, rnd, [0.0, -0.0, 0.1, 0.2, 0.3, 1 / 3, 2 / 3, 100.0]])
    out = out[np.isfinite(out)]
    return np.concatenate([out, -out])


def _fast_module() -> Any:
    """orjson when installed and exact on :func:`_probe_values` (checked once), else None."""
    global _ORJSON
    if _ORJSON is None:
        _ORJSON = False
        if os.environ.get("MECHKIN_CSV_ORJSON", "1") != "0":
            try:
                import orjson
            except ImportError:
                orjson = None
            if orjson is not None:
                v = _probe_values()
                v = v[~_needs_exponent(v)]  # the cells orjson writes; the others are repr's
                v = v[: len(v) // 3 * 3].reshape(-1, 3)
                try:
                    ok = _orjson_text(orjson, v) == _repr_block_text(v)
                except Exception:  # noqa: BLE001 - any failure means: do not use it
                    ok = False
                _ORJSON = orjson if ok else False
    return _ORJSON or None


def _rows_text(parts: list[Any], m: int) -> list[str]:
    """The row lines of a table: ``parts`` are float blocks (m, k) and cell lists (m,) in
    column order; returns chunks of text (rows joined by ``\\n``, no trailing newline)."""
    n_float = sum(p.shape[1] for p in parts if isinstance(p, np.ndarray))
    oj = _fast_module() if n_float * m >= FAST_MIN_CELLS else None

    def block(B: np.ndarray) -> str:
        return _fast_block_text(oj, B) if oj is not None else _repr_block_text(B)

    out = []
    for i in range(0, m, CHUNK_ROWS):
        j = min(i + CHUNK_ROWS, m)
        if len(parts) == 1 and isinstance(parts[0], np.ndarray):
            out.append(block(parts[0][i:j]))
            continue
        pieces = [block(p[i:j]).split("\n") if isinstance(p, np.ndarray) else p[i:j]
                  for p in parts]
        out.append("\n".join(map(",".join, zip(*pieces, strict=True))))
    return out


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
        The CSV text; floats are written with ``repr`` so they round-trip exactly (the module
        docstring says how long tables are formatted fast, byte for byte the same).

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
    cols: list[Any] = []
    for name in names:
        v = columns[name]
        cols.append(_float_column(name, v) if _is_float_column(v) else _column_cells(name, v))
    lengths = {name: len(c) for name, c in zip(names, cols, strict=False)}
    if len(set(lengths.values())) > 1:
        raise OutputError(f"CSV table: expected columns of equal length, got {lengths}")
    header = ",".join(_quote(n) for n in names)
    m = len(cols[0])
    if m == 0:
        return header + "\n"
    parts: list[Any] = []  # float columns side by side as blocks (m, k), others as cells
    run: list[np.ndarray] = []
    for c in cols:
        if isinstance(c, np.ndarray):
            run.append(c)
            continue
        if run:
            parts.append(np.column_stack(run))
            run = []
        parts.append(c)
    if run:
        parts.append(np.column_stack(run))
    return header + "\n" + "\n".join(_rows_text(parts, m)) + "\n"


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
