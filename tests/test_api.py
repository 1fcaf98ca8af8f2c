"""The public Python API, used only through ``mechkin.<name>`` (README: Python API)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mechkin

ROOT = Path(__file__).resolve().parents[1]


def test_all_lists_the_api():
    for name in ("load_mechanism", "load_scenario", "fk", "ik", "run", "Report", "FkResult",
                 "IkResult", "Mechanism", "MechkinError", "ConfigError", "__version__"):
        assert name in mechkin.__all__
        assert getattr(mechkin, name) is not None


def test_fk_then_ik_round_trip_on_a_closed_chain():
    mech = mechkin.load_mechanism(ROOT / "mechanisms/kim1995_direct_drive.yaml")
    # passive p_C = 90 deg - q2 - q3 must stay within its limits [5, 175] deg (issue 24: a
    # closure outside them is "outside limits", never converged)
    qv = np.array([[0.3, 1.0, 0.3], [0.4, 1.0, 0.2]])
    res = mechkin.fk(mech, qv)
    assert res.ok and res.q.shape == (2, mech.n) and res.within_limits == [True, True]
    out = mechkin.fk(mech, [[0.3, 1.2, 0.5]])
    assert out.status == ["outside limits"] and out.within_limits == [False]
    T = res.poses["end_effector"]
    assert T.shape == (2, 4, 4)
    sols = mechkin.ik(mech, T)
    assert [s.status.value for s in sols] == ["ok", "ok"]
    back = mechkin.fk(mech, np.array([s.q_v for s in sols])).poses["end_effector"]
    assert np.allclose(back, T, atol=1e-8)
    batch = mechkin.ik(mech, T, batch=True)
    assert all(s.status.value == "ok" for s in batch)


def test_fk_refuses_a_wrong_shape():
    mech = mechkin.load_mechanism(ROOT / "mechanisms/puma560.yaml")
    with pytest.raises(mechkin.ConfigError, match="q_v: expected 6 columns"):
        mechkin.fk(mech, np.zeros((1, 5)))


def test_run_returns_a_report_and_writes_nothing_until_asked(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rep = mechkin.run(ROOT / "scenarios/kim1995_direct_drive_fk.yaml")
    assert isinstance(rep, mechkin.Report)
    assert rep.status == "ok" and rep.exit_code == 0
    assert rep.summary["n_steps"] == 13
    assert not any(tmp_path.iterdir())  # nothing written yet
    summary = rep.write(tmp_path / "out", plots=False)
    assert set(summary["files"]) == {"fk.csv", "fk.layout.json", "fk.mcap", "summary.json"}
    on_disk = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert on_disk["status"] == "ok" and on_disk["files"] == summary["files"]


def test_run_accepts_a_loaded_scenario():
    sc = mechkin.load_scenario(ROOT / "scenarios/kim1995_table6_stewart_ik.yaml")
    rep = mechkin.run(sc)
    assert rep.task == "ik" and rep.ok
    assert rep.summary["counts"] == {"ok": 4}


def test_readme_api_example_runs(tmp_path):
    """The README's Python API block, executed as written from the repository root."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    head = "## Python API"
    assert head in text
    block = text.split(head, 1)[1].split("```python", 1)[1].split("```", 1)[0]
    proc = subprocess.run([sys.executable, "-c", block], cwd=ROOT, capture_output=True,
                          text=True, timeout=300,
                          env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin",
                               "NUMBA_CACHE_DIR": os.environ["NUMBA_CACHE_DIR"],
                               "MPLBACKEND": "Agg", "MECHKIN_OUT": str(tmp_path)})
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "ok" in proc.stdout
