"""The path-only FK of :func:`mechkin.model.kinematics.frame_poses` against the tree FK and
against a naive per-configuration composition of ``A Z(q) B`` (kim1995 Eq. (2)) on every bundled
mechanism, by every route: ``fk_route = "numpy"`` (MECHKIN_JIT=0: one configuration in plain
Python, small batches by 4x4 products, large batches block by block, column-major) and
``"compiled"`` (MECHKIN_JIT=1: the numba kernel of mechkin.model.fk_jit for every batch size);
and the fk task's open-chain shortcut against the loop-closure solver.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mechkin.model import fk_accel, load_mechanism
from mechkin.model import kinematics as K
from mechkin.model.closure import ClosureStatus, solve_trajectory
from mechkin.model.kinematics import forward_kinematics, frame_poses

ROOT = Path(__file__).resolve().parents[2]
FILES = sorted((ROOT / "mechanisms").glob("*.yaml"))
# one configuration, small batches, the first large batch, and more than one block
SIZES = (1, 2, 7, K.PLAN_LARGE_BATCH, K.PLAN_BLOCK + 37)


@pytest.fixture(params=["numpy", "compiled"])
def fk_route(request, monkeypatch):
    """frame_poses by one route: numpy / plain Python (MECHKIN_JIT=0) or compiled (=1)."""
    if request.param == "compiled":
        pytest.importorskip("numba")
    monkeypatch.setenv("MECHKIN_JIT", "0" if request.param == "numpy" else "1")
    fk_accel.reset()
    yield request.param
    fk_accel.reset()


def _naive(mech, q: np.ndarray, f: int) -> np.ndarray:
    """Pose of frame f for one configuration: walk from its link to the base composing
    A_j Z(q_j) B_j (an independent reference sharing no code with the FK under test)."""
    T = mech.frame_offset[f].copy()
    link = int(mech.frame_link[f])
    while mech.link_parent_joint[link] >= 0:
        j = int(mech.link_parent_joint[link])
        Z = np.eye(4)
        if mech.s[j] == 0:
            c, s = np.cos(q[j]), np.sin(q[j])
            Z[:2, :2] = [[c, -s], [s, c]]
        else:
            Z[2, 3] = q[j]
        T = mech.A[j] @ Z @ mech.B[j] @ T
        link = int(mech.joint_parent_link[j])
    return T


def _frame_sets(mech, rng) -> list:
    nf = len(mech.frame_names)
    ee = mech.end_effector if mech.end_effector is not None else nf - 1
    some = rng.choice(nf, size=min(4, nf), replace=False)
    return [[ee], None, list(some), np.asarray(some[::-1]), [0], [nf - 1, 0, nf - 1]]


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_path_fk_matches_tree_fk(path, fk_route):
    mech = load_mechanism(path)
    rng = np.random.default_rng(len(mech.joint_names))
    span = np.where(mech.s == 0, np.pi, 0.5)
    for m in SIZES:
        qs = rng.uniform(-span, span, size=(m, mech.n))
        kin = forward_kinematics(mech, qs)
        for idx in _frame_sets(mech, rng):
            got = frame_poses(mech, qs, idx)
            ref = kin.frames(mech, idx)
            assert got.shape == ref.shape
            np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12, err_msg=f"{m} {idx}")
            assert np.all(got[:, :, 3] == [0.0, 0.0, 0.0, 1.0])


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_path_fk_matches_naive_composition(path, fk_route):
    mech = load_mechanism(path)
    rng = np.random.default_rng(7)
    nf = len(mech.frame_names)
    for m in (1, 3, K.PLAN_LARGE_BATCH + 1):
        qs = rng.uniform(-2.0, 2.0, size=(m, mech.n))
        got = frame_poses(mech, qs)
        for r in range(0, m, max(1, m // 3)):
            for f in range(nf):
                np.testing.assert_allclose(got[r, f], _naive(mech, qs[r], f), rtol=0,
                                           atol=1e-12)


def test_puma560_ready_pose_published(fk_route):
    # Robotics Toolbox for Python 1.x, rtb.models.DH.Puma560().fkine(qr), qr = (0, 90, -90, 0,
    # 0, 0) deg: tool at (0.0203, -0.15005, 1.53543) m with the identity orientation
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    qr = np.radians([[0.0, 90.0, -90.0, 0.0, 0.0, 0.0]])
    for qs in (qr, np.repeat(qr, 5, axis=0), np.repeat(qr, K.PLAN_LARGE_BATCH, axis=0)):
        T = frame_poses(mech, qs, [mech.end_effector])[:, 0]
        np.testing.assert_allclose(T[:, :3, 3], np.broadcast_to([0.0203, -0.15005, 1.53543],
                                                                 (len(qs), 3)), atol=1e-12)
        np.testing.assert_allclose(T[:, :3, :3], np.broadcast_to(np.eye(3), (len(qs), 3, 3)),
                                   atol=1e-12)


def test_plan_only_walks_the_path_and_is_cached():
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_stewart.yaml")
    q = mech.home[None]
    for f in range(len(mech.frame_names)):
        frame_poses(mech, q, [f])
        plan = mech.__dict__["_fk_plans"][(f,)]
        anc = np.flatnonzero(mech.link_ancestors[mech.frame_link[f]])
        assert sorted(plan.joints.tolist()) == anc.tolist()
        frame_poses(mech, q, [f])
        assert mech.__dict__["_fk_plans"][(f,)] is plan


def test_edge_inputs_like_the_tree_fk(fk_route):
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    rng = np.random.default_rng(3)
    for m in (0, 1, 4, K.PLAN_LARGE_BATCH):
        qs = rng.uniform(-3, 3, size=(m, mech.n))
        kin = forward_kinematics(mech, qs)
        assert frame_poses(mech, qs, []).shape == (m, 0, 4, 4)  # the tree FK raises here
        for idx in ([-1], np.array([7, 0]), np.ones(8, bool), (1, 2), [3, 3]):
            got, ref = frame_poses(mech, qs, idx), kin.frames(mech, idx)
            assert got.shape == ref.shape
            np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    with pytest.raises(IndexError):
        frame_poses(mech, qs, [8])
    with pytest.raises(ValueError):
        frame_poses(mech, np.zeros((2, 5)), [0])


def test_fk_task_open_chain_shortcut_equals_the_closure_solver():
    from types import SimpleNamespace

    from mechkin.tasks.fk import _solve_in_chunks

    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    assert mech.n_cuts == 0 and len(mech.dependent) == 0
    qv = np.random.default_rng(5).uniform(-3, 3, size=(50, len(mech.independent)))
    tol = SimpleNamespace(phi=1e-10, dq=1e-10, max_iter=50)
    got = _solve_in_chunks(mech, qv, np.zeros(0), tol, progress=False)
    ref = solve_trajectory(mech, qv, np.zeros(0), tol_phi=1e-10, tol_dq=1e-10, max_iter=50)
    np.testing.assert_array_equal(got.q, ref.q)
    assert list(got.status) == list(ref.status) == [ClosureStatus.CONVERGED] * 50
    np.testing.assert_array_equal(got.iterations, ref.iterations)
    np.testing.assert_array_equal(got.residual, ref.residual)
    np.testing.assert_array_equal(got.cond, ref.cond)


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_large_batch_tree_fk_matches_joint_by_joint_and_naive(path):
    # forward_kinematics from LARGE_BATCH on runs the block-wise plan over every link
    mech = load_mechanism(path)
    rng = np.random.default_rng(11)
    m = K.LARGE_BATCH + K.PLAN_BLOCK + 3
    qs = rng.uniform(-2.0, 2.0, size=(m, mech.n))
    kin = forward_kinematics(mech, qs)
    T = np.empty((mech.n_links, m, 4, 4))
    T[0] = np.eye(4)
    K._fk_large_batch(mech, qs, T)
    np.testing.assert_allclose(kin.T_links, np.moveaxis(T, 0, 1), rtol=0, atol=1e-12)
    small = forward_kinematics(mech, qs[:5])
    np.testing.assert_allclose(kin.T_links[:5], small.T_links, rtol=0, atol=1e-12)
    for r in (0, m - 1):
        for f in range(mech.n_links):
            np.testing.assert_allclose(kin.T_links[r, f], _naive(mech, qs[r], f), rtol=0,
                                       atol=1e-12)
    z, o = kin.axes()
    z5, o5 = small.axes()
    np.testing.assert_allclose(z[:5], z5, rtol=0, atol=1e-12)
    np.testing.assert_allclose(o[:5], o5, rtol=0, atol=1e-12)
