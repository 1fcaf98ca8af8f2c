"""Condition numbers against numpy's SVD, and singularity classes of known configurations.

- the loop-closure cond (``ClosureResult.cond``) is that of d(phi)/d(q_w) at every converged
  solution (it read 1.0 before), on the kim1995 direct-drive arm, Stewart platform and
  end-effector robot;
- the reduced Jacobian J_r = dx_E/dq_v (kim1995 Eq. (10)) against central differences of the
  end-effector pose with the closure solved at q_v +- h e_i;
- the direct-drive arm driven until its parallelogram folds flat (crank along the upper arm,
  p_C = 90 deg - q2 - q3 = 0) is a constraint singularity, with "near" steps before it;
- the PUMA 560 with q5 = 0 (wrist axes 4 and 6 aligned) is an inverse-kinematic singularity,
  with q5 = 0.5 rad it is regular.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure, solve_trajectory
from mechkin.model.differential import motion_derivatives, reduced_jacobian
from mechkin.model.kinematics import _cut_arrays, closure_jacobian, forward_kinematics
from mechkin.model.singularity import (
    TOL_NEAR,
    TOL_SINGULAR,
    SingularityKind,
    characteristic_length,
    classify,
    mechanism_singularity_at_home,
)

ROOT = Path(__file__).resolve().parents[2]
CLOSED = ["kim1995_direct_drive", "kim1995_stewart", "kim1995_end_effector_robot"]
H_FD = 1e-6


def _mech(name):
    return load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")


def _home(mech):
    return np.where(np.isfinite(mech.home), mech.home, 0.0)


def _path(mech, m=6, amp=0.1):
    s = np.linspace(0.0, 1.0, m)[:, None]
    rng = np.random.default_rng(11)
    d = rng.uniform(-1.0, 1.0, len(mech.independent))
    return _home(mech)[mech.independent] + amp * s * d


@pytest.mark.parametrize("name", CLOSED)
def test_closure_cond_is_svd_condition_number_at_solution(name):
    mech = _mech(name)
    res = solve_trajectory(mech, _path(mech), _home(mech)[mech.dependent])
    assert res.ok.all()
    _, J = closure_jacobian(mech, forward_kinematics(mech, res.q))
    ref = np.linalg.cond(J[:, :, mech.dependent])  # sigma_1 / sigma_{n_w} by numpy's SVD
    np.testing.assert_allclose(res.cond, ref, rtol=1e-6)
    assert (res.cond > 1.5).all()  # never the placeholder 1.0
    # solve_closure alone (one batch) gives the same
    one = solve_closure(mech, res.q[:, mech.independent], res.q[:, mech.dependent])
    np.testing.assert_allclose(one.cond, ref, rtol=1e-6)


def test_direct_drive_scenario_cond_is_not_one():
    """scenarios/kim1995_direct_drive_fk.yaml, the motors of kim1995 Table 3 point 1..4."""
    mech = _mech("kim1995_direct_drive")
    qv = np.array([[0.0, 0.0, 0.0], [1.19381, -0.19897, 0.0], [3.07876, -0.51312, 0.0],
                   [-1.31947, -0.82728, 1e-5]])
    res = solve_trajectory(mech, qv, mech.home[mech.dependent])
    assert res.ok.all()
    # the passive angles fold from 90 deg towards 42.6 deg (p_C = 90 deg - q2 - q3 grows)
    assert np.all(np.diff(res.cond) > 0) and res.cond[0] > 5.0


@pytest.mark.parametrize("name", CLOSED + ["puma560"])
def test_classify_condition_numbers_against_numpy(name):
    mech = _mech(name)
    res = solve_trajectory(mech, _path(mech, 4), _home(mech)[mech.dependent])
    q = res.q
    L = characteristic_length(mech)
    rep = classify(mech, q)
    kin = forward_kinematics(mech, q)
    _, J = closure_jacobian(mech, kin)
    iv, iw = mech.independent, mech.dependent
    if len(iw):
        _, _, mask = _cut_arrays(mech)
        pos = np.tile([True, True, True, False, False, False], (len(mech.cuts), 1))[mask]
        Pw = J[:, :, iw].copy()
        Pw[:, pos, :] /= L
        Pw[:, :, mech.s[iw] == 1] *= L
        _same_cond(rep.cond_constraint, np.linalg.cond(Pw), rtol=1e-8)
        _same_cond(rep.cond_closure, np.linalg.cond(J[:, :, iw]), rtol=1e-8)
        _same_cond(rep.cond_closure, res.cond, rtol=1e-6)
    Jr = reduced_jacobian(mech, q)
    Jr[:, 3:, :] /= L
    Jr[:, :, mech.s[iv] == 1] *= L
    _same_cond(rep.cond_reduced, np.linalg.cond(Jr), rtol=1e-8)
    # unscaled when L = 1
    rep1 = classify(mech, q, length_scale=1.0)
    _same_cond(rep1.cond_reduced, np.linalg.cond(reduced_jacobian(mech, q)), rtol=1e-8)


def _same_cond(got, want, rtol):
    """Condition numbers compared as 1/cond: relative where the matrix is well conditioned,
    absolute (1e-12) near a singularity, where cond ~ 1e15..1e17 is round-off and two LAPACK
    builds give different values (7.0e17 vs 4.8e17 at a singular PUMA pose, same matrix)."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    np.testing.assert_allclose(1.0 / got, 1.0 / want, rtol=rtol, atol=1e-12)


@pytest.mark.parametrize("name", CLOSED)
def test_reduced_jacobian_against_finite_differences(name):
    """kim1995 Eq. (10): J_r columns = d(omega, p_E)/d q_v,i with the closure re-solved."""
    mech = _mech(name)
    qv0 = _path(mech, 3)[-1]
    nv = len(mech.independent)
    steps = np.concatenate([qv0 + H_FD * np.eye(nv), qv0 - H_FD * np.eye(nv), qv0[None]])
    base = solve_closure(mech, qv0[None], _home(mech)[mech.dependent][None])
    res = solve_closure(mech, steps, base.q[:, mech.dependent])
    assert res.ok.all()
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]
    Tp, Tm, T0 = T[:nv], T[nv:2 * nv], T[-1]
    dR = (Tp[:, :3, :3] - Tm[:, :3, :3]) / (2 * H_FD) @ T0[:3, :3].T
    w = np.stack([dR[:, 2, 1], dR[:, 0, 2], dR[:, 1, 0]], axis=0)
    v = ((Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * H_FD)).T
    Jr = reduced_jacobian(mech, res.q[-1:])[0]
    np.testing.assert_allclose(Jr, np.concatenate([w, v]), atol=1e-6)


def test_direct_drive_folded_is_constraint_singularity():
    """q2 = q3 -> 45 deg: p_C = 90 deg - q2 - q3 -> 0, the crank lines up with the upper arm."""
    mech = _mech("kim1995_direct_drive")
    s = np.concatenate([np.linspace(0.0, 0.975, 40), [0.99, 0.995, 0.999, 1.0]])[:, None]
    qv = np.array([0.3, np.pi / 4, np.pi / 4]) * s
    # near the fold the anti-parallelogram branch is close: start Newton on the parallelogram
    # branch from the closed form of the mechanism file (perturbed), every step at once
    q23 = qv[:, 1] + qv[:, 2]
    guess = np.stack([np.pi / 2 - q23, q23 + np.pi / 2, q23 + np.pi / 2], axis=1) + 1e-6
    res = solve_closure(mech, qv, guess)
    assert res.ok.all()
    pc = res.q[:, mech.joint_index("p_C")]
    np.testing.assert_allclose(pc, np.pi / 2 - q23, atol=1e-5)
    rep = classify(mech, res.q)
    assert rep.kind[0] is SingularityKind.REGULAR and rep.label[0] == "regular"
    assert rep.kind[-1] is SingularityKind.CONSTRAINT
    assert rep.label[-1] == "constraint singularity"
    assert rep.constraint_level[-1] == "singular" and rep.inverse_level[-1] != "singular"
    assert "near constraint singularity" in set(rep.label[:-1])
    assert rep.near.any() and rep.singular[-1] and not rep.singular[:-1].any()
    # the condition number grows like 1 / p_C as the loop folds
    c = rep.cond_constraint[20:-1]
    assert np.all(np.diff(c) > 0)
    close = pc[:-1] < 0.2  # p_C below ~11 deg: sigma_min is linear in p_C
    cp = rep.cond_constraint[:-1][close] * pc[:-1][close]
    assert close.sum() >= 5
    np.testing.assert_allclose(cp, cp[-1], rtol=0.01)
    assert res.cond[-1] > 1.0 / TOL_SINGULAR
    # exactly folded (assembled by the closed form of the mechanism file): rank lost
    q = np.array([[0.0, np.pi / 4, np.pi / 4, 0.0, np.pi, np.pi]])
    assert np.abs(solve_closure(mech, q[:, :3], q[:, 3:]).residual).max() < 1e-12
    md = motion_derivatives(mech, q, [0.1, 0.2, -0.1])
    assert md.singularity.kind[0] is SingularityKind.CONSTRAINT


@pytest.mark.parametrize("q5, kind", [(0.0, SingularityKind.INVERSE_KINEMATIC),
                                      (0.5, SingularityKind.REGULAR)])
def test_puma_wrist_singularity(q5, kind):
    mech = _mech("puma560")
    q = np.array([[0.3, -0.5, 0.4, 0.7, q5, 0.2]])
    rep = classify(mech, q)
    assert rep.kind[0] is kind
    assert rep.constraint_level[0] == "regular"  # an open chain has no closure
    if kind is SingularityKind.INVERSE_KINEMATIC:
        assert rep.ratio_reduced[0] < 1e-12
        # within the warning band on the way in
        near = classify(mech, q + [0, 0, 0, 0, 1e-3, 0])
        assert near.label[0] == "near inverse-kinematic singularity"
    else:
        assert rep.ratio_reduced[0] > TOL_NEAR and rep.label[0] == "regular"


@pytest.mark.parametrize("name", CLOSED)
def test_home_is_regular(name):
    mech = _mech(name)
    info = mechanism_singularity_at_home(mech)
    json.dumps(info, allow_nan=False)
    assert info["closure_converged"] and info["class"] == "regular"
    assert info["constraint"]["level"] == "regular"
    assert info["end_effector"]["level"] == "regular"


def test_home_info_puma_and_thresholds():
    puma = _mech("puma560")
    info = mechanism_singularity_at_home(puma)  # home q = 0: q5 = 0
    json.dumps(info, allow_nan=False)
    assert info["kind"] == "inverse-kinematic singularity" and info["constraint"] is None
    dd = _mech("kim1995_direct_drive")
    q = solve_closure(dd, dd.home[dd.independent][None], dd.home[dd.dependent][None]).q
    # with a loose warning threshold the (regular) home pose reads "near"
    rep = classify(dd, q, tol_near=0.5)
    assert "near" in rep.label[0] and not rep.singular[0]
    with pytest.raises(ValueError):
        classify(dd, q, tol_singular=0.1, tol_near=0.01)
    with pytest.raises(ValueError):
        classify(dd, q, length_scale=0.0)


def test_info_reports_singularity_at_home():
    from mechkin.cli.info import mechanism_info

    info = mechanism_info(_mech("kim1995_stewart"))
    assert info["singularity_at_home"]["class"] == "regular"
    assert info["singularity_at_home"]["constraint"]["cond_unscaled"] > 1.0


def test_non_finite_configurations_are_undefined():
    """A failed closure step (nan joints) gives nan rates and the class "undefined"; the other
    rows are unchanged."""
    mech = _mech("kim1995_stewart")
    res = solve_trajectory(mech, _path(mech, 3), _home(mech)[mech.dependent])
    q = res.q.copy()
    q[1, 7] = np.nan
    qd_v = np.ones(6)
    md = motion_derivatives(mech, q, qd_v)
    ref = motion_derivatives(mech, res.q[[0, 2]], qd_v)
    assert np.isnan(md.qd[1]).all() and np.isnan(md.twists[1]).all()
    np.testing.assert_array_equal(md.qdd[[0, 2]], ref.qdd)
    np.testing.assert_array_equal(md.q, q)
    rep = md.singularity
    assert rep.kind[1] is SingularityKind.UNDEFINED and rep.label[1] == "undefined"
    assert list(rep.label[[0, 2]]) == ["regular", "regular"] and not rep.singular[1]
    assert np.isnan(rep.cond_closure[1]) and np.isfinite(rep.cond_closure[[0, 2]]).all()
    assert classify(mech, q).label[1] == "undefined"
    allnan = motion_derivatives(mech, np.full((2, mech.n), np.nan), qd_v)
    assert allnan.qd.shape == (2, mech.n) and list(allnan.singularity.label) == ["undefined"] * 2
