"""A mechanism's own ``velocity_limit`` / ``torque_limit`` reach the URDF in the MCAP, and a
track run plans with its scenario's ``limits:`` only (the mechanism's are not defaults)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
import yaml

from tests.config.visual_poses import load_urdf
from tests.io.mcap_checks import strict_check

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = "planar3r_track_line"  # limits: {torque: [30, 8, 2], qd: [0.5, 0.3, 0.5]}


def _run(folder: Path, scenario: Path) -> tuple[dict, Path]:
    from mechkin.api import run

    report = run(scenario)
    report.write(folder, plots=False)
    return json.loads((folder / "summary.json").read_text()), folder / "track.mcap"


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, tuple[dict, Path]]:
    """The bundled scenario, and the same scenario on a copy of its mechanism whose joints
    give velocity limits of 1 deg/s and torque limits of 1 N m (far below the scenario's)."""
    tmp = tmp_path_factory.mktemp("rates")
    (tmp / "mechanisms").mkdir()
    (tmp / "scenarios").mkdir()
    mech = yaml.safe_load((ROOT / "mechanisms" / "planar3r.yaml").read_text())
    for j in mech["joints"]:
        j["velocity_limit"], j["torque_limit"] = 1.0, 1.0
    (tmp / "mechanisms" / "planar3r.yaml").write_text(yaml.safe_dump(mech, sort_keys=False))
    scen = tmp / "scenarios" / f"{SCENARIO}.yaml"
    scen.write_text((ROOT / "scenarios" / f"{SCENARIO}.yaml").read_text())
    fk = tmp / "scenarios" / "fk.yaml"
    fk.write_text("name: fk\ntask: fk\nmechanism: ../mechanisms/planar3r.yaml\n"
                  "fk:\n  time: {start: 0, stop: 0.1, step: 0.05}\n  motion:\n"
                  "    q1: {type: ramp, from: 0.1, to: 0.2}\n"
                  "    q2: {type: constant, value: 1.0}\n    q3: {type: constant, value: -1.0}\n")
    out = {}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MECHKIN_JIT", "0")
        if "NUMBA_CACHE_DIR" not in os.environ:
            mp.setenv("NUMBA_CACHE_DIR", str(tmp_path_factory.mktemp("numba")))
        out["bundled"] = _run(tmp_path_factory.mktemp("bundled"),
                              ROOT / "scenarios" / f"{SCENARIO}.yaml")
        out["limited"] = _run(tmp_path_factory.mktemp("limited"), scen)
        folder = tmp_path_factory.mktemp("fk")
        out["fk"] = (_run(folder, fk)[0], folder / "fk.mcap")
    return out


def test_track_plans_with_the_scenarios_limits_only(runs):
    a, b = runs["bundled"][0], runs["limited"][0]
    assert a["status"] == b["status"] == "ok"
    for key in ("t_a_s", "peak_torque", "limits_ok", "limits_si", "active_limits", "cost"):
        assert a[key] == b[key], key
    assert max(abs(t) for t in b["peak_torque"]) > 20  # far beyond the mechanism's 1 N m


def test_mcap_urdf_carries_the_mechanisms_limits(runs):
    """Bundled: the scenario's limits (no mechanism limits); limited: the mechanism's; an fk
    run's MCAP (no run limits): the mechanism's too."""
    import math

    for name, want in (("bundled", [(30.0, 0.5), (8.0, 0.3), (2.0, 0.5)]),
                       ("limited", [(1.0, math.radians(1.0))] * 3),
                       ("fk", [(1.0, math.radians(1.0))] * 3)):
        text = strict_check(runs[name][1])["msgs"]["/robot_description"][0][1]["data"]
        got = {j.name: (j.limit.effort, j.limit.velocity)
               for j in load_urdf(text).robot.joints if j.limit is not None}
        flat = [v for q in ("q1", "q2", "q3") for v in got[q]]  # (effort, velocity) per joint
        assert flat == pytest.approx([v for pair in want for v in pair], rel=1e-15), name
