"""The block CSV writer (io/csv_out.py) against today's writer, byte for byte.

``reference_format_csv`` below is the writer before the block path (cells one ``repr`` at a
time), kept verbatim as the reference: every table here, through both fast paths (orjson when
installed, ``str`` of the nested list without it) and both fix-ups of orjson's exponent cells
(rows, columns), must give the same text.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pytest

from mechkin.errors import OutputError
from mechkin.io import csv_out
from mechkin.io.csv_out import format_csv

# ---- today's writer, verbatim (only renamed) -------------------------------------------------

_NEEDS_QUOTES = (",", '"', "\n", "\r")


def _ref_quote(cell: str) -> str:
    if any(c in cell for c in _NEEDS_QUOTES) or cell != cell.strip():
        return '"' + cell.replace('"', '""') + '"'
    return cell


def _ref_cells(name: str, values: np.ndarray | Sequence[Any]) -> list[str]:
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
        return [_ref_quote(str(v)) for v in arr.astype(str).tolist()]
    if kind == "O":
        vals = arr.tolist()
        if all(type(v) is str for v in vals):  # labels (status, class): quote each value once
            memo = {v: _ref_quote(v) for v in set(vals)}
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
                cells.append(_ref_quote(v))
            else:
                raise OutputError(
                    f"CSV column {name!r}: expected numbers or strings, got "
                    f"{type(v).__name__} at row {i}"
                )
        return cells
    raise OutputError(f"CSV column {name!r}: expected numbers or strings, got dtype {arr.dtype}")


def reference_format_csv(columns: Mapping[str, np.ndarray | Sequence[Any]]) -> str:
    """Today's format_csv (before the block writer), verbatim."""
    if not columns:
        raise OutputError("CSV table: expected at least one column, got none")
    names = list(columns)
    for name in names:
        if not isinstance(name, str) or not name.strip():
            raise OutputError(f"CSV table: expected non-empty string column names, got {name!r}")
    cells = [_ref_cells(name, columns[name]) for name in names]
    lengths = {name: len(c) for name, c in zip(names, cells, strict=False)}
    if len(set(lengths.values())) > 1:
        raise OutputError(f"CSV table: expected columns of equal length, got {lengths}")
    lines = [",".join(_ref_quote(n) for n in names)]
    lines.extend(",".join(row) for row in zip(*cells, strict=False))
    return "\n".join(lines) + "\n"



# ---- fixtures ----------------------------------------------------------------------------------


class _Status(enum.Enum):
    OK = "ok"
    BAD = "not, converged"


def _awkward_floats(rng: np.random.Generator, m: int) -> np.ndarray:
    """Every decade of float64, the boundaries where repr and orjson switch to exponents,
    subnormals, signed zeros, short decimals and full 17-digit values."""
    x = rng.standard_normal(m) * 10.0 ** rng.integers(-320, 300, m)
    x[::3] = np.round(rng.standard_normal(len(x[::3])), 3)
    edges = np.array([0.0, -0.0, 1e-4, 1e-5, 9.999999999999999e-05, 5e-05, 1e16, 1e15,
                      9999999999999998.0, 1e22, 5e-324, 1.7976931348623157e308, 0.1, 1 / 3])
    with np.errstate(over="ignore"):
        near = np.concatenate([np.nextafter(edges, -np.inf), np.nextafter(edges, np.inf)])
    near = near[np.isfinite(near)]
    extra = np.concatenate([edges, near, -edges, -near])
    k = min(m, len(extra))
    x[:k] = extra[:k]
    return x


def _table(rng: np.random.Generator, m: int) -> dict[str, Any]:
    return {
        "t_s": np.arange(m) * 0.001,
        "q1_rad": _awkward_floats(rng, m),
        "q2_m": rng.standard_normal(m).astype(np.float32),
        "iterations": rng.integers(0, 50, m),
        "q3_rad": rng.uniform(-np.pi, np.pi, m),
        "tiny": rng.standard_normal(m) * 1e-17,
        "ok": rng.integers(0, 2, m).astype(bool),
        "label": ["a, b" if k % 7 else 'say "x"' for k in range(m)],
        "status": [_Status.OK if k % 5 else _Status.BAD for k in range(m)],
        "mixed": [1, 2.5, True, "s", _Status.OK] * (m // 5) + [0.0] * (m % 5),
        "last_m": rng.uniform(-2, 2, m),
    }


@pytest.fixture(params=["orjson", "repr"])
def fast_path(request, monkeypatch):
    """Both block paths: orjson (when installed; checked exact) and str of the nested list."""
    if request.param == "orjson":
        pytest.importorskip("orjson")
        monkeypatch.setattr(csv_out, "_ORJSON", None)  # redo the self-check
        monkeypatch.setattr(csv_out, "FAST_MIN_CELLS", 1)
        assert csv_out._fast_module() is not None, "orjson failed the self-check"
    else:
        monkeypatch.setattr(csv_out, "_ORJSON", False)
    return request.param


@pytest.mark.parametrize("m", [0, 1, 2, 7, 1000])
def test_block_writer_is_todays_text(fast_path, monkeypatch, m: int) -> None:
    monkeypatch.setattr(csv_out, "CHUNK_ROWS", 97)  # several chunks, a short last one
    cols = _table(np.random.default_rng(m), m)
    assert format_csv(cols) == reference_format_csv(cols)


def test_dense_and_sparse_exponent_cells(fast_path) -> None:
    """Exponent cells in every row (the column fix-up) and in a few rows (the row fix-up)."""
    rng = np.random.default_rng(3)
    m = 4000
    dense = {"a": rng.standard_normal(m) * 1e-9, "b": rng.standard_normal(m),
             "c": rng.standard_normal(m) * 1e20, "d": rng.standard_normal(m)}
    sparse = {k: v.copy() for k, v in dense.items()}
    sparse["a"] = rng.standard_normal(m)
    sparse["c"] = rng.standard_normal(m)
    sparse["a"][::500] = 3e-7
    sparse["c"][7] = -2e17
    sparse["b"][11] = 4.5e-5
    for cols in (dense, sparse, {"only": dense["a"]}, {"only": sparse["b"]}):
        assert format_csv(cols) == reference_format_csv(cols)


def test_random_bit_patterns(fast_path) -> None:
    """Random float64 bit patterns (every exponent, every mantissa) print as repr prints them."""
    bits = np.random.default_rng(11).integers(0, 2 ** 63, 60_000, dtype=np.int64)
    x = bits.view(np.float64)
    x = np.where(np.isfinite(x), x, 1.0)
    cols = {"x": x[:30_000], "y": -x[30_000:]}
    assert format_csv(cols) == reference_format_csv(cols)


def test_bundled_fk_table(fast_path) -> None:
    """The columns of a bundled fk run (floats, labels and statuses side by side)."""
    from mechkin.config.scenario import load_scenario
    from mechkin.tasks import fk
    from tests.conftest import ROOT

    rep = fk.run(load_scenario(ROOT / "scenarios" / "puma560_wave_fk.yaml"))
    cols = rep.data.columns
    assert format_csv(cols) == reference_format_csv(cols)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_refused_as_today(fast_path, bad: float) -> None:
    x = np.linspace(0, 1, 50)
    x[17] = bad
    cols = {"t_s": np.arange(50.0), "x_m": x}
    with pytest.raises(OutputError) as new:
        format_csv(cols)
    with pytest.raises(OutputError) as old:
        reference_format_csv(cols)
    assert str(new.value) == str(old.value)


def test_unequal_and_2d_refused_as_today() -> None:
    for cols in ({"a": np.zeros(3), "b": np.zeros(4)}, {"a": np.zeros((3, 2))},
                 {"a": np.zeros(3), "b": [1, 2]}):
        with pytest.raises(OutputError) as new:
            format_csv(cols)
        with pytest.raises(OutputError) as old:
            reference_format_csv(cols)
        assert str(new.value) == str(old.value)


def test_self_check_rejects_a_different_formatter(monkeypatch) -> None:
    """An orjson that prints floats otherwise (e.g. another exponent style) is not used."""

    class Fake:
        OPT_SERIALIZE_NUMPY = 0

        @staticmethod
        def dumps(a, option=0):
            rows = ",".join("[" + ",".join(f"{v:.6g}" for v in r) + "]" for r in a.tolist())
            return f"[{rows}]".encode()

    import sys

    monkeypatch.setitem(sys.modules, "orjson", Fake)
    monkeypatch.setattr(csv_out, "_ORJSON", None)
    assert csv_out._fast_module() is None
