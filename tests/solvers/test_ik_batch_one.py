"""``solve_ik_batch`` of one target on an open chain is the single solve (issue 29)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mechkin.model import load_mechanism
from mechkin.model.kinematics import frame_poses
from mechkin.solvers.ik import IkOptions, IkStatus, solve_ik, solve_ik_batch

ROOT = Path(__file__).resolve().parents[2]


def test_one_target_batch_equals_the_single_solve():
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    rng = np.random.default_rng(7)
    Q = rng.uniform(mech.lower, mech.upper, (4, mech.n))
    T = frame_poses(mech, Q, [mech.end_effector])[:, 0]
    opts = IkOptions(restarts=10)
    for k, Tk in enumerate(T):
        q_v0 = None if k % 2 else Q[k] + 0.05
        w = None if k < 2 else np.array([1.0, 1.0, 1.0, 0.5, 0.5, 0.5])
        b = solve_ik_batch(mech, Tk[None], q_v0=q_v0, weights=w, options=opts)
        s = solve_ik(mech, Tk, q_v0=q_v0, weights=w, options=opts)
        assert b.q.shape == (1, mech.n) and b.q_v.shape == (1, mech.n)
        assert b.status[0] is s.status is IkStatus.OK
        np.testing.assert_array_equal(b.q[0], s.q)
        assert b.position_error[0] == s.position_error
        assert b.orientation_error[0] == s.orientation_error
        assert b.iterations[0] == s.iterations and b.f[0] == s.f
