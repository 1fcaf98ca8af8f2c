"""`mechkin info` on real robot files (issue 25): coupled (mimic) joints are dependent and count
in the constraint equations, the dof and the Grübler mobility; a floating base is reported and
its six joints are independent. The reference counts are read from the files with the standard
library's XML parser (moving joints, <mimic> tags), not from mechkin."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from typer.testing import CliRunner

from mechkin.cli.app import app
from tests.config.robot_files import robots_dir, urdf_mimics

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()


def _info(path: Path) -> dict:
    res = runner.invoke(app, ["info", str(path), "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


@pytest.mark.parametrize("rel", ["panda_description/urdf/panda.urdf",
                                 "talos_data/robots/talos_full_v2.urdf"])
def test_mimic_joints_are_dependent_constraints(rel):
    path = robots_dir() / rel
    moving = [j.get("name") for j in ET.parse(path).getroot().iter("joint")
              if j.get("type") in ("revolute", "continuous", "prismatic")]
    mimic = urdf_mimics(path)
    assert mimic  # the file has couplings
    info = _info(path)
    assert info["n_coordinates"] == len(moving)
    assert info["n_equations"] == info["constraint_rank"] == len(mimic)
    assert info["dof"] == info["mobility"] == len(moving) - len(mimic)
    assert sorted(info["dependent"]) == sorted(mimic)
    assert not set(info["independent"]) & set(mimic)
    assert {c["joint"]: (c["master"], c["multiplier"], c["offset"])
            for c in info["couplings"]} == mimic
    assert info["floating_base"] is False


def test_floating_base_is_reported_and_its_joints_are_independent():
    path = ROOT / "mechanisms" / "biped_floating.xml"
    # the MJCF's joints read with the XML parser: a hinge is 1 coordinate, a ball 3, and the
    # free joint (the base) 6
    dofs = {"hinge": 1, "slide": 1, "ball": 3}
    n = sum(dofs[j.get("type", "hinge")] for j in ET.parse(path).getroot().iter("joint"))
    assert len(list(ET.parse(path).getroot().iter("freejoint"))) == 1
    info = _info(path)
    base = ["base_x", "base_y", "base_z", "base_yaw", "base_pitch", "base_roll"]
    assert info["floating_base"] is True
    assert info["independent"][:6] == base
    assert info["n_coordinates"] == info["dof"] == info["mobility"] == 6 + n == 18
    res = runner.invoke(app, ["info", str(path)])
    assert res.exit_code == 0, res.output
    line = next(x for x in res.stdout.splitlines() if x.strip().startswith("base "))
    assert line.split()[1] == "floating" and all(b in line for b in base)
