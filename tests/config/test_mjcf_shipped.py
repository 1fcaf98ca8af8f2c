"""MJCF files as they are shipped (issue 25), written here: a gripper whose second finger is
coupled by ``<equality><joint>`` and whose drive is a closed four-bar (``<connect>``), and a
biped with a free joint, ball hips and mesh files that do not exist on disk.

Reference: MuJoCo itself. mechkin solves the loop closure and the couplings; MuJoCo's
``mj_kinematics`` at that configuration must give the same body and site poses (<= 1e-10) and
MuJoCo's own equality residuals (``efc_pos`` of the equality rows after ``mj_forward``) must
vanish there, i.e. mechkin's configuration satisfies MuJoCo's constraints."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from mechkin.api import fk  # noqa: E402
from mechkin.errors import ConfigError  # noqa: E402
from mechkin.model import load_mechanism  # noqa: E402
from mechkin.spatial.rotations import matrix_from_rpy  # noqa: E402

TOL = 1e-10

GRIPPER = """<mujoco model="gripper">
  <compiler angle="radian"/>
  <worldbody>
    <body name="palm" pos="0 0 0.5">
      <joint name="lift" type="slide" axis="0 0 1" range="-0.1 0.1"/>
      <geom type="box" size="0.05 0.02 0.02"/>
      <body name="left" pos="0.03 0 -0.02">
        <joint name="left_finger" axis="0 1 0" range="-0.6 0.6"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.08" size="0.008"/>
        <site name="left_tip" pos="0 0 -0.08"/>
      </body>
      <body name="right" pos="-0.03 0 -0.02">
        <joint name="right_finger" axis="0 1 0" ref="0.1" range="-0.6 0.6"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.08" size="0.008"/>
        <site name="right_tip" pos="0 0 -0.08"/>
      </body>
      <body name="crank" pos="0 0.05 0">
        <joint name="crank" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.04 0 0" size="0.005"/>
        <body name="coupler" pos="0.04 0 0">
          <joint name="coupler" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.1" size="0.005"/>
        </body>
      </body>
      <body name="rocker" pos="0.08 0.05 0">
        <joint name="rocker" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 -0.04 0 -0.1" size="0.005"/>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint joint1="right_finger" joint2="left_finger" polycoef="0.02 -1 0 0 0"/>
    <connect body1="coupler" body2="rocker" anchor="0 0 -0.1"/>
  </equality>
  <actuator>
    <position joint="lift"/>
    <position joint="left_finger"/>
    <position joint="crank"/>
  </actuator>
</mujoco>
"""

LEG = """
      <body name="{s}_thigh" pos="0 {y} -0.1">
        <joint name="{s}_hip" type="ball"/>
        {geom}
        <body name="{s}_shin" pos="0 0 -0.4">
          <joint name="{s}_knee" axis="0 1 0" range="0 2.5"/>
          {geom}
          <body name="{s}_foot" pos="0 0 -0.4">
            <joint name="{s}_ankle" axis="0 1 0" range="-1 1"/>
            <joint name="{s}_ankle_roll" axis="1 0 0" range="-1 1"/>
            {geom}
            <site name="{s}_sole" pos="0.03 0 -0.05"/>
          </body>
        </body>
      </body>"""

BIPED = """<mujoco model="biped">
  <compiler angle="radian" meshdir="meshes_not_shipped"/>
  <asset><mesh name="part" file="part.stl"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="pelvis" pos="0 0 1">
      <freejoint name="root"/>
      {geom}
      <site name="pelvis_site"/>{left}{right}
    </body>
  </worldbody>
  <keyframe>
    <key name="home" qpos="0.1 -0.2 0.85  0.9950042 0 0 0.0998334
      0.9800666 0.1986693 0 0   0.6  -0.3  0.05
      0.9689124 0 -0.2474040 0   0.4  -0.2  -0.05"/>
  </keyframe>
</mujoco>
"""


def _biped(geom: str) -> str:
    legs = {s: LEG.format(s=s, y=y, geom=geom) for s, y in (("left", 0.1), ("right", -0.1))}
    return BIPED.format(geom=geom, left=legs["left"], right=legs["right"])


MESH_GEOM = '<geom type="mesh" mesh="part"/>'
SPHERE_GEOM = '<geom type="sphere" size="0.05"/>'


def _quat(R: np.ndarray) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R).reshape(-1))
    return q


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _mujoco_qpos(m, mech, q: np.ndarray) -> np.ndarray:
    """mechkin joints -> MuJoCo qpos: hinge/slide equal, ball from its x-y-z revolutes, the free
    joint from base_x..base_roll (R = Rz Ry Rx)."""
    qpos = np.zeros(m.nq)
    J = mujoco.mjtJoint
    for j in range(m.njnt):
        a = int(m.jnt_qposadr[j])
        nm = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
        t = int(m.jnt_type[j])
        if t == J.mjJNT_FREE:
            x = [q[mech.joint_index(f"base_{k}")] for k in ("x", "y", "z", "yaw", "pitch",
                                                             "roll")]
            qpos[a:a + 3] = x[:3]
            qpos[a + 3:a + 7] = _quat(_rz(x[3]) @ _ry(x[4]) @ _rx(x[5]))
        elif t == J.mjJNT_BALL:
            r = [q[mech.joint_index(f"{nm}_{k}")] for k in (1, 2, 3)]
            qpos[a:a + 4] = _quat(_rx(r[0]) @ _ry(r[1]) @ _rz(r[2]))
        else:
            qpos[a] = q[mech.joint_index(nm)]
    return qpos


def _compare(m, mech, q: np.ndarray) -> tuple[float, float]:
    """(max pose difference over named bodies and sites, max |MuJoCo equality residual|)."""
    d = mujoco.MjData(m)
    d.qpos[:] = _mujoco_qpos(m, mech, q)
    mujoco.mj_kinematics(m, d)
    names, ref = [], []
    for b in range(1, m.nbody):
        nm = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)
        if nm in mech.frame_names:
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = d.xmat[b].reshape(3, 3), d.xpos[b]
            names.append(nm)
            ref.append(T)
    for s in range(m.nsite):
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = d.site_xmat[s].reshape(3, 3), d.site_xpos[s]
        names.append(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, s))
        ref.append(T)
    got = fk(mech, q[mech.independent][None], frames=names).poses
    err = max(float(np.abs(got[n][0] - T).max()) for n, T in zip(names, ref, strict=True))
    mujoco.mj_forward(m, d)
    viol = float(np.abs(d.efc_pos[: d.ne]).max()) if d.ne else 0.0
    return err, viol


def test_gripper_couplings_and_linkage_match_mujoco(tmp_path):
    path = tmp_path / "gripper.xml"
    path.write_text(GRIPPER)
    mech = load_mechanism(path)
    assert len(mech.couplings) == 1 and len(mech.cuts) == 1
    assert mech.independent_names == ["lift", "left_finger", "crank"]
    assert "right_finger" in mech.dependent_names
    m = mujoco.MjModel.from_xml_path(str(path))
    rng = np.random.default_rng(3)
    qv = mech.home[mech.independent] + rng.uniform(-0.3, 0.3, (20, 3)) * [0.2, 1, 1]
    res = fk(mech, qv, frames=[])
    assert all(s == "converged" for s in res.status)
    worst = worst_viol = 0.0
    for q in res.q:
        # MuJoCo's joint equality is relative to qpos0: right - 0.1 = 0.02 - (left - 0)
        assert abs(q[mech.joint_index("right_finger")] - (0.12 - q[mech.joint_index(
            "left_finger")])) < 1e-12
        err, viol = _compare(m, mech, q)
        worst, worst_viol = max(worst, err), max(worst_viol, viol)
    assert worst <= TOL, worst
    assert worst_viol <= TOL, worst_viol


def test_biped_free_joint_without_meshes_matches_mujoco(tmp_path, capsys):
    path = tmp_path / "biped.xml"
    path.write_text(_biped(MESH_GEOM))  # meshes_not_shipped/part.stl does not exist
    ref_path = tmp_path / "biped_ref.xml"
    ref_path.write_text(_biped(SPHERE_GEOM).replace('<asset><mesh name="part" file="part.stl"/>'
                                                    '</asset>', ""))
    mech = load_mechanism(path)
    assert "compiled without" in capsys.readouterr().err
    assert mech.floating and mech.joint_names[:6] == ("base_x", "base_y", "base_z", "base_yaw",
                                                      "base_pitch", "base_roll")
    m = mujoco.MjModel.from_xml_path(str(ref_path))
    # home is the keyframe: the free joint's pose and the ball joints' quaternions
    d = mujoco.MjData(m)
    d.qpos[:] = m.key_qpos[0]
    mujoco.mj_kinematics(m, d)
    home = fk(mech, mech.home[mech.independent][None], frames=["pelvis", "left_foot",
                                                                "right_foot"]).poses
    for nm in ("pelvis", "left_foot", "right_foot"):
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, nm)
        assert np.abs(home[nm][0][:3, 3] - d.xpos[b]).max() < 1e-6  # keyframe's 7 digits
        assert np.abs(home[nm][0][:3, :3] - d.xmat[b].reshape(3, 3)).max() < 1e-6
    rng = np.random.default_rng(11)
    worst = 0.0
    for _ in range(30):
        q = mech.home.copy()
        q[mech.independent] += rng.uniform(-0.5, 0.5, len(mech.independent))
        q = fk(mech, q[mech.independent][None], frames=[]).q[0]
        worst = max(worst, _compare(m, mech, q)[0])
    assert worst <= TOL, worst


def test_nonlinear_joint_equality_is_refused_with_its_line(tmp_path):
    path = tmp_path / "g.xml"
    path.write_text(GRIPPER.replace('polycoef="0.02 -1 0 0 0"', 'polycoef="0 1 0.5 0 0"'))
    with pytest.raises(ConfigError) as exc:
        load_mechanism(path)
    (msg,) = exc.value.problems if hasattr(exc.value, "problems") else [str(exc.value)]
    line = GRIPPER.splitlines().index(next(x for x in GRIPPER.splitlines() if "polycoef" in x)) + 1
    assert msg.startswith(f"{path}:{line}: equality/joint (unnamed, 1.).polycoef: nonlinear")
    assert "fix:" in msg


def test_floating_base_rpy_matches_matrix_from_rpy():
    # the virtual chain's R = Rz(yaw) Ry(pitch) Rx(roll) is the URDF rpy of mechkin's frames
    r, p, y = 0.3, -0.4, 1.1
    assert np.allclose(_rz(y) @ _ry(p) @ _rx(r), matrix_from_rpy(np.array([r, p, y])),
                       atol=1e-15)


def test_mjcf_path_is_named_not_the_robot(tmp_path):
    path = tmp_path / "two_free.xml"
    path.write_text("<mujoco model='robotname'><worldbody>\n<body name='a'><freejoint/>"
                    "<geom size='0.1'/></body>\n<body name='b'>\n<freejoint/><geom size='0.1'/>"
                    "</body></worldbody></mujoco>")
    with pytest.raises(ConfigError) as exc:
        load_mechanism(path)
    msg = str(exc.value)
    assert msg.startswith(f"{path}:4: body[b].freejoint") and "fix:" in msg
    assert Path(path).name in msg


def test_sidecar_names_ball_joint_components(tmp_path):
    path = tmp_path / "biped.xml"
    path.write_text(_biped(MESH_GEOM))
    plain = load_mechanism(path)
    (tmp_path / "biped.mechkin.yaml").write_text("home: {left_hip_2: 0.25}\n"
                                                 "end_effector: left_sole\n")
    mech = load_mechanism(path)
    i = mech.joint_index("left_hip_2")
    assert mech.home[i] == 0.25 and plain.home[i] != 0.25
    j = mech.joint_index("left_hip_1")  # the other components keep the keyframe's values
    assert mech.home[j] == plain.home[j]
    assert mech.frame_names[mech.end_effector] == "left_sole"


TENDON = """<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="a"><joint name="ja" axis="0 0 1" ref="0.1"/><geom size="0.1"/>
      <body name="b" pos="0.2 0 0"><joint name="jb" axis="0 0 1"/><geom size="0.1"/>
        <site name="tip" pos="0.2 0 0"/></body>
    </body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="ja" coef="1"/><joint joint="jb" coef="-2"/></fixed>
  </tendon>
  <equality><tendon tendon1="t" polycoef="0.05 0 0 0 0"/></equality>
</mujoco>
"""


def test_fixed_tendon_of_two_joints_is_a_coupling(tmp_path):
    path = tmp_path / "tendon.xml"
    path.write_text(TENDON)
    mech = load_mechanism(path)
    (c,) = mech.couplings
    assert (mech.joint_names[c.joint], mech.joint_names[c.master]) == ("jb", "ja")
    m = mujoco.MjModel.from_xml_path(str(path))
    worst = worst_viol = 0.0
    for qa in np.linspace(-1.0, 1.0, 7):
        q = fk(mech, [[qa]], frames=[]).q[0]
        err, viol = _compare(m, mech, q)  # MuJoCo's tendon-equality residual at mechkin's q
        worst, worst_viol = max(worst, err), max(worst_viol, viol)
    assert worst <= TOL and worst_viol <= TOL, (worst, worst_viol)
