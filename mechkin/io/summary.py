"""summary.json: result records -> strict JSON (no NaN, no Infinity, insertion order kept)."""

from __future__ import annotations

import dataclasses
import enum
import json
import math
import os
from collections.abc import Mapping
from pathlib import PurePath
from typing import Any

import numpy as np

from mechkin.errors import OutputError
from mechkin.io.atomic import atomic_write_text

__all__ = ["jsonable", "summary_json", "write_summary"]


def _where(key_path: str) -> str:
    return key_path or "<root>"


def _finite_float(x: float, key_path: str) -> float:
    if not math.isfinite(x):
        raise OutputError(f"{_where(key_path)}: expected a finite number, got {x!r}")
    return x


def _key(k: Any, key_path: str) -> str:
    if isinstance(k, enum.Enum):
        k = k.value
    if isinstance(k, str):
        return k
    if isinstance(k, (bool, np.bool_)):
        return "true" if k else "false"
    if isinstance(k, (int, np.integer)):
        return str(int(k))
    raise OutputError(f"{_where(key_path)}: expected string keys, got {type(k).__name__} {k!r}")


def _array(a: np.ndarray, key_path: str) -> list[Any]:
    if a.dtype.kind in "fc":
        bad = ~np.isfinite(a)
        if bad.any():
            idx = "".join(f"[{i}]" for i in np.argwhere(bad)[0])
            raise OutputError(
                f"{key_path}{idx}: expected a finite number, got {a[tuple(np.argwhere(bad)[0])]!r}"
            )
        if a.dtype.kind == "c":
            raise OutputError(f"{_where(key_path)}: expected real numbers, got a complex array")
    if a.dtype.kind in "biuf":
        out: list[Any] = a.tolist()
        return out
    if a.dtype.kind in "US":
        out = a.astype(str).tolist()
        return out
    return [jsonable(v, f"{key_path}[{i}]") for i, v in enumerate(a.tolist())]


def jsonable(obj: Any, key_path: str = "") -> Any:
    """Convert ``obj`` to plain JSON types, refusing NaN and infinities.

    Conversions: numpy scalars -> Python numbers, arrays -> nested lists, enums -> their
    ``.value`` (converted in turn), paths -> ``str``, dataclass instances -> dicts of their
    fields, tuples -> lists, mapping keys -> ``str`` (enums by value, integers in decimal).
    Mapping order is kept.

    Parameters
    ----------
    obj : Any
        The record to convert.
    key_path : str
        Where ``obj`` sits in the enclosing document (used in error messages).

    Returns
    -------
    Any
        ``None``, ``bool``, ``int``, finite ``float``, ``str``, ``list`` or ``dict``.

    Raises
    ------
    OutputError
        ``"<key path>: expected a finite number, got nan"`` for NaN/inf, or a type that has no
        JSON form; the message names the key path, e.g. ``steps[3].residual``.
    """
    if obj is None or isinstance(obj, (str, bool)):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, enum.Enum):
        return jsonable(obj.value, key_path)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return _finite_float(float(obj), key_path)
    if isinstance(obj, PurePath):
        return str(obj)
    if isinstance(obj, np.ndarray):
        return _array(obj, key_path)
    if isinstance(obj, Mapping):
        out: dict[str, Any] = {}
        for k, v in obj.items():
            ks = _key(k, key_path)
            out[ks] = jsonable(v, f"{key_path}.{ks}" if key_path else ks)
        return out
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {
            f.name: jsonable(getattr(obj, f.name), f"{key_path}.{f.name}" if key_path else f.name)
            for f in dataclasses.fields(obj)
        }
    if isinstance(obj, (list, tuple)):
        return [jsonable(v, f"{key_path}[{i}]") for i, v in enumerate(obj)]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    raise OutputError(
        f"{_where(key_path)}: expected a JSON-compatible value, got {type(obj).__name__}"
    )


def summary_json(obj: Any) -> str:
    """Serialise a summary record as indented JSON (2 spaces, insertion order, trailing newline).

    Parameters
    ----------
    obj : Any
        Usually a dict such as ``{"status": Status.OK, "files": od.files, ...}``; see
        :func:`jsonable` for the accepted types.

    Returns
    -------
    str
        Strict JSON text (``allow_nan=False``), UTF-8 characters kept as they are.

    Raises
    ------
    OutputError
        A NaN/inf or an unsupported type; the message names the key path.
    """
    text = json.dumps(jsonable(obj), indent=2, ensure_ascii=False, allow_nan=False)
    return text + "\n"


def write_summary(path: str | os.PathLike[str], obj: Any) -> PurePath:
    """Write :func:`summary_json` of ``obj`` to ``path`` atomically; return the path."""
    return atomic_write_text(path, summary_json(obj))
