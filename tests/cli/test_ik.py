"""``mechkin ik`` end to end: the three kim1995 scenarios and an unreachable target."""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from mechkin.cli.app import app

runner = CliRunner()
SCENARIOS = ["kim1995_table3_direct_drive_ik", "kim1995_table6_stewart_ik",
             "kim1995_table9_end_effector_ik"]


def _walk_numbers(obj):
    if isinstance(obj, dict):
        for v in obj.values():
            yield from _walk_numbers(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from _walk_numbers(v)
    elif isinstance(obj, float):
        yield obj


@pytest.mark.parametrize("name", SCENARIOS)
def test_kim1995_scenarios_pass(root, tmp_path, name):
    out = tmp_path / name
    res = runner.invoke(app, ["ik", str(root / "scenarios" / f"{name}.yaml"), "--out", str(out)])
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "ok"
    assert s["expect"] and all(c["ok"] for c in s["expect"])
    for f in ("summary.json", "ik.csv", "stick.png", "convergence.png", "ik.mcap"):
        assert (out / f).is_file(), f
    rec = s["targets"][0]
    for key in ("status", "q", "q_v", "position_error", "orientation_error", "iterations",
                "time_s"):
        assert key in rec
    assert all(math.isfinite(v) for v in _walk_numbers(s))


def test_mcap_steps_one_second_apart(root, tmp_path):
    from mcap.reader import make_reader

    out = tmp_path / "t3"
    res = runner.invoke(app, ["ik", str(root / "scenarios" / f"{SCENARIOS[0]}.yaml"), "--out",
                              str(out), "--no-plots"])
    assert res.exit_code == 0, res.output
    with open(out / "ik.mcap", "rb") as fh:
        times = sorted({m.log_time for _, _, m in make_reader(fh).iter_messages(
            topics=["/joint_states"])})
    assert [t / 1e9 for t in times] == [0.0, 1.0, 2.0, 3.0]


def test_unreachable_target_exits_1(root, tmp_path):
    sc = tmp_path / "far.yaml"
    sc.write_text(f"""
name: puma_far
task: ik
mechanism: {root / 'mechanisms' / 'puma560.yaml'}
ik:
  method: lm
  targets:  # z = 0.4 and 0.5 m above the MATLAB model's base, + the pedestal d1 = 0.67183 m
    - xyz: [0.3, 0.1, 1.07183]
      euler: {{convention: ZYX, angles: [0.1, 0.2, 0.3]}}
    - xyz: [3.0, 0.0, 1.17183]
      quaternion: [1, 0, 0, 0]
""")
    out = tmp_path / "far"
    res = runner.invoke(app, ["ik", str(sc), "--out", str(out), "--no-plots"])
    assert res.exit_code == 1, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["targets"][1]["status"] in ("unreachable", "at a limit")
    assert s["targets"][1]["position_error"] > 1.5
    assert all(math.isfinite(v) for v in _walk_numbers(s))
    assert "NaN" not in (out / "ik.csv").read_text()


def test_bad_target_exits_2(root, tmp_path):
    sc = tmp_path / "bad.yaml"
    sc.write_text(f"""
name: bad
task: ik
mechanism: {root / 'mechanisms' / 'puma560.yaml'}
ik:
  targets:
    - xyz: [0.3, 0.1, 0.4]
""")
    res = runner.invoke(app, ["ik", str(sc), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert "rpy, euler or quaternion" in res.output
    assert not (tmp_path / "o").exists()



@pytest.mark.parametrize("name, edit, structure", [
    # UR5: three parallel axes (shoulder, elbow, wrist 1) and the last two meeting; PUMA 560:
    # a spherical wrist (the descriptions of mechkin.solvers.ik.analytic.classify)
    ("ur5_ik", ("method: lm", "method: auto"), "three parallel axes h2 || h3 || h4"),
    ("puma560_analytic_ik", ("task: ik", "task: ik"), "spherical wrist"),
])
def test_the_summary_names_the_analytic_structure(tmp_path, name, edit, structure):
    from tests.scenario_copy import local_scenario

    out = tmp_path / name
    res = runner.invoke(app, ["ik", str(local_scenario(tmp_path, name, edit)), "--out", str(out),
                              "--no-plots"])
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert "analytic" in s["methods_used"]
    assert s["analytic_structure"].startswith(structure), s["analytic_structure"]
