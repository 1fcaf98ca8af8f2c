"""``base_pose`` of a floating base (issue 25 item 2) in fk motions and ik target sets: fk with
``base_pose`` equals fk with the six base joints named; per-row base poses in a table; ik with
a known base pose holds the base there and solves the rest (verified by FK); the refusals are
one located line, exit 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mechkin
from mechkin.errors import ConfigError
from mechkin.model.kinematics import forward_kinematics
from mechkin.spatial.rotations import matrix_from_rpy

ROOT = Path(__file__).resolve().parents[2]
BIPED = ROOT / "mechanisms" / "biped_floating.xml"
LEG = {"hip_1": 5.0, "hip_2": -3.0, "hip_3": 4.0, "knee": 25.0, "ankle": -12.0,
       "ankle_roll": 2.0}
LEG_MOTION = "\n".join(f"    {s}_{j}: {{type: constant, value: {v}}}"
                       for s in ("left", "right") for j, v in LEG.items())
OFF = "outputs: {csv: false, plots: false, mcap: false}\n"


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _fk(tmp_path: Path, name: str, body: str, mech: Path = BIPED) -> Path:
    return _write(tmp_path, name, f"name: {name[:-5]}\ntask: fk\nmechanism: {mech}\n"
                                  f"units: {{length: mm, angle: deg}}\nfk:\n{body}{OFF}")


def test_fk_base_pose_equals_the_six_base_joints(tmp_path):
    time = "  time: {start: 0, stop: 1, step: 0.5}\n"
    a = _fk(tmp_path, "a.yaml", time + "  base_pose: {xyz: [100, -50, 900], rpy: [5, -10, 30]}\n"
            "  motion:\n" + LEG_MOTION + "\n")
    joints = {"base_x": 100, "base_y": -50, "base_z": 900, "base_roll": 5, "base_pitch": -10,
              "base_yaw": 30}
    b = _fk(tmp_path, "b.yaml", time + "  motion:\n" + LEG_MOTION + "\n" + "\n".join(
        f"    {k}: {{type: constant, value: {v}}}" for k, v in joints.items()) + "\n")
    ra, rb = mechkin.run(a), mechkin.run(b)
    assert ra.summary["status"] == rb.summary["status"] == "ok"
    assert np.array_equal(ra.data.q, rb.data.q)
    mech = mechkin.load_mechanism(BIPED)
    q = ra.data.q[0]
    # independent check: the pelvis (the floating body) sits at T(xyz) R(rpy), R = Rz Ry Rx
    pel = forward_kinematics(mech, q[None]).frames(mech, [mech.frame_index("pelvis")])[0, 0]
    R = matrix_from_rpy(np.radians([5.0, -10.0, 30.0]))
    cz, sz = np.cos(np.radians(30)), np.sin(np.radians(30))
    cy, sy = np.cos(np.radians(-10)), np.sin(np.radians(-10))
    cx, sx = np.cos(np.radians(5)), np.sin(np.radians(5))
    R_hand = (np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
              @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
              @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]))
    assert np.allclose(R, R_hand, atol=1e-15)
    assert np.allclose(pel[:3, :3], R_hand, atol=1e-14)
    assert np.allclose(pel[:3, 3], [0.1, -0.05, 0.9], atol=1e-14)
    assert q[mech.joint_index("left_knee")] == pytest.approx(np.radians(25.0), abs=1e-15)


def test_fk_table_rows_give_the_base_pose_and_base_pose_fills_a_table(tmp_path):
    legs = "".join(f"    {s}_{j}: [{v}, {v}, {v}]\n" for s in ("left", "right")
                   for j, v in LEG.items())
    rows = ("    base_x: [0, 10, 20]\n    base_y: [0, 0, 5]\n    base_z: [800, 850, 900]\n"
            "    base_roll: [0, 1, 2]\n    base_pitch: [0, -2, -4]\n    base_yaw: [0, 15, 30]\n")
    p = _fk(tmp_path, "rows.yaml", "  table:\n    t: [0, 0.5, 1]\n" + legs + rows)
    rep = mechkin.run(p)
    assert rep.summary["status"] == "ok"
    mech = mechkin.load_mechanism(BIPED)
    pel = forward_kinematics(mech, rep.data.q).frames(mech, [mech.frame_index("pelvis")])[:, 0]
    assert np.allclose(pel[:, :3, 3], [[0, 0, 0.8], [0.01, 0, 0.85], [0.02, 0.005, 0.9]],
                       atol=1e-14)
    R = matrix_from_rpy(np.radians([[0, 0, 0], [1, -2, 15], [2, -4, 30]]))
    assert np.allclose(pel[:, :3, :3], R, atol=1e-14)
    # a table without base columns takes fk.base_pose at every row
    q = _fk(tmp_path, "fill.yaml", "  base_pose: {xyz: [20, 5, 900], rpy: [2, -4, 30]}\n"
            "  table:\n    t: [0, 0.5, 1]\n" + legs)
    rq = mechkin.run(q)
    assert np.allclose(rq.data.q, rep.data.q[-1], atol=1e-15)


def test_fk_base_pose_refusals_are_one_line(tmp_path):
    time = "  time: {start: 0, stop: 1, step: 0.5}\n"
    both = _fk(tmp_path, "both.yaml", time + "  base_pose: {xyz: [0, 0, 900]}\n  motion:\n"
               + LEG_MOTION + "\n    base_z: {type: constant, value: 900}\n")
    with pytest.raises(ConfigError) as exc:
        mechkin.run(both)
    (msg,) = exc.value.problems
    assert msg == (f"{both}:7: fk.base_pose: give base_pose or the base joints in the motion, "
                   "table or csv, not both (named there: base_z)")
    fixed = _fk(tmp_path, "fixed.yaml", time + "  base_pose: {xyz: [0, 0, 900]}\n  motion:\n"
                "    q1: {type: constant, value: 0}\n    q2: {type: constant, value: 0}\n"
                "    q3: {type: constant, value: 0}\n", mech=ROOT / "mechanisms" / "planar3r.yaml")
    r = subprocess.run([sys.executable, "-m", "mechkin", "fk", str(fixed), "--out",
                        str(tmp_path / "o")], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2, r.stderr
    lines = [x for x in r.stderr.splitlines() if x.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith(f"{fixed}:7: fk.base_pose: mechanism 'planar3r.yaml' has no "
                               "floating base"), lines[0]
    assert "base: floating" in lines[0] and "Traceback" not in r.stderr


IK_SET = """name: {name}
task: ik
mechanism: {mech}
units: {{length: m, angle: deg}}
ik:
{section}  target_sets:
    - name: stand
{set_extra}      targets:
        - {{frame: left_sole, xyz: [0.05, 0.12, 0.0], rpy: [0, 0, 10]}}
        - {{frame: right_sole, xyz: [-0.05, -0.12, 0.0], rpy: [0, 0, 0]}}
outputs: {{csv: false, plots: false, mcap: false}}
"""


def _ik(tmp_path, name, section="", set_extra="", mech=BIPED):
    return _write(tmp_path, name, IK_SET.format(name=name[:-5], mech=mech, section=section,
                                                set_extra=set_extra))


@pytest.mark.parametrize("where", ["section", "set"])
def test_ik_known_base_pose_is_held_and_the_legs_solved(tmp_path, where):
    pose = "base_pose: {xyz: [0.02, 0.0, 0.8], rpy: [0, 3, 5]}\n"
    p = (_ik(tmp_path, "held.yaml", section="  " + pose) if where == "section"
         else _ik(tmp_path, "held.yaml", set_extra="      " + pose))
    rep = mechkin.run(p)
    s = rep.summary
    assert s["status"] == "ok", s
    rec = s["target_sets"][0]
    assert rec["base_pose"] == {"xyz_m": [0.02, 0.0, 0.8],
                                "rpy_rad": [0.0, np.radians(3.0), np.radians(5.0)]}
    mech = mechkin.load_mechanism(BIPED)
    q = np.array([rec["q"][n] for n in mech.joint_names])
    # held exactly: base_yaw = rpy[2], base_pitch = rpy[1], base_roll = rpy[0]
    assert [rec["q"][n] for n in ("base_x", "base_y", "base_z", "base_roll", "base_pitch",
                                  "base_yaw")] == [0.02, 0.0, 0.8, 0.0, np.radians(3.0),
                                                   np.radians(5.0)]
    kin = forward_kinematics(mech, q[None])  # FK after IK
    pel = kin.frames(mech, [mech.frame_index("pelvis")])[0, 0]
    assert np.allclose(pel[:3, 3], [0.02, 0.0, 0.8], atol=1e-15)
    assert np.allclose(pel[:3, :3], matrix_from_rpy(np.radians([0.0, 3.0, 5.0])), atol=1e-15)
    for frame, xyz, yaw in (("left_sole", [0.05, 0.12, 0.0], 10.0),
                            ("right_sole", [-0.05, -0.12, 0.0], 0.0)):
        T = kin.frames(mech, [mech.frame_index(frame)])[0, 0]
        assert np.abs(T[:3, 3] - xyz).max() < 1e-9, frame
        assert np.abs(T[:3, :3] - matrix_from_rpy(np.radians([0, 0, yaw]))).max() < 1e-9


def test_ik_free_base_is_the_default_and_a_set_may_override(tmp_path):
    p = _ik(tmp_path, "free.yaml",
            section="  base_pose: {xyz: [0.0, 0.0, 0.8], rpy: [0, 0, 0]}\n",
            set_extra="      base_pose: free\n")
    rec = mechkin.run(p).summary["target_sets"][0]
    assert rec["status"] == "ok" and rec["base_pose"] == "free"
    d = _ik(tmp_path, "default.yaml")
    rec = mechkin.run(d).summary["target_sets"][0]
    assert rec["status"] == "ok" and rec["base_pose"] == "free"


def test_ik_base_pose_refusals(tmp_path):
    arm = _write(tmp_path, "arm.yaml", f"""name: arm
task: ik
mechanism: {ROOT / 'mechanisms' / 'planar3r.yaml'}
ik:
  base_pose: {{xyz: [0, 0, 0]}}
  targets:
    - {{frame: hand, xyz: [1, 0, 0], rpy: [0, 0, 0]}}
""" + OFF)
    r = subprocess.run([sys.executable, "-m", "mechkin", "check", str(arm)],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2, (r.stdout, r.stderr)
    out = [x for x in (r.stdout + r.stderr).splitlines() if "base_pose" in x]
    assert len(out) == 1 and out[0].startswith(f"{arm}:5: ik.base_pose: mechanism "
                                               "'planar3r.yaml' has no floating base"), out
    plain = _write(tmp_path, "plain.yaml", f"""name: plain
task: ik
mechanism: {BIPED}
ik:
  base_pose: {{xyz: [0, 0, 0.8]}}
  targets:
    - {{xyz: [0, 0, 0], rpy: [0, 0, 0]}}
""" + OFF)
    with pytest.raises(ConfigError) as exc:
        mechkin.load_scenario(plain)
    (msg,) = exc.value.problems
    assert msg.startswith(f"{plain}:4: ik: base_pose: holds a floating base in target sets")


def test_python_api_ik_frames_with_a_base_pose():
    from mechkin.spatial.rotations import matrix_from_rpy

    mech = mechkin.load_mechanism(BIPED)
    B = np.eye(4)
    B[:3, :3] = matrix_from_rpy(np.array([0.02, -0.05, 0.3]))
    B[:3, 3] = [0.1, -0.02, 0.82]
    TL, TR = np.eye(4), np.eye(4)
    TL[:3, 3], TR[:3, 3] = [0.12, 0.15, 0.0], [0.05, -0.1, 0.0]
    TL[:3, :3] = TR[:3, :3] = matrix_from_rpy(np.array([0.0, 0.0, 0.3]))
    r = mechkin.ik_frames(mech, [{"frame": "left_sole", "T": TL}, {"frame": "right_sole",
                                                                    "T": TR}], base_pose=B)
    assert r.ok, (r.position_error, r.orientation_error)
    kin = forward_kinematics(mech, r.q[None])
    pel = kin.frames(mech, [mech.frame_index("pelvis")])[0, 0]
    assert np.abs(pel - B).max() < 1e-14  # held exactly where it was given
    for frame, T in (("left_sole", TL), ("right_sole", TR)):
        E = kin.frames(mech, [mech.frame_index(frame)])[0, 0]
        assert np.abs(E - T).max() < 1e-9
    with pytest.raises(ConfigError, match="no floating base"):
        mechkin.ik_frames(mechkin.load_mechanism(ROOT / "mechanisms" / "planar3r.yaml"),
                          [{"frame": "hand", "T": np.eye(4)}], base_pose=np.eye(4))


def test_fk_csv_without_base_columns_takes_base_pose(tmp_path):
    legs = [f"{s}_{j}" for s in ("left", "right") for j in LEG]
    rows = ["t_s," + ",".join(f"{n}_deg" for n in legs)]
    rows += [f"{t}," + ",".join(str(LEG[n.split('_', 1)[1]]) for n in legs) for t in (0, 0.5, 1)]
    (tmp_path / "legs.csv").write_text("\n".join(rows) + "\n")
    pose = "  base_pose: {xyz: [20, 5, 900], rpy: [2, -4, 30]}\n"
    a = _fk(tmp_path, "csv.yaml", pose + "  csv: legs.csv\n")
    ra = mechkin.run(a)
    b = _fk(tmp_path, "gen.yaml", pose + "  time: {start: 0, stop: 1, step: 0.5}\n  motion:\n"
            + LEG_MOTION + "\n")
    assert np.allclose(ra.data.q, mechkin.run(b).data.q, atol=1e-15, rtol=0)
    (tmp_path / "both.csv").write_text(rows[0] + ",base_z_mm\n"
                                       + "\n".join(r + ",900" for r in rows[1:]) + "\n")
    c = _fk(tmp_path, "both.yaml", pose + "  csv: both.csv\n")
    with pytest.raises(ConfigError) as exc:
        mechkin.run(c)
    (msg,) = exc.value.problems
    assert msg.startswith(f"{c}:6: fk.base_pose: give base_pose or the base joints in the "
                          "motion, table or csv, not both (named there: base_z)"), msg


def test_a_bad_base_pose_is_one_line_per_key(tmp_path):
    p = _ik(tmp_path, "typo.yaml", section="  base_pose: fixed\n",
            set_extra="      base_pose: {xyz: [0, 0], rpy: [0, 0, 0]}\n")
    with pytest.raises(ConfigError) as exc:
        mechkin.load_scenario(p)
    assert sorted(exc.value.problems) == sorted([
        f"{p}:6: ik.base_pose: Input should be 'free', got 'fixed'",
        f"{p}:9: ik.target_sets[0].base_pose.xyz: List should have at least 3 items after "
        "validation, not 2, got [0, 0]"])


def test_talos_feet_and_hands_with_the_base_held(tmp_path):
    """Talos (12 mimic joints) on a floating base held at a known pose: feet and hands of 20
    random configurations reached with the defaults, the base exactly where it was given, every
    frame verified by FK, the couplings kept."""
    from tests.config.robot_files import robots_dir

    src = robots_dir() / "talos_data/robots/talos_full_v2.urdf"
    path = tmp_path / "talos.urdf"
    path.write_text(src.read_text())
    (tmp_path / "talos.mechkin.yaml").write_text("base: floating\n")
    mech = mechkin.load_mechanism(path)
    assert mech.floating and len(mech.couplings) == 12
    frames = ["left_sole_link", "right_sole_link", "gripper_left_base_link",
              "gripper_right_base_link"]
    body = mech.link_names[int(mech.joint_child_link[mech.joint_index("base_roll")])]
    rng = np.random.default_rng(9)
    iv = mech.independent
    lo = np.where(np.isfinite(mech.lower[iv]), mech.lower[iv], -0.3)
    hi = np.where(np.isfinite(mech.upper[iv]), mech.upper[iv], 0.3)
    for _ in range(20):
        qv = rng.uniform(lo, hi)
        T = mechkin.fk(mech, qv[None], frames=[*frames, body]).poses
        r = mechkin.ik_frames(mech, [{"frame": f, "T": T[f][0]} for f in frames],
                              base_pose=T[body][0])
        assert r.ok, (r.position_error, r.orientation_error)
        kin = forward_kinematics(mech, r.q[None])
        B = kin.frames(mech, [mech.frame_index(body)])[0, 0]
        assert np.abs(B - T[body][0]).max() < 1e-12
        for f in frames:
            E = kin.frames(mech, [mech.frame_index(f)])[0, 0]
            assert np.abs(E - T[f][0]).max() < 1e-6, f
        for c in mech.couplings:
            assert abs(r.q[c.joint] - c.multiplier * r.q[c.master] - c.offset) < 1e-12
