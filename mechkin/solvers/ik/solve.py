r"""The public IK drivers: one precision point, a sequence, a batch (kim1995 §5.2).

.. math:: q_v^* = \arg\min f(q_v),\quad f = \tfrac12 x^T W x,\quad
          \phi_R(q_v^*, q_w^*) = 0

:func:`solve_ik` solves one precision point by lm or cg-golden with seeded restarts (codebook
seeds first, then random joints within the limits; closed chains jitter the start);
:func:`solve_ik_sequence` warm-starts each point from the previous solution (kim1995 §5.2
Step 2); :func:`solve_ik_batch` runs lm on many targets at once and re-solves the failed ones
together. Every result is verified by forward kinematics (:mod:`mechkin.solvers.ik.results`).

On an open chain whose independent joints are the serial path to {E} (PUMA 560, Panda, ...),
with the compiled kernels in use, :func:`solve_ik` and small :func:`solve_ik_batch` calls take
a compiled path (:func:`_solve_open_compiled`, :func:`_batch_open_compiled`): the same starts,
lm rows, restarts and choice of answer as the general loop, bit for bit (tested), with each
attempt's lm, nearest turn and verification in one compiled call. Measured (issue 15,
benchmarks/bench_ik.py ``--vs-rtb``): the general loop spent ~98 % of a single solve around
the lm kernel; the codebook lookup (scipy's KD-tree, ~40 us per call) is now the largest part.

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. May import every module of the family
and :mod:`mechkin.model`; never ``io/``, ``cli/`` or ``tasks/``.
"""

from __future__ import annotations

import time

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik import accel
from mechkin.solvers.ik.cg_golden import cg_golden
from mechkin.solvers.ik.closed_batch import better_rows, jitter_pass, random_start
from mechkin.solvers.ik.kernel import IkKernel, kernel_for, pose_errors
from mechkin.solvers.ik.lm import LM_MU, MAX_ITER_LM, STALL_WINDOW, lm_batch
from mechkin.solvers.ik.results import (
    IkBatchResult,
    IkOptions,
    IkResult,
    IkStatus,
    better,
    finite,
    passive_outside,
    status_of,
    statuses_of,
    weighted_errors,
)
from mechkin.solvers.ik.seeds import SEED_RESTARTS, seed_rows, seed_starts


def solve_ik(mech: Mechanism, T_P: np.ndarray, *, q_v0: np.ndarray | None = None,
             q_w0: np.ndarray | None = None, weights: np.ndarray | None = None,
             options: IkOptions | None = None, frame: int | None = None,
             kernel: IkKernel | None = None) -> IkResult:
    r"""Independent joints that bring {E} onto the precision point T_P (kim1995 Eq. (5)-(6)).

    .. math:: q_v^* = \arg\min f(q_v),\quad f = \tfrac12 x^T W x,\quad
              \phi_R(q_v^*, q_w^*) = 0

    Parameters
    ----------
    mech : Mechanism
    T_P : array, shape (4, 4)
        Precision point {P} in the base frame.
    q_v0 : array, shape (n_v,), optional
        Initial independent joints (default: home).
    q_w0 : array, shape (n_w,), optional
        Initial approximation of the dependent joints (default: home).
    weights : array, shape (6,), optional
        Diagonal of W: position (3), then orientation (3); zeros allowed (default ones).
    options : IkOptions, optional
    frame : int, optional
        {E} (default ``mech.end_effector``).

    Returns
    -------
    IkResult
        With errors verified by forward kinematics at the returned joints. A failed solve is
        retried from ``options.restarts`` starts: the nearest codebook poses (open chains),
        then seeded random q_v within the limits (closed chains: a seeded jitter). A
        revolute joint whose limits span more than a full turn is returned within its limits
        at the whole turn nearest ``q_v0`` (home without a guess).

    References
    ----------
    kim1995_complex_chain_ik §5.2 (cg-golden) and Eq. (7)-(10).
    """
    opts = options or IkOptions()
    kern = kernel or kernel_for(mech, frame)
    T_P = np.asarray(T_P, dtype=np.float64)
    w = np.ones(6) if weights is None else np.asarray(weights, dtype=np.float64)
    t0 = time.perf_counter()
    if opts.method == "lm" and _fast_open(kern) and accel.compiled_next("open", 1):
        return _solve_open_compiled(kern, T_P, w, q_v0, opts, t0)
    qv0 = mech.home[kern.iv].copy() if q_v0 is None else np.asarray(q_v0, dtype=np.float64)
    if q_v0 is None:  # no guess: the nearest pose of the seeded codebook (open chains)
        seeded = seed_starts(kern, T_P[None], w[None])
        if seeded is not None:
            qv0 = seeded[0, 0]
    qw0 = mech.home[kern.iw].copy() if q_w0 is None else np.asarray(q_w0, dtype=np.float64)
    # joints with limits over a full turn come back at the turn nearest the guess (or home)
    ref_v = mech.home[kern.iv] if q_v0 is None else np.asarray(q_v0, dtype=np.float64)
    rng: np.random.Generator | None = None
    best: dict | None = None
    tot_it = tot_ev = 0
    attempt = 0
    while attempt <= opts.restarts:
        if attempt == 0:
            starts_v, start_w = qv0[None], qw0
        else:
            rng = rng or np.random.default_rng(opts.seed)
            lo = np.where(np.isfinite(kern.lower_v), kern.lower_v, -np.pi)
            hi = np.where(np.isfinite(kern.upper_v), kern.upper_v, np.pi)
            # lm: every remaining restart at once, as rows of one batch that stops at the
            # first success; cg-golden: one at a time (kim1995 §5.2 is sequential)
            k = opts.restarts if opts.method == "lm" else 1
            if kern.mech.cuts:  # (joint couplings alone assemble from any joints)
                # closed chains: random joints seldom assemble, so restart near the given start
                # (which does) with a seeded jitter of 2 % of each range
                starts_v = kern.project(qv0 + rng.normal(0.0, 0.02, size=(k, kern.iv.size))
                                        * np.minimum(hi - lo, 2 * np.pi))
                start_w = qw0
            else:
                starts_v = rng.uniform(lo, hi, size=(k, kern.iv.size))
                start_w = qw0 if best is None else best["q_w"]
            # the nearest codebook poses not tried yet come first (lm: all in one batch;
            # cg-golden: the next one per attempt)
            first = (1 if q_v0 is None else 0) + (attempt - 1 if opts.method != "lm" else 0)
            nr = min(k, max(SEED_RESTARTS - first, 0))
            seed = (seed_starts(kern, T_P[None], w[None], ranks=range(first, first + nr))
                    if nr else None)
            if seed is not None:
                starts_v[:nr] = seed[0]
        if opts.method == "cg-golden":
            r = cg_golden(kern, starts_v[0], start_w, T_P, w, opts)
            hist = np.asarray(r["hist"], dtype=float)
            qv, qw = r["qv"], r["qw"]
            f, iters, nev, gn = r["f"], r["iters"], r["nev"], r["gnorm"]
            closed, conv = r["closed"], r["converged"]
            attempt += 1
        elif opts.method == "lm":
            k = starts_v.shape[0]
            r = lm_batch(kern, starts_v, np.broadcast_to(start_w, (k, kern.iw.size)),
                          np.broadcast_to(T_P, (k, 4, 4)) if k > 1 else T_P[None],
                          np.broadcast_to(w, (k, 6)) if k > 1 else w[None], opts,
                          history=True, stop_on_first=k > 1)
            if k == 1:
                b = 0
            else:
                fr = np.where(r["closed"], r["f"], np.inf)
                b = int(np.argmin(fr)) if np.isfinite(fr).any() else 0
            hist = np.asarray(r["hist"][b], dtype=float)
            qv, qw = r["qv"][b], r["qw"][b]
            f, iters, nev, gn = (float(r["f"][b]), int(r["iters"].max()),
                                 int(r["nev"].sum()), float(r["gnorm"][b]))
            closed, conv = bool(r["closed"][b]), bool(r["converged"][b])
            attempt += k
        else:
            raise ValueError(f"method: expected 'lm' or 'cg-golden', got {opts.method!r}")
        tot_it += int(iters)
        tot_ev += int(nev)
        q = np.empty(kern.n)
        q[kern.iv], q[kern.iw] = qv, qw
        q = finite(q, mech.home)
        q[kern.iv] = kern.nearest_turn(q[kern.iv], ref_v)
        if kern.coupling is not None:  # coupled joints: m q_master + c, exactly
            q = kern.coupling.full(q[kern.iv])
        st, pe, oe, at = status_of(kern, q, T_P, w, closed, conv, opts, float(gn))
        f_fin = float(f) if np.isfinite(f) else 0.5 * float(np.sum(w) * 4.0)
        if not np.isfinite(hist).all():
            hist = finite(hist, np.full_like(hist, f_fin))
        res = dict(q_v=q[kern.iv], q_w=q[kern.iw], q=q, status=st, position_error=pe,
                   orientation_error=oe, f=f_fin, grad_norm=float(gn) if np.isfinite(gn) else 0.0,
                   f_history=hist, at_limit=at, restarts_used=attempt - 1, method=opts.method)
        if best is None or better(res, best):
            best = res
        if best["status"] is IkStatus.OK:
            break
    assert best is not None
    return IkResult(**best, iterations=tot_it, evaluations=tot_ev,
                    time_s=time.perf_counter() - t0)


_STATUS_OF_CODE = [IkStatus.OK, IkStatus.SINGULAR, IkStatus.UNREACHABLE, IkStatus.NOT_CONVERGED,
                   IkStatus.AT_LIMIT]


def _solve_consts(kern: IkKernel) -> tuple:
    """The compiled kernels' constants of an open chain (:func:`_fast_open`), per kernel:
    the chain's Pc, Ps, Pd, P0, rev, A0, then bound_lo, bound_hi, cont_v, lower_v, upper_v
    and the home joints."""
    c = kern.__dict__.get("_solve_consts")
    if c is None:
        ch = kern.chain
        c = kern.__dict__["_solve_consts"] = (
            ch.Pc[:, 0].copy(), ch.Ps[:, 0].copy(), ch.Pd[:, 0].copy(), ch.P0[:, 0].copy(),
            ch.rev.copy(), ch.A0.copy(), kern.bound_lo.copy(), kern.bound_hi.copy(),
            kern.cont_v.copy(), kern.lower_v.copy(), kern.upper_v.copy(),
            np.asarray(kern.mech.home, dtype=np.float64)[kern.iv].copy())
    return c


def _fast_open(kern: IkKernel) -> bool:
    """Whether ``kern`` is an open chain whose independent joints are the serial path to {E}
    in order (every joint independent): the compiled single-solve path applies."""
    ok = kern.__dict__.get("_fast_open")
    if ok is None:
        ok = bool(kern.n_cuts == 0 and kern.iw.size == 0
                  and np.array_equal(kern.iv, np.arange(kern.n)) and kern.chain_cols is None)
        kern.__dict__["_fast_open"] = ok
    return ok


def _restart_draws(kern: IkKernel, seed: int, k: int) -> np.ndarray:
    """``default_rng(seed).uniform(lo, hi, (k, n_v))``, the random restart starts of
    :func:`solve_ik` (the same for every target of a kernel), drawn once per kernel, seed and
    k; the caller gets its own copy."""
    cache = kern.__dict__.setdefault("_restart_draws", {})
    hit = cache.get((seed, k))
    if hit is None:
        lo = np.where(np.isfinite(kern.lower_v), kern.lower_v, -np.pi)
        hi = np.where(np.isfinite(kern.upper_v), kern.upper_v, np.pi)
        hit = cache[(seed, k)] = np.random.default_rng(seed).uniform(lo, hi, size=(k, kern.iv.size))
    return hit.copy()


def _solve_open_compiled(kern: IkKernel, T_P: np.ndarray, w: np.ndarray,
                         q_v0: np.ndarray | None, opts: IkOptions, t0: float) -> IkResult:
    r""":func:`solve_ik` by lm on an open chain (:func:`_fast_open`) with the compiled kernels:
    the same starts, the same lm rows and the same choice of the answer as the general loop
    (bit-identical joints, tested), with each attempt's lm, choice of row, nearest turn and
    verification by forward kinematics in one compiled call
    (:func:`mechkin.solvers.ik.serial_jit.solve_rows`) instead of some forty array calls.
    Measured (issue 15): a single PUMA 560 solve spent about 2 % of its time in the lm
    kernel before."""
    from mechkin.solvers.ik import serial_jit

    mech = kern.mech
    Pc, Ps, Pd, P0, rev, A0, lo, hi, cont, lower, upper, home = _solve_consts(kern)
    accel.announce(serial_jit.solve_rows, "serial_jit.solve_rows")
    accel.mark_loaded("open")
    k = kern.iv.size
    max_iter = opts.max_iter or MAX_ITER_LM
    f_abs = 0.5 * (1e-3 * min(opts.tol_pos, opts.tol_ori)) ** 2
    stall = STALL_WINDOW if opts.restarts > 0 else 0
    T_P = np.ascontiguousarray(T_P)
    w = np.ascontiguousarray(w)
    F0 = kern.chain.first_frame(T_P[None])
    if q_v0 is None:
        start = seed_rows(kern, T_P, w, 0, 1)
        ref = home
    else:
        start = np.ascontiguousarray(q_v0, dtype=np.float64).reshape(1, k)
        ref = start[0]
    tot_it = tot_ev = 0
    best = None
    attempt = 0
    while True:
        q = np.empty(k)
        hist = np.empty(max_iter + 1)
        at = np.empty(k, dtype=np.bool_)
        info = np.empty(12)
        serial_jit.solve_rows(start, F0, w, Pc, Ps, Pd, P0, rev, A0, lo, hi, cont, lower, upper,
                              f_abs, opts.lm_grad_tol, max_iter, stall, LM_MU,
                              start.shape[0] > 1, home, ref, T_P, q, hist, at, info)
        attempt += start.shape[0]
        f, it_b, it_max, nev, gn, conv, pe, oe, wpe, woe, onb, fin = info.tolist()
        tot_it += int(it_max)
        tot_ev += int(nev)
        if not fin:
            st = IkStatus.SINGULAR
        elif wpe <= opts.tol_pos and woe <= opts.tol_ori:
            st = IkStatus.OK
        elif conv:
            st = IkStatus.AT_LIMIT if onb else IkStatus.UNREACHABLE
        elif not np.isfinite(gn) or gn > 1e6:
            st = IkStatus.SINGULAR
        else:
            st = IkStatus.NOT_CONVERGED
        f_fin = f if np.isfinite(f) else 0.5 * float(np.sum(w) * 4.0)
        hist = hist[: int(it_b) + 1]
        if not np.isfinite(hist).all():
            hist = finite(hist, np.full_like(hist, f_fin))
        names = mech.joint_names
        at_lim = tuple(names[j] for j in np.flatnonzero(at)) if at.any() else ()
        res = dict(q_v=q, q_w=np.empty(0), q=q.copy(), status=st, position_error=pe,
                   orientation_error=oe, f=f_fin, grad_norm=gn if np.isfinite(gn) else 0.0,
                   f_history=hist, at_limit=at_lim,
                   restarts_used=attempt - 1, method="lm")
        if best is None or better(res, best):
            best = res
        if best["status"] is IkStatus.OK or attempt > opts.restarts:
            break
        # every restart at once, as rows of one run that stops at the first success: the
        # nearest codebook poses not tried yet first, then seeded random joints
        nk = opts.restarts
        start = _restart_draws(kern, opts.seed, nk)
        first = 1 if q_v0 is None else 0
        nr = min(nk, max(SEED_RESTARTS - first, 0))
        if nr:
            start[:nr] = seed_rows(kern, T_P, w, first, nr)
    return IkResult(**best, iterations=tot_it, evaluations=tot_ev,
                    time_s=time.perf_counter() - t0)


#: solve_ik_batch: below this many targets an open chain (:func:`_fast_open`) with the
#: compiled kernels loaded runs :func:`_batch_open_compiled` (one compiled call per attempt);
#: above, the general loop (whose compiled lm spreads rows over threads).
SMALL_BATCH = 1024


class _RestartStarts:
    """The starts of restart k (0-based) of the rows ``bad`` of a batch: the nearest codebook
    poses not tried yet (rank k + 1 without a given start, k with one), then seeded random
    joints within the limits (one generator per batch, ``opts.seed``, drawn only when used).
    Shared by :func:`solve_ik_batch`'s general loop and :func:`_batch_open_compiled`, so both
    restart from the same starts."""

    def __init__(self, kern: IkKernel, T_P: np.ndarray, w: np.ndarray, given: bool,
                 seed: int, fast: bool) -> None:
        self.kern, self.T_P, self.w, self.given, self.seed = kern, T_P, w, given, seed
        self.fast = fast
        self.rng = None

    def __call__(self, k: int, bad: np.ndarray) -> np.ndarray:
        kern = self.kern
        rank = k if self.given else k + 1
        if rank < SEED_RESTARTS:
            if self.fast and bad.size == 1:
                return seed_rows(kern, self.T_P[bad[0]], self.w[bad[0]], rank, 1)
            start = seed_starts(kern, self.T_P[bad], self.w[bad], ranks=(rank,))
            if start is not None:
                return start[:, 0]
        if kern.mech.cuts and kern.iw.size:  # closed chains: the rows' restarts alike
            return np.tile(random_start(kern, self.seed, k), (bad.size, 1))
        if self.rng is None:
            self.rng = np.random.default_rng(self.seed)
            self.lo = np.where(np.isfinite(kern.lower_v), kern.lower_v, -np.pi)
            self.hi = np.where(np.isfinite(kern.upper_v), kern.upper_v, np.pi)
        return self.rng.uniform(self.lo, self.hi, size=(bad.size, kern.iv.size))


def _batch_open_compiled(kern: IkKernel, T_P: np.ndarray, q_v0: np.ndarray | None,
                         weights: np.ndarray | None, opts: IkOptions, t0: float
                         ) -> IkBatchResult:
    """:func:`solve_ik_batch` of a small batch on an open chain (:func:`_fast_open`) by the
    compiled kernels: the same starts, lm rows, restarts and answers as the general loop
    (bit-identical joints, tested), each attempt's lm and FK verification in one compiled call
    (:func:`mechkin.solvers.ik.serial_jit.lm_verify`), without the per-call array work that
    made m = 1 cost several rtb solves (issue 15)."""
    from mechkin.solvers.ik import serial_jit

    mech = kern.mech
    m = T_P.shape[0]
    nv = kern.iv.size
    Pc, Ps, Pd, P0, rev, A0, blo, bhi, cont, lower, upper, _ = _solve_consts(kern)
    accel.announce(serial_jit.lm_verify, "serial_jit.lm_verify")
    accel.mark_loaded("open")
    T_P = np.ascontiguousarray(T_P)
    ref = np.empty((m, nv))
    ref[:] = mech.home[kern.iv] if q_v0 is None else np.asarray(q_v0, float)
    w = np.empty((m, 6))
    w[:] = 1.0 if weights is None else np.asarray(weights, float)
    if q_v0 is None:
        qv0 = (seed_rows(kern, T_P[0], w[0], 0, 1) if m == 1
               else seed_starts(kern, T_P, w)[:, 0])
    else:
        qv0 = ref.copy()
    max_iter = opts.max_iter or MAX_ITER_LM
    f_abs = 0.5 * (1e-3 * min(opts.tol_pos, opts.tol_ori)) ** 2
    stall = STALL_WINDOW if opts.restarts > 0 else 0
    F0 = kern.chain.first_frame(T_P)

    def attempt(start, F, TT, ww):
        n = start.shape[0]
        out = (np.empty((n, nv)), np.empty(n), np.zeros(n, dtype=np.int64),
               np.zeros(n, dtype=np.bool_), np.zeros(n), np.empty((n, 4)))
        serial_jit.lm_verify(np.ascontiguousarray(start, dtype=np.float64), F, ww, Pc, Ps, Pd,
                             P0, rev, A0, blo, bhi, cont, lower, upper, f_abs,
                             opts.lm_grad_tol, max_iter, stall, LM_MU, TT, *out)
        return out

    q, f, iters, conv, _, e0 = attempt(qv0, F0, T_P, w)
    ok = (e0[:, 2] <= opts.tol_pos) & (e0[:, 3] <= opts.tol_ori)
    starts = _RestartStarts(kern, T_P, w, q_v0 is not None, opts.seed, fast=True)
    restarted = False
    for k in range(opts.restarts):
        bad = np.flatnonzero(~ok)
        if bad.size == 0:
            break
        restarted = True
        start = starts(k, bad)
        Tb = T_P[bad]
        q2, f2, it2, conv2, _, e2 = attempt(start, kern.chain.first_frame(Tb), Tb, w[bad])
        iters[bad] += it2
        lower_f = f2 < f[bad]
        sel = bad[lower_f]
        q[sel], f[sel], conv[sel] = q2[lower_f], f2[lower_f], conv2[lower_f]
        # rows kept at their previous answer stay failed (the same joints, the same check)
        ok[sel] = (e2[lower_f, 2] <= opts.tol_pos) & (e2[lower_f, 3] <= opts.tol_ori)
    q_before = None if restarted else q.copy()
    serial_jit.nearest_turn_rows(q, ref, cont, lower, upper)
    if q_before is not None and np.array_equal(q, q_before):
        e = e0
    else:
        e = np.empty((m, 4))
        serial_jit.verify_rows(q, A0, Pc, Ps, Pd, P0, rev, T_P, w, e)
    codes = np.where(ok, 0, np.where(conv, 2, 3))
    status = np.array(_STATUS_OF_CODE, dtype=object)[codes]
    return IkBatchResult(q_v=q.copy(), q_w=np.zeros((m, 0)), q=q, status=status,
                         position_error=e[:, 0].copy(), orientation_error=e[:, 1].copy(), f=f,
                         iterations=iters, time_s=time.perf_counter() - t0)


def _batch_of_one(mech: Mechanism, kern: IkKernel, T: np.ndarray, q_v0, weights,
                  opts: IkOptions, t0: float) -> IkBatchResult:
    """One target of :func:`solve_ik_batch` on an open chain: :func:`solve_ik` (one compiled
    call per attempt, restarts at once), as a one-row batch record."""
    qv = None if q_v0 is None else np.asarray(q_v0, dtype=np.float64).reshape(-1)
    w = None if weights is None else np.asarray(weights, dtype=np.float64).reshape(-1, 6)[0]
    r = solve_ik(mech, T, q_v0=qv, weights=w, options=opts, kernel=kern)
    return IkBatchResult(q_v=r.q_v[None], q_w=r.q_w[None], q=r.q[None],
                         status=np.array([r.status], dtype=object),
                         position_error=np.array([r.position_error]),
                         orientation_error=np.array([r.orientation_error]),
                         f=np.array([r.f]), iterations=np.array([r.iterations]),
                         time_s=time.perf_counter() - t0)


def solve_ik_batch(mech: Mechanism, T_P: np.ndarray, *, q_v0: np.ndarray | None = None,
                   q_w0: np.ndarray | None = None, weights: np.ndarray | None = None,
                   options: IkOptions | None = None, frame: int | None = None,
                   lone_restarts: bool = True) -> IkBatchResult:
    r"""Levenberg-Marquardt on many targets at once, vectorized across targets.

    Parameters
    ----------
    T_P : array, shape (m, 4, 4)
        Precision points (a trajectory, a grid), solved independently.
    q_v0 : array, shape (m, n_v) or (n_v,), optional
        Initial independent joints (default home).
    q_w0 : array, shape (m, n_w) or (n_w,), optional
    weights : array, shape (m, 6) or (6,), optional
    options : IkOptions, optional
        ``method`` is ignored (always lm); ``restarts`` re-solve the failed targets together,
        from the nearest codebook poses not tried yet (also when ``q_v0`` is given), then from
        seeded random starts (closed chains: restart k from the same joints for every row),
        then, on closed chains, rows still failed from the lone target's restarts
        (:mod:`mechkin.solvers.ik.closed_batch`) unless ``lone_restarts`` is False.

    Returns
    -------
    IkBatchResult
        Errors verified by forward kinematics at the returned joints. Revolute joints whose
        limits span more than a full turn come back at the whole turn nearest ``q_v0``.

    References
    ----------
    kim1995_complex_chain_ik Eq. (7)-(10); the step is Levenberg-Marquardt, not §5.2.
    """
    opts = options or IkOptions()
    kern = kernel_for(mech, frame)
    t0 = time.perf_counter()
    T_P = np.asarray(T_P, dtype=np.float64).reshape(-1, 4, 4)
    m = T_P.shape[0]
    if m == 1 and _fast_open(kern) and (q_w0 is None or np.size(q_w0) == 0):
        return _batch_of_one(mech, kern, T_P[0], q_v0, weights, opts, t0)
    if m < SMALL_BATCH and _fast_open(kern) and (q_w0 is None or np.size(q_w0) == 0) \
            and accel.compiled_next("open", m):
        return _batch_open_compiled(kern, T_P, q_v0, weights, opts, t0)
    nv, nw = kern.iv.size, kern.iw.size
    qv0 = np.empty((m, nv))
    qv0[:] = mech.home[kern.iv] if q_v0 is None else np.asarray(q_v0, float)
    w = np.empty((m, 6))
    w[:] = 1.0 if weights is None else np.asarray(weights, float)
    w_seed = w
    fast = _fast_open(kern)
    if q_v0 is None:
        seeded = (seed_rows(kern, T_P[0], w_seed[0], 0, 1)[None] if fast and m == 1
                  else seed_starts(kern, T_P, w_seed))
        if seeded is not None:
            qv0 = seeded[:, 0]
    qw0 = np.empty((m, nw))
    qw0[:] = mech.home[kern.iw] if q_w0 is None else np.asarray(q_w0, float)
    r = lm_batch(kern, qv0, qw0, T_P, w, opts)
    q, f, iters = r["q"], r["f"], r["iters"]
    conv, closed = r["converged"], r["closed"]

    def errors(qq: np.ndarray, TT: np.ndarray, ww: np.ndarray) -> np.ndarray | None:
        """(m, 4) errors of rows qq by the compiled FK (an open chain whose compiled lm ran
        in this process), else None."""
        if not (fast and accel.is_loaded("open")):
            return None
        from mechkin.solvers.ik import serial_jit

        accel.announce(serial_jit.verify_rows, "serial_jit.verify_rows")
        Pc, Ps, Pd, P0, rev, A0 = _solve_consts(kern)[:6]
        out = np.empty((qq.shape[0], 4))
        serial_jit.verify_rows(np.ascontiguousarray(qq), A0, Pc, Ps, Pd, P0, rev,
                               np.ascontiguousarray(TT), np.ascontiguousarray(ww), out)
        return out

    def check(qq: np.ndarray, TT: np.ndarray, ww: np.ndarray) -> np.ndarray:
        e = errors(qq, TT, ww)
        if e is None:
            T_E = kern.pose_check(qq)
            pe, oe = weighted_errors(T_E, TT, ww)
        else:
            pe, oe = e[:, 2], e[:, 3]
        return (pe <= opts.tol_pos) & (oe <= opts.tol_ori) & passive_ok(qq)

    def passive_ok(qq: np.ndarray) -> np.ndarray:
        """Rows whose passive joints are within their limits (a constraint: a row outside
        them is retried like a miss, issue 24)."""
        if nw == 0 or qq.shape[1] != kern.n:
            return np.ones(qq.shape[0], dtype=bool)
        return np.array([not o for o in passive_outside(mech, qq)], dtype=bool)

    e0 = errors(q, T_P, w)
    closed_chain = bool(nw and mech.cuts)
    if closed_chain:  # the status rule of a lone target (issue 24): passive limits included
        gn = r["gnorm"]
        st = statuses_of(kern, q, T_P, w, closed, conv, opts, gn)[0]
        ok = st == IkStatus.OK
    elif e0 is None:
        ok = check(q, T_P, w) & closed
    else:
        ok = (e0[:, 2] <= opts.tol_pos) & (e0[:, 3] <= opts.tol_ori) & closed
    starts = _RestartStarts(kern, T_P, w_seed, q_v0 is not None, opts.seed, fast)
    restarted = False
    for k in range(opts.restarts):
        bad = np.flatnonzero(~ok)
        if bad.size == 0:
            break
        restarted = True
        start = starts(k, bad)
        r2 = lm_batch(kern, start, qw0[bad], T_P[bad], w[bad], opts)
        iters[bad] += r2["iters"]
        if closed_chain:  # a better status first, then a lower f (as a lone target's restarts)
            st2 = statuses_of(kern, r2["q"], T_P[bad], w[bad], r2["closed"], r2["converged"],
                              opts, r2["gnorm"])[0]
            lower = better_rows(st2, r2["f"], st[bad], f[bad])
        else:
            lower = r2["f"] < f[bad]
        sel = bad[lower]
        q[sel], f[sel] = r2["q"][lower], r2["f"][lower]
        conv[sel], closed[sel] = r2["converged"][lower], r2["closed"][lower]
        if closed_chain:
            gn[sel], st[sel] = r2["gnorm"][lower], st2[lower]
            ok[bad] = st[bad] == IkStatus.OK
        else:
            ok[bad] = check(q[bad], T_P[bad], w[bad]) & closed[bad]
    bad = np.flatnonzero(~ok)
    if closed_chain and lone_restarts and opts.restarts > 0 and bad.size:
        r3 = jitter_pass(kern, qv0[bad], qw0[bad], T_P[bad], w[bad], opts)
        iters[bad] += r3["iters"]
        st3 = statuses_of(kern, r3["q"], T_P[bad], w[bad], r3["closed"], r3["converged"],
                          opts, r3["gnorm"])[0]
        lower = better_rows(st3, r3["f"], st[bad], f[bad])
        sel = bad[lower]
        q[sel], f[sel], gn[sel] = r3["q"][lower], r3["f"][lower], r3["gnorm"][lower]
        conv[sel], closed[sel] = r3["converged"][lower], r3["closed"][lower]
    # joints with limits over a full turn come back at the turn nearest the start (or home)
    ref = np.empty((m, nv))
    ref[:] = mech.home[kern.iv] if q_v0 is None else np.asarray(q_v0, float)
    if e0 is not None:  # an open chain (fast) whose compiled lm ran: q is q_v
        from mechkin.solvers.ik import serial_jit

        q0 = q.copy() if not restarted else None
        c = _solve_consts(kern)
        serial_jit.nearest_turn_rows(q, ref, c[8], c[9], c[10])
        e = e0 if q0 is not None and np.array_equal(q, q0) else errors(q, T_P, w)
    else:
        q[:, kern.iv] = kern.nearest_turn(q[:, kern.iv], ref)
        if kern.coupling is not None:  # coupled joints: m q_master + c, exactly
            q = kern.coupling.full(q[:, kern.iv])
        e = errors(q, T_P, w)
    if e is None:
        T_E = kern.pose_check(q)
        pe, oe = pose_errors(T_E, T_P)
    else:
        pe, oe = e[:, 0].copy(), e[:, 1].copy()
    if closed_chain:
        status = statuses_of(kern, q, T_P, w, closed, conv, opts, gn)[0]
    else:
        codes = np.where(ok, 0, np.where(~closed, 1, np.where(~passive_ok(q) & closed, 4,
                                                              np.where(conv, 2, 3))))
        status = np.array(_STATUS_OF_CODE, dtype=object)[codes]
    return IkBatchResult(q_v=q[:, kern.iv], q_w=q[:, kern.iw], q=q, status=status,
                         position_error=pe, orientation_error=oe, f=f, iterations=iters,
                         time_s=time.perf_counter() - t0)
