"""summary.json: numpy and enums converted, order kept, NaN refused with its key path."""

from __future__ import annotations

import dataclasses
import enum
import json
from pathlib import Path

import numpy as np
import pytest

from mechkin.errors import OutputError
from mechkin.io.summary import summary_json, write_summary


class _Status(enum.Enum):
    OK = "ok"
    SINGULAR = "singular Jacobian"


@dataclasses.dataclass(frozen=True)
class _Result:
    status: _Status
    q: np.ndarray
    iterations: int


def test_conversions_and_order() -> None:
    obj = {
        "zeta": 1,
        "status": _Status.OK,
        "q_rad": np.array([0.5, -1.25]),
        "n": np.int64(3),
        "ok": np.bool_(True),
        "err": np.float32(0.5),
        "file": Path("outputs") / "a.csv",
        "grid": np.arange(4).reshape(2, 2),
        "result": _Result(_Status.SINGULAR, np.zeros(2), 7),
        "names": ("a", "b"),
        "by_status": {_Status.OK: 2},
        "alpha": None,
    }
    text = summary_json(obj)
    assert text.endswith("}\n") and '\n  "zeta": 1,' in text
    back = json.loads(text)
    assert list(back) == list(obj)
    assert back["status"] == "ok"
    assert back["q_rad"] == [0.5, -1.25]
    assert back["n"] == 3 and back["ok"] is True and back["err"] == 0.5
    assert back["file"] == "outputs/a.csv"
    assert back["grid"] == [[0, 1], [2, 3]]
    assert back["result"] == {"status": "singular Jacobian", "q": [0.0, 0.0], "iterations": 7}
    assert back["names"] == ["a", "b"]
    assert back["by_status"] == {"ok": 2}


@pytest.mark.parametrize(
    ("obj", "where"),
    [
        ({"steps": [{"residual": 0.0}, {"residual": float("nan")}]}, r"steps\[1\]\.residual"),
        ({"q": np.array([[0.0, 1.0], [np.inf, 0.0]])}, r"q\[1\]\[0\]"),
        ({"a": {"b": np.float64(-np.inf)}}, r"a\.b"),
        ({"r": _Result(_Status.OK, np.array([np.nan]), 1)}, r"r\.q\[0\]"),
        (float("nan"), "<root>"),
    ],
)
def test_nan_refused_with_key_path(obj: object, where: str) -> None:
    with pytest.raises(OutputError, match=where + ": expected a finite number"):
        summary_json(obj)


def test_unsupported_type() -> None:
    with pytest.raises(OutputError, match=r"x: expected a JSON-compatible value, got set"):
        summary_json({"x": {1, 2}})


def test_write_summary_leaves_nothing_on_nan(tmp_path: Path) -> None:
    with pytest.raises(OutputError):
        write_summary(tmp_path / "summary.json", {"f": float("nan")})
    assert list(tmp_path.iterdir()) == []
    write_summary(tmp_path / "summary.json", {"f": 1.0})
    assert json.loads((tmp_path / "summary.json").read_text()) == {"f": 1.0}
