"""How the ik task solves its targets: in order (warm starts), in chunks, on workers.

:func:`solve_sequence` solves targets in order, each warm-started from the previous (a closed
form where the mechanism has one); :func:`_solve_split` cuts a long sequence into chunks that
overlap by a few warm-up targets and runs them as jobs (:mod:`mechkin.tasks.distributed`);
:func:`_solve_batch` runs independent targets through the batched lm in chunks;
:func:`batch_results` turns a batch result into :class:`~mechkin.solvers.ik.IkResult` records.
Split out of ``ik.py`` (issue 23: modules that fit in a head).

Imports: config, model, solvers, records, tasks.common, tasks.distributed.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from mechkin.config.ik_spec import IkSpec
from mechkin.config.scenario import Scenario
from mechkin.model import Mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.ik import (
    IkOptions,
    IkResult,
    IkStatus,
    pose_errors,
    solve_ik_batch,
    solve_ik_warm,
)
from mechkin.solvers.ik.all_solutions import (
    SAME_TOL,
    wrapped,
)
from mechkin.solvers.ik.analytic.dispatch import ANALYTIC_METHODS, solve_ik_method
from mechkin.tasks.distributed import Execution, map_jobs


def _closed_form(mech: Mechanism, T: np.ndarray, q_w0: np.ndarray, kind: str,
                 q_v0: np.ndarray | None = None) -> IkResult:
    """The closed form the mechanism's structure admits (``closed_form:`` or recognised from
    the geometry: Stewart leg lengths, kim1995's direct-drive appendix, lee's legs; all solved
    through the leg decomposition), then the loop closure and verification by forward
    kinematics. ``kind`` ``legs`` (a parallel mechanism without a named closed form whose legs
    decompose): every joint from the legs, each leg's branch nearest the guess (q_v0, q_w0)."""
    from mechkin.solvers.closed_form.recognise import closed_form_ik

    if kind == "legs":
        from dataclasses import replace

        from mechkin.solvers.ik.analytic.legs import legs_for, legs_ik

        qv = mech.home[mech.independent] if q_v0 is None else q_v0
        r = legs_ik(mech, legs_for(mech), T, qv, q_w0, 1e-4, 1e-4)
        return replace(r, method="closed-form")
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
                    time_s=0.0, f_history=np.zeros(0), method="reach bound",
                    at_limit=joints_at_limit(mech, q[None])[0])


def joints_at_limit(mech: Mechanism, q: np.ndarray, tol: float = 1e-9) -> list[tuple[str, ...]]:
    """Per row of q (k, n): the joints on or beyond a limit (passive ones after whole turns)."""
    from mechkin.model.continuation import within_limits

    qm, _ = within_limits(mech, np.atleast_2d(q))
    with np.errstate(invalid="ignore"):
        hit = (qm <= mech.lower + tol) | (qm >= mech.upper - tol)
    return [tuple(mech.joint_names[j] for j in np.flatnonzero(h)) for h in hit]


def batch_results(br: Any, k: int, mech: Mechanism | None = None) -> list[IkResult]:
    """One IkResult per row of a batched solve (its time shared equally; ``mech``: with the
    joints at a limit)."""
    per = br.time_s / k
    at = joints_at_limit(mech, br.q) if mech is not None else [()] * k
    return [IkResult(
        q_v=br.q_v[i], q_w=br.q_w[i], q=br.q[i], status=br.status[i],
        position_error=float(br.position_error[i]),
        orientation_error=float(br.orientation_error[i]), f=float(br.f[i]),
        grad_norm=0.0, iterations=int(br.iterations[i]),
        evaluations=int(br.iterations[i]) + 1, time_s=per,
        f_history=np.array([br.f[i]]), method="lm", at_limit=at[i]) for i in range(k)]


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
                   total: int | None = None,
                   cold: tuple[np.ndarray, np.ndarray] | None = None,
                   stop: Any = None,
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
    cold = (qv, qw) if cold is None else cold  # a failed warm target retried as a lone one
    for i, (T, w) in enumerate(zip(T_P, W, strict=False)):
        guesses.append((qv, qw))
        if far[i]:
            results.append(_out_of_reach(mech, qv, qw))
        else:
            if method == "closed-form":
                r = _closed_form(mech, T, qw, kind, qv)
            elif method in ANALYTIC_METHODS:
                r = solve_ik_method(mech, T, method=method, q_v0=qv, q_w0=qw, weights=w,
                                    options=opts)
            else:
                r = solve_ik_warm(mech, T, q_v0=qv, q_w0=qw, cold=cold if warm else None,
                                  weights=w, options=opts)
            results.append(r)
            if warm and r.status is not IkStatus.SINGULAR:
                qv, qw = r.q_v, r.q_w
        if update is not None and (i % 50 == 49 or i == len(T_P) - 1):
            update(offset + i + 1, total)
        if stop is not None and i + 1 < len(T_P) and stop():
            break  # --max-time: the targets solved so far are kept
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
                                        job["warm"], cold=(job["q_v0"], job["q_w0"]))
    entry = (qv, qw)
    res, guesses, last = solve_sequence(mech, job["T_P"][o:], job["W"][o:], job["far"][o:],
                                        job["method"], job["kind"], job["options"], qv, qw,
                                        job["warm"], cold=(job["q_v0"], job["q_w0"]))
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
    parts = map_jobs(_sequence_job, jobs, f"ik: {k} targets", ex, partial=True)
    repaired = []
    for j in range(1, len(parts)):
        if warm and not _same_start(mech, parts[j]["entry"], parts[j - 1]["last"]):
            job = jobs[j]
            o = job["overlap"]
            res, guesses, last = solve_sequence(
                mech, job["T_P"][o:], job["W"][o:], job["far"][o:], spec.method, kind, opts,
                *parts[j - 1]["last"], warm, cold=(qv0, qw0))
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
    return batch_results(br, len(job["T_P"]), mech)


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
    parts = map_jobs(_batch_job, jobs, f"ik: {k} targets (batch)", ex, partial=True)
    info = ({**ex.describe(len(jobs)), "chunk": BATCH_CHUNK} if ex.split else None)
    return [r for p in parts for r in p], info
