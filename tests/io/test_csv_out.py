"""CSV tables: exact float round trip, units in headers, strings, and NaN refusal."""

from __future__ import annotations

import csv
import enum
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechkin.errors import OutputError
from mechkin.io.csv_out import format_csv, read_csv, write_csv


class _Status(enum.Enum):
    OK = "ok"
    NOT_CONVERGED = "not converged"


def test_round_trip_exact(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 1.0, 11)
    q = rng.normal(size=(11, 2)) * 10.0 ** rng.integers(-12, 12, size=(11, 2))
    status = [_Status.OK] * 10 + [_Status.NOT_CONVERGED]
    path = write_csv(tmp_path / "q.csv", {"t_s": t, "q1_rad": q[:, 0], "q2_m": q[:, 1],
                                          "iterations": np.arange(11), "status": status})
    back = read_csv(path)
    assert list(back) == ["t_s", "q1_rad", "q2_m", "iterations", "status"]
    assert np.array_equal(back["t_s"], t)
    assert np.array_equal(back["q1_rad"], q[:, 0])
    assert np.array_equal(back["q2_m"], q[:, 1])
    assert np.array_equal(back["iterations"], np.arange(11))
    assert back["status"].tolist() == ["ok"] * 10 + ["not converged"]


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=20))
def test_any_finite_float_round_trips(values: list[float]) -> None:
    text = format_csv({"x_m": np.array(values)})
    rows = text.splitlines()[1:]
    assert [float(r) for r in rows] == values


def test_strings_are_quoted_when_needed() -> None:
    text = format_csv({"k": [1, 2], "note": ['a, "b"', "plain"]})
    rows = list(csv.reader(text.splitlines()))
    assert rows == [["k", "note"], ["1", 'a, "b"'], ["2", "plain"]]


def test_bools_and_header_only() -> None:
    assert format_csv({"ok": np.array([True, False])}) == "ok\n1\n0\n"
    assert format_csv({"t_s": np.zeros(0), "q1_rad": []}) == "t_s,q1_rad\n"


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nan_refused_naming_column_and_row(tmp_path: Path, bad: float) -> None:
    path = tmp_path / "q.csv"
    with pytest.raises(OutputError, match=r"'q2_rad'.*row 2"):
        write_csv(path, {"t_s": np.arange(3.0), "q2_rad": np.array([0.0, 1.0, bad])})
    assert not path.exists()
    assert list(tmp_path.iterdir()) == []


def test_nan_refused_in_lists() -> None:
    with pytest.raises(OutputError, match="'err_m'"):
        format_csv({"err_m": [0.1, float("nan")]})


@pytest.mark.parametrize(
    ("columns", "match"),
    [
        ({}, "at least one column"),
        ({"a": np.zeros(2), "b": np.zeros(3)}, "equal length"),
        ({"a": np.zeros((2, 2))}, "1-D"),
        ({"a": [object()]}, "numbers or strings"),
        ({"": [1]}, "non-empty"),
    ],
)
def test_bad_tables(columns: dict, match: str) -> None:
    with pytest.raises(OutputError, match=match):
        format_csv(columns)


def test_read_csv_skips_blank_lines_and_reports_ragged_rows(tmp_path: Path) -> None:
    path = tmp_path / "in.csv"
    path.write_text("t_s,q1_rad\n0,1\n\n0.5,2\n\n")
    back = read_csv(path)
    assert back["t_s"].tolist() == [0.0, 0.5] and back["q1_rad"].tolist() == [1.0, 2.0]
    path.write_text("t_s,q1_rad\n0,1\n0.5\n")
    with pytest.raises(ValueError, match="line 3: expected 2 cells, got 1"):
        read_csv(path)
