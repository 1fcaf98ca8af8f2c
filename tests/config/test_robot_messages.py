"""Messages that point at the robot file (issue 25): the file's path, the real line and name of
the offending element, and the fix (which sidecar key, with an example). One line each."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mechkin.errors import ConfigError
from mechkin.model import load_mechanism
from tests.config.robot_files import robots_dir

ROOT = Path(__file__).resolve().parents[2]

LOOP = """<robot name="some_robot">
  <link name="g"/><link name="a"/><link name="b"/>
  <joint name="j1" type="continuous"><parent link="g"/><child link="a"/><axis xyz="0 0 1"/></joint>
  <joint name="j2" type="continuous"><parent link="g"/><child link="b"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 1"/></joint>
</robot>
"""


def _one_line(exc) -> str:
    (msg,) = exc.value.problems
    return msg


def test_missing_sidecar_key_names_the_sidecar(tmp_path):
    p = tmp_path / "loop.urdf"
    p.write_text(LOOP)
    (tmp_path / "loop.mechkin.yaml").write_text("cuts:\n  - {name: c, frames: [a, b], "
                                                 "mask: [x, y]}\n")
    with pytest.raises(ConfigError) as exc:
        load_mechanism(p)
    msg = _one_line(exc)
    assert msg.startswith(f"{p}:1: independent (not in the robot file: set 'independent:' in "
                          "the sidecar loop.mechkin.yaml)")
    assert "some_robot" not in msg


def test_sidecar_problem_points_at_the_sidecar_line(tmp_path):
    p = tmp_path / "loop.urdf"
    p.write_text(LOOP)
    side = tmp_path / "loop.mechkin.yaml"
    side.write_text("cuts:\n  - {name: c, frames: [a, b], mask: [x, y]}\nindependent: [j1, j2]\n")
    with pytest.raises(ConfigError) as exc:
        load_mechanism(p)
    assert _one_line(exc).startswith(f"{side}:3: independent: expected 1 independent joints")


def test_unnamed_tendon_equality_real_line_and_fix(tmp_path):
    p = tmp_path / "t.xml"
    p.write_text("""<mujoco>
  <worldbody>
    <body name="a"><joint name="ja" axis="0 0 1"/><geom size="0.1"/>
      <body name="b" pos="0.2 0 0"><joint name="jb" axis="0 0 1"/><joint name="jc"/>
        <geom size="0.1"/></body>
    </body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="ja" coef="1"/><joint joint="jb" coef="-1"/>
    <joint joint="jc" coef="0.5"/></fixed></tendon>
  <equality>
    <tendon tendon1="t"/>
  </equality>
</mujoco>
""")
    with pytest.raises(ConfigError) as exc:
        load_mechanism(p)
    msg = _one_line(exc)
    assert msg.startswith(f"{p}:11: equality/tendon (unnamed, 1.): tendon equalities are not "
                          "supported")
    assert "fix:" in msg and "couplings: [{joint:" in msg and len(msg) - len(str(p)) < 230


def test_ik_without_end_effector_lists_candidates_and_the_sidecar(tmp_path):
    src = robots_dir() / "solo_description/robots/solo12.urdf"
    robot = tmp_path / "solo12.urdf"
    robot.write_text(src.read_text())
    sc = tmp_path / "ik.yaml"
    sc.write_text("name: solo_ik\ntask: ik\nmechanism: solo12.urdf\nik:\n  targets: [{xyz: [0, 0, "
                  "-0.2], euler: {convention: ZYX, angles: [0, 0, 0]}}]\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run = subprocess.run([sys.executable, "-m", "mechkin", "ik", str(sc), "--out",
                          str(tmp_path / "out")], capture_output=True, text=True, timeout=120,
                         env=env)
    assert run.returncode == 2
    lines = [ln for ln in run.stderr.splitlines() if "end_effector" in ln]
    assert len(lines) == 1, run.stderr
    assert lines[0].startswith(f"{sc}:3: mechanism: mechanism 'solo12.urdf' has no end_effector"
                               " frame; fix: set end_effector in the sidecar solo12.mechkin.yaml "
                               "beside it, e.g. 'end_effector: FL_FOOT'")
    assert "candidate frames: FL_FOOT, FR_FOOT, HL_FOOT, HR_FOOT" in lines[0]
    assert "Traceback" not in run.stderr
