"""The compiled DP stage (mechkin.solvers.track.dp_jit) gives the numpy stage's tables bit
for bit: V, T, NP and the blocking diagnosis, on park's cases (tracking, intercept, time, the
DPOptions readings, a start ahead of the hand with the time-penalty search, an infeasible
grid)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

import mechkin.solvers.track.dp_stage as DS  # noqa: E402
import mechkin.solvers.track.dpct as D  # noqa: E402
from mechkin.solvers.dynamics.open_chain import PlanarTwoLinkDynamics  # noqa: E402
from mechkin.solvers.track.path import PlanarTwoLinkLinePath  # noqa: E402

_RUN_DP = D._run_dp
PATH = PlanarTwoLinkLinePath([-0.8, 1.732], [-0.3, 1.732])
DYN = PlanarTwoLinkDynamics()
REF = D.ConveyorReference(part_start=[-0.9, 1.732], belt_velocity=[0.2, 0.0])
AHEAD = D.ConveyorReference(part_start=[-0.7, 1.732], belt_velocity=[0.1, 0.0])
TQ = dict(torque=[0.5, 0.2])
FULL = dict(torque=[0.5, 0.2], qd=[0.2, 0.2], qdd=[0.3, 0.3], jerk=[2.3, 2.0])
TVA = dict(torque=[0.5, 0.2], qd=[0.2, 0.2], qdd=[0.3, 0.3])

CASES = [
    ("tracking", REF, {}, 50, 100, None),
    ("tracking", REF, TQ, 50, 100, None),
    ("tracking", REF, FULL, 30, 50, None),
    ("tracking", REF, FULL, 50, 100, None),
    ("tracking", REF, FULL, 50, 100, D.DPOptions(jerk_ends=True, wait_cost=True)),
    ("tracking", REF, TQ, 50, 100, D.DPOptions(step_time="euler")),
    ("tracking", REF, FULL, 50, 100, D.DPOptions(step_time="euler")),
    ("intercept", REF, FULL, 50, 100, None),
    ("tracking", AHEAD, TQ, 30, 60, None),
    ("time", None, TQ, 30, 200, None),
    ("time", None, TVA, 30, 200, None),
    ("time", None, FULL, 30, 200, None),
    ("tracking", REF, dict(torque=[0.05, 0.02]), 20, 40, None),  # infeasible at stage 0
    ("tracking", REF, dict(torque=[0.5, 0.2], jerk=[0.05, 0.05]), 20, 40, None),  # stage 3
    ("tracking", REF, dict(torque=[0.5, 0.2], qdd=[0.02, 0.02]), 20, 40, None),  # stage 19
    ("time", None, dict(torque=[0.5, 0.2], qd=[0.2, 0.2], jerk=[0.01, 0.01]), 20, 40, None),
]


def _solve(monkeypatch, compiled: bool, objective, ref, lim, N1, N2, dp):
    monkeypatch.setattr(DS, "use_compiled_dp", lambda pairs: compiled)
    tabs = []
    orig = _RUN_DP

    def spy(*a, **k):
        tab = orig(*a, **k)
        tabs.append(tab)
        return tab

    monkeypatch.setattr(D, "_run_dp", spy)
    res = D.solve_conveyor_tracking(dynamics=DYN, path=PATH, reference=ref,
                                    limits=D.TrackLimits.symmetric(**lim), N1=N1, N2=N2,
                                    objective=objective, dp=dp)
    return res, tabs


@pytest.mark.parametrize("case", CASES, ids=[f"{c[0]}-{len(c[2])}-{c[3]}x{c[4]}-{i}"
                                              for i, c in enumerate(CASES)])
def test_compiled_stage_is_numpy_bit_for_bit(monkeypatch, case):
    a, ta = _solve(monkeypatch, False, *case)
    b, tb = _solve(monkeypatch, True, *case)
    assert a.status == b.status and a.message == b.message
    assert len(ta) == len(tb) >= 1
    for x, y in zip(ta, tb, strict=True):
        assert np.array_equal(x.V, y.V)
        assert np.array_equal(x.T, y.T, equal_nan=True)
        assert np.array_equal(x.NP, y.NP)
        assert x.blocked == y.blocked
    if a.trajectory is not None:
        assert np.array_equal(a.trajectory.t, b.trajectory.t)
        assert np.array_equal(a.trajectory.torque, b.trajectory.torque)


def test_rent_or_buy(monkeypatch):
    """Small DPs stay numpy until the estimated numpy time would pay the kernel's load."""
    from mechkin.solvers.ik import accel

    monkeypatch.delenv("MECHKIN_JIT", raising=False)
    monkeypatch.setattr(accel, "compiled_lm_available", lambda: True)
    monkeypatch.setattr(DS, "_dp_spent", [0.0])
    monkeypatch.setattr(DS, "_dp_loaded", [False])
    assert not DS.use_compiled_dp(49 * 101**2)  # park 50 x 100: ~0.05 s of numpy
    assert DS.use_compiled_dp(49 * 501**2)  # time-optimal 50 x 500: ~1.2 s
    monkeypatch.setattr(accel, "compiled_lm_available", lambda: False)
    assert not DS.use_compiled_dp(49 * 501**2)


def test_time_refinement_only_shortens_and_keeps_the_limits():
    """objective time: the r' band refinement gives a duration <= the uniform grid's (the
    uniform path stays in the band), limits still hold; refine=False is the uniform grid."""
    lim = D.TrackLimits.symmetric(**TVA)
    kw = dict(dynamics=DYN, path=PATH, limits=lim, N1=30, N2=200, objective="time")
    fine = D.solve_conveyor_tracking(**kw)
    coarse = D.solve_conveyor_tracking(**kw, refine=False)
    assert fine.limits_ok and coarse.limits_ok
    assert fine.duration_s <= coarse.duration_s
    assert "refined" in fine.message and "refined" not in coarse.message
    assert fine.trajectory.t.shape == coarse.trajectory.t.shape  # same 30 stages


def test_tracking_never_refines():
    kw = dict(dynamics=DYN, path=PATH, reference=REF, limits=D.TrackLimits.symmetric(**FULL),
              N1=30, N2=50)
    a = D.solve_conveyor_tracking(**kw)
    b = D.solve_conveyor_tracking(**kw, refine=False)
    assert a.t_a_s == b.t_a_s and a.cost == b.cost
    assert np.array_equal(a.trajectory.torque, b.trajectory.torque)
