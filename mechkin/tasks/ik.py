"""The ik task: independent joints that bring {E} onto each precision point (kim1995 §3-5),
by ``lm``, ``cg-golden`` or a closed form. Returns a :class:`mechkin.records.Report`; writes
nothing.

``solutions: all`` adds every distinct verified solution of each target
(:mod:`mechkin.solvers.ik.all_solutions`: the closed form where the mechanism has one, else
multi-start lm; the method's own answer is always one of them): each target record gets
``solutions`` (``q_v``, ``q``, ``position_error``, ``orientation_error`` per solution, nearest
the guess first) and ``n_solutions``, and ik.csv gets one row per solution with a ``solution``
column (0, 1, ... in that order; -1 for a target without any verified solution, whose row is
the method's answer) and ``primary`` (1 on the row that is the method's answer).

How the targets are solved (in order, in chunks, on workers) is in :mod:`~mechkin.tasks.ik_solve`,
``solutions: all`` in :mod:`~mechkin.tasks.ik_all`.

Imports: config, model, solvers, records, tasks.common, tasks.ik_solve, tasks.ik_all.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from mechkin.config.ik_spec import IkSpec, target_matrix
from mechkin.config.scenario import Scenario
from mechkin.config.units import angle_factor, length_factor
from mechkin.errors import ConfigError
from mechkin.model import Mechanism, load_mechanism
from mechkin.model.continuation import fk_rows
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.records import Report
from mechkin.solvers.ik import (
    IkOptions,
    IkStatus,
    pose_errors,
)
from mechkin.solvers.ik.all_solutions import (
    TOL_ORI_ALL,
    TOL_POS_ALL,
)
from mechkin.tasks import budget
from mechkin.tasks.common import (
    check_motion_budget,
    expect_messages,
    joint_factor,
    motion_record,
    output_flags,
    with_expect,
)
from mechkin.tasks.distributed import resolve as resolve_execution
from mechkin.tasks.estimates import ik_seconds
from mechkin.tasks.ik_all import _all_solutions, _clean, _solution_rows, _solutions_record
from mechkin.tasks.ik_analytic import (
    analytic_problem,
    analytic_structure,
    held_values,
    methods_used,
    solutions_summary_extra,
    solve_batch_analytic,
    solve_held,
    solve_sequence_batched,
)
from mechkin.tasks.ik_frames import has_target_sets, run_target_sets
from mechkin.tasks.ik_solve import _safe_norm, _solve_batch, _solve_split, solve_sequence
from mechkin.tasks.prepare import Prepared


def _closed_form_kind(scenario: Scenario, prepared: Prepared) -> str:
    """The closed form of the mechanism by structure (recognised once: by the validation
    when it ran), or ``legs`` for a parallel mechanism without a named closed form whose legs
    decompose; a declared one that does not fit, or none that fits, is bad input naming the
    mismatch."""
    from mechkin.solvers.closed_form.recognise import ClosedFormMismatch

    mech = prepared.mechanism
    try:
        kind = prepared.recognise_closed_form()
    except ClosedFormMismatch as exc:
        raise ConfigError(f"{scenario.doc.where(('mechanism',))}: {exc}") from None
    if kind is None:
        from mechkin.tasks.validate import _legs_decompose

        if _legs_decompose(mech):
            return "legs"  # any parallel mechanism whose legs decompose: the legs route
        raise ConfigError(f"{scenario.doc.where(('ik', 'method'))}: no closed form fits "
                          f"mechanism {mech.name} (declare closed_form: stewart | direct_drive | "
                          "lee_spherical in the mechanism file, give a parallel mechanism whose "
                          "legs decompose, or use method: lm)")
    return kind


def _targets(sc: Scenario, mech: Mechanism) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Precision points (k, 4, 4) [SI], weights (k, 6) and labels."""
    spec: IkSpec = sc.section
    Ts, Ws, names = [], [], []
    for i, t in enumerate(spec.targets):
        Ts.append(target_matrix(t, sc.spec.units))
        Ws.append(t.weights if t.weights is not None else spec.weights)
        names.append(t.name or f"P{i + 1}")
    if spec.random_targets is not None:
        rt = spec.random_targets
        _check_targets(sc, mech, rt.count + len(Ts))
        rng = np.random.default_rng(rt.seed)
        iv = mech.independent
        lo = np.where(np.isfinite(mech.lower[iv]), mech.lower[iv], -np.pi)
        hi = np.where(np.isfinite(mech.upper[iv]), mech.upper[iv], np.pi)
        qv = rng.uniform(lo, hi, size=(rt.count, len(iv)))
        res, _ = fk_rows(mech, qv)  # the assembly connected to home, within the limits
        kin = forward_kinematics(mech, res.q)
        T_E = kin.frames(mech, [mech.end_effector])[:, 0]
        keep = np.flatnonzero(res.ok)
        for k in keep:
            Ts.append(T_E[k])
            Ws.append(spec.weights)
            names.append(f"R{k + 1}")
    return np.array(Ts).reshape(-1, 4, 4), np.array(Ws, dtype=float), names


def _initial(sc: Scenario, mech: Mechanism) -> tuple[np.ndarray, np.ndarray]:
    qv, qw = mech.home[mech.independent].copy(), mech.home[mech.dependent].copy()
    guess = sc.section.initial_guess or {}
    ind, dep = mech.independent_names, mech.dependent_names
    bad = [k for k in guess if k not in ind and k not in dep]
    if bad:
        raise ConfigError([f"{sc.doc.where(('ik', 'initial_guess', k))}: not a joint of "
                           f"{mech.name} (independent: {', '.join(ind)})" for k in bad])
    for k, v in guess.items():
        val = v * joint_factor(mech, mech.joint_index(k), sc.spec.units)
        if k in ind:
            qv[ind.index(k)] = val
        else:
            qw[dep.index(k)] = val
    return qv, qw


def ik_options(spec: IkSpec, units: Any) -> IkOptions:
    """The solver options of an ``ik:`` section (tolerances converted to SI; the defaults of
    an IkSpec give the task's default solve: lm, restarts 50)."""
    tol = spec.tolerances
    L = length_factor(units.length)
    A = angle_factor(units.angle)
    return IkOptions(
        method="cg-golden" if spec.method == "cg-golden" else "lm", grad_tol=tol.grad,
        max_iter=tol.max_iter, tol_pos=tol.position * L if tol.position else 1e-6,
        tol_ori=tol.orientation * A if tol.orientation else 1e-6, restarts=spec.restarts,
        seed=spec.seed, tol_phi=tol.closure, line_tol=tol.line, cg_restart=spec.cg_restart,
        cg_variant=spec.variant,
        lm_grad_tol=tol.grad if "grad" in tol.model_fields_set else 0.0)


def reach_bound(mech: Mechanism) -> float:
    """An upper bound [m] of the distance of any frame from the base: the sum of every stick
    segment at home (constant for revolute joints) plus the largest stroke of every prismatic
    joint; inf when a stroke is unbounded."""
    from mechkin.model.drawing import skeleton_segments

    q0 = np.where(np.isfinite(mech.home), mech.home, 0.0)[None]
    seg = skeleton_segments(mech, forward_kinematics(mech, q0))[0]
    total = float(np.linalg.norm(seg[:, 1] - seg[:, 0], axis=-1).sum()) if seg.size else 0.0
    for j in np.flatnonzero(mech.s == 1):
        total += float(max(abs(mech.lower[j]), abs(mech.upper[j]))) + abs(float(q0[0, j]))
    return total


def beyond_reach(mech: Mechanism, T_P: np.ndarray, W: np.ndarray) -> np.ndarray:
    """Targets (k,) whose weighted position lies farther from the base than any frame can be
    (:func:`reach_bound`, with a 10 % margin): unreachable without a search."""
    bound = reach_bound(mech)
    if not np.isfinite(bound):
        return np.zeros(len(T_P), dtype=bool)
    dist = _safe_norm(T_P[:, :3, 3] * (W[:, :3] > 0))
    return dist > 1.1 * bound + 1e-9


def check_budget(scenario: Scenario) -> None:
    """The run's memory budget check (random targets) and time estimate, without solving."""
    spec: IkSpec = scenario.section
    if has_target_sets(spec):
        return
    rt = spec.random_targets
    mech = load_mechanism(scenario.mechanism_path)
    if rt is not None:
        _check_targets(scenario, mech, rt.count + len(spec.targets))
    _estimate(scenario, mech, (rt.count if rt is not None else 0) + len(spec.targets))


def _estimate(scenario: Scenario, mech: Mechanism, k: int) -> None:
    """k targets' time before any work (:func:`mechkin.tasks.estimates.ik_seconds`)."""
    spec: IkSpec = scenario.section
    key = ("ik", "random_targets") if spec.random_targets is not None else ("ik", "targets")
    budget.estimate_time(scenario.doc.where(key), ik_seconds(
        mech, k, spec.method, spec.restarts, scenario.spec.outputs),
        f"{k} ik targets ({spec.method}, up to {spec.restarts} restarts each)")


def _check_targets(scenario: Scenario, mech: Mechanism, k: int) -> None:
    """k ik targets (with their summary records) against the memory budget."""
    check_motion_budget(scenario, mech, k, ("ik", "random_targets", "count"), "ik targets",
                        extra_per_item=4000.0)


def run(scenario: Scenario, progress: bool | None = None, prepared: Prepared | None = None
        ) -> Report:
    """Solve every precision point in order (each warm-started from the previous solution,
    kim1995 §5.2 Step 2), or all at once with ``batch: true``; verify each by forward
    kinematics. Returns the report (summary, expect results, motion record with the
    convergence histories). ``prepared``: what validation computed (:func:`mechkin.tasks.run`
    hands it on: the mechanism and its closed form).
    """
    spec: IkSpec = scenario.section
    if prepared is None or prepared.mechanism is None:
        prepared = Prepared(mechanism=load_mechanism(scenario.mechanism_path))
    mech = prepared.mechanism
    if has_target_sets(spec):  # targets naming their frames: solved together per set
        o = ik_options(spec, scenario.spec.units)
        return run_target_sets(scenario, mech, *_initial(scenario, mech), o.tol_pos, o.tol_ori)
    if mech.end_effector is None:
        raise ConfigError(f"{scenario.doc.where(('mechanism',))}: mechanism {mech.name} has no "
                          "end_effector frame")
    kind = _closed_form_kind(scenario, prepared) if spec.method == "closed-form" else None
    if spec.method == "analytic":
        why = analytic_problem(scenario, mech)
        if why:
            raise ConfigError(why)
    T_P, W, labels = _targets(scenario, mech)
    if len(T_P) == 0:
        raise ConfigError(f"{scenario.doc.where(('ik',))}: no targets to solve")
    _estimate(scenario, mech, len(T_P))
    qv0, qw0 = _initial(scenario, mech)
    far = beyond_reach(mech, T_P, W)
    opts = ik_options(spec, scenario.spec.units)
    t0 = time.perf_counter()
    ex = resolve_execution(progress=progress)
    execution_info: dict[str, Any] | None = None
    fixed = held_values(scenario, mech)
    exact_batch = (solve_batch_analytic(mech, spec.method, T_P, W, qv0, qw0, opts)
                   if spec.batch and not far.any() and not fixed else None)
    # many targets of an open chain that decomposes: the sequence in one compiled loop
    # (the same answers as one by one, warm starts included)
    seq_batch = (solve_sequence_batched(mech, T_P, W, far, spec.method, opts, qv0, qw0,
                                        spec.warm_start)
                 if not spec.batch and not fixed else None)
    if fixed:  # held joints: the remaining chain by subproblems, warm-started
        results, guesses = solve_held(mech, fixed, T_P, W, qv0, opts, spec.warm_start)
    elif exact_batch is not None:  # auto / analytic: one compiled call for every target
        results, guesses = exact_batch, [(qv0, qw0)] * len(T_P)
    elif seq_batch is not None:
        results, guesses = seq_batch
    elif spec.batch and not far.any():
        results, execution_info = _solve_batch(scenario, T_P, W, qv0, qw0, opts, ex)
        guesses = [(qv0, qw0)] * len(T_P)
    elif ex.split:
        results, guesses, execution_info = _solve_split(scenario, mech, T_P, W, far, kind,
                                                        opts, qv0, qw0, ex)
    else:
        from mechkin.tasks.progress import progress_bar

        show = progress if progress is not None or len(T_P) >= 1000 else False
        with progress_bar(show, f"ik: {len(T_P)} targets", deadline=False) as update:
            results, guesses, _ = solve_sequence(mech, T_P, W, far, spec.method, kind, opts,
                                                 qv0, qw0, spec.warm_start, update,
                                                 stop=budget.overrun)
    solve_s = time.perf_counter() - t0
    if len(results) < len(T_P):  # stopped by --max-time: the solved targets only
        budget.note_done(len(results), len(T_P), "targets")
        k = len(results)
        T_P, W, labels, far, guesses = T_P[:k], W[:k], labels[:k], far[:k], guesses[:k]
    all_sols = (_all_solutions(scenario, prepared, T_P, W, results, guesses, far, opts)
                if spec.solutions == "all" else None)
    q = np.array([r.q for r in results])
    q = np.where(np.isfinite(q), q, mech.home)
    kin = forward_kinematics(mech, q)
    T_E = kin.frames(mech, [mech.end_effector])[:, 0]
    with np.errstate(over="ignore", invalid="ignore"):
        pe, oe = pose_errors(T_E, T_P)  # verified by forward kinematics of the model
    pe = np.where(np.isfinite(pe), pe, _safe_norm(T_E[:, :3, 3] - T_P[:, :3, 3]))
    phi = closure_residual(mech, kin)
    phin = np.linalg.norm(phi, axis=1) if phi.shape[1] else np.zeros(len(q))
    status = [r.status.value for r in results]
    counts = {s.value: status.count(s.value) for s in IkStatus if s.value in status}
    overall = "ok" if counts.get("ok", 0) == len(results) else next(
        s.value for s in (IkStatus.SINGULAR, IkStatus.UNREACHABLE, IkStatus.AT_LIMIT,
                          IkStatus.NOT_CONVERGED) if s.value in status)
    records = []
    for i, r in enumerate(results):
        rec: dict[str, Any] = {
            "name": labels[i],
            "status": r.status.value,
            "q": {n: float(v) for n, v in zip(mech.joint_names, q[i], strict=False)},
            "q_v": {n: float(q[i, j]) for n, j in zip(mech.independent_names,
                                                       mech.independent, strict=False)},
            "position_error": _clean(pe[i]),
            "orientation_error": _clean(oe[i]),
            "weights": [float(v) for v in W[i]],
            "f": _clean(r.f),
            "grad_norm": _clean(r.grad_norm),
            "iterations": int(r.iterations),
            "evaluations": int(r.evaluations),
            "time_s": float(r.time_s),
            "closure_residual": _clean(phin[i]),
            "joints_at_limit": list(r.at_limit),
            "target": {"xyz_m": T_P[i, :3, 3].tolist(), "R": T_P[i, :3, :3].tolist()},
            "end_effector": {"xyz_m": T_E[i, :3, 3].tolist(), "R": T_E[i, :3, :3].tolist()},
        }
        if r.restarts_used:
            rec["restarts_used"] = int(r.restarts_used)
        if all_sols is not None:
            rec.update(_solutions_record(mech, all_sols[i]))
        records.append(rec)
    times_s = np.array([r.time_s for r in results])
    summary: dict[str, Any] = {
        "scenario": scenario.name,
        "task": "ik",
        "mechanism": mech.name,
        "method": spec.method,
        "methods_used": methods_used(results),
        "status": overall,
        "n_targets": len(results),
        "counts": counts,
        "max_position_error": _clean(float(pe.max())),
        "max_orientation_error": _clean(float(oe.max())),
        "solve_time_s": solve_s,
        "median_time_per_target_s": float(np.median(times_s)),
        "end_effector": mech.frame_names[mech.end_effector],
        "targets": records,
    }
    if "analytic" in summary["methods_used"]:
        structure = analytic_structure(mech, fixed)
        if structure:
            summary["analytic_structure"] = structure
    if execution_info is not None:
        summary["execution"] = execution_info
    if all_sols is not None:
        n_sol = [a.count for a in all_sols]
        summary["solutions"] = {
            "mode": "all", "source": sorted({a.source for a in all_sols}),
            "n_solutions": n_sol, "total": int(sum(n_sol)),
            "time_s": float(sum(a.time_s for a in all_sols)),
            "time_per_target_s": float(np.mean([a.time_s for a in all_sols])),
            "tolerances": {"position_m": TOL_POS_ALL, "orientation_rad": TOL_ORI_ALL},
            # more independent joints than weighted pose components: the solutions form a
            # continuum and the list is a sample of it
            "continuum": bool(len(mech.independent) > int((W > 0).sum(axis=1).min())),
            **solutions_summary_extra(all_sols),
        }
    checks = with_expect(summary, scenario)
    if all_sols is not None:
        kin, T_E, pe, oe, phin, status, labels_rows, extra_rows = _solution_rows(
            mech, T_P, labels, results, all_sols, kin, pe, oe, phin, status)
    else:
        labels_rows = labels
        extra_rows = {}
    m_rows = len(labels_rows)
    times = np.arange(m_rows, dtype=float)  # one second per precision point (or solution)
    snaps = list(range(m_rows)) if m_rows <= 8 else list(
        np.linspace(0, m_rows - 1, 8).round().astype(int))
    T_rows = T_P if all_sols is None else extra_rows.pop("_T")
    row_iters = (extra_rows.pop("_iterations") if all_sols is not None
                 else [r.iterations for r in results])
    extra_cols: dict[str, Any] = {
        "target": labels_rows,
        **extra_rows,
        "position_error_m": pe, "orientation_error_rad": oe,
        "iterations": row_iters,
        "target_x_m": T_rows[:, 0, 3], "target_y_m": T_rows[:, 1, 3],
        "target_z_m": T_rows[:, 2, 3],
    }
    rec = motion_record(
        scenario=scenario, mech=mech, kin=kin, times=times, step_status=status, residual=phin,
        task="ik", extra_columns=extra_cols,
        extra_state=[{"target": labels_rows[i], "position_error": float(pe[i]),
                      "orientation_error": float(oe[i])} for i in range(m_rows)],
        snapshots=snaps, snapshot_labels=[labels_rows[k] for k in snaps],
    )
    rec.convergence = {labels[i]: np.maximum(r.f_history, 0.0)
                       for i, r in enumerate(results) if len(r.f_history)}
    rec.targets = np.asarray(T_rows[:, :3, 3], dtype=float)
    rec.target_poses = np.asarray(T_rows, dtype=float)
    rec.convergence_ylabel = "f = 1/2 x^T W x"
    rec.convergence_title = f"{scenario.name}: {spec.method} (kim1995 Eq. (9))"
    return Report(task="ik", scenario=scenario.name, summary=summary, checks=checks,
                  solver_ok=overall == "ok", writer="motion", data=rec,
                  outputs=output_flags(scenario), scenario_path=scenario.path,
                  messages=expect_messages(checks, scenario.path))
