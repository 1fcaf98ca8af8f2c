"""`mechkin info` reproduces kim1995 Table 10 (relative coordinates); every bundled fk scenario
runs with exit 0 and its expect entries holding."""

import json
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from mechkin.cli.app import app

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()

# kim1995 Table 10, "Relative" row: (NC, NE); degrees of freedom 3, 6, 6 (§6)
TABLE10 = {
    "kim1995_direct_drive.yaml": (6, 6, 3),
    "kim1995_stewart.yaml": (36, 30, 6),
    "kim1995_end_effector_robot.yaml": (18, 12, 6),
}

# kim1995 Table 10, "Absolute (13)" row (Haug 1989): (NC, NE)
TABLE10_ABSOLUTE = {
    "kim1995_direct_drive.yaml": (18, 15),
    "kim1995_stewart.yaml": (98, 92),
    "kim1995_end_effector_robot.yaml": (63, 57),
}


@pytest.mark.parametrize("name", sorted(TABLE10))
def test_info_reproduces_table10(name):
    res = runner.invoke(app, ["info", str(ROOT / "mechanisms" / name), "--json"])
    assert res.exit_code == 0, res.output
    info = json.loads(res.stdout)
    assert (info["n_coordinates"], info["n_equations"], info["dof"]) == TABLE10[name]
    assert len(info["independent"]) == info["dof"]
    ab = info["absolute"]
    assert (ab["n_coordinates"], ab["n_equations"]) == TABLE10_ABSOLUTE[name]


def test_info_lee_mobility_3():
    res = runner.invoke(app, ["info", str(ROOT / "mechanisms" / "lee_spherical_rrps.yaml"),
                              "--json"])
    info = json.loads(res.stdout)
    assert info["mobility"] == 3 and info["dof"] == 3


def test_info_direct_drive_notes_planar_loop():
    res = runner.invoke(app, ["info", str(ROOT / "mechanisms" / "kim1995_direct_drive.yaml")])
    assert res.exit_code == 0
    assert "rank 3" in res.stdout and "degrees of freedom        3" in res.stdout


FK_SCENARIOS = sorted(p.name for p in (ROOT / "scenarios").glob("*.yaml")
                      if yaml.safe_load(p.read_text()).get("task") == "fk")


@pytest.mark.parametrize("name", FK_SCENARIOS)
def test_bundled_fk_scenarios_exit_0(tmp_path, name):
    res = runner.invoke(app, ["fk", str(ROOT / "scenarios" / name), "--out", str(tmp_path / "o"),
                              "--no-plots"])
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert all(c["ok"] for c in summary.get("expect", []))
