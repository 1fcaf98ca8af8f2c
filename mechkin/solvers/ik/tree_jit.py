r"""Compiled lm for closed and complex chains (optional accelerator, needs ``numba``).

The numpy ``lm`` of :mod:`mechkin.solvers.ik.lm` on a mechanism with cut joints, written as
loops over one configuration and compiled by numba (``pip install "mechkin[fast]"``). Each
evaluation is what the numpy path does with :mod:`mechkin.model`:

* tree forward kinematics (kim1995 Eq. (2)), joint axes;
* loop closure phi_R(q_v, q_w) = 0 by Newton-Raphson (kim1995 §5.1; joint couplings are rows of
  phi after the cuts', :mod:`mechkin.model.couplings`; as
  :func:`mechkin.model.closure.solve_closure`: pseudo-inverse step, 0.5 trust region, halving
  of steps that raise ||phi||, revolute dependents brought back to the branch of the guess);
* residual x of {E} relative to {P} (position, vector part of the Euler parameters, Eq. (8))
  and the reduced Jacobian ``J_r = J_v - J_w (dphi/dq_w)^+ dphi/dq_v`` (Eq. (10));

and the Levenberg-Marquardt iteration is the numpy one (Marquardt damping, projection on the
limits of q_v, first-order predictor of q_w for the next closure).

The pseudo-inverse is a direct LU solve for a square ``dphi/dq_w`` and the normal equations
(Cholesky) for a tall one (rank-deficient rows, as the direct-drive arm's planar loop, are
fine; a column-rank loss is reported as a failed closure, like the numpy path's "singular").

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. Imports numpy, numba and
:mod:`mechkin.solvers.ik.serial_jit` (shared loop kernels) and
:mod:`mechkin.solvers.ik.tree_closure_jit` (kinematics and loop closure of one configuration);
never ``io/``, ``cli/`` or
``tasks/``.
"""

from __future__ import annotations

from mechkin.solvers.ik.accel import configure_numba_cache

configure_numba_cache()  # before numba reads NUMBA_CACHE_DIR (a read-only install: user cache)

import numba  # noqa: E402
import numpy as np  # noqa: E402

from mechkin.solvers.ik.serial_jit import (  # noqa: E402
    half_wsq,
    lm_decide,
    lm_step,
    project,
)
from mechkin.solvers.ik.tree_closure_jit import evaluate_closed, lstsq_solve  # noqa: E402

_njit = numba.njit(cache=True, nogil=True)


@_njit
def passive_limited_step(H, g, lam, mu, step, q, iw, S, lo_w, hi_w):
    """Re-solve the lm step (q_v <- q_v - step) with the dependent joints that the predicted
    ``q_w + S step`` would carry across a limit held on it (KKT system, active set grown until
    nothing crosses): mechkin.solvers.ik.lm.passive_limited_steps for one row."""
    nv, nw = step.size, iw.size
    act = np.zeros(nw, dtype=np.bool_)
    tgt = np.zeros(nw)
    for _ in range(nw):
        new = False
        for i in range(nw):
            p = q[iw[i]]
            for b in range(nv):
                p += S[i, b] * step[b]
            if not act[i] and (p > hi_w[i] or p < lo_w[i]):
                act[i] = True
                tgt[i] = (hi_w[i] if p > hi_w[i] else lo_w[i]) - q[iw[i]]
                new = True
        if not new:
            return
        na = 0
        for i in range(nw):
            if act[i]:
                na += 1
        K = np.zeros((nv + na, nv + na))
        rhs = np.zeros((nv + na, 1))
        sol = np.empty((nv + na, 1))
        for a in range(nv):
            for b in range(nv):
                K[a, b] = H[a, b]
            K[a, a] += lam * (H[a, a] + mu)
            rhs[a, 0] = g[a]
        c = nv
        for i in range(nw):
            if act[i]:
                for b in range(nv):
                    K[c, b] = S[i, b]
                    K[b, c] = S[i, b]
                rhs[c, 0] = tgt[i]
                c += 1
        if not lstsq_solve(K, rhs, sol):
            return
        for a in range(nv):
            step[a] = sol[a, 0]


@_njit
def within(q, iw, lo_w, hi_w, band):
    for i in range(iw.size):
        if q[iw[i]] < lo_w[i] - band[i] or q[iw[i]] > hi_w[i] + band[i]:
            return False
    return True


@_njit
def equation_count(K):
    """Number of loop-closure equations: the kept components of every cut, then one per joint
    coupling."""
    mask = K[14]
    neq = K[16].size
    for c in range(mask.shape[0]):
        for comp in range(6):
            if mask[c, comp]:
                neq += 1
    return neq


@_njit
def workspace(n, n_links, neq, nv, nw):
    return (np.empty((n_links, 4, 4)), np.empty((n, 3)), np.empty((n, 3)), np.empty(neq),
            np.empty((neq, n)), np.empty((4, 4)), np.empty((4, 4)), np.empty(6),
            np.empty((6, n)), np.empty((4, 4)), np.empty((6, n)), np.empty((neq, nw)),
            np.empty((neq, nv)))


@_njit
def lm_closed(qv0, qw0, TP, w, iv, iw, K, fe_link, fe_off, sigE, lo, hi, cont, lower, upper,
              n_links, tol_phi, tol_dq, max_iter_closure, f_abs, grad_tol, max_iter, mu, lo_w,
              hi_w,
              band_w, passive, stop_first, qv_out, qw_out, f, iters, done, gnorm, closed, hist):
    """Levenberg-Marquardt on the reduced Jacobian, row by row (see the module docstring).
    With ``stop_first`` (several starts for one target) the rows after the first that
    converges (E < f_abs) are not run: E inf, 0 iterations, not closed."""
    m, nv = qv0.shape
    nw = iw.size
    n = nv + nw
    neq = equation_count(K)
    W = workspace(n, n_links, neq, nv, nw)
    q = np.empty(n)
    qn_full = np.empty(n)
    x = np.empty(6)
    Jr = np.empty((6, nv))
    S = np.empty((nw, nv))
    xn = np.empty(6)
    Jn = np.empty((6, nv))
    Sn = np.empty((nw, nv))
    g = np.empty(nv)
    H = np.empty((nv, nv))
    A = np.empty((nv, nv))
    step = np.empty(nv)
    qv = np.empty(nv)
    qn = np.empty(nv)
    blk = np.zeros(nv, dtype=np.bool_)
    keep_hist = hist.shape[0] > 0
    for r in range(m):
        for i in range(nv):
            qv[i] = qv0[r, i]
        project(qv, lo, hi, cont, lower, upper)
        for i in range(nv):
            q[iv[i]] = qv[i]
        for i in range(nw):
            q[iw[i]] = qw0[r, i]
        ok = evaluate_closed(q, iv, iw, K, fe_link, fe_off, sigE, TP[r], tol_phi, tol_dq,
                             max_iter_closure, x, Jr, S, W)
        closed[r] = ok
        fr = half_wsq(w[r], x)
        if not ok:
            fr = np.inf
        if keep_hist:
            hist[r, 0] = fr
        lam = 1e-2
        fin = (not ok) or fr < f_abs
        it = 0
        gn = 0.0
        while not fin and it < max_iter:
            gn = lm_step(Jr, x, w[r], qv, lo, hi, lam, mu, g, H, A, step, blk)
            if gn < grad_tol:  # ||grad E|| below tolerances.grad: stationary
                fin = True
                break
            if passive:
                passive_limited_step(H, g, lam, mu, step, q, iw, S, lo_w, hi_w)
            for a in range(nv):
                qn[a] = qv[a] - step[a]
            project(qn, lo, hi, cont, lower, upper)
            # first-order predictor of the dependent joints: q_w - S (q_v,new - q_v)
            for i in range(nv):
                qn_full[iv[i]] = qn[i]
            for i in range(nw):
                acc = q[iw[i]]
                for b in range(nv):
                    acc -= S[i, b] * (qn[b] - qv[b])
                qn_full[iw[i]] = acc
            okn = evaluate_closed(qn_full, iv, iw, K, fe_link, fe_off, sigE, TP[r], tol_phi,
                                  tol_dq, max_iter_closure, xn, Jn, Sn, W)
            if passive and okn:
                okn = within(qn_full, iw, lo_w, hi_w, band_w)
            fn = half_wsq(w[r], xn)
            it += 1
            accept, lam, fin = lm_decide(fr, fn, okn, lam, step, f_abs)
            if accept:
                for a in range(nv):
                    qv[a] = qn[a]
                    for i in range(6):
                        Jr[i, a] = Jn[i, a]
                    for i in range(nw):
                        S[i, a] = Sn[i, a]
                for i in range(n):
                    q[i] = qn_full[i]
                for i in range(6):
                    x[i] = xn[i]
                fr = fn
            if keep_hist:
                hist[r, it] = fr
        for i in range(nv):
            qv_out[r, i] = qv[i]
        for i in range(nw):
            qw_out[r, i] = q[iw[i]]
        f[r] = fr
        iters[r] = it
        done[r] = fin
        gnorm[r] = gn
        if stop_first and fr < f_abs:
            for rr in range(r + 1, m):
                for i in range(nv):
                    qv_out[rr, i] = qv0[rr, i]
                project(qv_out[rr], lo, hi, cont, lower, upper)
                for i in range(nw):
                    qw_out[rr, i] = qw0[rr, i]
                f[rr] = np.inf
                iters[rr] = 0
                done[rr] = False
                gnorm[rr] = 0.0
                closed[rr] = False
            break


@_njit
def evaluate_one(q, iv, iw, K, fe_link, fe_off, sigE, TP, tol_phi, tol_dq, max_iter, n_links,
                 x, Jr, S):
    """:func:`evaluate_closed` with its own workspace (one call from Python)."""
    neq = equation_count(K)
    W = workspace(q.size, n_links, neq, iv.size, iw.size)
    return evaluate_closed(q, iv, iw, K, fe_link, fe_off, sigE, TP, tol_phi, tol_dq, max_iter,
                           x, Jr, S, W)


class ClosedEvaluator:
    """One configuration at a time, from Python: loop closure from a guess, x (Eq. (8)), the
    reduced Jacobian (Eq. (10)) and S; for kim1995 §5.2 (cg-golden), which evaluates f along
    line searches one point after another."""

    def __init__(self, kern, tol_phi: float, tol_dq: float, max_iter: int) -> None:
        self.kern = kern
        self.K, self.fe_link, self.fe_off, self.sigE = tree_constants(kern.mech, kern.frame)
        self.iv, self.iw = kern.iv.astype(np.int64), kern.iw.astype(np.int64)
        self.args = (float(tol_phi), float(tol_dq), int(max_iter), kern.mech.n_links)

    def __call__(self, qv: np.ndarray, qw: np.ndarray, T_P: np.ndarray):
        """(closed, x (6,), J_r (6, n_v), q (n,), S (n_w, n_v)) at q_v from the guess q_w."""
        q = np.empty(self.kern.n)
        q[self.iv], q[self.iw] = qv, qw
        x = np.empty(6)
        Jr = np.empty((6, self.iv.size))
        S = np.empty((self.iw.size, self.iv.size))
        ok = evaluate_one(q, self.iv, self.iw, self.K, self.fe_link, self.fe_off, self.sigE,
                          np.ascontiguousarray(T_P, dtype=np.float64), *self.args, x, Jr, S)
        return bool(ok), x, Jr, q, S


def tree_constants(mech, frame: int):
    """The arrays the kernels read, built once per mechanism and {E} (cached on it)."""
    cache = mech.__dict__.setdefault("_jit_tree", {})
    hit = cache.get(frame)
    if hit is not None:
        return hit
    from mechkin.model.kinematics import _cut_arrays, _local_factors

    P0, Pc, Ps, Pd = _local_factors(mech)
    fa, fb, mask = _cut_arrays(mech)
    anc = mech.link_ancestors.astype(np.float64)
    sig = np.ascontiguousarray(anc[mech.frame_link[fb]] - anc[mech.frame_link[fa]])
    K = (np.ascontiguousarray(np.concatenate(mech.levels).astype(np.int64)),
         mech.joint_parent_link.astype(np.int64), mech.joint_child_link.astype(np.int64),
         np.ascontiguousarray(Pc), np.ascontiguousarray(Ps), np.ascontiguousarray(Pd),
         np.ascontiguousarray(P0), np.ascontiguousarray(mech.s == 0),
         np.ascontiguousarray(mech.A[:, :3, 2]), np.ascontiguousarray(mech.A[:, :3, 3]),
         mech.frame_link.astype(np.int64), np.ascontiguousarray(mech.frame_offset),
         fa.astype(np.int64), fb.astype(np.int64), np.ascontiguousarray(mask), sig,
         np.array([c.joint for c in mech.couplings], dtype=np.int64),
         np.array([c.master for c in mech.couplings], dtype=np.int64),
         np.array([c.multiplier for c in mech.couplings], dtype=np.float64),
         np.array([c.offset for c in mech.couplings], dtype=np.float64))
    hit = (K, int(mech.frame_link[frame]), np.ascontiguousarray(mech.frame_offset[frame]),
           np.ascontiguousarray(anc[mech.frame_link[frame]]))
    cache[frame] = hit
    return hit


def lm_closed_rows(kern, q_v0: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray, w: np.ndarray, *,
                   tol_phi: float, tol_dq: float, max_iter_closure: int, f_abs: float,
                   max_iter: int, mu: float, history: bool, passive_band: float,
                   stop_first: bool = False, grad_tol: float = 0.0):
    """Run the compiled closed-chain lm on every row; returns a dict like
    :func:`mechkin.solvers.ik.lm.lm_batch`."""
    mech = kern.mech
    K, fe_link, fe_off, sigE = tree_constants(mech, kern.frame)
    m, nv = q_v0.shape
    nw = kern.iw.size
    qv = np.empty((m, nv))
    qw = np.empty((m, nw))
    f = np.empty(m)
    iters = np.zeros(m, dtype=np.int64)
    done = np.zeros(m, dtype=np.bool_)
    gnorm = np.zeros(m)
    closed = np.zeros(m, dtype=np.bool_)
    hist = np.full((m, max_iter + 1) if history else (0, 0), np.nan)
    lm_closed(np.ascontiguousarray(q_v0, dtype=np.float64),
              np.ascontiguousarray(q_w0, dtype=np.float64), np.ascontiguousarray(T_P),
              np.ascontiguousarray(w, dtype=np.float64), kern.iv.astype(np.int64),
              kern.iw.astype(np.int64), K, fe_link, fe_off, sigE,
              *(np.ascontiguousarray(a) for a in (kern.bound_lo, kern.bound_hi, kern.cont_v,
                                                 kern.lower_v, kern.upper_v)),
              mech.n_links, float(tol_phi), float(tol_dq), int(max_iter_closure), float(f_abs),
              float(grad_tol), int(max_iter), float(mu), np.ascontiguousarray(kern.lo_w),
              np.ascontiguousarray(kern.hi_w), np.ascontiguousarray(passive_band * kern.range_w),
              kern.passive_bounded, bool(stop_first), qv, qw, f, iters, done, gnorm, closed,
              hist)
    q = np.empty((m, kern.n))
    q[:, kern.iv] = qv
    q[:, kern.iw] = qw
    hl = [list(h[: i + 1]) for h, i in zip(hist, iters, strict=True)] if history else []
    return dict(q=q, qv=qv, qw=qw, f=f, iters=iters, nev=iters + 1, gnorm=gnorm,
                closed=closed, converged=done | ~closed, hist=hl)
