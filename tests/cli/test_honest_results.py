"""Honest statuses: overflowing work is a solver failure with a summary (never NaN or inf in a
file, no warning noise), and a failed expect: says so in the status and the stdout line."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]


def _run(tmp_path: Path, task: str, doc: dict) -> tuple[subprocess.CompletedProcess, Path]:
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    out = tmp_path / "o"
    r = subprocess.run([sys.executable, "-m", "mechkin", task, str(p), "--out", str(out),
                        "--no-plots"], capture_output=True, text=True, timeout=300,
                       env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin",
                            "NUMBA_CACHE_DIR": os.environ["NUMBA_CACHE_DIR"], "MECHKIN_JIT": "0",
                            "MPLBACKEND": "Agg"})
    return r, out


def _all_finite(path: Path) -> bool:
    text = path.read_text()
    return "nan" not in text.lower().split(",") and "inf" not in text.lower()


def test_ik_target_beyond_reach_is_unreachable_with_a_summary(tmp_path):
    r, out = _run(tmp_path, "ik", {
        "name": "far", "task": "ik", "mechanism": str(ROOT / "mechanisms/puma560.yaml"),
        "units": {"length": "m", "angle": "deg"},
        "ik": {"targets": [{"name": "far", "xyz": [1e300, 0.0, 0.0],
                            "euler": {"convention": "zyz", "angles": [0, 0, 0]}},
                           {"name": "near", "xyz": [0.4521, -0.15005, 0.4318],
                            "euler": {"convention": "zyz", "angles": [0, 0, 0]}}]}})
    assert r.returncode == 1, r.stderr
    assert "Warning" not in r.stderr and "Traceback" not in r.stderr
    s = json.loads((out / "summary.json").read_text())
    assert [t["status"] for t in s["targets"]] == ["unreachable", "ok"]
    assert math.isfinite(s["targets"][0]["position_error"])
    assert _all_finite(out / "ik.csv")


def test_fk_legs_driven_to_overflow_are_a_solver_failure(tmp_path):
    motion = {f"leg{i}": {"type": "constant", "value": 1e300} for i in range(1, 7)}
    r, out = _run(tmp_path, "fk", {
        "name": "huge", "task": "fk", "mechanism": str(ROOT / "mechanisms/kim1995_stewart.yaml"),
        "units": {"length": "m", "angle": "deg"},
        "fk": {"time": {"start": 0, "stop": 1, "step": 0.5}, "motion": motion}})
    assert r.returncode == 1, r.stderr
    assert "Warning" not in r.stderr and "Traceback" not in r.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "not converged"
    assert _all_finite(out / "fk.csv")


def test_failed_expect_is_the_status(tmp_path):
    doc = yaml.safe_load((ROOT / "scenarios/kim1995_direct_drive_fk.yaml").read_text())
    doc["mechanism"] = str(ROOT / "mechanisms/kim1995_direct_drive.yaml")
    doc["expect"] = [{"key": "n_steps", "value": 12, "tol": 0}]
    r, out = _run(tmp_path, "fk", doc)
    assert r.returncode == 5  # an expect failed
    assert r.stdout.startswith(f"{doc['name']}: expect failed")
    assert "expect n_steps" in r.stderr
    assert json.loads((out / "summary.json").read_text())["status"] == "expect failed"
