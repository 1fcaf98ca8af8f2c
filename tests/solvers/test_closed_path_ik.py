r"""Path IK and tracking of closed chains (issue 11 item 3): ``mechkin track`` on the kim1995
direct-drive arm and Stewart platform.

Cross-checks:

- the joint map ``q(r)`` closes the loops and puts the hand on the line (forward kinematics);
  its r-derivatives (dependent joints included) against finite differences of ``q(r)``;
- the torques of the realised plan at its peak node against Lagrange's equation evaluated by
  finite differences of energies computed from the loop closure and forward kinematics only
  (:func:`lagrange_torques`: no Newton-Euler, no closure derivatives, no ``S``);
- the bundled track scenarios run with exit 0 and their ``expect:`` entries hold.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mechkin.config.scenario import load_scenario
from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.solvers.dynamics.closed_chain import ClosedChainDynamics
from mechkin.solvers.track.closed_path_ik import ClosedHandLineIK, ClosedHandPathIK
from mechkin.solvers.track.path_geometry import ArcGeometry, SlerpOrientation
from mechkin.spatial.rotations import matrix_from_rpy
from mechkin.tasks import track

ROOT = Path(__file__).resolve().parents[2]
D1 = np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / 12.0  # 5-point first derivative, O(h^4)
D2 = np.array([-1.0, 16.0, -30.0, 16.0, -1.0]) / 12.0  # 5-point second derivative, O(h^4)
OFFS = np.arange(-2, 3)


def _closer(mech, q_ref: np.ndarray):
    """q_v (m, n_v) -> assembled q (m, n), the loops closed from q_ref (one assembly mode)."""
    def close(qv: np.ndarray) -> np.ndarray:
        res = solve_closure(mech, qv, np.broadcast_to(q_ref[mech.dependent],
                                                      (qv.shape[0], len(mech.dependent))))
        assert res.ok.all()
        return res.q
    return close


def _kinetic(mech, close, qv: np.ndarray, dirs: np.ndarray, eps: float = 1e-3) -> np.ndarray:
    """KE (m,) at q_v (n_v,) for independent rates ``dirs (m, n_v)``: link velocities from
    the 5-point difference of link poses along q_v + s * dirs (closure and FK only)."""
    m = dirs.shape[0]
    qs = close((qv[None, None, :] + eps * OFFS[None, :, None] * dirs[:, None, :])
               .reshape(-1, qv.size))
    T = forward_kinematics(mech, qs).T_links.reshape((m, 5) + (mech.n_links, 4, 4))
    R = T[..., :3, :3]
    c = (R @ mech.com[None, None, :, :, None])[..., 0] + T[..., :3, 3]
    dc = np.einsum("k,mkli->mli", D1, c) / eps
    dR = np.einsum("k,mklij->mlij", D1, R) / eps
    W = dR @ np.swapaxes(R[:, 2], -1, -2)
    w = np.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], axis=-1)
    Iw = np.einsum("mlij,ljk,mlnk,mln->mli", R[:, 2], mech.inertia, R[:, 2], w)
    return 0.5 * (np.einsum("l,mli,mli->m", mech.mass, dc, dc) + np.einsum("mli,mli->m", w, Iw))


def _mass_matrix(mech, close, qv: np.ndarray) -> np.ndarray:
    """M(q_v) (n_v, n_v) by polarisation of the (quadratic) kinetic energy."""
    nv = qv.size
    E = np.eye(nv)
    pairs = [(i, j) for i in range(nv) for j in range(i + 1, nv)]
    dirs = np.vstack([E] + [E[i] + E[j] for i, j in pairs]) if pairs else E
    ke = _kinetic(mech, close, qv, dirs)
    M = np.diag(2.0 * ke[:nv])
    for k, (i, j) in enumerate(pairs):
        M[i, j] = M[j, i] = ke[nv + k] - ke[i] - ke[j]
    return M


def lagrange_torques(mech, q_ref: np.ndarray, qv: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                     h: float = 1e-3) -> np.ndarray:
    r"""Independent-joint torques by Lagrange's equation, energies from FK and closure only.

    With ``T = 1/2 qd^T M(q_v) qd`` and ``V(q_v) = -sum m_l g . c_l``:
    ``tau = M qdd + (dM/dt) qd - 1/2 d/dq_v (qd^T M qd) + dV/dq_v``, ``dM/dt`` the 5-point
    difference of M along ``q_v + s qd``, the gradients 5-point differences over each q_v.
    """
    close = _closer(mech, q_ref)
    nv = qv.size
    M = _mass_matrix(mech, close, qv)
    Ms = [_mass_matrix(mech, close, qv + h * k * qd) for k in OFFS]
    dM = np.tensordot(D1, np.array(Ms), axes=1) / h
    dT = np.empty(nv)
    dV = np.empty(nv)
    for i in range(nv):
        pts = qv[None] + h * OFFS[:, None] * np.eye(nv)[i]
        dT[i] = D1 @ np.array([_kinetic(mech, close, p, qd[None])[0] for p in pts]) / h
        qs = close(pts)
        c = (forward_kinematics(mech, qs).T_links[..., :3, :3] @ mech.com[None, :, :, None]
             )[..., 0] + forward_kinematics(mech, qs).T_links[..., :3, 3]
        V = -np.einsum("l,kli,i->k", mech.mass, c, mech.gravity)
        dV[i] = D1 @ V / h
    return M @ qdd + dM @ qd - dT + dV


# ---- the Lagrange reference itself agrees with Newton-Euler at random states ------------------

@pytest.mark.parametrize("name", ["kim1995_direct_drive", "kim1995_stewart"])
def test_lagrange_by_differences_equals_projected_newton_euler(name: str) -> None:
    """Every independent joint, not only the power: tau_v (tree RNEA projected by virtual work)
    equals Lagrange's equation with energies from closure + FK only, to 1e-6 relative."""
    mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
    rng = np.random.default_rng(5)
    home = solve_closure(mech, mech.home[mech.independent][None],
                         mech.home[mech.dependent][None]).q[0]
    dyn = ClosedChainDynamics(mech)
    scale = np.where(mech.s[mech.independent] == 1, 0.5, 0.3)
    qv = home[mech.independent] + rng.uniform(-1, 1, scale.size) * scale
    q = _closer(mech, home)(qv[None])
    qd, qdd = rng.normal(size=scale.size), rng.normal(size=scale.size)
    ref = lagrange_torques(mech, home, qv, qd, qdd)
    got = dyn.independent_torques(q, qd[None], qdd[None])[0]
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-6 * np.abs(ref).max())


# ---- the path IK of a closed chain --------------------------------------------------------------

def _dd_ik() -> ClosedHandLineIK:
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_direct_drive.yaml")
    q0 = mech.home.copy()
    q0[mech.independent] = np.deg2rad([20.0, 20.0, 10.0])
    p0 = np.array([-0.28793852, -0.10480105, 0.65711504])
    return ClosedHandLineIK(mech, mech.end_effector, p0, p0 + [0, 0.3, 0], q0, 1e-10)


def _stewart_ik() -> ClosedHandLineIK:
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_stewart.yaml")
    return ClosedHandLineIK(mech, mech.end_effector, np.array([0.0, 0, 12]),
                            np.array([2.0, 0, 12]), mech.home, 1e-10,
                            mask=("x", "y", "z", "rx", "ry", "rz"), tol_rot=1e-10)


def _dd_arc_ik() -> ClosedHandPathIK:
    """The direct-drive arm's tool on a horizontal arc (position only: 3 motors)."""
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_direct_drive.yaml")
    q0 = mech.home.copy()
    q0[mech.independent] = np.deg2rad([20.0, 20.0, 10.0])
    p0 = np.array([-0.28793852, -0.10480105, 0.65711504])
    arc = ArcGeometry(p0, p0 + [-0.05, 0.15, 0.0], p0 + [0.0, 0.3, 0.0])
    return ClosedHandPathIK(mech, mech.end_effector, arc, q0, 1e-10)


def _stewart_arc_slerp_ik() -> ClosedHandPathIK:
    """The Stewart plate on a vertical arc while it turns 10 deg about z and 5 deg about x
    (slerp): the whole 6-D pose varies with r."""
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_stewart.yaml")
    arc = ArcGeometry(np.array([0.0, 0, 12]), np.array([1.0, 0, 12.5]), np.array([2.0, 0, 12]))
    R0 = forward_kinematics(mech, mech.home[None]).frames(mech, [mech.end_effector])[0, 0, :3, :3]
    R1 = matrix_from_rpy(np.deg2rad([5.0, 0.0, 10.0])) @ R0
    slerp = SlerpOrientation(np.stack([R0, R1]), np.array([0.0, 1.0]))
    return ClosedHandPathIK(mech, mech.end_effector, arc, mech.home, 1e-10,
                            mask=("x", "y", "z", "rx", "ry", "rz"), tol_rot=1e-10,
                            orientation=slerp)


@pytest.mark.parametrize("make", [_dd_ik, _stewart_ik, _dd_arc_ik, _stewart_arc_slerp_ik],
                         ids=["direct_drive", "stewart", "direct_drive_arc", "stewart_arc_slerp"])
def test_closed_path_ik_closes_the_loops_and_follows_the_line(make) -> None:
    ik = make()
    mech = ik.closed_mech
    assert ik.n_joints == mech.n and ik.n == len(mech.independent) and ik.redundancy == 0
    r = np.linspace(0.0, 1.0, 21)
    q = ik.q(r)
    kin = forward_kinematics(mech, q)
    assert np.abs(closure_residual(mech, kin)).max() < 1e-10
    assert ik.pose_errors(q, r)["max_position_error_m"] < 1e-9
    if ik.orientation_held:
        assert ik.pose_errors(q, r)["max_orientation_error_rad"] < 1e-9
    # the independent joints' limits and the passive joints' are inside the mechanism's
    assert np.all(q >= mech.lower - 1e-12) and np.all(q <= mech.upper + 1e-12)
    # r-derivatives of all joints (the dependent ones through the closure) vs differences:
    # f' against q(r) (step 1e-2: the IK's 1e-10 tolerance is noise of ~1e-8 after division),
    # f'' against f'(r) (a smooth function of the solved q)
    rr = r[3:-3]
    h = 1e-2
    fd1 = np.tensordot(D1, np.array([ik.q(rr + k * h) for k in OFFS]), axes=1) / h
    h = 1e-3
    fd2 = np.tensordot(D1, np.array([ik.dq(rr + k * h) for k in OFFS]), axes=1) / h
    f1, f2 = ik.dq(rr), ik.ddq(rr)
    np.testing.assert_allclose(f1, fd1, rtol=0, atol=1e-6 * max(1.0, np.abs(f1).max()))
    np.testing.assert_allclose(f2, fd2, rtol=0, atol=1e-6 * max(1.0, np.abs(f2).max()))


def test_closed_path_ik_bad_start_is_located() -> None:
    from mechkin.solvers.track.path_ik import PathIKError

    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_direct_drive.yaml")
    with pytest.raises(PathIKError, match="cannot reach") as exc:
        ClosedHandLineIK(mech, mech.end_effector, np.array([2.0, 0, 0.5]), np.array([2.0, 1, 0.5]),
                         mech.home, 1e-10)
    assert exc.value.key == "start"


# ---- the bundled track scenarios ----------------------------------------------------------------

@pytest.mark.parametrize("name", ["kim1995_direct_drive_track", "kim1995_stewart_track"])
def test_plan_torques_equal_lagrange_at_the_peak(name: str) -> None:
    """The realised plan: at the node of the largest torque the DP's torques equal Lagrange's
    equation (energies from closure + FK) with q_v', q_v'' from differences of the path's
    q_v(r); the plan holds every limit and its expect entries (the peak torques typed in the
    scenario are these verified values)."""
    sc = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    rep = track.run(sc)
    assert rep.solver_ok and all(c["ok"] for c in rep.checks), rep.checks
    traj = rep.data.trajectory
    mech = load_mechanism(sc.mechanism_path)
    iv = mech.independent
    assert np.all(traj.torque[:, mech.dependent] == 0.0)
    k = int(np.argmax(np.abs(traj.torque[:, iv]).max(axis=1)))
    ik = track.hand_ik(sc, mech)
    h = 1e-3
    r = traj.r[k]
    qv = np.array([ik.q(np.array([r + j * h]))[0, iv] for j in OFFS])
    f1 = D1 @ qv / h
    f2 = D2 @ qv / h**2
    qd = f1 * traj.rd[k]
    qdd = f2 * traj.rd[k] ** 2 + f1 * traj.rdd[k]
    ref = lagrange_torques(mech, traj.q[k], qv[2], qd, qdd)
    got = traj.torque[k, iv]
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-5 * np.abs(ref).max())


@pytest.mark.parametrize("name", ["kim1995_direct_drive_track", "kim1995_stewart_track"])
def test_closed_track_scenarios_exit_0(tmp_path: Path, name: str) -> None:
    from typer.testing import CliRunner

    from mechkin.cli.app import app

    res = CliRunner().invoke(app, ["track", str(ROOT / "scenarios" / f"{name}.yaml"), "--out",
                                   str(tmp_path / "o"), "--no-plots"])
    assert res.exit_code == 0, res.output
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["status"] == "ok" and s["limits_ok"] and all(c["ok"] for c in s["expect"])
