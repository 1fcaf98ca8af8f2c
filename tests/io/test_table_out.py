"""Binary tables (``outputs: {table: npz | parquet}``, io/table_out.py): the CSV's columns,
names and values (float64 bit for bit), and bad ``outputs.table`` values refused on their line.
"""

from __future__ import annotations

import enum
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mechkin.cli.app import app
from mechkin.config.scenario import load_scenario
from mechkin.errors import ConfigError, OutputError
from mechkin.io.csv_out import read_csv, write_csv
from mechkin.io.table_out import table_arrays, table_name, write_table_file
from tests.scenario_copy import local_scenario

runner = CliRunner()


def _with_table(tmp_path: Path, name: str, value: str) -> Path:
    """A bundled scenario with ``outputs: {table: value}`` added (a top-level key at the end)."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    sc = local_scenario(tmp_path, name)
    sc.write_text(sc.read_text().rstrip("\n") + f"\noutputs:\n  table: {value}\n")
    return sc


def _read_table(path: Path) -> dict[str, np.ndarray]:
    if path.suffix == ".npz":
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    import pyarrow.parquet as pq

    t = pq.read_table(path)
    return {k: t.column(k).to_numpy(zero_copy_only=False) for k in t.column_names}


def _same_as_csv(csv_cols: dict[str, np.ndarray], tab: dict[str, np.ndarray]) -> None:
    assert list(tab) == list(csv_cols)  # same names (units included), same order
    for k, c in csv_cols.items():
        v = tab[k]
        if c.dtype.kind == "f":  # CSV numbers (floats, ints, 0/1 booleans) as float64
            assert np.array_equal(np.asarray(v, dtype=np.float64), c), k
            if v.dtype.kind == "f":
                assert v.dtype == np.float64, k
        else:
            assert [str(x) for x in v] == c.tolist(), k


@pytest.mark.parametrize("fmt", ["npz", "parquet"])
@pytest.mark.parametrize("name", ["puma560_wave_fk", "kim1995_direct_drive_moving_base_fk"])
def test_fk_table_round_trip_equals_csv(tmp_path: Path, fmt: str, name: str) -> None:
    if fmt == "parquet":
        pytest.importorskip("pyarrow")
    runs = {}
    for tab in ("csv", fmt):
        sc = _with_table(tmp_path / tab, name, tab)
        out = tmp_path / f"out_{tab}"
        res = runner.invoke(app, ["fk", str(sc), "--out", str(out), "--no-plots", "--json"])
        assert res.exit_code in (0, 1), res.output
        runs[tab] = (out, json.loads(res.stdout))
    out_csv, s_csv = runs["csv"]
    out_bin, s_bin = runs[fmt]
    assert f"fk.{fmt}" in s_bin["files"] and "fk.csv" not in s_bin["files"]
    assert not (out_bin / "fk.csv").exists()
    _same_as_csv(read_csv(out_csv / "fk.csv"), _read_table(out_bin / f"fk.{fmt}"))


class _E(enum.Enum):
    A = "a, b"


@pytest.mark.parametrize("fmt", ["npz", "parquet"])
def test_table_writer_types_and_values(tmp_path: Path, fmt: str) -> None:
    if fmt == "parquet":
        pytest.importorskip("pyarrow")
    rng = np.random.default_rng(2)
    m = 50
    cols = {"t_s": np.arange(m) * 0.1,
            "x_m": rng.standard_normal(m) * 10.0 ** rng.integers(-300, 300, m),
            "n": np.arange(m), "ok": rng.integers(0, 2, m).astype(bool),
            "status": ["converged", 'say "x", y'] * (m // 2),
            "kind": [_E.A] * m, "f32": rng.standard_normal(m).astype(np.float32),
            "listed": [float(v) for v in rng.standard_normal(m)]}
    arrays = table_arrays(cols)
    assert arrays["x_m"].dtype == np.float64 and arrays["n"].dtype == np.int64
    assert arrays["ok"].dtype == bool and arrays["status"].dtype.kind == "U"
    path = write_table_file(tmp_path / table_name("t", fmt), cols, fmt)
    back = _read_table(path)
    _same_as_csv(read_csv(write_csv(tmp_path / "t.csv", cols)), back)
    assert back["kind"].tolist() == ["a, b"] * m


def test_table_writer_refuses_what_the_csv_refuses(tmp_path: Path) -> None:
    x = np.zeros(5)
    x[3] = np.nan
    with pytest.raises(OutputError, match="'x_m'.*row 3"):
        table_arrays({"x_m": x})
    with pytest.raises(OutputError, match="equal length"):
        table_arrays({"a": np.zeros(3), "b": np.zeros(4)})
    with pytest.raises(OutputError, match="xlsx"):
        write_table_file(tmp_path / "t.xlsx", {"a": np.zeros(2)}, "xlsx")


@pytest.mark.parametrize("bad", ["xlsx", "CSV", "3", "true", "[csv]"])
def test_bad_table_value_is_a_located_config_error(tmp_path: Path, bad: str) -> None:
    sc = _with_table(tmp_path, "puma560_wave_fk", bad)
    with pytest.raises(ConfigError) as e:
        load_scenario(sc)
    msg = str(e.value)
    line = sc.read_text().splitlines().index(f"  table: {bad}") + 1
    assert f"{sc}:{line}: outputs.table:" in msg and "'csv', 'npz' or 'parquet'" in msg
    assert len(msg.splitlines()) == 1


def test_parquet_without_pyarrow(tmp_path: Path, monkeypatch) -> None:
    """table: parquet without pyarrow: one located line naming the key and the pip command,
    exit 2, nothing written."""
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda n, *a: None if n == "pyarrow" else real(n, *a))
    sc = _with_table(tmp_path, "puma560_wave_fk", "parquet")
    out = tmp_path / "out"
    res = runner.invoke(app, ["fk", str(sc), "--out", str(out), "--no-plots"])
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1, res.output
    assert "outputs.table:" in lines[0] and 'pip install "mechkin[parquet]"' in lines[0]
    assert lines[0].startswith(f"{sc}:")
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("name", ["ur5_ik", "planar3r_track_line", "five_bar_workspace",
                                  "lee_fig3_isotropy_r025", "custom_biped_slope_step"])
def test_every_task_writes_its_tables_in_the_format(tmp_path: Path, name: str) -> None:
    """``outputs.table`` applies to every task's tables (ik, track, workspace grids and lee
    maps, biped legs): each CSV of the csv run has an npz twin with the same columns and
    values, and the npz run leaves no CSV."""
    runs = {}
    for tab in ("csv", "npz"):
        sc = _with_table(tmp_path / tab, name, tab)
        task = next(t for t in ("fk", "ik", "track", "workspace")
                    if f"\ntask: {t}\n" in sc.read_text())
        out = tmp_path / f"out_{tab}"
        res = runner.invoke(app, [task, str(sc), "--out", str(out), "--no-plots", "--json"])
        assert res.exit_code in (0, 1), res.output
        runs[tab] = (out, json.loads(res.stdout)["files"])
    (out_csv, f_csv), (out_npz, f_npz) = runs["csv"], runs["npz"]
    csvs = [f for f in f_csv if f.endswith(".csv")]
    assert csvs, f_csv
    assert not [f for f in f_npz if f.endswith(".csv")], f_npz
    for f in csvs:
        twin = f[: -len(".csv")] + ".npz"
        assert twin in f_npz, (twin, f_npz)
        _same_as_csv(read_csv(out_csv / f), _read_table(out_npz / twin))
