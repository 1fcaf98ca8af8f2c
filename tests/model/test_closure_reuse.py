"""The closure's last Newton iterate reused by the IK evaluation (issue 15.2): the poses and
the closure Jacobian it returns are those a fresh forward kinematics gives at the solution,
bit for bit, so the numpy IK takes exactly the steps it took before."""

from __future__ import annotations

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import closure_jacobian, forward_kinematics
from mechkin.solvers.ik.kernel import evaluate, kernel_for


@pytest.mark.parametrize("name", ["kim1995_stewart", "kim1995_direct_drive",
                                  "kim1995_end_effector_robot"])
def test_kept_kinematics_equal_a_fresh_evaluation(mechanisms_dir, name):
    mech = load_mechanism(mechanisms_dir / f"{name}.yaml")
    rng = np.random.default_rng(3)
    q = np.repeat(mech.home[None], 5, axis=0)
    qv = q[:, mech.independent] + rng.normal(0.0, 0.01, (5, len(mech.independent)))
    res = solve_closure(mech, qv, q[:, mech.dependent], keep_kinematics=True)
    assert res.ok.all() and res.T_links is not None
    kin = forward_kinematics(mech, res.q)
    np.testing.assert_array_equal(res.T_links, kin.T_links)
    np.testing.assert_array_equal(res.jacobian, closure_jacobian(mech, kin)[1])
    plain = solve_closure(mech, qv, q[:, mech.dependent])
    np.testing.assert_array_equal(plain.q, res.q)
    assert plain.T_links is None


def test_not_converged_rows_give_no_kept_kinematics(mechanisms_dir):
    mech = load_mechanism(mechanisms_dir / "kim1995_stewart.yaml")
    q = mech.home[None]
    res = solve_closure(mech, q[:, mech.independent] * 3.0, q[:, mech.dependent],
                        max_iter=1, keep_kinematics=True)
    assert not res.ok.all() and res.T_links is None and res.jacobian is None


@pytest.mark.parametrize("name", ["kim1995_stewart", "kim1995_direct_drive"])
def test_ik_evaluation_unchanged(mechanisms_dir, name, monkeypatch):
    """evaluate() with the reuse against evaluate() forced to recompute (T_links dropped)."""
    import mechkin.solvers.ik.kernel as K

    mech = load_mechanism(mechanisms_dir / f"{name}.yaml")
    kern = kernel_for(mech)
    q = mech.home[None]
    qv, qw = q[:, kern.iv] + 0.02, q[:, kern.iw].copy()
    T = kern.end_effector(kern.kinematics(q))
    a = evaluate(kern, qv, qw, T)

    def no_keep(*args, **kw):
        kw["keep_kinematics"] = False
        return solve_closure(*args, **kw)

    monkeypatch.setattr(K, "solve_closure", no_keep)
    b = evaluate(kern, qv, qw, T)
    for f in ("q", "x", "J", "S", "phi_norm"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
