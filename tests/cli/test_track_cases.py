"""`track: dp:` readings and `track: cases:` (issue 17 item 4) through `mechkin track`."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from mechkin.cli.app import app
from tests.scenario_copy import local_scenario as _local

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "scenarios"
runner = CliRunner()


@pytest.fixture(scope="module")
def overlay(tmp_path_factory) -> tuple[dict, Path]:
    out = tmp_path_factory.mktemp("overlay") / "out"
    res = runner.invoke(app, ["track", str(SCEN / "park_cases_overlay.yaml"), "--out", str(out),
                              "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout), out


def test_overlay_scenario_plans_the_three_cases(overlay) -> None:
    """park §5.3: t_a of the three cases, as the single-case scenarios give them (0.65 s,
    0.90 s, 1.10 s at 50 x 100; printed 0.65, 0.8, 1.1 s)."""
    summary, out = overlay
    cases = summary["cases"]
    assert [c["name"] for c in cases] == ["1: no limits", "2: torque", "3: all limits"]
    assert [round(c["t_a_s"], 9) for c in cases] == [0.65, 0.9, 1.1]
    assert cases[2]["t_a_s"] == summary["t_a_s"] and cases[2]["cost"] == summary["cost"]
    assert all(c["status"] == "ok" and c["limits_ok"] for c in cases)
    assert cases[1]["dp"] == {"step_time": "trapezoid", "wait_cost": False, "jerk_ends": False}
    for png in ("cases_phase.png", "cases_hand.png", "cases_joint_velocities.png",
                "cases_torques.png", "path_3d.png", "joint_positions.png"):
        assert png in summary["files"] and (out / png).stat().st_size > 0
    assert all(e["ok"] for e in summary["expect"])


def test_single_case_scenarios_agree_with_the_cases(overlay, tmp_path: Path) -> None:
    summary, _ = overlay
    res = runner.invoke(app, ["track", str(SCEN / "park_conveyor_torque.yaml"), "--out",
                              str(tmp_path / "t"), "--json", "--no-plots"])
    assert res.exit_code == 0, res.output
    single = json.loads(res.stdout)
    assert single["t_a_s"] == summary["cases"][1]["t_a_s"]
    # the same plan; the torques agree to round-off (the summation order of the inverse dynamics
    # may differ between the two runs' routes: once 1e-12 apart under load)
    assert single["peak_torque"] == pytest.approx(summary["cases"][1]["peak_torque"], rel=1e-9)


def test_dp_block_selects_the_literal_eq26(tmp_path: Path) -> None:
    """dp: {step_time: euler}: torque-only t_a 0.85 s instead of 0.90 s (issue 17 item 4)."""
    p = _local(tmp_path, "park_conveyor_torque",
               ("dynamics: rnea", "dynamics: rnea\n  dp: {step_time: euler}"))
    res = runner.invoke(app, ["track", str(p), "--out", str(tmp_path / "o"), "--json",
                              "--no-plots"])
    assert res.exit_code == 0, res.output
    s = json.loads(res.stdout)
    assert s["t_a_s"] == pytest.approx(0.85, abs=1e-9) and s["dp"]["step_time"] == "euler"


def test_case_dp_overrides_the_scenario_dp(tmp_path: Path) -> None:
    p = _local(tmp_path, "park_cases_overlay",
               ('- {name: "3: all limits"}',
                '- {name: "3: all limits"}\n    - {name: "2 euler", limits: {torque: [0.5, 0.2]},'
                ' dp: {step_time: euler}}'))
    res = runner.invoke(app, ["track", str(p), "--out", str(tmp_path / "o"), "--json",
                              "--no-plots"])
    assert res.exit_code == 0, res.output
    cases = json.loads(res.stdout)["cases"]
    assert cases[3]["name"] == "2 euler" and cases[3]["t_a_s"] == pytest.approx(0.85, abs=1e-9)
    assert cases[1]["t_a_s"] == pytest.approx(0.90, abs=1e-9)


@pytest.mark.parametrize(("edit", "pattern"), [
    (("dynamics: rnea", "dynamics: rnea\n  dp: {step_time: midpoint}"),
     r":\d+: track\.dp\.step_time: "),
    (("dynamics: rnea", "dynamics: rnea\n  dp: {wait_cost: maybe}"),
     r":\d+: track\.dp\.wait_cost: "),
    (("dynamics: rnea", "dynamics: rnea\n  dp: {jerk_end: true}"),
     r":\d+: track\.dp\.jerk_end: unknown key"),
    (('{name: "2: torque", limits: {torque: [0.5, 0.2]}}',
      '{name: "2: torque", limits: {torque: [0.5]}}'),
     r":\d+: track\.cases\[1\]\.limits\.torque: expected 2 values"),
    (('{name: "2: torque",', '{name: "1: no limits",'), r":\d+: track.*used twice"),
    (('{name: "3: all limits"}', '{limits: {}}'), r":\d+: track\.cases\[2\]\.name: "),
])
def test_bad_dp_or_cases_exit_2(tmp_path: Path, edit, pattern) -> None:
    p = _local(tmp_path, "park_cases_overlay", edit)
    out = tmp_path / "out"
    res = runner.invoke(app, ["track", str(p), "--out", str(out), "--no-plots"])
    assert res.exit_code == 2, res.output
    assert re.search(re.escape(str(p)) + pattern, res.stderr), res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_wait_cost_needs_tracking(tmp_path: Path) -> None:
    p = _local(tmp_path, "park_time_optimal_torque",
               ("dynamics: rnea", "dynamics: rnea\n  dp: {wait_cost: true}"))
    res = runner.invoke(app, ["track", str(p), "--out", str(tmp_path / "o"), "--no-plots"])
    assert res.exit_code == 2, res.output
    assert "wait_cost needs objective tracking" in res.stderr
