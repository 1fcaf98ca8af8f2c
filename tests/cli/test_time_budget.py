"""Long jobs say how long before they start, and --max-time bounds them (issue 28 item 11): a
5000 x 5000 track grid is estimated (10 min with the compiled DP stage) on stderr, in `check`
and refused beyond --max-time before any work; a job that overruns is stopped at its next safe
point (exit 1, the finished rows written whole; tests/cli/test_max_time_stop.py)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mechkin.errors import ConfigError
from mechkin.tasks import budget

ROOT = Path(__file__).resolve().parents[2]


def _env(tmp_path: Path) -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", MECHKIN_JIT="0",
                NUMBA_CACHE_DIR=str(tmp_path / "numba"))


def _mechkin(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mechkin", *args], capture_output=True,
                          text=True, timeout=180, cwd=tmp_path, env=_env(tmp_path))


def _scenario(tmp_path: Path, name: str, old: str = "", new: str = "") -> Path:
    text = (ROOT / "scenarios" / name).read_text().replace("../mechanisms/",
                                                           f"{ROOT}/mechanisms/")
    p = tmp_path / name
    p.write_text(text.replace(old, new) if old else text)
    return p


def test_a_huge_track_grid_is_estimated_and_refused_beyond_max_time(tmp_path):
    sc = _scenario(tmp_path, "park_conveyor_torque.yaml", "N1: 50, N2: 100",
                   "N1: 5000, N2: 5000")
    t0 = time.perf_counter()
    r = _mechkin(tmp_path, "track", str(sc), "--out", "o", "--max-time", "4m")
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "track.grid" in lines[0] and " min, more" in lines[0], lines
    assert "--max-time 4 min" in lines[0] and "about 10 min" in lines[0]
    assert time.perf_counter() - t0 < 60 and not (tmp_path / "o").exists()
    r = _mechkin(tmp_path, "check", str(sc))  # check says it too (and accepts: no limit)
    assert r.returncode == 0 and "estimated about 10 min" in r.stderr


def test_a_run_that_overruns_max_time_stops_cleanly(tmp_path):
    sc = _scenario(tmp_path, "puma560_reachability.yaml")
    out = tmp_path / "o"
    r = _mechkin(tmp_path, "workspace", str(sc), "--out", str(out), "--max-time", "8s",
                 "--no-plots", "--workers", "1")  # estimated 12 s: accepted (2x slack), stopped
    if r.returncode == 0:
        pytest.skip("the sweep finished within 8 s on this machine")
    assert r.returncode == 1, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "stopped after" in lines[0] and sc.name in lines[0], lines
    import json

    summary = json.loads((out / "summary.json").read_text())  # the finished chunks, whole
    assert summary["status"] == "stopped: max-time"
    assert summary["n_poses"] == summary["stopped"]["done"] < 121


@pytest.mark.parametrize("bad", ["soon", "0", "-5m", "1e308", "nan"])
def test_a_bad_max_time_is_one_line(tmp_path, bad):
    sc = ROOT / "scenarios" / "kim1995_direct_drive_fk.yaml"
    r = _mechkin(tmp_path, "fk", str(sc), "--out", "o", "--max-time", bad)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "--max-time" in r.stderr


def test_estimates_are_kept_for_the_summary_and_noted_beyond_30_s(capsys):
    with budget.time_budget(None) as found:
        budget.estimate_time("s.yaml:3: track.grid", 5.0, "a small grid")
        budget.estimate_time("s.yaml:3: track.grid", 100.0, "a larger grid")
    assert [e["seconds"] for e in found] == [5.0, 100.0]  # both kept for the summary
    err = capsys.readouterr().err
    assert "a larger grid: estimated about 100 s" in err and "small" not in err
    with budget.time_budget(60.0), pytest.raises(ConfigError, match="more than --max-time"):
        budget.estimate_time("s.yaml:3: track.grid", 1000.0, "a grid")


def test_parse_duration():
    assert budget.parse_duration("90") == 90.0
    assert budget.parse_duration("5m") == 300.0
    assert budget.parse_duration("1.5h") == 5400.0
    assert budget.parse_duration("2d") == 172800.0
    for bad in ("", "x", "0", "-1s", "inf", "nan", "400d"):
        with pytest.raises(ValueError):
            budget.parse_duration(bad)
