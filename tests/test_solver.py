"""The public fast path: ``mechkin.fk`` on open chains and ``mechkin.Solver`` (issue 29).

Cross-checks: the open-chain route against the loop-closure route it replaces (the closure
solver's open-chain branch and the tree FK), bit for bit; the solver object against
``mechkin.fk`` / ``mechkin.ik``; closed chains unchanged.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mechkin
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import forward_kinematics

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def puma():
    return mechkin.load_mechanism(ROOT / "mechanisms/puma560.yaml")


def _closure_route(mech, qv, qw0, idx):
    """What mechkin.fk computed before the open-chain branch: the loop closure, then FK."""
    qw0 = np.broadcast_to(np.atleast_2d(qw0), (len(qv), len(mech.dependent)))
    res = solve_closure(mech, qv, qw0)
    T = forward_kinematics(mech, res.q).frames(mech, idx)
    return res, T


def test_open_chain_fk_equals_the_closure_route(puma):
    rng = np.random.default_rng(3)
    for m in (1, 5, 300):
        qv = rng.uniform(puma.lower, puma.upper, (m, 6))
        got = mechkin.fk(puma, qv, frames=["end_effector", puma.frame_names[3]])
        res, T = _closure_route(puma, qv, np.zeros(0), [puma.end_effector, 3])
        np.testing.assert_array_equal(got.q, res.q)
        np.testing.assert_allclose(got.poses["end_effector"], T[:, 0], rtol=0, atol=1e-14)
        np.testing.assert_allclose(got.poses[puma.frame_names[3]], T[:, 1], rtol=0, atol=1e-14)
        assert got.status == ["converged"] * m and got.ok
        np.testing.assert_array_equal(got.residual, res.residual)
        np.testing.assert_array_equal(got.iterations, res.iterations)
        assert got.joint_names == list(puma.joint_names)


def test_open_chain_with_a_held_joint_uses_q_w0(puma):
    """An open chain whose last joint is dependent (no cut): held at q_w0 (home by default),
    as the closure route did."""
    mech = dataclasses.replace(puma, independent=np.arange(5), dependent=np.array([5]))
    qv = np.array([[0.1, -0.4, 0.3, 0.2, 0.5], [0.0, 0.1, 0.2, 0.3, 0.4]])
    for qw0 in (None, [0.7], [[0.7], [-0.2]]):
        got = mechkin.fk(mech, qv, q_w0=qw0)
        ref_w = mech.home[[5]] if qw0 is None else np.asarray(qw0, float)
        res, T = _closure_route(mech, qv, ref_w, [mech.end_effector])
        np.testing.assert_array_equal(got.q, res.q)
        np.testing.assert_allclose(got.poses["end_effector"], T[:, 0], rtol=0, atol=1e-14)
    sol = mechkin.Solver(mech)
    np.testing.assert_array_equal(sol.pose(qv[0]), mechkin.fk(mech, qv[0]).poses["end_effector"][0])


def test_solver_single_and_batched_match_the_function(puma):
    sol = mechkin.Solver(puma)
    rng = np.random.default_rng(4)
    Q = rng.uniform(puma.lower, puma.upper, (20, 6))
    for q in Q[:5]:
        T = sol.pose(q)
        assert T.shape == (4, 4)
        np.testing.assert_array_equal(T, mechkin.fk(puma, q).poses["end_effector"][0])
        np.testing.assert_array_equal(T, sol.pose(list(q)))  # lists take the general path
        np.testing.assert_array_equal(T, sol.fk(q).poses["end_effector"][0])
    np.testing.assert_array_equal(sol.poses(Q)[:, 0], mechkin.fk(puma, Q).poses["end_effector"])
    r = sol.fk(Q)
    assert r.q.shape == (20, 6) and r.ok
    # a strided (non-contiguous) row and a Fortran array give the same bits
    F = np.asfortranarray(Q)
    np.testing.assert_array_equal(sol.pose(F[2]), sol.pose(Q[2]))
    np.testing.assert_array_equal(sol.fk(F).poses["end_effector"], r.poses["end_effector"])


def test_solver_results_are_fresh_arrays(puma):
    sol = mechkin.Solver(puma)
    q = np.full(6, 0.2)
    a = sol.pose(q)
    b = sol.pose(q)
    assert a is not b and not np.shares_memory(a, b)
    r = sol.fk(q)
    r.q[0, 0] = 9.0
    assert q[0] == 0.2


def test_solver_refuses_wrong_shapes_and_names(puma):
    sol = mechkin.Solver(puma)
    with pytest.raises(mechkin.ConfigError, match="q_v: expected 6 columns"):
        sol.pose(np.zeros(5))
    with pytest.raises(mechkin.ConfigError, match="q_v: expected 6 columns"):
        sol.fk(np.zeros((2, 7)))
    with pytest.raises(mechkin.ConfigError, match="frames: unknown frame"):
        mechkin.Solver(puma, frames=["nope"])
    with pytest.raises(mechkin.ConfigError, match="method"):
        mechkin.Solver(puma, method="newton")


def test_solver_ik_equals_the_function(puma):
    sol = mechkin.Solver(puma)
    rng = np.random.default_rng(5)
    T = mechkin.fk(puma, rng.uniform(puma.lower, puma.upper, (3, 6))).poses["end_effector"]
    one = sol.ik(T[0])
    ref = mechkin.ik(puma, T[0])[0]
    assert one.status == ref.status and one.ok
    np.testing.assert_array_equal(one.q, ref.q)
    many = sol.ik(T)
    assert [s.status for s in many] == [s.status for s in mechkin.ik(puma, T)]
    batch = sol.ik(T, batch=True)
    assert all(s.ok for s in batch)


def test_solver_on_a_closed_chain_calls_the_loop_closure():
    mech = mechkin.load_mechanism(ROOT / "mechanisms/kim1995_direct_drive.yaml")
    sol = mechkin.Solver(mech)
    qv = np.array([[0.3, 1.2, 0.5], [0.4, 1.0, 0.2]])
    got, ref = sol.fk(qv), mechkin.fk(mech, qv)
    np.testing.assert_array_equal(got.q, ref.q)
    np.testing.assert_array_equal(got.poses["end_effector"], ref.poses["end_effector"])
    np.testing.assert_array_equal(sol.pose(qv[0]),
                                  mechkin.fk(mech, qv[0]).poses["end_effector"][0])
    np.testing.assert_array_equal(sol.poses(qv)[:, 0], ref.poses["end_effector"])
    sols = sol.ik(ref.poses["end_effector"][0])
    assert sols.ok


def test_a_mechanism_with_cached_solvers_pickles():
    """mechkin.fk caches a solver on the mechanism; mechanisms travel to distributed workers."""
    import pickle

    mech = mechkin.load_mechanism(ROOT / "mechanisms/ur5.yaml")
    q = np.full(mech.n, 0.3)
    ref = mechkin.fk(mech, q).poses["end_effector"]
    sol = mechkin.Solver(mech)
    back, sol2 = pickle.loads(pickle.dumps((mech, sol)))
    np.testing.assert_array_equal(mechkin.fk(back, q).poses["end_effector"], ref)
    np.testing.assert_array_equal(sol2.pose(q), ref[0])
    assert sol2.ik(ref[0]).ok
