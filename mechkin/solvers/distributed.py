r"""Long loop-closure trajectories in chunks with overlapping warm starts (jobs for workers).

The continuation of :func:`mechkin.model.closure.solve_trajectory` (kim1995 §5.1 Steps 1-5)
is sequential: each step starts from the previous solution, which keeps the motion on one
assembly mode. :func:`solve_trajectory_chunks` splits a long motion into chunks that run as
independent jobs (:func:`mechkin.solvers.workspace.sweeps.run_jobs`: local processes or a Dask
cluster) and still follows the assembly mode of a single run:

1. **Coarse pass** (here): the same continuation on every ``stride``-th step gives a solved
   configuration at the start of every chunk's overlap, on the branch the motion follows
   (the steps are ``stride`` times longer; the closure's trust region and the predictor keep
   them on the branch for the motions the fine run can follow).
2. **Chunks** (jobs): chunk ``k`` solves steps ``[s_k - overlap, e_k)`` from the coarse
   solution at ``s_k - overlap`` and keeps ``[s_k, e_k)``.
3. **Check and repair** (here): chunk ``k``'s solution at ``s_k - 1`` must match the end of
   chunk ``k - 1`` (every joint within :data:`SAME_MODE_TOL`); a chunk that does not (another
   assembly mode, a failed closure) is solved again here from the end of chunk ``k - 1``,
   which is exactly the single run's continuation.

Every step is then a converged Newton solution started from a converged solution of the
previous step on the same branch, so the joints agree with a single run to the closure
tolerance (``||phi|| < tol_phi``, ``||dq_w|| < tol_dq``; about 1e-12 with the defaults), not
bitwise: the Newton iterates start from points that differ at that level. Statuses agree;
iteration counts may differ by one in a few steps.

Imports: numpy, model.closure.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields
from typing import Any

import numpy as np

from mechkin.model.closure import ClosureResult, ClosureStatus, solve_trajectory

__all__ = ["SAME_MODE_TOL", "solve_trajectory_chunks", "trajectory_job"]

#: Largest joint difference [rad | m] between two solutions of one step on the same mode.
SAME_MODE_TOL = 1e-6


def trajectory_job(job: dict[str, Any]) -> ClosureResult:
    """One chunk (module level, so it pickles): :func:`_motion` over its steps from
    its warm start."""
    mech = job["mechanism"]
    if not hasattr(mech, "dependent"):
        from mechkin.solvers.workspace.sweeps import job_mechanism

        mech = job_mechanism(mech)
    return _motion(mech, job["q_v"], job["q_w0"], job["kw"])


def _motion(mech: Any, q_v: np.ndarray, q_w0: np.ndarray, kw: dict[str, Any]) -> ClosureResult:
    """The loop closure along q_v from the guess q_w0 at its first sample: step to step with
    the branch checks and continuation of :func:`mechkin.model.continuation.solve_motion` (a
    step that jumps mode, a big step, a change point), as the single-process run; an open chain
    or one without loops: :func:`solve_trajectory`."""
    if len(mech.dependent) == 0 or mech.n_equations == 0:
        return solve_trajectory(mech, q_v, q_w0, **kw)
    from mechkin.model.continuation import solve_motion

    return solve_motion(mech, q_v, q_w0=np.asarray(q_w0, float), guess=True, **kw)


def _cat(parts: list[ClosureResult]) -> ClosureResult:
    """The chunks' results end to end (optional fields, e.g. the kept kinematics, only when
    every chunk has them)."""
    out = {}
    for f in fields(ClosureResult):
        vals = [getattr(p, f.name) for p in parts]
        out[f.name] = None if any(v is None for v in vals) else np.concatenate(vals)
    return ClosureResult(**out)


def _cut(r: ClosureResult, a: int) -> ClosureResult:
    """``r`` without its first ``a`` steps (optional fields that are None stay None)."""
    return ClosureResult(**{f.name: None if getattr(r, f.name) is None
                            else getattr(r, f.name)[a:] for f in fields(ClosureResult)})


def _same(mech: Any, qa: np.ndarray, qb: np.ndarray) -> bool:
    d = np.asarray(qa, float) - np.asarray(qb, float)
    rev = mech.s == 0
    d = np.where(rev, (d + np.pi) % (2 * np.pi) - np.pi, d)
    return bool(np.all(np.isfinite(d)) and np.all(np.abs(d) < SAME_MODE_TOL))


def solve_trajectory_chunks(
    mech: Any,
    q_v: np.ndarray,
    q_w0: np.ndarray,
    *,
    run_jobs: Callable[..., list[Any]],
    chunk_steps: int,
    overlap: int = 32,
    stride: int = 16,
    mechanism: Any = None,
    progress: Callable[[int, int], None] | None = None,
    **kw: Any,
) -> tuple[ClosureResult, dict[str, Any]]:
    """Loop closure along ``q_v`` (m, n_v) in chunks run as jobs (see the module docstring).

    Parameters
    ----------
    mech : Mechanism
    q_v : array, shape (m, n_v)
    q_w0 : array, shape (n_w,)
        Initial approximation of the dependent joints at the first step.
    run_jobs : callable
        ``run_jobs(fn, jobs, progress) -> results in job order``.
    chunk_steps : int
        Steps per chunk.
    overlap : int
        Steps a chunk solves before its own first step (discarded).
    stride : int
        Step of the coarse pass.
    mechanism : MechanismSpec, optional
        What the jobs carry (default ``mech`` pickled).
    progress : callable, optional
        ``progress(done, total)`` over the chunks.
    **kw
        ``tol_phi``, ``tol_dq``, ``max_iter`` of :func:`solve_trajectory`.

    Returns
    -------
    ClosureResult, dict
        The result over all steps, and ``{"chunks", "chunk_steps", "overlap", "stride",
        "repaired_chunks"}``.
    """
    qv = np.atleast_2d(np.asarray(q_v, dtype=np.float64))
    m = qv.shape[0]
    c = max(1, int(chunk_steps))
    starts = list(range(0, m, c))
    # the warm-up start of chunk k (k >= 1), on the coarse grid
    warm = [max(0, (s - overlap) // stride * stride) for s in starts]
    coarse_idx = np.unique(np.concatenate([np.arange(0, m, stride), warm])) if m else \
        np.zeros(0, dtype=int)
    coarse = _motion(mech, qv[coarse_idx], q_w0, kw)
    at = {int(i): k for k, i in enumerate(coarse_idx)}
    carried = mech if mechanism is None else mechanism
    jobs = []
    for k, (s, w) in enumerate(zip(starts, warm, strict=True)):
        e = min(m, s + c)
        if k == 0:
            jobs.append({"mechanism": carried, "q_v": qv[0:e], "q_w0": q_w0, "kw": kw,
                         "skip": 0})
            continue
        j = at[w]
        qc = coarse.q[j]
        start_w = qc[mech.dependent] if coarse.status[j] is ClosureStatus.CONVERGED and \
            np.all(np.isfinite(qc)) else np.asarray(q_w0, float)
        jobs.append({"mechanism": carried, "q_v": qv[w:e], "q_w0": start_w, "kw": kw,
                     "skip": s - w})
    parts = run_jobs(trajectory_job, jobs, progress)
    kept: list[ClosureResult] = []
    repaired: list[int] = []
    for k, (job, r) in enumerate(zip(jobs[:len(parts)], parts, strict=True)):  # a prefix
        # after a stop (run_jobs' stop=): the chunks finished
        sk = job["skip"]
        if k > 0:
            prev = kept[-1]
            ok_prev = prev.status[-1] is ClosureStatus.CONVERGED
            entry_ok = sk > 0 and r.status[sk - 1] is ClosureStatus.CONVERGED
            if not (ok_prev and entry_ok and _same(mech, r.q[sk - 1], prev.q[-1])):
                # not on the single run's branch at the seam: continue from the previous
                # chunk's end, as a single run does
                last = prev.q[-1][mech.dependent]
                if not np.all(np.isfinite(last)):
                    last = np.asarray(q_w0, float)
                s = starts[k]
                r = _motion(mech, qv[s:s + c], last, kw)
                sk = 0
                repaired.append(k)
        kept.append(_cut(r, sk))
    info = {"chunks": len(jobs), "chunk_steps": c, "overlap": overlap, "stride": stride,
            "repaired_chunks": repaired}
    return _cat(kept), info
