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

Imports: config, model, solvers, records, tasks.common.
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
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.records import Report
from mechkin.solvers.ik import (
    IkOptions,
    IkResult,
    IkStatus,
    pose_errors,
    solve_ik,
    solve_ik_batch,
)
from mechkin.solvers.ik.all_solutions import (
    SAME_TOL,
    TOL_ORI_ALL,
    TOL_POS_ALL,
    IkSolutions,
    closed_form_all,
    multistart_all,
    wrapped,
)
from mechkin.tasks.common import (
    check_motion_budget,
    expect_messages,
    joint_factor,
    motion_record,
    output_flags,
    with_expect,
)
from mechkin.tasks.distributed import Execution, map_jobs
from mechkin.tasks.distributed import resolve as resolve_execution
from mechkin.tasks.ik_frames import has_target_sets, run_target_sets


def _closed_form_kind(scenario: Scenario, mech: Mechanism) -> str:
    """The closed form of ``mech`` by structure; a declared one that does not fit, or none
    that fits, is bad input naming the mismatch."""
    from mechkin.solvers.closed_form.recognise import ClosedFormMismatch, recognise_closed_form

    try:
        kind = recognise_closed_form(mech)
    except ClosedFormMismatch as exc:
        raise ConfigError(f"{scenario.doc.where(('mechanism',))}: {exc}") from None
    if kind is None:
        raise ConfigError(f"{scenario.doc.where(('ik', 'method'))}: no closed form fits "
                          f"mechanism {mech.name} (declare closed_form: stewart | direct_drive | "
                          "lee_spherical in the mechanism file, or use method: lm)")
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
        res = solve_closure(mech, qv, mech.home[mech.dependent][None])
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


def _closed_form(mech: Mechanism, T: np.ndarray, q_w0: np.ndarray, kind: str) -> IkResult:
    """The closed form the mechanism's structure admits (``closed_form:`` or recognised from
    the geometry: Stewart leg lengths, kim1995's direct-drive appendix, lee's legs), then the
    loop closure and verification by forward kinematics."""
    from mechkin.solvers.closed_form.recognise import closed_form_ik

    t0 = time.perf_counter()
    qv, _ = closed_form_ik(mech, T[None], kind, tol=1e-4)
    res = solve_closure(mech, qv, q_w0[None])
    q = res.q[0]
    T_E = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]
    pe, oe = pose_errors(T_E, T[None])
    ok = bool(res.ok[0]) and pe[0] < 1e-4 and oe[0] < 1e-4
    return IkResult(q_v=q[mech.independent], q_w=q[mech.dependent], q=q,
                    status=IkStatus.OK if ok else IkStatus.UNREACHABLE,
                    position_error=float(pe[0]), orientation_error=float(oe[0]), f=0.0,
                    grad_norm=0.0, iterations=0, evaluations=1,
                    time_s=time.perf_counter() - t0, f_history=np.zeros(1),
                    method="closed-form")


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


def _safe_norm(x: np.ndarray) -> np.ndarray:
    """Row norms of x (k, 3) without overflow (scaled by the largest entry)."""
    scale = np.max(np.abs(x), axis=1)
    safe = np.where(scale > 0, scale, 1.0)
    return scale * np.sqrt(((x / safe[:, None]) ** 2).sum(axis=1))


def _out_of_reach(mech: Mechanism, qv: np.ndarray, qw: np.ndarray) -> IkResult:
    q = np.asarray(mech.home, dtype=float).copy()
    q[mech.independent], q[mech.dependent] = qv, qw
    return IkResult(q_v=np.asarray(qv, float), q_w=np.asarray(qw, float), q=q,
                    status=IkStatus.UNREACHABLE, position_error=float("inf"),
                    orientation_error=0.0, f=0.0, grad_norm=0.0, iterations=0, evaluations=0,
                    time_s=0.0, f_history=np.zeros(0), method="reach bound")


def batch_results(br: Any, k: int) -> list[IkResult]:
    """One IkResult per row of a batched solve (its time shared equally)."""
    per = br.time_s / k
    return [IkResult(
        q_v=br.q_v[i], q_w=br.q_w[i], q=br.q[i], status=br.status[i],
        position_error=float(br.position_error[i]),
        orientation_error=float(br.orientation_error[i]), f=float(br.f[i]),
        grad_norm=0.0, iterations=int(br.iterations[i]),
        evaluations=int(br.iterations[i]) + 1, time_s=per,
        f_history=np.array([br.f[i]]), method="lm") for i in range(k)]


#: Targets per job of a batched solve (``batch: true``). The batch is solved in these chunks
#: in one process too, so the result never depends on the executor; only seeded random
#: restarts see the chunk (their draws follow the failed targets of a chunk).
BATCH_CHUNK = 2000
#: Most and fewest targets per job of a sequential (``batch: false``) solve split over
#: workers (about four jobs per worker in between).
SEQUENCE_CHUNK = 2000
SEQUENCE_MIN_CHUNK = 25
#: Targets a chunk of a warm-started chain solves before its own first target (from the
#: initial guess), so that its first warm start is a solved configuration on the chain.
WARM_OVERLAP = 8


def solve_sequence(mech: Mechanism, T_P: np.ndarray, W: np.ndarray, far: np.ndarray,
                   method: str, kind: str | None, opts: IkOptions, qv: np.ndarray,
                   qw: np.ndarray, warm: bool, update: Any = None, offset: int = 0,
                   total: int | None = None
                   ) -> tuple[list[IkResult], list[tuple[np.ndarray, np.ndarray]],
                              tuple[np.ndarray, np.ndarray]]:
    """Solve the targets in order, each warm-started from the previous solution when
    ``warm`` (kim1995 §5.2 Step 2; a singular solve does not move the start).

    Returns
    -------
    results, guesses, (q_v, q_w)
        One result and its start per target, and the start of the next target.
    """
    results: list[IkResult] = []
    guesses: list[tuple[np.ndarray, np.ndarray]] = []
    total = len(T_P) if total is None else total
    for i, (T, w) in enumerate(zip(T_P, W, strict=False)):
        guesses.append((qv, qw))
        if far[i]:
            results.append(_out_of_reach(mech, qv, qw))
        else:
            if method == "closed-form":
                r = _closed_form(mech, T, qw, kind)
            else:
                r = solve_ik(mech, T, q_v0=qv, q_w0=qw, weights=w, options=opts)
            results.append(r)
            if warm and r.status is not IkStatus.SINGULAR:
                qv, qw = r.q_v, r.q_w
        if update is not None and (i % 50 == 49 or i == len(T_P) - 1):
            update(offset + i + 1, total)
    return results, guesses, (qv, qw)


def _sequence_job(job: dict[str, Any]) -> dict[str, Any]:
    """One chunk of a sequential solve (a worker job): the ``overlap`` targets before the
    chunk (warm-up of a warm-started chain, from the initial guess), then the chunk."""
    from mechkin.solvers.workspace.sweeps import job_mechanism

    mech = job_mechanism(job["mechanism"])
    o = job["overlap"]
    qv, qw = job["q_v0"], job["q_w0"]
    if o:
        _, _, (qv, qw) = solve_sequence(mech, job["T_P"][:o], job["W"][:o], job["far"][:o],
                                        job["method"], job["kind"], job["options"], qv, qw,
                                        job["warm"])
    entry = (qv, qw)
    res, guesses, last = solve_sequence(mech, job["T_P"][o:], job["W"][o:], job["far"][o:],
                                        job["method"], job["kind"], job["options"], qv, qw,
                                        job["warm"])
    return {"results": res, "guesses": guesses, "entry": entry, "last": last}


def _same_start(mech: Mechanism, a: tuple[np.ndarray, np.ndarray],
                b: tuple[np.ndarray, np.ndarray]) -> bool:
    """Two warm starts on the same solution branch (joints within SAME_TOL, revolute ones
    wrapped)."""
    dv = wrapped(mech, mech.independent, np.asarray(a[0]) - np.asarray(b[0]))
    dw = wrapped(mech, mech.dependent, np.asarray(a[1]) - np.asarray(b[1]))
    return bool(np.all(np.abs(dv) < SAME_TOL) and np.all(np.abs(dw) < SAME_TOL))


def _solve_split(sc: Scenario, mech: Mechanism, T_P: np.ndarray, W: np.ndarray,
                 far: np.ndarray, kind: str | None, opts: IkOptions, qv0: np.ndarray,
                 qw0: np.ndarray, ex: Execution
                 ) -> tuple[list[IkResult], list[tuple[np.ndarray, np.ndarray]],
                            dict[str, Any]]:
    """A sequential solve in chunks of targets on the run's executor.

    Independent targets (``warm_start: false``) give bitwise the results of one process.
    A warm-started chain: every chunk but the first solves the :data:`WARM_OVERLAP` targets
    before it first (from the initial guess), so its first warm start is a solved
    configuration; where that start is not on the branch the previous chunk ended on (joints
    differ by more than SAME_TOL), the chunk is solved again here from the previous chunk's
    end (``repaired_chunks``). Each target is then solved from a start equal to the one of a
    single run within the solver's tolerance, so the solutions agree within the ik
    tolerances (``tolerances.position`` / ``orientation``), on the same branch.
    """
    from mechkin.solvers.workspace.sweeps import mechanism_spec

    spec: IkSpec = sc.section
    k = len(T_P)
    n = ex.n_workers(1) or 8
    chunk = int(min(SEQUENCE_CHUNK, max(SEQUENCE_MIN_CHUNK, -(-k // (4 * n)))))
    warm = bool(spec.warm_start)
    mspec = mechanism_spec(sc.mechanism_path)
    jobs = []
    for a in range(0, k, chunk):
        o = min(WARM_OVERLAP, a) if warm else 0
        sl = slice(a - o, min(k, a + chunk))
        jobs.append({"mechanism": mspec, "T_P": T_P[sl], "W": W[sl], "far": far[sl],
                     "method": spec.method, "kind": kind, "options": opts, "q_v0": qv0,
                     "q_w0": qw0, "warm": warm, "overlap": o, "start": a})
    parts = map_jobs(_sequence_job, jobs, f"ik: {k} targets", ex)
    repaired = []
    for j in range(1, len(parts)):
        if warm and not _same_start(mech, parts[j]["entry"], parts[j - 1]["last"]):
            job = jobs[j]
            o = job["overlap"]
            res, guesses, last = solve_sequence(
                mech, job["T_P"][o:], job["W"][o:], job["far"][o:], spec.method, kind, opts,
                *parts[j - 1]["last"], warm)
            parts[j] = {"results": res, "guesses": guesses, "entry": parts[j - 1]["last"],
                        "last": last}
            repaired.append(j)
    results = [r for p in parts for r in p["results"]]
    guesses = [g for p in parts for g in p["guesses"]]
    info = {**ex.describe(len(jobs)), "chunk": chunk,
            "overlap": WARM_OVERLAP if warm else 0, "repaired_chunks": repaired}
    return results, guesses, info


def _batch_job(job: dict[str, Any]) -> list[IkResult]:
    """One chunk of a batched solve (a worker job)."""
    from mechkin.solvers.workspace.sweeps import job_mechanism

    mech = job_mechanism(job["mechanism"])
    br = solve_ik_batch(mech, job["T_P"], q_v0=job["q_v0"], q_w0=job["q_w0"],
                        weights=job["W"], options=job["options"])
    return batch_results(br, len(job["T_P"]))


def _solve_batch(sc: Scenario, T_P: np.ndarray, W: np.ndarray, qv0: np.ndarray,
                 qw0: np.ndarray, opts: IkOptions, ex: Execution
                 ) -> tuple[list[IkResult], dict[str, Any] | None]:
    """``batch: true``: the batched lm in chunks of :data:`BATCH_CHUNK` targets on the run's
    executor (bitwise the same results in one process and on any number of workers)."""
    from mechkin.solvers.workspace.sweeps import mechanism_spec

    k = len(T_P)
    mspec = mechanism_spec(sc.mechanism_path)
    jobs = [{"mechanism": mspec, "T_P": T_P[a:a + BATCH_CHUNK], "W": W[a:a + BATCH_CHUNK],
             "q_v0": qv0, "q_w0": qw0, "options": opts} for a in range(0, k, BATCH_CHUNK)]
    parts = map_jobs(_batch_job, jobs, f"ik: {k} targets (batch)", ex)
    info = ({**ex.describe(len(jobs)), "chunk": BATCH_CHUNK} if ex.split else None)
    return [r for p in parts for r in p], info


def _all_solutions(sc: Scenario, mech: Mechanism, T_P: np.ndarray, W: np.ndarray,
                   results: list[IkResult], guesses: list[tuple[np.ndarray, np.ndarray]],
                   far: np.ndarray, opts: IkOptions) -> list[IkSolutions]:
    """Every distinct verified solution of each target: the closed form when the mechanism
    has one (declared or recognised), else multi-start lm; the method's answer is a candidate."""
    from mechkin.solvers.closed_form.recognise import ClosedFormMismatch, recognise_closed_form

    spec: IkSpec = sc.section
    try:
        kind = recognise_closed_form(mech)
    except ClosedFormMismatch:
        kind = None
    out: list[IkSolutions] = []
    for i, (T, w) in enumerate(zip(T_P, W, strict=True)):
        qv, qw = guesses[i]
        extra = results[i].q[None] if np.all(np.isfinite(results[i].q)) else None
        if far[i]:  # beyond the reach bound: no solution, nothing to search
            n = mech.n
            out.append(IkSolutions(q=np.zeros((0, n)), q_v=np.zeros((0, len(mech.independent))),
                                   position_error=np.zeros(0), orientation_error=np.zeros(0),
                                   distance=np.zeros(0), source="reach bound", starts=0,
                                   time_s=0.0))
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


def check_budget(scenario: Scenario) -> None:
    """The run's memory budget check (random targets), without solving."""
    rt = scenario.section.random_targets
    if rt is not None:
        mech = load_mechanism(scenario.mechanism_path)
        _check_targets(scenario, mech, rt.count + len(scenario.section.targets))


def _check_targets(scenario: Scenario, mech: Mechanism, k: int) -> None:
    """k ik targets (with their summary records) against the memory budget."""
    check_motion_budget(scenario, mech, k, ("ik", "random_targets", "count"), "ik targets",
                        extra_per_item=4000.0)


def run(scenario: Scenario, progress: bool | None = None) -> Report:
    """Solve every precision point in order (each warm-started from the previous solution,
    kim1995 §5.2 Step 2), or all at once with ``batch: true``; verify each by forward
    kinematics. Returns the report (summary, expect results, motion record with the
    convergence histories).
    """
    spec: IkSpec = scenario.section
    mech = load_mechanism(scenario.mechanism_path)
    if has_target_sets(spec):  # targets naming their frames: solved together per set
        o = ik_options(spec, scenario.spec.units)
        return run_target_sets(scenario, mech, *_initial(scenario, mech), o.tol_pos, o.tol_ori)
    if mech.end_effector is None:
        raise ConfigError(f"{scenario.doc.where(('mechanism',))}: mechanism {mech.name} has no "
                          "end_effector frame")
    kind = _closed_form_kind(scenario, mech) if spec.method == "closed-form" else None
    T_P, W, labels = _targets(scenario, mech)
    if len(T_P) == 0:
        raise ConfigError(f"{scenario.doc.where(('ik',))}: no targets to solve")
    qv0, qw0 = _initial(scenario, mech)
    far = beyond_reach(mech, T_P, W)
    opts = ik_options(spec, scenario.spec.units)
    t0 = time.perf_counter()
    ex = resolve_execution(progress=progress)
    execution_info: dict[str, Any] | None = None
    if spec.batch and not far.any():
        results, execution_info = _solve_batch(scenario, T_P, W, qv0, qw0, opts, ex)
        guesses = [(qv0, qw0)] * len(T_P)
    elif ex.split:
        results, guesses, execution_info = _solve_split(scenario, mech, T_P, W, far, kind,
                                                        opts, qv0, qw0, ex)
    else:
        from mechkin.tasks.progress import progress_bar

        show = progress if progress is not None or len(T_P) >= 1000 else False
        with progress_bar(show, f"ik: {len(T_P)} targets") as update:
            results, guesses, _ = solve_sequence(mech, T_P, W, far, spec.method, kind, opts,
                                                 qv0, qw0, spec.warm_start, update)
    solve_s = time.perf_counter() - t0
    all_sols = (_all_solutions(scenario, mech, T_P, W, results, guesses, far, opts)
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
    rec.convergence_ylabel = "f = 1/2 x^T W x"
    rec.convergence_title = f"{scenario.name}: {spec.method} (kim1995 Eq. (9))"
    return Report(task="ik", scenario=scenario.name, summary=summary, checks=checks,
                  solver_ok=overall == "ok", writer="motion", data=rec,
                  outputs=output_flags(scenario), scenario_path=scenario.path,
                  messages=expect_messages(checks, scenario.path))
