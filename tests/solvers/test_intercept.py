"""TOPP-RA time and intercept plans of the track task (mechkin.solvers.track.intercept), the DP
intercept by decomposition (dpct reading 11), the accelerating belt, and toppra's
rest-to-moving-state minimum time (skipped when toppra, the bench extra, is missing)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from mechkin.config.scenario import load_scenario
from mechkin.errors import ConfigError
from mechkin.solvers.dynamics.open_chain import PlanarTwoLinkDynamics
from mechkin.solvers.result import Status
from mechkin.solvers.track.dpct import (
    ConveyorReference,
    PartMotion,
    TrackLimits,
    TrackResult,
    TrackStatus,
)
from mechkin.solvers.track.path import PlanarTwoLinkLinePath, phase_coefficients
from mechkin.solvers.track.plan import plan_track as solve_conveyor_tracking
from mechkin.solvers.track.topp import plan_time_optimal
from tests.scenario_copy import local_scenario as _local

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "scenarios"
PATH = PlanarTwoLinkLinePath([-0.8, 1.732], [-0.3, 1.732])
DYN = PlanarTwoLinkDynamics()
TORQUE, QD, QDD = np.array([0.5, 0.2]), np.array([0.2, 0.2]), np.array([0.3, 0.3])
FULL = TrackLimits.symmetric(torque=TORQUE, qd=QD, qdd=QDD)
#: park §5.1's part (behind the hand by 0.1 m, 0.2 m/s); a slow part ahead; an accelerating
#: belt (park §6), part behind.
REFS = {
    "behind": ConveyorReference([-0.9, 1.732], [0.2, 0.0]),
    "ahead": ConveyorReference([-0.75, 1.732], [0.05, 0.0]),
    "accelerating": ConveyorReference([-0.9, 1.732], [0.1, 0.0], [0.05, 0.0]),
}
#: The DP grids of the comparison (N2 = 10 N1 where the DP's fastest leg needs a fine r' grid,
#: as for the time objective: park_time_optimal_*.yaml).
DP_GRIDS = {"behind": (50, 100), "ahead": (50, 500), "accelerating": (100, 200)}


@cache
def topp(case: str, N: int = 1000) -> TrackResult:
    return solve_conveyor_tracking(dynamics=DYN, path=PATH, reference=REFS[case], limits=FULL,
                                   N1=N, objective="intercept", planner="topp")


def test_part_motion_time_and_speed_invert_the_position() -> None:
    """``time_at`` and ``speed_at`` invert ``r~(t) = r0 + rd t + ra t^2 / 2`` (any sign of
    ra while the part moves forwards)."""
    t = np.linspace(0.0, 3.0, 31)
    for ra in (0.0, 0.05, -0.05):
        pm = PartMotion(-0.2, 0.2, ra)
        r = pm.position(t)
        np.testing.assert_allclose(pm.time_at(r), t, atol=1e-12)
        np.testing.assert_allclose(pm.speed_at(r), pm.speed(t), atol=1e-12)


def test_reference_motion_maps_the_belt_acceleration_onto_the_line() -> None:
    """Hand line of length 0.5 m along x: 0.05 m/s^2 is r'' = 0.1 /s^2; off the line: refused."""
    pm = REFS["accelerating"].motion(PATH)
    assert (pm.r0, pm.rd, pm.ra) == pytest.approx((-0.2, 0.2, 0.1), abs=1e-12)
    np.testing.assert_allclose(REFS["accelerating"].position(np.array([2.0]))[0],
                               [-0.9 + 0.2 + 0.1, 1.732], atol=1e-12)
    off = ConveyorReference([-0.9, 1.732], [0.1, 0.0], [0.05, 0.01])
    with pytest.raises(ConfigError, match="acceleration is not along the hand's line"):
        off.motion(PATH)


@pytest.mark.parametrize("case", list(REFS))
def test_topp_intercept_meets_the_part_and_stays_on_it(case: str) -> None:
    res = topp(case)
    assert res.status is TrackStatus.OK and res.limits_ok, res.message
    assert res.planner == "topp" and "intercepts the part" in res.message
    tr = res.trajectory
    pm = REFS[case].motion(PATH)
    assert tr.t[0] == 0.0 and tr.rd[0] == 0.0 and tr.r[0] == 0.0  # from rest at t = 0
    after = tr.t >= res.t_a_s - 1e-12
    assert np.max(np.abs(tr.tracking_error[after])) <= 1e-9
    np.testing.assert_allclose(tr.rd[after], pm.speed(tr.t[after]), atol=1e-9)
    before = tr.t < res.t_a_s - 1e-9
    assert np.all(np.linalg.norm(tr.tracking_error[before], axis=1) > 1e-9)
    assert res.t_a_s == pytest.approx(float(pm.time_at(res.intercept_r)), abs=1e-12)
    assert tr.t[-1] == pytest.approx(float(pm.time_at(1.0)), abs=1e-12)
    assert np.all(np.diff(tr.t) > 0)
    # the realised torques, by inverse dynamics of the realised (q, qd, qdd), are the record's
    tau = DYN.inverse_dynamics(tr.q, tr.qd, tr.qdd)
    np.testing.assert_allclose(tau, tr.torque, atol=1e-12)


@pytest.mark.parametrize("case", list(REFS))
def test_topp_intercept_is_the_earliest(case: str) -> None:
    """At the grid point before s*, the fastest arrival at the part's state is later than the
    part; at the one after, it is in time (T_fast - T_part changes sign at s*)."""
    res = topp(case, 200)
    pm = REFS[case].motion(PATH)
    s = np.linspace(0.0, 1.0, 201)
    k = int(np.searchsorted(s, res.intercept_r))  # s[k-1] < s* <= s[k]

    def gap(j: int) -> float:
        pc = phase_coefficients(DYN, PATH, s[: j + 1])
        r = plan_time_optimal(s[: j + 1], pc.dq, pc.ddq, torque=TORQUE,
                              torque_coeffs=(pc.a, pc.b, pc.g), qd=QD, qdd=QDD,
                              sd_end=float(pm.speed_at(s[j])))
        if r.status is not Status.OK:
            return np.inf
        return float(r.duration_s) - float(pm.time_at(s[j]))

    assert gap(k - 1) > 0.0 or s[k - 1] <= max(pm.r0, 0.0)
    assert gap(min(k + 1, 200)) <= 1e-12


@pytest.mark.parametrize("case", list(REFS))
def test_dp_intercept_is_never_faster_than_topp_and_within_2_percent(case: str) -> None:
    """Issue 11 item 5: the DP (reading 10 for the part behind on a constant belt, reading 11
    for a part ahead or an accelerating belt) never beats TOPP-RA's intercept (converged:
    N = 1000 and 2000 agree to 1e-3) and is within 2 % at a fine grid."""
    ref = topp(case).t_a_s
    assert topp(case, 2000).t_a_s == pytest.approx(ref, rel=1e-3)
    N1, N2 = DP_GRIDS[case]
    dp = solve_conveyor_tracking(dynamics=DYN, path=PATH, reference=REFS[case], limits=FULL,
                                 N1=N1, N2=N2, objective="intercept", planner="dp")
    assert dp.status is TrackStatus.OK and dp.limits_ok, dp.message
    assert dp.planner == "dp"
    assert ref <= dp.t_a_s <= 1.02 * ref, (ref, dp.t_a_s)
    tr = dp.trajectory
    after = tr.t >= dp.t_a_s - 1e-12
    assert np.max(np.abs(tr.tracking_error[after])) <= 1e-9


def test_dp_tracking_refuses_an_accelerating_belt() -> None:
    with pytest.raises(ConfigError, match="belt_acceleration: the tracking objective"):
        solve_conveyor_tracking(dynamics=DYN, path=PATH, reference=REFS["accelerating"],
                                limits=FULL, objective="tracking")


def test_hand_cannot_catch_the_part_is_infeasible_and_says_why() -> None:
    """A fast part far ahead: at the end of the line the fastest arrival with its speed is
    later than the part (which is then refused for every earlier intercept point too)."""
    ref = ConveyorReference([-0.5, 1.732], [0.15, 0.0])  # r~(t) = 0.6 + 0.3 t
    res = solve_conveyor_tracking(dynamics=DYN, path=PATH, reference=ref, limits=FULL, N1=200,
                                  objective="intercept", planner="topp")
    assert res.status is TrackStatus.INFEASIBLE
    assert "cannot catch the part" in res.message and "t_f = 1.333 s" in res.message


def test_topp_time_objective_equals_plan_time_optimal() -> None:
    res = solve_conveyor_tracking(dynamics=DYN, path=PATH, limits=FULL, N1=400,
                                  objective="time", planner="auto")
    assert res.planner == "topp" and res.status is TrackStatus.OK and res.limits_ok
    s = np.linspace(0.0, 1.0, 401)
    pc = phase_coefficients(DYN, PATH, s)
    ref = plan_time_optimal(s, pc.dq, pc.ddq, torque=TORQUE, torque_coeffs=(pc.a, pc.b, pc.g),
                            qd=QD, qdd=QDD)
    assert res.duration_s == ref.duration_s
    np.testing.assert_array_equal(res.trajectory.rd, ref.sd)
    assert res.trajectory.rd[-1] == 0.0 and res.trajectory.qd[-1].tolist() == [0.0, 0.0]


def test_topp_joint_position_limit_names_the_joint_and_r() -> None:
    """q2 falls along the line (elbow opening); an upper limit below its start value blocks at
    r = 0, one below a later value at the first grid point past it."""
    s = np.linspace(0.0, 1.0, 101)
    q = PATH.q(s)
    j = 0 if np.ptp(q[:, 0]) > np.ptp(q[:, 1]) else 1
    inc = q[-1, j] > q[0, j]
    cut = 0.5 * (q[40, j] + q[41, j])
    lo, hi = np.full(2, -10.0), np.full(2, 10.0)
    if inc:
        hi[j] = cut
    else:
        lo[j] = cut
    lim = TrackLimits(torque=(-TORQUE, TORQUE), q=(lo, hi))
    for objective, ref in (("time", None), ("intercept", REFS["behind"])):
        res = solve_conveyor_tracking(dynamics=DYN, path=PATH, reference=ref, limits=lim,
                                      N1=100, objective=objective, planner="topp",
                                      joint_names=["q1", "q2"])
        assert res.status is TrackStatus.INFEASIBLE
        assert f"joint {j + 1} = q{j + 1}" in res.message and "r = 0.41" in res.message
        assert res.blocking_limits == (f"q_{j + 1}",)


def test_planner_resolution() -> None:
    from mechkin.solvers.track.dpct import resolve_planner

    jerk = TrackLimits.symmetric(torque=TORQUE, jerk=np.array([2.3, 2.0]))
    assert resolve_planner("auto", "time", FULL) == "topp"
    assert resolve_planner("auto", "intercept", FULL) == "topp"
    assert resolve_planner("auto", "tracking", FULL) == "dp"
    assert resolve_planner("auto", "time", jerk) == "dp"
    assert resolve_planner("auto", "intercept", TrackLimits()) == "dp"  # nothing bounds r'
    with pytest.raises(ConfigError, match="cannot impose jerk limits"):
        resolve_planner("topp", "time", jerk)
    with pytest.raises(ConfigError, match="tracking"):
        resolve_planner("topp", "tracking", FULL)


# --- toppra: rest to a moving state ----------------------------------------------------------


@pytest.mark.parametrize("sd_end", [0.2, 0.35])
def test_rest_to_moving_state_matches_toppra(sd_end: float) -> None:
    """mechkin's TOPP-RA and toppra's TOPPRA on the same spline path and grid, torque +
    velocity + acceleration limits, from rest to s_dot = sd_end: within 0.5 % at N = 1000
    (issue 15's target; the same LPs, so in fact far closer)."""
    pytest.importorskip("toppra")
    import toppra
    import toppra.algorithm
    import toppra.constraint as tc

    toppra.setup_logging("WARNING")
    knots = np.linspace(0.0, 1.0, 41)
    spline = toppra.SplineInterpolator(knots, PATH.q(knots))
    grid = np.linspace(0.0, 1.0, 1001)

    def inv_dyn(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        return DYN.inverse_dynamics(q[None], qd[None], qdd[None])[0]

    kind = tc.DiscretizationType.Interpolation
    cons = [tc.JointTorqueConstraint(inv_dyn, np.stack([-TORQUE, TORQUE], 1), np.zeros(2),
                                     discretization_scheme=kind),
            tc.JointVelocityConstraint(np.stack([-QD, QD], 1)),
            tc.JointAccelerationConstraint(np.stack([-QDD, QDD], 1), discretization_scheme=kind)]
    algo = toppra.algorithm.TOPPRA(cons, spline, gridpoints=grid, solver_wrapper="seidel")
    traj = algo.compute_trajectory(0.0, sd_end)
    assert traj is not None
    q, dq, ddq = spline(grid), spline(grid, 1), spline(grid, 2)
    res = plan_time_optimal(grid, dq, ddq, q=q, torque=TORQUE,
                            inverse_dynamics=DYN.inverse_dynamics, qd=QD, qdd=QDD,
                            sd_end=sd_end)
    assert res.status is Status.OK and res.limits_ok, res.message
    assert res.sd[-1] == pytest.approx(sd_end, abs=1e-12)
    assert abs(res.duration_s - traj.duration) / traj.duration < 5e-3
    assert res.duration_s == pytest.approx(traj.duration, rel=1e-4)


# --- through the task -------------------------------------------------------------------------


def test_time_objective_through_the_task_auto_is_topp(tmp_path: Path) -> None:
    """planner auto = planner topp exactly, and it matches TOPP-RA on park's analytic path
    (the task's path IK and RNEA are independent of it) to 1e-6."""
    from mechkin.tasks.track import run

    edit = ("grid: {N1: 1000}", "grid: {N1: 400}")
    auto = run(load_scenario(_local(tmp_path, "park_time_optimal_full_topp", edit)))
    p = _local(tmp_path, "park_time_optimal_full_topp", edit, ("planner: auto", "planner: topp"))
    explicit = run(load_scenario(p))
    assert auto.summary["planner"] == explicit.summary["planner"] == "topp"
    assert auto.summary["duration_s"] == explicit.summary["duration_s"]
    direct = solve_conveyor_tracking(dynamics=DYN, path=PATH, limits=FULL, N1=400,
                                     objective="time", planner="topp")
    assert auto.summary["duration_s"] == pytest.approx(direct.duration_s, rel=1e-6)
    assert auto.solver_ok and auto.summary["limits_ok"]


def test_task_intercept_on_an_accelerating_belt(tmp_path: Path) -> None:
    from mechkin.tasks.track import run

    p = _local(tmp_path, "park_intercept_accelerating_belt", ("N1: 500", "N1: 200"))
    rep = run(load_scenario(p))
    s = rep.summary
    assert rep.solver_ok and s["planner"] == "topp" and s["objective"] == "intercept"
    assert s["reference"]["rdd_1_s2"] == pytest.approx(0.1, abs=1e-12)
    assert s["t_a_s"] == pytest.approx(topp("accelerating", 200).t_a_s, rel=1e-6)
    assert "topp" in s["csv_notes"]


@pytest.mark.parametrize(("edits", "match"), [
    ((("limits: {torque: [0.5, 0.2], qd: [0.2, 0.2], qdd: [0.3, 0.3]}",
       "limits: {torque: [0.5, 0.2], jerk: [2.3, 2.0]}"), ("planner: auto", "planner: topp")),
     "cannot impose jerk limits"),
    ((("objective: time", "objective: tracking"), ("planner: auto", "planner: topp")),
     "tracking"),
])
def test_bad_planner_is_a_located_config_error(tmp_path: Path, edits, match: str) -> None:
    p = _local(tmp_path, "park_time_optimal_full_topp", *edits)
    with pytest.raises(ConfigError, match=match) as exc:
        load_scenario(p)
    assert str(exc.value).startswith(f"{p}:")
    assert "\n" not in str(exc.value)


def test_accelerating_belt_with_the_dp_tracking_is_a_located_config_error(
        tmp_path: Path) -> None:
    p = _local(tmp_path, "park_intercept_accelerating_belt",
               ("objective: intercept", "objective: tracking"))
    with pytest.raises(ConfigError, match="belt_acceleration") as exc:
        load_scenario(p)
    assert str(exc.value).startswith(f"{p}:")


def test_task_topp_joint_limit_names_the_joint_and_r(tmp_path: Path) -> None:
    """park's elbow q2 opens from 0.61 rad as the hand comes closer to the base; an upper
    limit of 0.8 rad on it blocks the TOPP-RA plan where q2 first exceeds it."""
    from mechkin.tasks.track import run

    p = _local(tmp_path, "park_time_optimal_torque_topp", ("grid: {N1: 1000}", "grid: {N1: 200}"),
               ("limits: {torque: [0.5, 0.2]}",
                "limits: {torque: [0.5, 0.2], q: {min: [-10, -10], max: [10, 0.8]}}"))
    rep = run(load_scenario(p))
    s = rep.summary
    assert not rep.solver_ok and s["status"] == "infeasible" and s["planner"] == "topp"
    assert "joint position limit (joint 2 = " in s["message"] and "r = " in s["message"]
    assert s["blocking_limits"] == ["q_2"]
    r_b = s["blocked_at_r"][0]
    q2 = PATH.q(np.array([r_b - 1 / 200, r_b]))[:, 1]
    assert q2[0] <= 0.8 < q2[1]  # the first grid point past the limit
