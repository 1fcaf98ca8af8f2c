"""Closed forms (kim1995 appendix; Stewart leg lengths) against the numerical solvers."""

from __future__ import annotations

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.closed_form.direct_drive import (
    direct_drive_branches,
    direct_drive_fk,
    direct_drive_ik,
)
from mechkin.solvers.closed_form.stewart import leg_lengths, stewart_attachments
from mechkin.solvers.ik import IkOptions, IkStatus, solve_ik


def _ee_poses(mech, q_v):
    res = solve_closure(mech, q_v, np.broadcast_to(mech.home[mech.dependent], (len(q_v),
                                                                               len(mech.dependent))))
    assert res.ok.all()
    return forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0], res.q


def test_direct_drive_fk_matches_mechanism(root):
    mech = load_mechanism(root / "mechanisms" / "kim1995_direct_drive.yaml")
    rng = np.random.default_rng(0)
    qv = rng.uniform(-0.6, 0.6, size=(20, 3))
    T, _ = _ee_poses(mech, qv)
    np.testing.assert_allclose(direct_drive_fk(qv), T, atol=1e-12)


def test_direct_drive_closed_form_vs_numerical(root):
    mech = load_mechanism(root / "mechanisms" / "kim1995_direct_drive.yaml")
    rng = np.random.default_rng(1)
    qv = rng.uniform(-0.6, 0.6, size=(10, 3))
    qv[:, 0] = rng.uniform(-3.0, 3.0, size=10)
    T, _ = _ee_poses(mech, qv)
    q_cf, ok = direct_drive_ik(T)
    assert ok.all()
    np.testing.assert_allclose(q_cf, qv, atol=1e-10)
    for k in range(len(T)):
        r = solve_ik(mech, T[k], q_v0=qv[k] + 0.05, options=IkOptions(grad_tol=1e-14))
        assert r.status is IkStatus.OK
        np.testing.assert_allclose(r.q_v, q_cf[k], atol=1e-8)


def test_direct_drive_every_branch(root):
    """Both signs of q1 and of s3 are evaluated; only the lower-sign branches reproduce the
    pose of this arm (PAPER_NOTES), and the s_y = 0 case (q1 = +-pi/2) is handled."""
    q = np.array([[np.pi / 2, 0.2, -0.1], [-np.pi / 2, -0.3, 0.2], [0.4, 0.1, 0.3]])
    T = direct_drive_fk(q)
    sol = direct_drive_branches(T)
    assert sol.q.shape == (3, 4, 3)
    assert np.all(np.isfinite(sol.q))
    assert sol.valid[:, 0].all()
    assert not sol.valid[:, 2:].any()  # q1 + pi cannot reproduce s
    np.testing.assert_allclose(sol.q[:, 0], q, atol=1e-12)


def test_stewart_closed_form_vs_numerical(root):
    mech = load_mechanism(root / "mechanisms" / "kim1995_stewart.yaml")
    a, b = stewart_attachments(mech)
    rng = np.random.default_rng(2)
    qv = mech.home[mech.independent] + rng.uniform(-1.0, 1.0, size=(6, 6))
    T, _ = _ee_poses(mech, qv)
    np.testing.assert_allclose(leg_lengths(T, a, b), qv, atol=1e-9)
    for k in range(3):
        r = solve_ik(mech, T[k], options=IkOptions(grad_tol=1e-12))
        assert r.status is IkStatus.OK
        np.testing.assert_allclose(r.q_v, qv[k], atol=1e-8)


def test_stewart_attachments_rejects_serial_arm(root):
    mech = load_mechanism(root / "mechanisms" / "puma560.yaml")
    with pytest.raises(ValueError, match="not a prismatic leg"):
        stewart_attachments(mech)
