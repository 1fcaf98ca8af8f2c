"""The track task: conveyor tracking (or minimum time) by DP in the phase plane (park §2-§5).

The hand moves on a path of :mod:`mechkin.solvers.track.path_geometry` (a straight line, park
Eq. (7), a circular arc or a C2 spline, r its normalised arc length) with its orientation
held, slerped or free; the joints follow it by the path inverse kinematics of
:mod:`mechkin.solvers.track.path_ik`
(continued along the path from the start solution, on the branch the scenario names); the
torques come from the mechanism's inertial parameters
(recursive Newton-Euler, park Eq. (8)); :func:`mechkin.solvers.track.plan.plan_track` plans
``r(t)`` by the DP of :func:`mechkin.solvers.track.dpct.solve_conveyor_tracking` or, for the
time and intercept objectives without a jerk limit (``planner: auto``), by TOPP-RA
(:mod:`mechkin.solvers.track.intercept`). Returns a
:class:`mechkin.records.Report` whose record (:class:`mechkin.records.track.TrackRecord`) the
writer :mod:`mechkin.io.track_out` turns into ``track.csv``, plots like park Figs. 4-8 and
``track.mcap``; writes nothing.

Imports: config, model, solvers, records, tasks.common.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mechkin.config.scenario import Scenario
from mechkin.config.track_spec import (
    GridSpec,
    TrackSpec,
    limit_count_message,
    mechanism_limits_si,
    path_mask,
    point_si,
)
from mechkin.config.units import angle_factor, length_factor
from mechkin.errors import ConfigError
from mechkin.model import Mechanism, load_mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.records import Report
from mechkin.records.track import GridTrace, TrackRecord
from mechkin.solvers.dynamics.from_mechanism import (
    dynamics_from_mechanism,
    planar_two_link_from_mechanism,
)
from mechkin.solvers.dynamics.open_chain import InverseDynamics
from mechkin.solvers.result import Stopped, stop_when
from mechkin.solvers.track.dpct import (
    ConveyorReference,
    TrackLimits,
    TrackResult,
    TrackStatus,
)
from mechkin.solvers.track.path_geometry import (
    ArcGeometry,
    LineGeometry,
    PathGeometry,
    SlerpOrientation,
    SplineGeometry,
)
from mechkin.solvers.track.path_ik import HandLineIK, HandPathIK, PathIKError
from mechkin.solvers.track.plan import plan_track
from mechkin.spatial.rotations import matrix_from_rpy
from mechkin.tasks import budget
from mechkin.tasks.common import evaluate_expect, expect_messages, joint_factor, output_flags
from mechkin.tasks.track_cases import case_record, case_traces, dp_options, solve_cases

CSV_NOTE_TOPP = ("planner topp: qdd = q' r'' + q'' r'^2 at each node with the r'' of the "
                 "segment leaving it (TOPP-RA, constant r'' per segment); jerk is its forward "
                 "difference (no jerk limit applies); where undefined (jerk at the last node "
                 "and across the initial wait) it is written as 0 and flagged 0 in "
                 "jerk_defined")
CSV_NOTE = ("qdd and jerk are forward differences (park Eq. (32)-(33)); where undefined (qdd at "
            "the last node, jerk at the last two nodes and across the initial wait) they are "
            "written as 0 and flagged 0 in qdd_defined / jerk_defined")


def _dynamics(sc: Scenario, mech: Mechanism) -> InverseDynamics:
    spec: TrackSpec = sc.section
    if spec.dynamics == "closed_form_2link":
        return planar_two_link_from_mechanism(mech)
    return dynamics_from_mechanism(mech)


def path_geometry(sc: Scenario) -> PathGeometry:
    """The scenario's hand path in SI: a line, arc or spline of
    :mod:`mechkin.solvers.track.path_geometry`."""
    spec: TrackSpec = sc.section
    path = spec.path
    units = sc.spec.units
    try:
        if path.type == "arc":
            return ArcGeometry(point_si(path.start, units), point_si(path.via, units),
                               point_si(path.end, units))
        if path.type == "spline":
            return SplineGeometry(np.stack([point_si(p, units) for p in path.points]))
        return LineGeometry(point_si(path.start, units), point_si(path.end, units))
    except ValueError as exc:
        raise ConfigError(f"{sc.doc.where(('track', 'path'))}: {exc}") from None


def path_orientation(sc: Scenario, geometry: PathGeometry) -> SlerpOrientation | None:
    """The given hand orientations (URDF rpy in the scenario's angle unit) as keyframes at r = 0
    (one: held), r = 0 and 1 (two) or the spline's points; None: held at the start pose."""
    path = sc.section.path
    if path.orientations is None:
        return None
    rpy = np.asarray(path.orientations, dtype=float) * angle_factor(sc.spec.units.angle)
    k = rpy.shape[0]
    knots = (np.zeros(1) if k == 1 else np.array([0.0, 1.0]) if k == 2
             else np.asarray(geometry.r_knots, dtype=float))
    return SlerpOrientation(matrix_from_rpy(rpy), knots, path.orientation_blend)


def hand_ik(sc: Scenario, mech: Mechanism) -> HandPathIK:
    """The path inverse kinematics of the scenario's hand path, frame, orientation, initial
    guess and branch (park Eq. (9)); every failure is a ConfigError located at its scenario
    key."""
    spec: TrackSpec = sc.section
    doc = sc.doc
    tol = spec.ik.tolerance * length_factor(sc.spec.units.length)
    fname = spec.path.frame
    if fname is None:
        if mech.end_effector is None:
            raise ConfigError(f"{doc.where(('track', 'path'))}: the mechanism has no "
                              "end_effector; name the hand frame in path.frame")
        f = int(mech.end_effector)
    else:
        try:
            f = mech.frame_index(fname)
        except KeyError as exc:
            raise ConfigError(f"{doc.where(('track', 'path', 'frame'))}: {exc.args[0]}") \
                from None
    q0 = np.asarray(mech.home, dtype=float).copy()
    guess = spec.ik.initial_guess or {}
    for name, v in guess.items():
        try:
            j = mech.joint_index(name)
        except KeyError as exc:
            raise ConfigError(f"{doc.where(('track', 'ik', 'initial_guess', name))}: "
                              f"{exc.args[0]}") from None
        q0[j] = v * joint_factor(mech, j, sc.spec.units)
    branch: dict[int, int] = {}
    for name, sign in (spec.ik.branch or {}).items():
        try:
            branch[mech.joint_index(name)] = 1 if sign == "positive" else -1
        except KeyError as exc:
            raise ConfigError(f"{doc.where(('track', 'ik', 'branch', name))}: "
                              f"{exc.args[0]}") from None
    geometry = path_geometry(sc)
    orientation = path_orientation(sc, geometry)
    try:
        if mech.is_closed and len(mech.dependent):  # closed chain: IK in q_v, loops closed
            from mechkin.solvers.track.closed_path_ik import ClosedHandLineIK, ClosedHandPathIK

            cmask = path_mask(spec.path, len(mech.independent))
            if geometry.straight and orientation is None:
                return ClosedHandLineIK(mech, f, geometry.p0, geometry.p1, q0, tol, branch,
                                        mask=cmask, tol_rot=spec.ik.orientation_tolerance)
            return ClosedHandPathIK(mech, f, geometry, q0, tol, branch, mask=cmask,
                                    tol_rot=spec.ik.orientation_tolerance,
                                    orientation=orientation)
        if geometry.straight and orientation is None:
            return HandLineIK(mech, f, geometry.p0, geometry.p1, q0, tol, branch,
                              mask=path_mask(spec.path, mech.n),
                              tol_rot=spec.ik.orientation_tolerance)
        return HandPathIK(mech, f, geometry, q0, tol, branch, mask=path_mask(spec.path, mech.n),
                          tol_rot=spec.ik.orientation_tolerance, orientation=orientation)
    except PathIKError as exc:
        first = ("track", "path", "points", "0") if spec.path.type == "spline" else \
            ("track", "path", "start")
        key = {"start": first, "path": ("track", "path"),
               "branch": ("track", "ik", "branch", exc.joint)}[exc.key]
        raise ConfigError(f"{doc.where(key)}: {exc.message}") from None
    except ValueError as exc:
        raise ConfigError(f"{doc.where(('track', 'path'))}: {exc}") from None


def _finite_or_none(a: np.ndarray) -> list[float | None]:
    """A limit vector for summary.json: an unbounded side is null."""
    return [float(v) if np.isfinite(v) else None for v in np.asarray(a, dtype=float)]


def _solve(spec: TrackSpec, grid: GridSpec, dyn: InverseDynamics, path: HandPathIK,
           ref: ConveyorReference | None, limits: TrackLimits, joint_names: list[str],
           dp: Any = None) -> TrackResult:
    return plan_track(
        dynamics=dyn, path=path, reference=ref, limits=limits, N1=grid.N1, N2=grid.N2,
        objective=spec.objective, nt_fraction=grid.nt_fraction,
        x2_max=grid.x2_max if spec.objective == "time" else None, joint_names=joint_names,
        planner=spec.resolved_planner(),
        dp=dp_options(spec.dp) if dp is None else dp,  # track.dp, or a case's dp
    )


def _solve_whole(*args: Any) -> TrackResult:
    """:func:`_solve` of one grid of a grid study (a job): never stopped inside its DP (the
    run stops between two grids, keeping the grids solved)."""
    with stop_when(None):
        return _solve(*args)


def _grid_record(res: TrackResult) -> dict[str, Any]:
    s = res.summary()
    keys = ("status", "message", "t_a_s", "t_start_s", "duration_s", "peak_torque", "limits_ok",
            "active_limits", "solve_time_s", "cost", "blocked_at_r", "blocking_limits")
    rec = {"N1": res.grid.N1, "N2": res.grid.N2, "Nt": res.grid.Nt,
           "x2_max_1_s": res.grid.x2_max}
    rec.update({k: s[k] for k in keys})
    return rec


def _check_budget(scenario: Scenario, mech: Any) -> None:
    """The DP's memory before any work: N1 x N2 states (cost, predecessor, times, joint
    values, rates and torques per state) plus one stage's N2 x N2 transitions per joint."""
    from mechkin.tasks.estimates import dp_seconds

    spec: TrackSpec = scenario.section
    grids = [spec.grid] + list(spec.grid_study or [])
    for k, g in enumerate(grids):
        states = 8.0 * g.N1 * g.N2 * (8 + 4 * mech.n)
        stage = 8.0 * g.N2 * g.N2 * (4 + 3 * mech.n)
        key = ("track", "grid") if k == 0 else ("track", "grid_study", str(k - 1))
        budget.check(scenario.doc.where(key), 2.0 * (states + stage),
                     f"a {g.N1} x {g.N2} DP grid for {mech.n} joints")
        budget.estimate_time(scenario.doc.where(key), dp_seconds(g.N1, g.N2, k == 0),
                             f"a {g.N1} x {g.N2} DP grid")


def check_budget(scenario: Scenario) -> None:
    """The run's memory budget check, without solving."""
    _check_budget(scenario, load_mechanism(scenario.mechanism_path))


def run(scenario: Scenario) -> Report:
    """Plan the scenario's tracking (or minimum-time) motion.

    The report's ``solver_ok`` holds when the plan exists and every limit holds on the
    realised trajectory (on every grid of a grid study); an infeasible problem has status
    ``infeasible`` and a message naming the blocking limit and where it blocks.
    """
    spec: TrackSpec = scenario.section
    units = scenario.spec.units
    doc = scenario.doc
    mech = load_mechanism(scenario.mechanism_path)
    _check_budget(scenario, mech)
    dyn = _dynamics(scenario, mech)
    lim = mechanism_limits_si(spec.limits, units, mech)
    if "q" not in lim:  # the mechanism's joint limits are DP constraints (dpct reading 8)
        lim["q"] = (np.asarray(mech.lower, dtype=float), np.asarray(mech.upper, dtype=float))
    for name, (lo, _) in lim.items():
        if lo.shape != (mech.n,):
            raise ConfigError(f"{doc.where(('track', 'limits', name))}: "
                              f"{limit_count_message(mech, lo.shape[0])}")
    limits = TrackLimits(**lim)
    ik = path = hand_ik(scenario, mech)
    p0, p1 = ik.p0, ik.p1
    ref = None
    if spec.conveyor is not None:
        acc = spec.conveyor.belt_acceleration
        ref = ConveyorReference(part_start=point_si(spec.conveyor.part_start, units),
                                belt_velocity=point_si(spec.conveyor.belt_velocity, units),
                                belt_acceleration=None if acc is None else point_si(acc, units))
        try:
            ref.motion(path)
        except ConfigError as exc:
            raise ConfigError(f"{doc.where(('track', 'conveyor'))}: {exc}") from None

    n_plans = (1 + len([g for g in spec.grid_study or [] if g != spec.grid])
               + len(spec.cases or []))  # the scenario's grid, the other grids, the cases
    try:
        res = _solve(spec, spec.grid, dyn, path, ref, limits, list(mech.joint_names))
    except Stopped:  # --max-time between two DP stages: no plan, the summary says so
        budget.note_done(0, n_plans, "plans")
        return _stopped_report(scenario, mech)
    study: list[dict[str, Any]] | None = None
    study_results: list[TrackResult] = []
    if spec.grid_study is not None:
        # the other grids are independent jobs (mechkin.tasks.distributed): one process,
        # --workers N or --scheduler; the same solve on the same inputs, so bitwise the same
        from mechkin.tasks.distributed import call, map_jobs

        todo = [g for g in spec.grid_study if g != spec.grid]
        solved = iter(map_jobs(call, [(_solve_whole, (spec, g, dyn, path, ref, limits,
                                                list(mech.joint_names))) for g in todo],
                               f"track: grid study ({len(todo)} grids)", partial=True))
        # after a --max-time stop: the grids solved so far
        study_results = [r for r in (res if g == spec.grid else next(solved, None)
                                     for g in spec.grid_study) if r is not None]
        study = [_grid_record(r) for r in study_results]
    cases = solve_cases(scenario, mech, res, lambda lm, dp: _solve(
        spec, spec.grid, dyn, path, ref, lm, list(mech.joint_names), dp))  # track.cases
    done = 1 + len([r for r in study_results if r is not res]) + len(cases)
    if budget.stop_info() is not None and done < n_plans:  # stopped before the last plan
        budget.note_done(done, n_plans, "plans")

    summary: dict[str, Any] = {
        "scenario": scenario.name,
        "task": "track",
        "mechanism": mech.name,
        "dynamics": spec.dynamics,
        **res.summary(),
    }
    summary["actuated_joints"] = [mech.joint_names[j] for j in (
        mech.independent if mech.is_closed and len(mech.dependent) else range(mech.n))]
    summary["peak_torque_by_joint"] = (
        None if res.peak_torque is None
        else {n: float(v) for n, v in zip(mech.joint_names, res.peak_torque, strict=True)})
    summary["path"] = {**ik.geometry.summary(), "frame": mech.frame_names[ik.f],
                       "orientation": ik.orientation_mode, "mask": list(ik.mask),
                       "task_rank": ik.rank, "redundancy": ik.redundancy}
    if ik.orientation is not None and ik.orientation.varying:
        summary["path"]["orientation_blend"] = ik.orientation.blend
    if hasattr(ik, "singularities_crossed"):  # a closed chain: change points passed
        summary["path"]["constraint_singularities_crossed"] = ik.singularities_crossed()
    if res.trajectory is not None:  # the realised plan, verified by forward kinematics
        summary["path"].update(ik.pose_errors(res.trajectory.q, res.trajectory.r))
    if ref is not None:
        pm = ref.motion(path)
        t_f = float(pm.time_at(1.0))
        summary["reference"] = {"r0": pm.r0, "rd_1_s": pm.rd,
                                "t_f_s": t_f if np.isfinite(t_f) else None,
                                "rdd_1_s2": pm.ra}
    summary["limits_si"] = {k: {"min": _finite_or_none(lo), "max": _finite_or_none(hi)}
                            for k, (lo, hi) in lim.items()}
    if study is not None:
        summary["grid_study"] = study
    if cases:
        summary["cases"] = [case_record(c, r) for c, r, _ in cases]
    traj = res.trajectory
    if traj is not None:
        summary["n_samples"] = int(traj.t.shape[0])
        summary["csv_notes"] = CSV_NOTE_TOPP if res.planner == "topp" else CSV_NOTE
    checks = evaluate_expect(summary, scenario.spec.expect)
    for c in checks:  # a value missing from the summary (infeasible: t_a_s None) is null, not NaN
        for k in ("actual", "error"):
            if isinstance(c.get(k), float) and not np.isfinite(c[k]):
                c[k] = None
                c.setdefault("message", f"no value at {c['key']!r} in the summary")
    if checks:
        summary["expect"] = checks
    ok = res.status is TrackStatus.OK and res.limits_ok
    if study is not None:
        ok = ok and all(r["status"] == "ok" and r["limits_ok"] for r in study)
    ok = ok and all(r.status is TrackStatus.OK and r.limits_ok for _, r, _ in cases)
    messages_cases = [f"{scenario.path}: case {c.name}: {r.message}" for c, r, _ in cases
                      if r.status is not TrackStatus.OK]
    messages = expect_messages(checks, scenario.path)
    if res.status is not TrackStatus.OK:
        messages.append(f"{scenario.path}: {res.message}")
    messages += messages_cases
    rec = None
    if traj is not None:
        rec = _record(scenario, mech, res, [r for r in study_results if r is not res], lim,
                      summary.get("reference"),
                      (p0, p1) if ik.geometry.straight else tuple(ik.hand(np.linspace(0, 1, 129))),
                      ref)
        rec.cases = case_traces(cases)  # overlays of park Figs. 5-8
        rec.hand_frame = mech.frame_names[ik.f]
        if mech.is_closed and len(mech.dependent):  # the motors' panels, not 30 zero torques
            rec.actuated = [int(j) for j in mech.independent]
    return Report(task="track", scenario=scenario.name, summary=summary, checks=checks,
                  solver_ok=ok, writer="track", data=rec, outputs=output_flags(scenario),
                  scenario_path=scenario.path, messages=messages)


def _stopped_report(scenario: Scenario, mech: Mechanism) -> Report:
    """The report of a run stopped by ``--max-time`` inside the scenario's own DP: no plan
    (only summary.json; :func:`mechkin.tasks.budget.mark_stopped` adds the status)."""
    g = scenario.section.grid
    summary = {"scenario": scenario.name, "task": "track", "mechanism": mech.name,
               "dynamics": scenario.section.dynamics, "status": "stopped",
               "grid": {"N1": g.N1, "N2": g.N2}}
    return Report(task="track", scenario=scenario.name, summary=summary, solver_ok=False,
                  writer="track", data=None, outputs=output_flags(scenario),
                  scenario_path=scenario.path)


def _record(scenario: Scenario, mech: Mechanism, res: TrackResult, others: list[TrackResult],
            lim: dict[str, tuple[np.ndarray, np.ndarray]], reference: dict[str, float] | None,
            ends: tuple[np.ndarray, np.ndarray], ref: ConveyorReference | None) -> TrackRecord:
    """The writer's record of a feasible plan: trajectory, grid traces, frame tree, scene."""
    traj = res.trajectory
    assert traj is not None
    spec: TrackSpec = scenario.section
    rec = TrackRecord(
        title=scenario.name, mechanism=mech.name, joint_names=list(mech.joint_names),
        prismatic=[bool(s == 1) for s in mech.s], trajectory=traj,
        grid=(res.grid.N1, res.grid.N2), t_a_s=res.t_a_s,
        phase_ref=None if reference is None else (reference["r0"], reference["rd_1_s"]),
        study=[GridTrace(o.grid.N1, o.grid.N2, o.trajectory.r, o.trajectory.rd)
               for o in others if o.trajectory is not None],
        limits={k: (np.asarray(lo), np.asarray(hi)) for k, (lo, hi) in lim.items()},
        ends=np.stack(ends),
        metadata={"scenario": scenario.name, "mechanism": mech.name, "task": "track"},
    )
    if ref is not None and spec.conveyor is not None:
        rec.belt_velocity = np.asarray(ref.belt_velocity, dtype=float)
        rec.part_size = point_si(spec.conveyor.part_size, scenario.spec.units)
    if scenario.spec.outputs.mcap or scenario.spec.outputs.plots:
        from mechkin.model.drawing import frame_tree, skeleton_segments

        kin = forward_kinematics(mech, traj.q)
        fname = spec.path.frame
        f = mech.frame_index(fname) if fname is not None else int(mech.end_effector)
        rec.hand_T = kin.frames(mech, f)  # the hand triads of path_3d.png
        rec.frame_root, rec.frame_names, rec.frame_parents, rec.T_parent_child = \
            frame_tree(mech, kin)
        rec.segments = skeleton_segments(mech, kin)
        rec.axis_points = kin.axes()[1]
    if scenario.spec.outputs.mcap:
        from mechkin.tasks.robot import rate_limits, robot_description

        rec.robot = robot_description(mech, rate_limits(mech, rec.limits))
        rec.motors = [mech.joint_names[i] for i in mech.independent]
    return rec
