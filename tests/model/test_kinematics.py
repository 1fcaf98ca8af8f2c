"""Forward kinematics against published values; Jacobians against finite differences."""

from pathlib import Path

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.closure import ClosureStatus, solve_closure, solve_trajectory
from mechkin.model.kinematics import (
    closure_jacobian,
    closure_residual,
    forward_kinematics,
    frame_jacobian,
    frame_poses,
    relative_jacobian,
)
from tests.tolerances import ATOL_FD, ATOL_POSE, FD_STEP, TOL_CLOSURE

ROOT = Path(__file__).resolve().parents[2]
PUMA = ROOT / "mechanisms" / "puma560.yaml"
FOURBAR = ROOT / "tests" / "data" / "fourbar.yaml"

# Corke, Robotics Toolbox, standard D-H: p560.fkine(q). The poses are those of MATLAB's
# mdl_puma560 (d1 = 0) with z raised by the Python toolbox's pedestal d1 = 26.45 in = 0.67183 m
# (models.DH.Puma560, which mechanisms/puma560.yaml follows): T_python = Tz(d1) T_matlab.
# qz: the "L" shape; qr: ready, arm straight up; qs: stretched along x.
PUMA_D1 = 0.67183
PUMA_PUBLISHED = {
    "qz": ([0, 0, 0, 0, 0, 0],
           [[1, 0, 0, 0.4521], [0, 1, 0, -0.15005], [0, 0, 1, 0.4318 + PUMA_D1], [0, 0, 0, 1]]),
    "qr": ([0, np.pi / 2, -np.pi / 2, 0, 0, 0],
           [[1, 0, 0, 0.0203], [0, 1, 0, -0.15005], [0, 0, 1, 0.8636 + PUMA_D1], [0, 0, 0, 1]]),
    "qs": ([0, 0, -np.pi / 2, 0, 0, 0],
           [[0, 0, 1, 0.8636], [0, 1, 0, -0.15005], [-1, 0, 0, -0.0203 + PUMA_D1],
            [0, 0, 0, 1]]),
}


def _dh(theta, d, a, alpha):
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
                     [0, sa, ca, d], [0, 0, 0, 1]])


def _puma_reference(q):
    """Independent product of Paul's standard D-H matrices (written out element by element)."""
    a = [0, 0.4318, 0.0203, 0, 0, 0]
    d = [PUMA_D1, 0, 0.15005, 0.4318, 0, 0]
    al = [np.pi / 2, 0, -np.pi / 2, np.pi / 2, -np.pi / 2, 0]
    T = np.eye(4)
    for i in range(6):
        T = T @ _dh(q[i], d[i], a[i], al[i])
    return T


@pytest.mark.parametrize("name", sorted(PUMA_PUBLISHED))
def test_puma560_published_poses(name):
    q, T_ref = PUMA_PUBLISHED[name]
    mech = load_mechanism(PUMA)
    T = frame_poses(mech, np.array([q]), [mech.end_effector])[0, 0]
    np.testing.assert_allclose(T, T_ref, atol=ATOL_POSE)


def test_puma560_batched_matches_reference_product():
    mech = load_mechanism(PUMA)
    rng = np.random.default_rng(1)
    qs = rng.uniform(-np.pi, np.pi, size=(200, 6))
    T = frame_poses(mech, qs, [mech.end_effector])[:, 0]
    for k in range(0, 200, 17):
        np.testing.assert_allclose(T[k], _puma_reference(qs[k]), atol=ATOL_POSE)


def _fd(fun, q, eps=FD_STEP):
    cols = []
    for i in range(q.shape[1]):
        e = np.zeros(q.shape[1])
        e[i] = eps
        cols.append((fun(q + e) - fun(q - e)) / (2 * eps))
    return np.stack(cols, axis=-1)


def _twist_fd(mech, q, f, eps=FD_STEP):
    """Finite-difference (omega, v) Jacobian of frame f from poses."""
    T0 = frame_poses(mech, q, [f])[:, 0]
    cols = []
    for i in range(mech.n):
        e = np.zeros(mech.n)
        e[i] = eps
        Tp = frame_poses(mech, q + e, [f])[:, 0]
        Tm = frame_poses(mech, q - e, [f])[:, 0]
        dR = (Tp[:, :3, :3] - Tm[:, :3, :3]) / (2 * eps)
        W = dR @ np.swapaxes(T0[:, :3, :3], 1, 2)
        w = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=-1)
        v = (Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * eps)
        cols.append(np.concatenate([w, v], axis=-1))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("path", [PUMA, FOURBAR])
def test_frame_jacobian_vs_finite_differences(path):
    mech = load_mechanism(path)
    rng = np.random.default_rng(7)
    q = rng.uniform(-1.5, 1.5, size=(5, mech.n))
    kin = forward_kinematics(mech, q)
    for f in range(len(mech.frame_names)):
        np.testing.assert_allclose(frame_jacobian(mech, kin, f), _twist_fd(mech, q, f),
                                   atol=ATOL_FD)


def test_closure_and_relative_jacobians_vs_finite_differences():
    mech = load_mechanism(FOURBAR)
    rng = np.random.default_rng(3)
    q = rng.uniform(-2, 2, size=(6, mech.n))
    kin = forward_kinematics(mech, q)
    phi, J = closure_jacobian(mech, kin)
    np.testing.assert_allclose(phi, closure_residual(mech, kin))
    Jfd = _fd(lambda x: closure_residual(mech, forward_kinematics(mech, x)), q)
    np.testing.assert_allclose(J, Jfd, atol=ATOL_FD)
    # a fixed target frame (kim1995 Eq. (7)): residual of the end effector in the target
    T_p = frame_poses(mech, q[:1] + 0.3, [mech.end_effector])[0, 0]
    x, Jx = relative_jacobian(mech, kin, None, mech.end_effector, T_p)
    from mechkin.model.kinematics import relative_residual

    def res(x_):
        return relative_residual(np.broadcast_to(T_p, (len(x_), 4, 4)),
                                 frame_poses(mech, x_, [mech.end_effector])[:, 0])

    np.testing.assert_allclose(x, res(q), atol=1e-14)
    np.testing.assert_allclose(Jx, _fd(res, q), atol=ATOL_FD)


def test_fourbar_closure_matches_circle_intersection():
    """Loop closure vs the closed form of the planar four-bar (circle intersection)."""
    mech = load_mechanism(FOURBAR)
    crank = np.deg2rad(np.arange(0, 360, 15.0))
    res = solve_trajectory(mech, crank[:, None], mech.home[mech.dependent])
    assert all(s is ClosureStatus.CONVERGED for s in res.status)
    T = frame_poses(mech, res.q, [mech.frame_index("coupler_end")])[:, 0]
    B = np.stack([0.3 * np.cos(crank), 0.3 * np.sin(crank)], axis=1)  # crank tip
    C = T[:, :2, 3]  # coupler end = rocker end
    np.testing.assert_allclose(np.linalg.norm(C - B, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(C - [1.0, 0.0], axis=1), 0.8, atol=1e-12)
    assert np.linalg.norm(closure_residual(mech, forward_kinematics(mech, res.q)),
                          axis=1).max() < TOL_CLOSURE


def test_closure_reports_unreachable_without_crashing():
    """A crank angle past the linkage's reach ends NOT_CONVERGED or SINGULAR, never NaN."""
    from mechkin.config.mechanism_file import read_mechanism_spec
    from mechkin.model.build import build_mechanism

    spec, doc = read_mechanism_spec(FOURBAR)
    d = spec.model_dump()
    d["joints"][1]["origin"]["xyz"] = [3.0, 0.0, 0.0]  # crank 3 m: the loop cannot close
    d["joints"][0]["home"] = 0.0
    from mechkin.config.schema import MechanismSpec

    mech = build_mechanism(MechanismSpec.model_validate(d), None)
    res = solve_closure(mech, np.array([[0.0]]), mech.home[mech.dependent][None])
    assert res.status[0] in (ClosureStatus.NOT_CONVERGED, ClosureStatus.SINGULAR)
    assert np.all(np.isfinite(res.q)) and np.isfinite(res.residual[0])


def test_partition_matrices():
    mech = load_mechanism(FOURBAR)
    q_v, q_w = np.array([0.1]), np.array([0.2, 0.3])
    q = mech.assemble(q_v, q_w)
    np.testing.assert_allclose(q, mech.L_v @ q_v + mech.L_w @ q_w)  # kim1995 Eq. (3)


def test_cut_onto_the_base_closes_a_loop():
    """A serial chain closed back onto the ground gives the same linkage as the two-branch form."""
    a = load_mechanism(FOURBAR)
    b = load_mechanism(ROOT / "tests" / "data" / "fourbar_ground_cut.yaml")
    crank = np.deg2rad([30.0, 75.0, 140.0])[:, None]
    ra = solve_trajectory(a, crank, a.home[a.dependent])
    rb = solve_trajectory(b, crank, b.home[b.dependent])
    assert all(s is ClosureStatus.CONVERGED for s in rb.status)
    pb = frame_poses(b, rb.q, [b.frame_index("rocker")])[:, 0, :3, 3]  # coupler-rocker pin
    tip = np.column_stack([0.3 * np.cos(crank[:, 0]), 0.3 * np.sin(crank[:, 0])])
    np.testing.assert_allclose(np.linalg.norm(pb[:, :2] - tip, axis=1), 1.0, atol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(pb[:, :2] - [1.0, 0.0], axis=1), 0.8, atol=1e-10)
    assert ra.q.shape == rb.q.shape


@pytest.mark.parametrize("name", ["puma560.yaml", "kim1995_stewart.yaml", "panda.yaml"])
def test_large_batch_path_equals_level_path(name, monkeypatch):
    """The per-joint GEMM path used for large batches gives the same poses as the level path."""
    import mechkin.model.kinematics as K

    mech = load_mechanism(ROOT / "mechanisms" / name)
    qs = mech.home + np.random.default_rng(5).uniform(-0.3, 0.3, size=(K.LARGE_BATCH, mech.n))
    big = K.forward_kinematics(mech, qs).T_links
    monkeypatch.setattr(K, "LARGE_BATCH", 10**9)
    small = K.forward_kinematics(mech, qs).T_links
    np.testing.assert_allclose(big, small, atol=1e-13)
