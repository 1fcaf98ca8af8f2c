"""URDF import and export (mechkin.config.urdf, mechkin.io.urdf_out).

The three arm URDFs in tests/data are written by ``arm_urdf`` below from parameters typed here
with their sources -- not by mechkin's exporter -- and committed (``python
tests/config/test_urdf.py`` rewrites them; a test checks they are unchanged):

- PUMA 560: standard D-H of Corke's Robotics Toolbox for Python ``models.DH.Puma560``
  (d1 = 0.67183 m as in mechanisms/puma560.yaml); each D-H link i is a URDF link placed by a
  revolute joint about z of frame i-1 (origin identity) moving ``<link>_axis``, then a fixed
  joint ``xyz = (a, 0, d), rpy = (alpha, 0, 0)`` = Tz(d) Tx(a) Rx(alpha);
- UR5: Universal Robots' published standard D-H (d1 0.089159, a2 -0.425, a3 -0.39225,
  d4 0.10915, d5 0.09465, d6 0.0823 m), the same construction;
- Panda: franka_description ``panda_arm.xacro`` joint origins (xyz, rpy with the exact pi/2 for
  their 1.5708 -- the D-H table is exact), flange ``joint8`` 0.107 m, hand rpy (0, 0, -pi/4),
  TCP 0.1034 m (franka_hand.xacro).

Each is imported and its FK compared with the bundled YAML (independently typed D-H) to 1e-12
at random configurations; every bundled mechanism goes YAML -> URDF -> YAML with the same FK
(closed chains: loop-closure FK, the cuts carried by the mechkin:cut elements); Pinocchio (if
installed) loads every exported URDF with the same spanning-tree FK.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("yourdfpy")

from mechkin.config.urdf import read_urdf_spec  # noqa: E402
from mechkin.errors import ConfigError  # noqa: E402
from mechkin.io.urdf_out import mechanism_to_urdf  # noqa: E402
from mechkin.model import load_mechanism  # noqa: E402
from mechkin.model.kinematics import frame_poses  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
MECHS = sorted((ROOT / "mechanisms").glob("*.yaml"))
PI2 = math.pi / 2
D = math.pi / 180

# (name, a, alpha, d, limits deg) -- Robotics Toolbox for Python models.DH.Puma560
PUMA_DH = [("link1", 0.0, PI2, 0.67183, 160), ("link2", 0.4318, 0.0, 0.0, 110),
           ("link3", 0.0203, -PI2, 0.15005, 135), ("link4", 0.0, PI2, 0.4318, 266),
           ("link5", 0.0, -PI2, 0.0, 100), ("link6", 0.0, 0.0, 0.0, 266)]
# Universal Robots, "DH parameters for calculations of kinematics and dynamics" (UR5)
UR5_DH = [("shoulder", 0.0, PI2, 0.089159, 360), ("upper_arm", -0.425, 0.0, 0.0, 360),
          ("forearm", -0.39225, 0.0, 0.0, 360), ("wrist1", 0.0, PI2, 0.10915, 360),
          ("wrist2", 0.0, -PI2, 0.09465, 360), ("wrist3", 0.0, 0.0, 0.0823, 360)]
# franka_description panda_arm.xacro: joint i origin (xyz, rpy) and limits (rad)
PANDA = [((0, 0, 0.333), (0, 0, 0), (-2.8973, 2.8973)),
         ((0, 0, 0), (-PI2, 0, 0), (-1.7628, 1.7628)),
         ((0, -0.316, 0), (PI2, 0, 0), (-2.8973, 2.8973)),
         ((0.0825, 0, 0), (PI2, 0, 0), (-3.0718, -0.0698)),
         ((-0.0825, 0.384, 0), (-PI2, 0, 0), (-2.8973, 2.8973)),
         ((0, 0, 0), (PI2, 0, 0), (-0.0175, 3.7525)),
         ((0.088, 0, 0), (PI2, 0, 0), (-2.8973, 2.8973))]


def _v(x) -> str:
    return " ".join(repr(float(v)) for v in x)


def _joint(name, typ, parent, child, xyz=(0, 0, 0), rpy=(0, 0, 0), lim=None) -> str:
    s = (f'  <joint name="{name}" type="{typ}">\n    <parent link="{parent}"/>'
         f'<child link="{child}"/>\n    <origin xyz="{_v(xyz)}" rpy="{_v(rpy)}"/>')
    if typ != "fixed":
        s += '\n    <axis xyz="0 0 1"/>'
    if lim is not None:
        s += f'\n    <limit lower="{lim[0]!r}" upper="{lim[1]!r}" effort="100" velocity="2"/>'
    return s + "\n  </joint>\n"


def arm_urdf(which: str) -> str:
    """The URDF text of puma560 | ur5 | panda from the typed parameters above."""
    links, joints = [], []
    if which in ("puma560", "ur5"):
        rows, prev = (PUMA_DH if which == "puma560" else UR5_DH), "base"
        links.append(prev)
        for i, (name, a, alpha, d, lim) in enumerate(rows):
            axis = f"{name}_axis"
            links += [axis, name]
            joints.append(_joint(f"q{i + 1}", "revolute", prev, axis,
                                 lim=(-lim * D, lim * D)))
            joints.append(_joint(f"{name}_dh", "fixed", axis, name, (a, 0, d), (alpha, 0, 0)))
            prev = name
        links.append("tool")
        joints.append(_joint("tool_joint", "fixed", prev, "tool"))
    else:
        links.append("link0")
        for i, (xyz, rpy, lim) in enumerate(PANDA):
            links.append(f"link{i + 1}")
            joints.append(_joint(f"q{i + 1}", "revolute", f"link{i}", f"link{i + 1}", xyz, rpy,
                                 lim))
        links += ["flange", "hand", "hand_tcp"]
        joints.append(_joint("joint8", "fixed", "link7", "flange", (0, 0, 0.107)))
        joints.append(_joint("hand_joint", "fixed", "flange", "hand", rpy=(0, 0, -math.pi / 4)))
        joints.append(_joint("tcp_joint", "fixed", "hand", "hand_tcp", (0, 0, 0.1034)))
    body = "".join(f'  <link name="{n}"/>\n' for n in links) + "".join(joints)
    return (f'<?xml version="1.0"?>\n<!-- {which}: generated by tests/config/test_urdf.py '
            f"from typed published parameters -->\n<robot name=\"{which}\">\n{body}</robot>\n")


@pytest.mark.parametrize("which", ["puma560", "panda", "ur5"])
def test_data_urdf_is_the_typed_parameters(which):
    assert (DATA / f"{which}.urdf").read_text() == arm_urdf(which)


def _q_within(mech, m, rng):
    lo = np.where(np.isfinite(mech.lower), mech.lower, -math.pi)
    hi = np.where(np.isfinite(mech.upper), mech.upper, math.pi)
    return rng.uniform(lo, hi, (m, mech.n))


def _compare_open(a, b, m=50, seed=7):
    """FK of every frame of ``a`` against the same-named frame of ``b`` (same joint names)."""
    rng = np.random.default_rng(seed)
    q = _q_within(a, m, rng)
    qb = np.zeros((m, b.n))
    qb[:, [b.joint_names.index(n) for n in a.joint_names]] = q
    Pa = frame_poses(a, q)
    Pb = frame_poses(b, qb)[:, [b.frame_names.index(n) for n in a.frame_names]]
    return float(np.abs(Pa - Pb).max())


@pytest.mark.parametrize("which", ["puma560", "panda", "ur5"])
def test_published_urdf_fk_equals_bundled_yaml(which):
    urdf = load_mechanism(DATA / f"{which}.urdf")
    yaml_mech = load_mechanism(ROOT / "mechanisms" / f"{which}.yaml")
    assert urdf.n == 6 + (which == "panda")
    err = _compare_open(yaml_mech, urdf)
    assert err < 1e-12, err
    # limits: imported in SI from the URDF
    k = urdf.joint_names.index("q2")
    assert urdf.upper[k] == pytest.approx(yaml_mech.upper[yaml_mech.joint_names.index("q2")],
                                          abs=1e-12)


def test_rpy_round_trip_is_exact_at_the_poles():
    """The importer's and exporter's rpy reproduce R to rounding error, also in gimbal lock
    (where asin-based formulas lose half the digits)."""
    from mechkin.io.urdf_out import rpy_of as _rpy  # the exporter uses the shared one
    from mechkin.spatial.rotations import matrix_from_rpy, rpy_of

    rng = np.random.default_rng(2)
    rpy = rng.uniform(-3, 3, (3000, 3))
    rpy[::2, 1] = np.sign(rpy[::2, 1]) * PI2 + rng.normal(size=1500) * 10.0 ** rng.uniform(
        -17, -3, 1500)
    for f in (rpy_of, _rpy):
        R = matrix_from_rpy(rpy)
        back = matrix_from_rpy(np.array([f(r) for r in R]))
        assert np.abs(back - R).max() < 2e-15


def _roundtrip(path: Path, tmp_path: Path):
    mech = load_mechanism(path)
    out = tmp_path / f"{path.stem}.urdf"
    out.write_text(mechanism_to_urdf(mech))
    return mech, load_mechanism(out), out


@pytest.mark.parametrize("path", MECHS, ids=[p.stem for p in MECHS])
def test_roundtrip_yaml_urdf_yaml_same_kinematics(path, tmp_path):
    import mechkin

    mech, back, _ = _roundtrip(path, tmp_path)
    assert set(mech.joint_names) == set(back.joint_names)
    assert [c.name for c in back.cuts] == [c.name for c in mech.cuts]
    for c, c2 in zip(mech.cuts, back.cuts, strict=True):
        assert np.array_equal(c.mask, c2.mask)
        assert back.frame_names[c2.a] == mech.frame_names[c.a]
        assert back.frame_names[c2.b] == mech.frame_names[c.b]
    assert [back.joint_names[i] for i in back.independent] == \
        [mech.joint_names[i] for i in mech.independent]
    assert (back.end_effector is None) == (mech.end_effector is None)
    if mech.end_effector is not None:
        assert back.frame_names[back.end_effector] == mech.frame_names[mech.end_effector]
    # the spanning tree at random joint values, every frame by name
    assert _compare_open(mech, back) < 1e-12
    if mech.cuts:  # loop-closure FK near home (the home values ride in mechkin:joint)
        rng = np.random.default_rng(3)
        qv = mech.home[mech.independent] + 0.02 * rng.standard_normal((5, len(mech.independent)))
        names = list(mech.frame_names)
        r1, r2 = mechkin.fk(mech, qv, frames=names), mechkin.fk(back, qv, frames=names)
        assert list(r1.status) == list(r2.status)
        err = max(float(np.abs(r1.poses[n] - r2.poses[n]).max()) for n in names)
        assert err < 1e-12, err
    # dynamics parameters survive too (lumped back onto the same bodies)
    for k, name in enumerate(mech.link_names):
        if name in back.link_names:
            j = back.link_names.index(name)
            assert back.mass[j] == pytest.approx(mech.mass[k], abs=1e-12)


def test_export_is_valid_for_pinocchio(tmp_path):
    pin = pytest.importorskip("pinocchio")
    rng = np.random.default_rng(11)
    for path in MECHS:
        mech, _, out = _roundtrip(path, tmp_path)
        model = pin.buildModelFromUrdf(str(out))
        data = model.createData()
        for _ in range(5):
            q = _q_within(mech, 1, rng)[0]
            qp = pin.neutral(model)
            for jid in range(1, model.njoints):
                jn, iq = model.names[jid], model.idx_qs[jid]
                v = q[mech.joint_names.index(jn)]
                if model.nqs[jid] == 2:  # continuous joint: (cos, sin)
                    qp[iq:iq + 2] = [math.cos(v), math.sin(v)]
                else:
                    qp[iq] = v
            pin.framesForwardKinematics(model, data, qp)
            P = frame_poses(mech, q[None])[0]
            for f, fname in enumerate(mech.frame_names):
                assert model.existFrame(fname), (path.stem, fname)
                M = data.oMf[model.getFrameId(fname)]
                assert np.abs(M.homogeneous - P[f]).max() < 1e-12, (path.stem, fname)


FOURBAR_TREE = """<?xml version="1.0"?>
<robot name="fourbar_urdf">
  <link name="ground"/>
  <link name="crank"/>
  <link name="coupler"/>
  <link name="rocker"/>
  <link name="coupler_end"/>
  <link name="rocker_end"/>
  <joint name="q_crank" type="continuous"><parent link="ground"/><child link="crank"/>
    <axis xyz="0 0 1"/></joint>
  <joint name="q_coupler" type="continuous"><parent link="crank"/><child link="coupler"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="q_rocker" type="continuous"><parent link="ground"/><child link="rocker"/>
    <origin xyz="1.0 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="coupler_end_joint" type="fixed"><parent link="coupler"/>
    <child link="coupler_end"/><origin xyz="1.0 0 0"/></joint>
  <joint name="rocker_end_joint" type="fixed"><parent link="rocker"/>
    <child link="rocker_end"/><origin xyz="0.8 0 0"/></joint>
  <transmission name="t1"><type>transmission_interface/SimpleTransmission</type></transmission>
  <gazebo reference="crank"><material>Gazebo/Red</material></gazebo>
</robot>
"""
FOURBAR_SIDECAR = """\
cuts:
  - {name: pin, frames: [coupler_end, rocker_end], mask: [x, y]}
independent: [q_crank]
end_effector: coupler_end
home: {q_crank: 1.0471975511965976, q_coupler: -0.6981317007977318, q_rocker: 1.5707963267948966}
"""


def test_closed_chain_from_sidecar_matches_yaml_fourbar(tmp_path, capsys):
    import mechkin

    (tmp_path / "fourbar.urdf").write_text(FOURBAR_TREE)
    (tmp_path / "fourbar.mechkin.yaml").write_text(FOURBAR_SIDECAR)
    mech = load_mechanism(tmp_path / "fourbar.urdf")
    err = capsys.readouterr().err
    assert "ignored 1 <gazebo>, 1 <transmission>" in err and len(err.strip().splitlines()) == 1
    ref = load_mechanism(DATA / "fourbar.yaml")
    assert [mech.joint_names[i] for i in mech.dependent] == ["q_coupler", "q_rocker"]
    qv = np.radians([[60.0], [75.0], [45.0]])
    names = ["coupler_end", "rocker_end", "coupler", "rocker"]
    r1, r2 = mechkin.fk(ref, qv, frames=names), mechkin.fk(mech, qv, frames=names)
    assert all(s == "converged" for s in r2.status)
    assert max(float(np.abs(r1.poses[n] - r2.poses[n]).max()) for n in names) < 1e-12
    # an edited sidecar is read again (load_mechanism's cache keys on it too)
    side = tmp_path / "fourbar.mechkin.yaml"
    side.write_text(FOURBAR_SIDECAR.replace("end_effector: coupler_end", "end_effector: rocker"))
    os.utime(side, ns=(side.stat().st_atime_ns, side.stat().st_mtime_ns + 10**9))
    again = load_mechanism(tmp_path / "fourbar.urdf")
    assert again.frame_names[again.end_effector] == "rocker"
    # --sidecar FILE: the same from elsewhere; a bad frame name is file:line of the sidecar
    bad = tmp_path / "bad.yaml"
    bad.write_text(FOURBAR_SIDECAR.replace("rocker_end]", "rocker_tip]"))
    with pytest.raises(ConfigError, match=r"bad\.yaml:2: cuts\[0\]\.frames: unknown frame "
                                          r"'rocker_tip'"):
        read_urdf_spec(tmp_path / "fourbar.urdf", sidecar=bad)


def test_closed_chain_without_sidecar_is_an_error_with_the_line(tmp_path):
    p = tmp_path / "loop.urdf"
    p.write_text(FOURBAR_TREE.replace(
        "</robot>", '  <joint name="pin" type="continuous"><parent link="coupler_end"/>'
        '<child link="rocker"/><axis xyz="0 0 1"/></joint>\n</robot>'))
    with pytest.raises(ConfigError) as exc:
        load_mechanism(p)
    msg = str(exc.value)
    assert f"{p}:21: joint[pin].child: link 'rocker' is already the child of joint " \
           "'q_rocker'" in msg and "sidecar" in msg


def test_mimic_joint_is_a_coupling(tmp_path):
    p = tmp_path / "mimic.urdf"
    p.write_text(FOURBAR_TREE.replace(
        '<origin xyz="1.0 0 0"/><axis xyz="0 0 1"/></joint>',
        '<origin xyz="1.0 0 0"/><axis xyz="0 0 1"/>\n    <mimic joint="q_crank" '
        'multiplier="2"/></joint>'))
    mech = load_mechanism(p)
    (c,) = mech.couplings
    assert (mech.joint_names[c.joint], mech.joint_names[c.master], c.multiplier, c.offset) \
        == ("q_rocker", "q_crank", 2.0, 0.0)
    assert "q_rocker" in mech.dependent_names


INERTIAL = """<?xml version="1.0"?>
<robot name="inertial">
  <link name="base"/>
  <link name="arm">
    <inertial><origin xyz="0.1 0.2 0.3" rpy="0.3 -0.4 1.1"/><mass value="2.0"/>
      <inertia ixx="0.5" ixy="0.01" ixz="-0.02" iyy="0.7" iyz="0.03" izz="0.9"/></inertial>
  </link>
  <link name="tool">
    <inertial><origin xyz="0 0 0.05"/><mass value="1.0"/>
      <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.2"/></inertial>
  </link>
  <joint name="q" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="t" type="fixed"><parent link="arm"/><child link="tool"/>
    <origin xyz="0.5 0 0" rpy="0 0 1.5707963267948966"/></joint>
</robot>
"""


def test_inertial_to_link_axes_and_fixed_links_lumped(tmp_path):
    """URDF inertia is about the com in the inertial frame; mechkin's in the link axes."""
    from scipy.spatial.transform import Rotation

    p = tmp_path / "inertial.urdf"
    p.write_text(INERTIAL)
    mech = load_mechanism(p)
    k = mech.link_names.index("arm")
    R1 = Rotation.from_euler("xyz", [0.3, -0.4, 1.1]).as_matrix()  # extrinsic x-y-z = URDF rpy
    I1 = R1 @ np.array([[0.5, 0.01, -0.02], [0.01, 0.7, 0.03], [-0.02, 0.03, 0.9]]) @ R1.T
    R2 = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    I2 = R2 @ np.diag([0.1, 0.1, 0.2]) @ R2.T
    c1, c2 = np.array([0.1, 0.2, 0.3]), np.array([0.5, 0, 0.05])
    c = (2 * c1 + c2) / 3
    pa = lambda m, d: m * (d @ d * np.eye(3) - np.outer(d, d))  # noqa: E731
    I_ref = I1 + pa(2.0, c1 - c) + I2 + pa(1.0, c2 - c)
    assert mech.mass[k] == pytest.approx(3.0)
    assert np.allclose(mech.com[k], c, atol=1e-15)
    assert np.abs(mech.inertia[k] - I_ref).max() < 1e-14
    assert "tool" in mech.frame_names and "tool" not in mech.link_names


def test_cli_import_export(tmp_path):
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin",
           "NUMBA_CACHE_DIR": os.environ["NUMBA_CACHE_DIR"]}
    yml = tmp_path / "ur5.yaml"
    run = subprocess.run([sys.executable, "-m", "mechkin", "import", str(DATA / "ur5.urdf"),
                          "-o", str(yml)], capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 0, run.stderr
    assert _compare_open(load_mechanism(ROOT / "mechanisms/ur5.yaml"), load_mechanism(yml)) \
        < 1e-12
    out = tmp_path / "five_bar.urdf"
    run = subprocess.run([sys.executable, "-m", "mechkin", "export",
                          str(ROOT / "mechanisms/five_bar.yaml"), "-o", str(out)],
                         capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 0, run.stderr
    text = out.read_text()
    assert '<mechkin:cut name="pin_P" frames="P P2" mask="x y"/>' in text
    assert "pin_P: P == P2 in x y -->" in text
    # a scenario runs on the URDF directly
    scen = tmp_path / "fb_fk.yaml"
    scen.write_text(f"name: fb_urdf_fk\ntask: fk\nmechanism: {out.name}\nunits: {{angle: deg}}\n"
                    "fk:\n  time: {start: 0, stop: 1, step: 0.5}\n  motion:\n"
                    "    q1: {type: ramp, from: 135, to: 125}\n"
                    "    q2: {type: constant, value: 45}\n")
    run = subprocess.run([sys.executable, "-m", "mechkin", "fk", str(scen), "--out",
                          str(tmp_path / "o"), "--no-plots", "--json"], capture_output=True,
                         text=True, env=env | {"MECHKIN_JIT": "0"}, timeout=300)
    assert run.returncode == 0, run.stderr + run.stdout
    bad = subprocess.run([sys.executable, "-m", "mechkin", "import", str(tmp_path / "no.urdf")],
                         capture_output=True, text=True, env=env, timeout=120)
    assert bad.returncode == 2 and "no.urdf: file not found" in bad.stderr


if __name__ == "__main__":  # rewrite tests/data/{puma560,panda,ur5}.urdf
    for w in ("puma560", "panda", "ur5"):
        (DATA / f"{w}.urdf").write_text(arm_urdf(w))
