"""Notes on stderr: an orientation angle above 2 pi in a file whose angle unit is rad (the
default) is pointed out once (almost surely degrees); a robot file's import notes are written
once per file version, although a run reads the file twice (check's spec read, the build)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from mechkin.config.load import note_once
from mechkin.config.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]

SCEN = """name: s
task: ik
mechanism: {mech}
{units}ik:
  targets:
    - {{xyz: [0.4, 0.1, 0.3], rpy: [0, 0, 1.5]}}
    - {{xyz: [0.3, -0.2, 0.5], rpy: [RPY, 0, 0.7]}}
"""


def _scenario(tmp_path: Path, rpy: str, units: str = "") -> Path:
    p = tmp_path / "s.yaml"
    p.write_text(SCEN.format(mech=ROOT / "mechanisms" / "puma560.yaml", units=units)
                 .replace("RPY", rpy))
    return p


def test_an_angle_above_two_pi_in_radians_is_noted_at_its_line(tmp_path, capsys):
    p = _scenario(tmp_path, "90")
    load_scenario(p)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"{p}:7: ik.targets[1].rpy: note: 90 is read as radians")
    assert "units: {angle: deg}" in err[0]


def test_no_note_for_radians_or_for_a_degree_file(tmp_path, capsys):
    load_scenario(_scenario(tmp_path, "3.1"))
    load_scenario(_scenario(tmp_path, "90", units="units: {angle: deg}\n"))
    assert capsys.readouterr().err == ""


def test_note_once_per_file_version(tmp_path, capsys):
    f = tmp_path / "r.urdf"
    f.write_text("a")
    note_once(f, "r.urdf: note: x")
    note_once(tmp_path / "." / "r.urdf", "r.urdf: note: x")  # the same file by another path
    assert capsys.readouterr().err == "r.urdf: note: x\n"
    f.write_text("ab")  # changed on disk: said again
    note_once(f, "r.urdf: note: x")
    assert capsys.readouterr().err == "r.urdf: note: x\n"


def test_an_imported_robots_note_is_written_once_per_run(tmp_path):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text("""<robot name="arm">
  <link name="base"/><link name="l1"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <gazebo reference="l1"/>
</robot>
""")
    sc = tmp_path / "fk.yaml"
    sc.write_text("name: fk1\ntask: fk\nmechanism: arm.urdf\nfk:\n  time: {start: 0, stop: 1, "
                  "step: 0.5}\n  motion: {j1: {type: ramp, from: 0, to: 1}}\n")
    r = subprocess.run([sys.executable, "-m", "mechkin", "fk", str(sc), "--no-plots", "--out",
                        str(tmp_path / "o")], capture_output=True, text=True, cwd=tmp_path,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    notes = [ln for ln in r.stderr.splitlines() if ": note: ignored" in ln]
    assert notes == ["arm.urdf: note: ignored 1 <gazebo> (not kinematics)"], r.stderr
