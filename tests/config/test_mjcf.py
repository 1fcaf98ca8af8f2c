"""MJCF import through MuJoCo's compiler (mechkin.config.mjcf), checked against MuJoCo itself.

tests/data/fourbar_mjcf.xml (site <connect>) and five_bar_mjcf.xml (body <connect> whose second
anchor MuJoCo's compiler computes, joint refs = home) are imported; for actuated joint values
near home, mechkin's loop-closure FK (Newton, kim1995 §5.1) must equal the configuration MuJoCo
reaches when it enforces its own equality constraints with the actuated joints held:

MuJoCo's constraints are soft: each step drives the violation r like a damped spring
(``a_ref = -b r' - k r``, solref time constant tc). We set tc = 2 dt (the stiffest stable), turn
contacts off (the capsules at a shared pin would otherwise push back and leave a millimetre
gap), give the held joints a huge armature (constraint forces then move only the passive
joints), zero the velocities every step (a heavily damped projection) and hold the actuated
qpos, and switch off the solver's early exit (``opt.tolerance``; at the default 1e-8 the
violation stalls near 1e-6); r then shrinks about 25 % per step, so after 600 steps it is at
MuJoCo's solver floor (~1e-11 here; the weld's rotation part needs 2000 steps). The test
allows 1e-8 rad and m: three orders above that floor, far below any modelling error (a wrong
anchor or axis would show at 1e-3).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import mechkin  # noqa: E402
from mechkin.errors import ConfigError  # noqa: E402
from mechkin.model import load_mechanism  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "data"
TOL = 1e-8


def _mujoco_closure(path: Path, targets: np.ndarray, steps: int = 600):
    """MuJoCo's constrained configuration for each row of actuated joint values."""
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    m.opt.gravity[:] = 0
    m.opt.tolerance = 1e-15  # no early exit of the constraint solver (default 1e-8 stalls ~1e-6)
    m.eq_solref[:] = [2 * m.opt.timestep, 1.0]
    jnt = [int(m.actuator_trnid[a, 0]) for a in range(m.nu)]
    act = [int(m.jnt_qposadr[j]) for j in jnt]
    m.dof_armature[[int(m.jnt_dofadr[j]) for j in jnt]] = 1e8
    d = mujoco.MjData(m)
    key = [k for k in range(m.nkey) if mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_KEY, k) == "home"]
    q0 = m.key_qpos[key[0]].copy() if key else m.qpos0.copy()
    out = []
    for t in targets:
        d.qpos[:] = q0
        for s in range(steps):  # ramp the held joints to the target over the first 200 steps
            w = min(1.0, (s + 1) / 200)
            d.qpos[act] = (1 - w) * q0[act] + w * t
            d.qvel[:] = 0
            mujoco.mj_step(m, d)
        d.qpos[act] = t
        mujoco.mj_forward(m, d)
        out.append((d.qpos.copy(), d.xpos.copy(), d.site_xpos.copy(),
                    float(np.abs(d.efc_pos[:d.ne]).max())))
    return m, out


@pytest.mark.parametrize("name", ["fourbar_mjcf", "five_bar_mjcf"])
def test_loop_closure_equals_mujoco(name):
    path = DATA / f"{name}.xml"
    mech = load_mechanism(path)
    assert len(mech.cuts) == 1
    nv = len(mech.independent)
    assert nv == {"fourbar_mjcf": 1, "five_bar_mjcf": 2}[name]  # the actuated joints
    rng = np.random.default_rng(5)
    targets = mech.home[mech.independent] + rng.uniform(-0.25, 0.25, (6, nv))
    m, out = _mujoco_closure(path, targets)
    frames = list(mech.frame_names)
    res = mechkin.fk(mech, targets, frames=frames)
    assert all(s == "converged" for s in res.status)
    obj = mujoco.mjtObj
    for i, (qpos, xpos, site_xpos, viol) in enumerate(out):
        assert viol < TOL  # MuJoCo converged (else the comparison means nothing)
        for k, jn in enumerate(mech.joint_names):  # mechkin q = MuJoCo qpos (offset -qpos0)
            adr = m.jnt_qposadr[mujoco.mj_name2id(m, obj.mjOBJ_JOINT, jn)]
            assert abs(res.q[i, k] - qpos[adr]) < TOL, (jn, res.q[i, k], qpos[adr])
        for b in range(1, m.nbody):
            bn = mujoco.mj_id2name(m, obj.mjOBJ_BODY, b)
            assert np.abs(res.poses[bn][i, :3, 3] - xpos[b]).max() < TOL
        for s in range(m.nsite):
            sn = mujoco.mj_id2name(m, obj.mjOBJ_SITE, s)
            assert np.abs(res.poses[sn][i, :3, 3] - site_xpos[s]).max() < TOL


WELD = """<mujoco model="weld_chain">
  <option gravity="0 0 0"/>
  <default><geom type="capsule" size="0.01"/></default>
  <worldbody>
    <body name="anchor" pos="1.0 0.3 0" euler="0 0 30"/>
    <body name="l1"><joint name="j1" axis="0 0 1"/><geom fromto="0 0 0 0.3 0 0"/>
      <body name="l2" pos="0.3 0 0" euler="0 0 50"><joint name="j2" axis="0 0 1"/>
        <geom fromto="0 0 0 0.3 0 0"/>
        <body name="l3" pos="0.3 0 0" euler="0 0 -70"><joint name="j3" axis="0 0 1" pos="0.05 0 0"/>
          <geom fromto="0 0 0 0.3 0 0"/>
          <body name="tip" pos="0.3 0 0" euler="0 0 10"><joint name="j4" axis="0 0 1"/>
            <geom fromto="0 0 0 0.2 0 0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <equality><weld name="w" body1="tip" body2="anchor" anchor="0.1 0 0"/></equality>
  <actuator><motor joint="j1"/></actuator>
</mujoco>
"""


def test_weld_is_a_full_cut_and_matches_mujoco(tmp_path):
    """A planar RRRR chain (bent at qpos0: a straight one is a constraint singularity) welded
    to a body in the world: MuJoCo's compiler sets the relative pose from qpos0 (body1's
    relpos/relquat, the anchor on body2); a hinge off its body origin (j3 at pos 0.05)
    exercises the anchor-offset frames."""
    p = tmp_path / "weld.xml"
    p.write_text(WELD)
    mech = load_mechanism(p)
    assert mech.cuts[0].mask.all()
    assert "l3" in mech.frame_names and "l3_j3" in mech.link_names
    targets = np.array([[0.15], [-0.2], [0.3]])
    m, out = _mujoco_closure(p, targets, steps=2000)  # the weld's rotation part is slower
    res = mechkin.fk(mech, targets, frames=list(mech.frame_names))
    assert all(s == "converged" for s in res.status)
    for i, (qpos, xpos, _, viol) in enumerate(out):
        assert viol < TOL
        assert np.abs(res.q[i] - qpos).max() < TOL
        for b in range(1, m.nbody):
            bn = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)
            assert np.abs(res.poses[bn][i, :3, 3] - xpos[b]).max() < TOL


def test_unsupported_mjcf_is_a_config_error(tmp_path):
    free = tmp_path / "free.xml"  # a free body: a floating base now (issue 25)
    free.write_text('<mujoco>\n<worldbody>\n<body name="b">\n<freejoint name="f"/>\n'
                    '<geom size="0.1"/>\n</body>\n</worldbody>\n</mujoco>\n')
    mech = load_mechanism(free)
    assert mech.floating and mech.n == 6
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco>\n<worldbody>\n<body name='b'><joint type='wobble'/></body>\n"
                   "</worldbody>\n</mujoco>\n")
    with pytest.raises(ConfigError, match=r"bad\.xml:\d+: MJCF: "):
        load_mechanism(bad)
    coupled = tmp_path / "coupled.xml"  # a linear joint equality is a coupling now
    coupled.write_text(WELD.replace('<weld name="w" body1="tip" body2="anchor" anchor="0.1 0 0"/>',
                                    '<joint name="c" joint1="j1" joint2="j2"/>'))
    assert len(load_mechanism(coupled).couplings) == 1
    nonlin = tmp_path / "nonlin.xml"
    nonlin.write_text(WELD.replace(
        '<weld name="w" body1="tip" body2="anchor" anchor="0.1 0 0"/>',
        '<joint name="c" joint1="j1" joint2="j2" polycoef="0 1 2 0 0"/>'))
    with pytest.raises(ConfigError, match=r"nonlin\.xml:18: equality/joint\[c\]\.polycoef: "
                                          r"nonlinear.*fix: "):
        load_mechanism(nonlin)


def test_cli_import_mjcf_with_sidecar(tmp_path):
    """``mechkin import`` of the MJCF five-bar, end effector from a sidecar: the YAML written
    has the same loop-closure FK as the MJCF itself."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    side = tmp_path / "side.yaml"
    side.write_text("end_effector: P\nname: five_bar_from_mjcf\n")
    out = tmp_path / "fb.yaml"
    run = subprocess.run([sys.executable, "-m", "mechkin", "import",
                          str(DATA / "five_bar_mjcf.xml"), "--sidecar", str(side), "-o", str(out)],
                         capture_output=True, text=True, timeout=120,
                         env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin",
                              "NUMBA_CACHE_DIR": os.environ["NUMBA_CACHE_DIR"]})
    assert run.returncode == 0, run.stderr
    a, b = load_mechanism(DATA / "five_bar_mjcf.xml"), load_mechanism(out)
    assert b.name == "five_bar_from_mjcf" and b.frame_names[b.end_effector] == "P"
    qv = np.radians([[135.0, 45.0], [120.0, 50.0]])
    ra, rb = mechkin.fk(a, qv, frames=["P"]), mechkin.fk(b, qv, frames=["P"])
    assert np.abs(ra.poses["P"] - rb.poses["P"]).max() < 1e-12
