"""DPCT (park §4): limits on the realised path, DP bookkeeping, infeasibility, minimum time."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mechkin.errors import ConfigError
from mechkin.solvers.dynamics.open_chain import PlanarTwoLinkDynamics, SerialChainDynamics
from mechkin.solvers.track.dpct import (
    ConveyorReference,
    TrackLimits,
    TrackResult,
    TrackStatus,
    solve_conveyor_tracking,
)
from mechkin.solvers.track.path import PlanarTwoLinkLinePath, path_torques

# park §5.1 (PAPER_NOTES): hand (-0.8, 1.732) -> (-0.3, 1.732); part from (-0.9, 1.732) at 0.2 m/s
PATH = PlanarTwoLinkLinePath([-0.8, 1.732], [-0.3, 1.732])
DYN = PlanarTwoLinkDynamics()
REF = ConveyorReference(part_start=[-0.9, 1.732], belt_velocity=[0.2, 0.0])
# park Eq. (36)-(37)
TORQUE = np.array([0.5, 0.2])
QD, QDD, JERK = np.array([0.2, 0.2]), np.array([0.3, 0.3]), np.array([2.3, 2.0])
LIMITS = {
    "none": TrackLimits(),
    "torque": TrackLimits.symmetric(torque=TORQUE),
    "full": TrackLimits.symmetric(torque=TORQUE, qd=QD, qdd=QDD, jerk=JERK),
    "tva": TrackLimits.symmetric(torque=TORQUE, qd=QD, qdd=QDD),
}
GRIDS = [(30, 50), (50, 100), (100, 200)]
TOL = 1e-9


@cache
def solve(case: str, N1: int, N2: int, objective: str = "tracking") -> TrackResult:
    return solve_conveyor_tracking(
        dynamics=DYN,
        path=PATH,
        reference=REF,
        limits=LIMITS[case],
        N1=N1,
        N2=N2,
        objective=objective,  # type: ignore[arg-type]
    )


def plan_part(res: TrackResult) -> slice:
    """The DP nodes (the optional rest node at t = 0 before the hand moves is dropped)."""
    assert res.trajectory is not None
    return slice(1, None) if res.trajectory.t.size == res.grid.N1 + 2 else slice(None)


@pytest.mark.parametrize(("N1", "N2"), GRIDS)
def test_all_limits_hold_on_the_realised_trajectory(N1: int, N2: int) -> None:
    """|qd| at the nodes (Eq. (4)), qdd and jerk by the Eq. (31)-(33) differences, torque (3)."""
    res = solve("full", N1, N2)
    assert res.status is TrackStatus.OK and res.limits_ok
    tr = res.trajectory
    assert tr is not None
    k = plan_part(res)
    t, qd = tr.t[k], tr.qd[k]
    assert np.all(np.abs(tr.qd) <= QD + TOL)
    qdd = np.diff(qd, axis=0) / np.diff(t)[:, None]  # park Eq. (32)
    jerk = np.diff(qdd, axis=0) / np.diff(t)[:-1, None]  # park Eq. (33)
    assert np.all(np.abs(qdd) <= QDD + TOL)
    assert np.all(np.abs(jerk) <= JERK + TOL)
    assert_allclose(tr.qdd[k][:-1], qdd, atol=1e-9)
    assert np.all(np.abs(tr.torque) <= TORQUE + TOL)
    U = path_torques(DYN, PATH, tr.r, tr.rd, tr.rdd)  # park Eq. (12), independent evaluation
    assert_allclose(tr.torque, U, atol=1e-12)


@pytest.mark.parametrize("case", ["none", "torque", "full"])
def test_zero_tracking_error_after_t_a(case: str) -> None:
    res = solve(case, 50, 100)
    tr = res.trajectory
    assert tr is not None and tr.tracking_error is not None and res.t_a_s is not None
    after = tr.t >= res.t_a_s - 1e-12
    assert after.sum() >= 2
    assert np.max(np.abs(tr.tracking_error[after])) <= 1e-9
    hand_speed = tr.rd[after][:, None] * (PATH.p1 - PATH.p0)
    assert_allclose(hand_speed, np.broadcast_to(REF.belt_velocity, hand_speed.shape), atol=1e-12)
    # before t_a the hand is not yet on the part
    assert np.max(np.abs(tr.tracking_error[~after])) > 1e-3
    # steady state: Eq. (26) timing dt = dx1 / x~2 with x~2 = 0.4 /s
    assert_allclose(np.diff(tr.t[after]), (1 / 50) / 0.4, atol=1e-12)
    assert tr.t[-1] == pytest.approx(3.0, abs=1e-12)  # t_f: the part reaches r = 1


def test_dp_cost_equals_the_cost_of_the_realised_path() -> None:
    """J*(0, 0) of Eq. (30) is the Eq. (22)/(28) sum along the followed NP pointers."""
    res = solve("full", 50, 100)
    tr = res.trajectory
    assert tr is not None
    k = plan_part(res)
    t, r, rd = tr.t[k], tr.r[k], tr.rd[k]
    dt = np.diff(t)
    ref_r = 0.4 * t[:-1] - 0.2  # park Eq. (17)
    J = np.sum(dt * ((r[:-1] - ref_r) ** 2 + (rd[:-1] - 0.4) ** 2))
    assert res.cost == pytest.approx(J, rel=1e-12)


def test_trajectory_starts_at_rest_at_t0() -> None:
    res = solve("full", 50, 100)
    tr = res.trajectory
    assert tr is not None and res.t_start_s is not None
    assert tr.t[0] == 0.0 and tr.r[0] == 0.0 and tr.rd[0] == 0.0
    assert 0.0 <= res.t_start_s < res.t_a_s  # type: ignore[operator]
    assert np.all(np.diff(tr.t) > 0)
    assert_allclose(tr.hand[0], PATH.p0, atol=1e-15)
    shapes = {a.shape[0] for a in (tr.t, tr.r, tr.rd, tr.q, tr.qd, tr.qdd, tr.jerk, tr.torque)}
    assert shapes == {tr.t.size}


def test_result_record_fields() -> None:
    res = solve("torque", 50, 100)
    assert res.grid.N1 == 50 and res.grid.N2 == 100 and res.grid.Nt == 80
    assert res.grid.x2_max == pytest.approx(0.5)  # x2[N2] = 0.4 * 100 / 80
    assert res.peak_torque is not None and res.peak_torque.shape == (2,)
    assert "torque_1" in res.active_limits
    assert res.limit_usage["torque_1"] <= 1.0 + TOL
    assert res.duration_s == pytest.approx(3.0)
    assert res.solve_time_s > 0.0
    with pytest.raises(AttributeError):
        res.t_a_s = 0.0  # type: ignore[misc]


def test_general_chain_dynamics_gives_the_same_plan() -> None:
    """The DP only needs inverse dynamics: RNEA on park's arm reproduces the closed form."""
    eye = np.eye(4)
    tip = np.eye(4)
    tip[0, 3] = 1.0
    rod = np.diag([0.0, 1.0, 1.0]) / 12.0
    chain = SerialChainDynamics(
        A=np.stack([eye, tip]),
        B=np.stack([eye, eye]),
        kinds=np.array([0, 0]),
        masses=np.ones(2),
        coms=np.array([[0.5, 0, 0], [0.5, 0, 0]]),
        inertias=np.stack([rod, rod]),
        gravity=np.array([0.0, 0.0, -9.81]),
    )
    res = solve_conveyor_tracking(
        dynamics=chain, path=PATH, reference=REF, limits=LIMITS["full"], N1=30, N2=50
    )
    ref = solve("full", 30, 50)
    assert res.t_a_s == ref.t_a_s
    assert_allclose(res.peak_torque, ref.peak_torque, atol=1e-12)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("limits", "where", "names"),
    [
        (TrackLimits.symmetric(torque=[0.5, 0.004]), (1.0, 1.0), ("torque_2",)),
        (TrackLimits.symmetric(qd=[0.1, 0.1]), (1.0, 1.0), ("qd_1",)),
        (TrackLimits.symmetric(torque=[0.05, 0.05]), (0.0, 0.02), ("torque_1", "torque_2")),
        (TrackLimits.symmetric(qdd=[0.01, 0.01]), (0.98, 1.0), ("qdd_1", "qdd_2")),
    ],
)
def test_infeasible_limits_are_named_with_their_place(limits, where, names) -> None:
    res = solve_conveyor_tracking(
        dynamics=DYN, path=PATH, reference=REF, limits=limits, N1=50, N2=100
    )
    assert res.status is TrackStatus.INFEASIBLE
    assert res.trajectory is None and not res.limits_ok
    assert res.blocked_at_r == pytest.approx(where)
    assert res.blocking_limits == names
    assert res.message.startswith("infeasible: ")
    family = {"torque": "torque limit", "qd": "joint velocity limit", "qdd": "acceleration"}
    assert family[names[0].split("_")[0]] in res.message
    assert "r = " in res.message


def test_time_optimal_torque_limits_vs_toppra_value() -> None:
    """PAPER_NOTES: TOPP-RA gives 2.530 s rest to rest with the torque limits of Eq. (36)."""
    res = solve("torque", 50, 500, "time")
    assert res.status is TrackStatus.OK and res.limits_ok
    assert 2.530 <= res.duration_s <= 2.530 * 1.02  # type: ignore[operator]
    tr = res.trajectory
    assert tr is not None
    assert tr.rd[0] == 0.0 and tr.rd[-1] == 0.0 and tr.t[0] == 0.0
    assert res.t_a_s is None
    assert solve("torque", 30, 300, "time").duration_s >= 2.530  # type: ignore[operator]


def test_time_optimal_torque_velocity_acceleration_vs_toppra_value() -> None:
    """PAPER_NOTES: TOPP-RA gives 3.041 s with torque + |qd| <= 0.2 + |qdd| <= 0.3."""
    res = solve("tva", 50, 500, "time")
    assert res.status is TrackStatus.OK and res.limits_ok
    assert 3.041 <= res.duration_s <= 3.041 * 1.02  # type: ignore[operator]
    tr = res.trajectory
    assert tr is not None
    assert np.all(np.abs(tr.qd) <= QD + TOL)
    assert np.all(np.abs(tr.qdd[:-1]) <= QDD + TOL)


def test_time_optimal_with_jerk_is_never_faster() -> None:
    full = solve("full", 30, 300, "time")
    tva = solve("tva", 30, 300, "time")
    assert full.status is TrackStatus.OK and full.limits_ok
    assert full.duration_s >= tva.duration_s >= 3.041  # type: ignore[operator]


def test_bad_problems_raise_config_error() -> None:
    with pytest.raises(ConfigError, match="line"):
        solve_conveyor_tracking(
            dynamics=DYN,
            path=PATH,
            reference=ConveyorReference([-0.9, 1.7], [0.2, 0.0]),
            N1=10,
            N2=20,
        )
    with pytest.raises(ConfigError, match="away"):
        solve_conveyor_tracking(
            dynamics=DYN,
            path=PATH,
            reference=ConveyorReference([-0.9, 1.732], [-0.2, 0.0]),
            N1=10,
            N2=20,
        )
    with pytest.raises(ConfigError, match="reference"):
        solve_conveyor_tracking(dynamics=DYN, path=PATH, N1=10, N2=20)
    with pytest.raises(ConfigError, match="bound"):
        solve_conveyor_tracking(dynamics=DYN, path=PATH, N1=10, N2=20, objective="time")
    with pytest.raises(ConfigError, match="2 values"):
        solve_conveyor_tracking(
            dynamics=DYN,
            path=PATH,
            reference=REF,
            limits=TrackLimits.symmetric(torque=[1.0, 1.0, 1.0]),
            N1=10,
            N2=20,
        )


def test_limits_validation() -> None:
    with pytest.raises(ValueError, match="lo <= hi"):
        TrackLimits(torque=(np.array([1.0, 0.0]), np.array([0.0, 1.0])))


def test_summary_and_columns_are_writer_ready() -> None:
    import json

    res = solve("full", 30, 50)
    summary = json.loads(json.dumps(res.summary()))
    assert summary["status"] == "ok" and summary["grid"]["Nt"] == 40
    assert summary["t_a_s"] == pytest.approx(res.t_a_s)
    assert len(summary["peak_torque"]) == 2
    assert res.trajectory is not None
    cols = res.trajectory.columns()
    assert {"t_s", "q1_rad", "qd2_rad_s", "jerk1_rad_s3", "u2_Nm", "part_x_m", "error_y_m"} <= set(
        cols
    )
    assert {c.shape for c in cols.values()} == {res.trajectory.t.shape}
    bad = solve_conveyor_tracking(
        dynamics=DYN,
        path=PATH,
        reference=REF,
        limits=TrackLimits.symmetric(qd=[0.1, 0.1]),
        N1=10,
        N2=20,
    )
    assert json.loads(json.dumps(bad.summary()))["status"] == "infeasible"


def test_joint_position_limits_are_dp_constraints() -> None:
    """dpct reading 8: a stage whose q(r) leaves the joint limits makes the plan infeasible,
    named by joint and r; inside the limits their usage is reported like the others."""
    q = PATH.q(np.linspace(0.0, 1.0, 51))
    q2_max = float(np.median(q[:, 1]))  # q2 crosses this half way along the line
    lo = np.array([-np.pi, -np.pi])
    res = solve_conveyor_tracking(
        dynamics=DYN, path=PATH, reference=REF, N1=50, N2=100,
        limits=TrackLimits(q=(lo, np.array([np.pi, q2_max]))), joint_names=["q1", "q2"])
    assert res.status is TrackStatus.INFEASIBLE
    assert res.blocking_limits == ("q_2",)
    i = int(np.flatnonzero(q[:, 1] > q2_max * (1 + 1e-9) + 1e-9)[0])
    assert res.blocked_at_r == (pytest.approx(i / 50), pytest.approx(i / 50))
    assert "joint position limit (joint 2 = q2)" in res.message
    assert f"at r = {i / 50:.4g}" in res.message
    ok = solve_conveyor_tracking(
        dynamics=DYN, path=PATH, reference=REF, N1=50, N2=100,
        limits=TrackLimits(q=(lo, np.array([np.pi, 1.01 * float(q[:, 1].max())]))))
    assert ok.status is TrackStatus.OK and ok.limits_ok
    # usage: distance from the middle of [lo, hi] over the half width
    u2 = (q[:, 1].max() - 0.5 * (-np.pi + 1.01 * q[:, 1].max())) / (
        0.5 * (1.01 * q[:, 1].max() + np.pi))
    assert ok.limit_usage["q_2"] == pytest.approx(u2, rel=1e-9)
    assert ok.t_a_s == solve("none", 50, 100).t_a_s  # a slack position limit changes nothing


def test_part_ahead_of_the_hand_is_planned_with_a_time_penalty() -> None:
    """dpct reading 9: the part starts ahead of the hand (r~(0) = 0.04), no limits at all.
    Was infeasible ("start no earlier than t_0 = 0"); the relaxed start rule plans it: the
    hand leaves rest at t = 0, never runs earlier, and ends on the part."""
    ref = ConveyorReference(part_start=[-0.78, 1.732], belt_velocity=[0.2, 0.0])
    res = solve_conveyor_tracking(dynamics=DYN, path=PATH, reference=ref, N1=50, N2=100)
    assert res.status is TrackStatus.OK, res.message
    assert res.time_penalty > 0.0 and "part starts ahead" in res.message
    tr = res.trajectory
    assert tr is not None and tr.t[0] == 0.0 and np.all(np.diff(tr.t) > 0.0)
    assert res.t_start_s >= -1e-9
    assert tr.t[-1] == pytest.approx((1.0 - 0.04) / 0.4, abs=1e-12)  # t_f of Eq. (17)
    assert np.max(np.abs(tr.tracking_error[tr.t >= res.t_a_s - 1e-12])) <= 1e-9
    # the reported cost is the tracking cost of Eq. (28) alone, recomputed from the nodes
    k = plan_part(res)
    t, r, rd = tr.t[k], tr.r[k], tr.rd[k]
    dt = np.diff(t)
    j = dt * ((r[:-1] - (0.04 + 0.4 * t[:-1])) ** 2 + (rd[:-1] - 0.4) ** 2)
    assert res.cost == pytest.approx(float(np.sum(j)), rel=1e-9)
    # the part behind the hand (park) needs no penalty
    assert solve("none", 50, 100).time_penalty == 0.0


def test_part_too_far_ahead_is_infeasible_and_says_why() -> None:
    """r~(0) = 0.4: the hand must cover r = 1 in t_f = 1.5 s, an average r' of 0.667 /s, above
    the grid's top x2[N2] = 0.4 * 100 / 80 = 0.5 /s: no plan exists on this grid."""
    ref = ConveyorReference(part_start=[-0.6, 1.732], belt_velocity=[0.2, 0.0])
    res = solve_conveyor_tracking(dynamics=DYN, path=PATH, reference=ref, N1=50, N2=100)
    assert 1.0 / 1.5 > res.grid.x2_max == pytest.approx(0.5)
    assert res.status is TrackStatus.INFEASIBLE
    assert "the part starts ahead of the hand (r~(0) = 0.4)" in res.message
    assert "1.25 x the part's r'" in res.message
    ok = solve_conveyor_tracking(dynamics=DYN, path=PATH, reference=ref, N1=50, N2=100,
                                 nt_fraction=0.5)  # top 0.8 /s > 0.667 /s
    assert ok.status is TrackStatus.OK and ok.trajectory.t[0] == 0.0


@pytest.mark.parametrize("case", ["none", "torque", "full"])
def test_intercept_objective_gives_the_earliest_steady_tracking(case: str) -> None:
    """dpct reading 10: cost = time off the part, J*(0, 0) = t_a. It never tracks later than
    DPCT on the same grid; without limits it meets the earliest on-part node of the grid:
    the first stage r = 0.02 at t = (0.02 + 0.2) / 0.4 = 0.55 s (the rest node r = 0 has
    r' = 0 != x~2); with all limits t_a >= 1.0935 s (PAPER_NOTES: |qd2| <= 0.2 at r' = 0.4)."""
    res = solve_conveyor_tracking(dynamics=DYN, path=PATH, reference=REF, N1=50, N2=100,
                                  limits=LIMITS[case], objective="intercept")
    assert res.status is TrackStatus.OK and res.limits_ok, res.message
    assert "intercepts the part" in res.message
    track = solve(case, 50, 100)
    assert res.t_a_s <= track.t_a_s + 1e-12
    assert res.cost == pytest.approx(res.t_a_s, abs=1e-5)  # plus 1e-6 x the tracking cost
    tr = res.trajectory
    after = tr.t >= res.t_a_s - 1e-12
    assert np.max(np.abs(tr.tracking_error[after])) <= 1e-9
    if case == "none":
        assert res.t_a_s == pytest.approx(0.55, abs=1e-12)
    if case == "full":
        assert 1.0935 <= res.t_a_s <= 1.10 + 1e-9
