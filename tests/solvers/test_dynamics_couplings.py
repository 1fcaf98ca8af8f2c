r"""Inverse dynamics with joint couplings (issue 25 item 1: "rates and accelerations follow it",
the track torques honour it). A coupling q_j = m q_i + c is a holonomic constraint row of phi
like a loop closure, so the coupled joint moves with its master (qd_j = m qd_i, qdd_j = m qdd_i)
and by virtual work the master's torque carries m times the coupled joint's:
tau_i = tau_tree,i + m tau_tree,j (mechkin.solvers.dynamics.closed_chain).

Cross-checks, each independent of the code under test:

- Pinocchio's own mimic joints (``buildModelFromUrdf(..., mimic=True)``: a JointModelMimic, its
  RNEA in the reduced velocity space) on a small 3-D arm with a mimic joint (general inertias,
  a skewed axis, multiplier -0.6, offset 0.2) and on example-robot-data's Panda (mimic finger);
- Pinocchio's RNEA of the unconstrained tree (mimic ignored), projected by hand with the
  coupling Jacobian;
- mechkin track on a planar 3R arm whose third joint is coupled to the second: the torques of
  the plan equal mechkin's other recursion (:class:`SerialChainDynamics`, link frames) of the
  uncoupled arm at the plan's q, qd, qdd, projected the same way.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mechkin
from mechkin.solvers.dynamics.closed_chain import ClosedChainDynamics
from mechkin.solvers.dynamics.from_mechanism import dynamics_from_mechanism

pin = pytest.importorskip("pinocchio")

ROOT = Path(__file__).resolve().parents[2]
MULT, OFF = -0.6, 0.2
ARM = f"""<robot name="mimic_arm">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0.2 0.01 0" rpy="0.1 0 0"/><mass value="2.0"/>
    <inertia ixx="0.01" ixy="0.001" ixz="0" iyy="0.03" iyz="0.002" izz="0.025"/></inertial>
  </link>
  <link name="l2"><inertial><origin xyz="0.15 0 0.02"/><mass value="1.2"/>
    <inertia ixx="0.004" ixy="0" ixz="0.0005" iyy="0.012" iyz="0" izz="0.011"/></inertial>
  </link>
  <link name="l3"><inertial><origin xyz="0.1 -0.02 0"/><mass value="0.7"/>
    <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.004" iyz="0.0003" izz="0.005"/></inertial>
  </link>
  <link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.4 0 0" rpy="1.5707963 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
    <mimic joint="j2" multiplier="{MULT}" offset="{OFF}"/></joint>
  <joint name="jt" type="fixed"><parent link="l3"/><child link="tool"/>
    <origin xyz="0.2 0 0"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    p = tmp_path_factory.mktemp("arm") / "mimic_arm.urdf"
    p.write_text(ARM)
    return p


def _states(rng, k: int):
    """k random (q, qd, qdd) (3,) of the arm with the coupling kept, and the independent parts."""
    for _ in range(k):
        qv, qdv, qddv = (rng.uniform(-2.0, 2.0, 2) for _ in range(3))
        q = np.array([qv[0], qv[1], MULT * qv[1] + OFF])
        qd = np.array([*qdv, MULT * qdv[1]])
        qdd = np.array([*qddv, MULT * qddv[1]])
        yield q, qd, qdd, qv, qdv, qddv


def test_coupled_arm_torques_equal_pinocchio_mimic_and_projected_tree(arm):
    mech = mechkin.load_mechanism(arm)
    assert mech.independent_names == ["j1", "j2"] and mech.dependent_names == ["j3"]
    dyn = dynamics_from_mechanism(mech)
    assert isinstance(dyn, ClosedChainDynamics)
    mimic = pin.buildModelFromUrdf(str(arm), mimic=True)
    tree = pin.buildModelFromUrdf(str(arm))  # the mimic tag ignored: three free joints
    assert (mimic.nv, tree.nv) == (2, 3)
    dm, dt = mimic.createData(), tree.createData()
    rng = np.random.default_rng(25)
    worst = 0.0
    for q, qd, qdd, qv, qdv, qddv in _states(rng, 30):
        got = dyn.inverse_dynamics(q[None], qd[None], qdd[None])[0]
        assert got[2] == 0.0  # the coupled joint has no motor
        ref = pin.rnea(mimic, dm, qv, qdv, qddv)
        t = pin.rnea(tree, dt, q, qd, qdd)
        by_hand = t[:2] + np.array([0.0, MULT]) * t[2]  # virtual work: J_c^T tau_tree
        scale = max(1.0, np.abs(ref).max())
        assert np.abs(got[:2] - ref).max() <= 1e-12 * scale
        assert np.abs(by_hand - ref).max() <= 1e-12 * scale
        worst = max(worst, float(np.abs(got[:2] - ref).max()))
        # the independent interface (q_v, qd_v, qdd_v) closes the coupling itself
        tv = dyn.independent(q).inverse_dynamics(qv[None], qdv[None], qddv[None])[0]
        assert np.abs(tv - ref).max() <= 1e-12 * scale
    assert worst < 1e-12


def test_coupled_joint_moves_with_its_master(arm):
    mech = mechkin.load_mechanism(arm)
    dyn = dynamics_from_mechanism(mech)
    rng = np.random.default_rng(3)
    for q, _, _, _, qdv, qddv in _states(rng, 5):
        mo = dyn.motion(q[None], qdv[None], qddv[None])
        assert mo.S[0] == pytest.approx(np.array([[0.0, MULT]]), abs=1e-15)
        assert mo.qd[0, 2] == pytest.approx(MULT * qdv[1], abs=1e-14)
        assert mo.qdd[0, 2] == pytest.approx(MULT * qddv[1], abs=1e-14)


def test_panda_mimic_finger_torques_equal_pinocchio():
    from tests.config.robot_files import pin_model, pin_q, random_q_v, robots_dir

    path = robots_dir() / "panda_description" / "urdf" / "panda.urdf"
    mech = mechkin.load_mechanism(path)
    assert mech.dependent_names == ["panda_finger_joint2"]
    _, model, data = pin_model(path)
    if model.mimic_from_xml:
        pytest.skip("this Pinocchio refuses the Panda's mimic joint")
    dyn = dynamics_from_mechanism(mech)
    rng = np.random.default_rng(7)
    qv = random_q_v(mech, rng, 20)
    for k in range(20):
        q = mech.assemble(qv[k], np.zeros(len(mech.dependent)))
        q[mech.joint_index("panda_finger_joint2")] = q[mech.joint_index("panda_finger_joint1")]
        qd_v, qdd_v = rng.uniform(-1.0, 1.0, (2, len(mech.independent)))
        tau = dyn.independent_torques(q[None], qd_v[None], qdd_v[None])[0]
        # Pinocchio's velocity vector: one entry per non-mimic joint, in its joint order
        order = [model.names[j] for j in range(1, model.njoints)
                 if model.joints[j].shortname() != "JointModelMimic"]
        col = [mech.independent_names.index(n) for n in order]
        ref = pin.rnea(model, data, pin_q(model, mech, q), qd_v[col], qdd_v[col])
        assert np.abs(tau[col] - ref).max() <= 1e-10 * max(1.0, np.abs(ref).max()), k


class _ProjectedSerial:
    """The uncoupled planar 3R arm's serial RNEA (all three joints move as given), its torques
    projected on the motors by the coupling q3 = -q2: (tau1, tau2 - tau3, 0)."""

    def __init__(self) -> None:
        mech = mechkin.load_mechanism(ROOT / "mechanisms" / "planar3r.yaml")
        self.free = dynamics_from_mechanism(mech)
        self.n_joints = 3

    def inverse_dynamics(self, q, qd, qdd):
        t = self.free.inverse_dynamics(q, qd, qdd)
        return np.column_stack([t[:, 0], t[:, 1] - t[:, 2], np.zeros(len(t))])


def test_track_torques_of_a_coupled_arm(tmp_path):
    """mechkin track on planar3r with q3 = -q2 (the last rod stays parallel to the first):
    the plan's motor torques (park Eq. (12) along the task's own joint path) equal the
    uncoupled arm's serial RNEA, projected; the coupled joint follows its master on the path."""
    from mechkin.solvers.track.path import path_torques
    from mechkin.tasks.track import hand_ik

    base = (ROOT / "mechanisms" / "planar3r.yaml").read_text()
    coupled = base.replace("independent: [q1, q2, q3]", "independent: [q1, q2]\ncouplings:\n"
                           "  - {joint: q3, master: q2, multiplier: -1.0, offset: 0}")
    assert coupled != base
    mp = tmp_path / "planar3r_coupled.yaml"
    mp.write_text(coupled.replace("name: planar3r", "name: planar3r_coupled"))
    sp = tmp_path / "track.yaml"
    sp.write_text(f"""name: coupled_track
task: track
mechanism: {mp}
track:
  objective: tracking
  path: {{start: [0.7794228634059948, 0.95], end: [0.3794228634059948, 0.95]}}
  conveyor: {{part_start: [0.8794228634059948, 0.95], belt_velocity: [-0.1, 0]}}
  grid: {{N1: 30, N2: 60, nt_fraction: 0.8}}
  limits: {{torque: [30, 8], qd: [0.5, 0.3]}}
  dynamics: rnea
outputs: {{csv: false, plots: false, mcap: false}}
""")
    rep = mechkin.run(sp)
    assert rep.summary["status"] == "ok", rep.summary.get("message")
    tr = rep.data.trajectory
    assert np.allclose(tr.q[:, 2], -tr.q[:, 1], atol=1e-12)
    assert np.allclose(tr.qd[:, 2], -tr.qd[:, 1], atol=1e-12)
    assert np.all(tr.torque[:, 2] == 0.0)  # the coupled joint has no motor
    sc = mechkin.load_scenario(sp)
    path = hand_ik(sc, mechkin.load_mechanism(mp))
    r = np.clip(tr.r, 0.0, 1.0)
    assert np.allclose(path.dq(r)[:, 2], -path.dq(r)[:, 1], atol=1e-12)
    assert np.allclose(path.ddq(r)[:, 2], -path.ddq(r)[:, 1], atol=1e-9)
    want = path_torques(_ProjectedSerial(), path, r, tr.rd, tr.rdd)
    scale = max(1.0, np.abs(want).max())
    assert np.abs(tr.torque - want).max() <= 1e-9 * scale
    assert np.abs(want[:, 1]).max() > 0.1  # the coupled joint's torque is in the master's
