"""``solutions: all`` of the ik task: every distinct verified solution of each target.

:func:`_all_solutions` (the closed form where the mechanism has one,
:func:`mechkin.solvers.closed_form.all_solutions.closed_form_all`, else multi-start lm,
:func:`mechkin.solvers.ik.all_solutions.multistart_all`; the method's own answer is always one
of them) and the target records and ik.csv rows they become. Split out of ``ik.py`` (issue 23:
modules that fit in a head).

Imports: config, model, solvers, records, tasks.common, tasks.ik_solve.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mechkin.config.ik_spec import IkSpec
from mechkin.config.scenario import Scenario
from mechkin.model import Mechanism
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.solvers.closed_form.all_solutions import closed_form_all
from mechkin.solvers.ik import (
    IkOptions,
    IkResult,
    pose_errors,
)
from mechkin.solvers.ik.all_solutions import (
    SAME_TOL,
    IkSolutions,
    multistart_all,
    wrapped,
)
from mechkin.tasks.ik_analytic import (
    analytic_all,
    analytic_rows,
    held_values,
    legs_all_solutions,
    parallel_legs,
)
from mechkin.tasks.ik_solve import _safe_norm
from mechkin.tasks.prepare import Prepared


def _all_solutions(sc: Scenario, prepared: Prepared, T_P: np.ndarray, W: np.ndarray,
                   results: list[IkResult], guesses: list[tuple[np.ndarray, np.ndarray]],
                   far: np.ndarray, opts: IkOptions) -> list[IkSolutions]:
    """Every distinct verified solution of each target: the closed form when the mechanism
    has one (declared or recognised, once: ``prepared``), else multi-start lm; the method's
    answer is a candidate."""
    from mechkin.solvers.closed_form.recognise import ClosedFormMismatch

    spec: IkSpec = sc.section
    mech = prepared.mechanism
    fixed = held_values(sc, mech)
    legs = parallel_legs(mech, spec.method)
    exact = analytic_rows(mech, spec.method, W, fixed) & ~far
    if exact.any():  # the analytic branches: complete (mechkin.solvers.ik.analytic)
        refs = np.array([g[0] for g in guesses])
        found = iter(analytic_all(mech, T_P[exact], refs[exact], fixed))
    try:
        kind = prepared.recognise_closed_form()
    except ClosedFormMismatch:
        kind = None
    if legs is None and kind is None and spec.method == "closed-form":
        from mechkin.solvers.ik.analytic.legs import legs_for

        legs = legs_for(mech)  # closed-form on a parallel mechanism whose legs decompose
    out: list[IkSolutions] = []
    for i, (T, w) in enumerate(zip(T_P, W, strict=True)):
        qv, qw = guesses[i]
        extra = results[i].q[None] if np.all(np.isfinite(results[i].q)) else None
        if far[i]:  # beyond the reach bound: no solution, nothing to search
            n = mech.n
            out.append(IkSolutions(q=np.zeros((0, n)), q_v=np.zeros((0, len(mech.independent))),
                                   position_error=np.zeros(0), orientation_error=np.zeros(0),
                                   distance=np.zeros(0), source="reach bound", starts=0,
                                   time_s=0.0, complete=True))
        elif exact[i]:
            out.append(next(found))
        elif legs is not None and bool(np.all(w > 0)):
            out.append(legs_all_solutions(mech, legs, T, qv, qw, w))
        elif kind is not None:
            out.append(closed_form_all(mech, T, kind, q_w0=qw, ref=qv, extra=extra,
                                       weights=w))
        else:
            out.append(multistart_all(mech, T, q_v0=qv, q_w0=qw, weights=w, options=opts,
                                      starts=spec.solution_starts, seed=spec.seed + i,
                                      extra=extra))
    return out


def _solutions_record(mech: Mechanism, a: IkSolutions) -> dict[str, Any]:
    sols = []
    for k in range(a.count):
        sols.append({
            "q_v": {n: float(a.q[k, j]) for n, j in zip(mech.independent_names,
                                                        mech.independent, strict=True)},
            "q": {n: float(v) for n, v in zip(mech.joint_names, a.q[k], strict=True)},
            "position_error": float(a.position_error[k]),
            "orientation_error": float(a.orientation_error[k]),
            "distance_from_guess": float(a.distance[k]),
        })
    return {"n_solutions": a.count, "solutions": sols, "solutions_source": a.source}


def _solution_rows(mech: Mechanism, T_P: np.ndarray, labels: list[str],
                   results: list[IkResult], all_sols: list[IkSolutions], kin: Any,
                   pe: np.ndarray, oe: np.ndarray, phin: np.ndarray, status: list[str]):
    """ik.csv rows for ``solutions: all``: one per solution of each target (the method's
    answer alone, with solution -1, where a target has none)."""
    rows_q, rows_t, sol_idx, primary, row_status, lab, iters = [], [], [], [], [], [], []
    iv = mech.independent
    for i, a in enumerate(all_sols):
        if a.count == 0:
            rows_q.append(kin.q[i])
            rows_t.append(i)
            sol_idx.append(-1)
            primary.append(1)
            row_status.append(status[i])
            lab.append(labels[i])
            iters.append(results[i].iterations)
            continue
        d = np.abs(wrapped(mech, iv, a.q_v - kin.q[i, iv][None])).max(axis=1)
        prim = int(np.argmin(d)) if status[i] == "ok" and d.min() < SAME_TOL else -1
        for k in range(a.count):
            rows_q.append(a.q[k])
            rows_t.append(i)
            sol_idx.append(k)
            primary.append(int(k == prim))
            row_status.append("ok")
            lab.append(labels[i])
            iters.append(results[i].iterations if k == prim else 0)
    q = np.array(rows_q)
    idx = np.array(rows_t, dtype=int)
    kin = forward_kinematics(mech, q)
    T_E = kin.frames(mech, [mech.end_effector])[:, 0]
    with np.errstate(over="ignore", invalid="ignore"):
        pe, oe = pose_errors(T_E, T_P[idx])
    pe = np.where(np.isfinite(pe), pe, _safe_norm(T_E[:, :3, 3] - T_P[idx, :3, 3]))
    phi = closure_residual(mech, kin)
    phin = np.linalg.norm(phi, axis=1) if phi.shape[1] else np.zeros(len(q))
    extra = {"solution": np.array(sol_idx), "primary": np.array(primary), "_T": T_P[idx],
             "_iterations": iters}
    return kin, T_E, pe, oe, phin, row_status, lab, extra


def _clean(v: float) -> float:
    return float(v) if np.isfinite(v) else 0.0
