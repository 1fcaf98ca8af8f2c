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


# ---- files yourdfpy (or the URDF rules) reject: the real line, the element, the fix ----------

ARM = """<robot name="arm">
  <link name="base"/>
  <link name="a"/>
  <link name="b"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="a"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="a"/><child link="b"/>
    <origin xyz="0.3 0 0" rpy="0 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
    <mimic joint="j1" multiplier="0.5"/>
  </joint>
</robot>
"""

# (edit of ARM, line, text that must follow "file:line: " up to the fix, the fix)
REJECTED = {
    "missing_child_link": (('<child link="b"/>', '<child link="nolink"/>'), 11,
                           "joint[j2].child: unknown link 'nolink'", "fix: declare the link"),
    "mimic_unknown_joint": (('<mimic joint="j1"', '<mimic joint="nojoint"'), 14,
                            "joint[j2].mimic.joint: unknown joint 'nojoint'",
                            "fix: name the joint it follows, e.g. <mimic joint=\"j1\"/>"),
    "origin_two_numbers": (('xyz="0.3 0 0"', 'xyz="0.3 0"'), 12,
                           "joint[j2].origin.xyz: expected 3 finite numbers, got '0.3 0'",
                           "fix: e.g. xyz="),
    "origin_not_a_number": (('rpy="0 0 0"/>\n    <axis xyz="0 0 1"/><limit lower="-1" upper="1" '
                             'effort="1" velocity="1"/>\n    <mimic',
                             'rpy="0 zero 0"/>\n    <axis xyz="0 0 1"/><limit lower="-1" '
                             'upper="1" effort="1" velocity="1"/>\n    <mimic'), 12,
                            "joint[j2].origin.rpy: expected 3 finite numbers, got '0 zero 0'",
                            "fix: e.g. rpy="),
    "missing_parent": (('<parent link="a"/>', ''), 10,
                       "joint[j2].parent: missing <parent link=\"...\"/>",
                       "fix: name the parent link"),
    "unnamed_joint": (('<joint name="j2" type="revolute">', '<joint type="revolute">'), 10,
                      "joint (unnamed, 2.): missing name=", "fix: give every <joint> a unique"),
    "mass_not_a_number": (('<link name="a"/>', '<link name="a"><inertial><mass value="heavy"/>'
                           '</inertial></link>'), 3,
                          "link[a].inertial.mass.value: expected a finite number >= 0 [kg], "
                          "got 'heavy'", "fix: e.g. <mass value="),
    "axis_two_numbers": (('<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" '
                          'velocity="1"/>\n    <mimic',
                          '<axis xyz="0 1"/><limit lower="-1" upper="1" effort="1" '
                          'velocity="1"/>\n    <mimic'), 13,
                         "joint[j2].axis.xyz: expected 3 finite numbers, not all zero, "
                         "got '0 1'", "fix: e.g. <axis xyz=\"0 0 1\"/>"),
    "missing_type": (('<joint name="j2" type="revolute">', '<joint name="j2">'), 10,
                     "joint[j2].type: missing type=", "fix: type=\"revolute\""),
    "duplicate_link": (('<link name="b"/>', '<link name="b"/>\n  <link name="a"/>'), 5,
                       "link[a]: duplicate name (the <link> on line 3 has it too)",
                       "fix: rename one of them"),
}


@pytest.mark.parametrize("case", sorted(REJECTED))
def test_rejected_urdf_names_file_real_line_element_and_fix(tmp_path, case):
    (old, new), line, text, fix = REJECTED[case]
    assert old in ARM
    p = tmp_path / f"{case}.urdf"
    p.write_text(ARM.replace(old, new, 1))
    with pytest.raises(ConfigError) as exc:
        load_mechanism(p)
    msg = _one_line(exc)
    assert msg.startswith(f"{p}:{line}: {text}"), msg
    assert fix in msg and "\n" not in msg and "arm" not in msg.replace(str(p), ""), msg


def test_rejected_urdf_is_exit_2_with_one_line(tmp_path):
    p = tmp_path / "bad.urdf"
    p.write_text(ARM.replace('xyz="0.3 0 0"', 'xyz="0.3 0"'))
    r = subprocess.run([sys.executable, "-m", "mechkin", "info", str(p)], capture_output=True,
                       text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    lines = [x for x in r.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert lines[0].startswith(f"{p}:12: joint[j2].origin.xyz: expected 3 finite numbers"), lines


def test_unknown_visual_shape_is_no_reason_to_refuse(tmp_path):
    """mechkin uses no geometry: a capsule (not in yourdfpy's URDF) in a visual is skipped."""
    p = tmp_path / "capsule.urdf"
    p.write_text(ARM.replace('<link name="b"/>', '<link name="b"><visual><geometry><capsule '
                             'radius="0.1" length="0.3"/></geometry></visual></link>'))
    mech = load_mechanism(p)
    assert mech.joint_names == ("j1", "j2") and len(mech.couplings) == 1


def test_other_yourdfpy_rejections_are_located_by_element(tmp_path):
    """What the element checks do not read (here a joint's <safety_controller>) but yourdfpy
    refuses is located by parsing each element alone with yourdfpy's own parser: the joint's
    line."""
    p = tmp_path / "safety.urdf"
    p.write_text(ARM.replace('<mimic joint="j1" multiplier="0.5"/>',
                             '<mimic joint="j1" multiplier="0.5"/>'
                             '<safety_controller k_velocity="lots"/>'))
    with pytest.raises(ConfigError) as exc:
        load_mechanism(p)
    msg = _one_line(exc)
    assert msg.startswith(f"{p}:10: joint[j2]: yourdfpy cannot read this element (ValueError: "
                          "could not convert string to float: 'lots')"), msg
    assert "fix: " in msg


def test_names_mechkin_cannot_hold_are_renamed_everywhere(tmp_path, capfd):
    """A vendor's ``a/b`` names: renamed ``a_b`` (``a_b_2`` where ``a_b`` is taken) in the
    joints' ends, a mimic's master and the frames, with one note."""
    p = tmp_path / "slash.urdf"
    p.write_text(ARM.replace('"j1"', '"arm/j1"').replace('<link name="b"/>',
                 '<link name="b"/><link name="b/tip"/><link name="b_tip"/>').replace(
                 "</robot>", '  <joint name="t1" type="fixed"><parent link="b"/>'
                 '<child link="b/tip"/></joint>\n  <joint name="t2" type="fixed">'
                 '<parent link="b"/><child link="b_tip"/></joint>\n</robot>'))
    mech = load_mechanism(p)
    assert "renamed 2 names" in capfd.readouterr().err
    assert mech.joint_names == ("arm_j1", "j2")
    assert {"b_tip", "b_tip_2"} <= set(mech.frame_names)
    (c,) = mech.couplings
    assert mech.joint_names[c.master] == "arm_j1" and c.multiplier == 0.5


MJCF_ARM = """<mujoco>
  <worldbody>
    <body name="a">
      <joint name="ja" axis="0 0 1"/>
      <geom size="0.1"/>
      <body name="b" pos="0.3 0 0">
        <joint name="jb" axis="0 0 1"/>
        <geom size="0.1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("old, new, line, text", [
    ('<joint name="jb" axis="0 0 1"/>', '<joint name="jb" axis="0 1"/>', 7,
     "attribute 'axis' does not have enough data Element 'joint'"),
    # a word where a number goes: mechkin's own numeric check, before MuJoCo reads the file
    ('pos="0.3 0 0"', 'pos="0.3 zero 0"', 6, "body[b].pos: expected finite numbers, got "
     "'0.3 zero 0'"),
    ('<joint name="jb"', '<joint name="ja"', 7, "repeated name 'ja' in joint"),
    ('<geom size="0.1"/>\n      </body>', '<geom size="0.1">\n      </body>', 8,
     "XML_ERROR_MISMATCHED_ELEMENT"),
])
def test_mujoco_rejections_name_the_real_line(tmp_path, old, new, line, text):
    assert old in MJCF_ARM
    p = tmp_path / "arm.xml"
    p.write_text(MJCF_ARM.replace(old, new, 1))
    with pytest.raises(ConfigError) as exc:
        load_mechanism(p)
    msg = _one_line(exc)
    assert msg.startswith(f"{p}:{line}: ") and text in msg, msg
    assert "MJCF: " in msg or "expected finite numbers" in msg, msg


def test_a_single_body_robot_names_the_fix_and_takes_it(tmp_path):
    """hector's quadrotor_base.urdf is one body without joints: refused with the fix (a
    floating base in the sidecar), and imported with it."""
    src = robots_dir() / "hector_description" / "robots" / "quadrotor_base.urdf"
    p = tmp_path / "quadrotor_base.urdf"
    p.write_text(src.read_text())
    with pytest.raises(ConfigError) as exc:
        load_mechanism(p)
    msg = _one_line(exc)
    assert msg.startswith(f"{p}:1: joints: a mechanism needs at least one joint") and \
        "base: floating" in msg and "sidecar" in msg, msg
    (tmp_path / "quadrotor_base.mechkin.yaml").write_text("base: floating\n")
    mech = load_mechanism(p)
    assert mech.floating and mech.n == 6 and len(mech.independent) == 6
