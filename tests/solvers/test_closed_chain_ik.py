"""IK of closed chains (issue 24): passive limits are constraints and sequential solving never
loses a target the same defaults solve alone."""

from __future__ import annotations

import numpy as np

import mechkin
from tests.model import closed_chain_models as M
from tests.model.test_continuation import load, random_qv

W_POS = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])  # the leg's toe position (2 actuators)


def _passive_inside(mech, q):
    from mechkin.model.continuation import within_limits

    return within_limits(mech, np.atleast_2d(q))[1]


def test_sequential_ik_solves_every_target_solved_alone(tmp_path):
    # narrow rod limits: some targets are reachable only in another knee branch
    mech, _ = load(tmp_path, M.CASSIE, **{"limits: [-90, 90]": "limits: [-60, 10]"})
    qv = random_qv(mech, 12, seed=11)
    fk = mechkin.fk(mech, qv)
    T = fk.poses["end_effector"]
    seq = mechkin.ik(mech, T, weights=W_POS, restarts=4)
    alone = [mechkin.ik(mech, T[k], weights=W_POS, restarts=4)[0] for k in range(len(T))]
    ok_alone = [r.status.value == "ok" for r in alone]
    ok_seq = [r.status.value == "ok" for r in seq]
    assert sum(ok_alone) >= 6
    assert all(s for s, a in zip(ok_seq, ok_alone, strict=True) if a)
    for r in seq + alone:  # no ok answer with a passive joint outside its limits
        if r.status.value == "ok":
            assert _passive_inside(mech, r.q)[0]
        elif r.status.value == "at a limit":
            assert r.at_limit


def test_batch_ik_never_reports_ok_outside_passive_limits(tmp_path):
    mech, _ = load(tmp_path, M.CASSIE, **{"limits: [-90, 90]": "limits: [-60, 10]"})
    qv = random_qv(mech, 16, seed=12)
    T = mechkin.fk(mech, qv).poses["end_effector"]
    res = mechkin.ik(mech, T, weights=W_POS, batch=True, restarts=3)
    for r in res:
        if r.status.value == "ok":
            assert _passive_inside(mech, r.q)[0]
        if not _passive_inside(mech, r.q)[0]:
            assert r.status.value != "ok" and r.at_limit
