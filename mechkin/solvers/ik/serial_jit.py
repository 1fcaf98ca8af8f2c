r"""Compiled Levenberg-Marquardt for open chains (optional accelerator, needs ``numba``).

The same iteration as the numpy ``lm`` of :mod:`mechkin.solvers.ik.lm` on the serial path
to {E} (:class:`mechkin.model.serial.SerialChain`), written as plain loops and compiled by numba
(``pip install "mechkin[fast]"``). For one target the numpy version spends almost all its time
in the fixed cost of small array calls; compiled, a whole solve takes tens of microseconds.

Per row (target), with the chain expressed in {P} (``F_0 = T_P^{-1} A_0``):

* residual x = (position of {E} in {P}, rotation vector of R_P^T R_E), Jacobian the geometric
  Jacobian in {P} (exact for the position, exact at zero rotation for the orientation);
* Marquardt step ``(H + lambda (diag H + mu I)) delta = -g``, ``H = J^T W J``, ``g = J^T W x``,
  joints on a limit whose gradient points outward frozen, the step projected onto the limits
  (continuous joints wrapped);
* a step is kept when E = 1/2 x^T W x decreases (lambda / 10), else lambda x 4; a row stops when
  E < f_abs, when a kept step gains less than 1e-14 E, when a rejected step is shorter than
  1e-13 or lambda > 1e10, or (``stall > 0``) when E has not halved in ``stall`` iterations.

Importing this module imports numba; :func:`mechkin.solvers.ik.accel.compiled_lm_available` says
whether it can be used (numba installed, ``MECHKIN_JIT`` not ``0``). The compiled code is cached
on disk (:func:`mechkin.solvers.ik.accel.configure_numba_cache` picks the folder before numba is
imported); ``mechkin warmup`` compiles it ahead of first use.

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. Imports numpy, numba and
:mod:`mechkin.solvers.ik.accel` (the chain constants come in as arrays); never ``io/``,
``cli/`` or ``tasks/``.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

from mechkin.solvers.ik.accel import configure_numba_cache

configure_numba_cache()  # before numba reads NUMBA_CACHE_DIR (a read-only install: user cache)

import numba  # noqa: E402
import numpy as np  # noqa: E402

PARALLEL_ROWS = 512  # rows per thread below which one thread runs the whole batch
_CPUS = os.cpu_count() or 1  # once: os.cpu_count() took ~1 ms per call here (profiled)

_njit = numba.njit(cache=True, nogil=True)


@_njit
def chain_frames(q, F0, Pc, Ps, Pd, P0, rev, F):
    """F[0] = F0, F[i+1] = F[i] (c Pc + s Ps + d Pd + P0)_i: joint frames and the end pose."""
    for a in range(4):
        for b in range(4):
            F[0, a, b] = F0[a, b]
    for i in range(q.size):
        if rev[i]:
            c, s, d = np.cos(q[i]), np.sin(q[i]), 0.0
        else:
            c, s, d = 0.0, 0.0, q[i]
        for a in range(3):
            for b in range(4):
                acc = 0.0
                for t in range(4):
                    acc += F[i, a, t] * (c * Pc[i, t, b] + s * Ps[i, t, b] + d * Pd[i, t, b]
                                         + P0[i, t, b])
                F[i + 1, a, b] = acc
        F[i + 1, 3, 0] = 0.0
        F[i + 1, 3, 1] = 0.0
        F[i + 1, 3, 2] = 0.0
        F[i + 1, 3, 3] = 1.0


@_njit
def rotation_vector(E, x):
    """x[3:6] = rotation vector of E[:3, :3] (as mechkin.spatial.rotations.rotation_log)."""
    wx = 0.5 * (E[2, 1] - E[1, 2])
    wy = 0.5 * (E[0, 2] - E[2, 0])
    wz = 0.5 * (E[1, 0] - E[0, 1])
    cs = 0.5 * (E[0, 0] + E[1, 1] + E[2, 2] - 1.0)
    sn = np.sqrt(wx * wx + wy * wy + wz * wz)
    ang = np.arctan2(sn, cs)
    if cs < -0.985:
        # near a half turn: the axis is the dominant column of sym(R) - cos I, signed by w
        b00, b11, b22 = E[0, 0] - cs, E[1, 1] - cs, E[2, 2] - cs
        b01 = 0.5 * (E[0, 1] + E[1, 0])
        b02 = 0.5 * (E[0, 2] + E[2, 0])
        b12 = 0.5 * (E[1, 2] + E[2, 1])
        if b00 >= b11 and b00 >= b22:
            ax, ay, az = b00, b01, b02
        elif b11 >= b22:
            ax, ay, az = b01, b11, b12
        else:
            ax, ay, az = b02, b12, b22
        nrm = np.sqrt(ax * ax + ay * ay + az * az)
        scale = ang / nrm if ax * wx + ay * wy + az * wz >= 0.0 else -ang / nrm
        wx, wy, wz = ax, ay, az
    else:
        scale = ang / sn if sn > 1e-300 else 1.0
    x[3] = wx * scale
    x[4] = wy * scale
    x[5] = wz * scale


@_njit
def evaluate(q, F0, Pc, Ps, Pd, P0, rev, F, x, J):
    """x (6,) and J (6, k) of one configuration q (k,); F (k+1, 4, 4) workspace."""
    k = q.size
    chain_frames(q, F0, Pc, Ps, Pd, P0, rev, F)
    px, py, pz = F[k, 0, 3], F[k, 1, 3], F[k, 2, 3]
    x[0] = px
    x[1] = py
    x[2] = pz
    rotation_vector(F[k], x)
    for i in range(k):
        zx, zy, zz = F[i, 0, 2], F[i, 1, 2], F[i, 2, 2]
        if rev[i]:
            rx, ry, rz = px - F[i, 0, 3], py - F[i, 1, 3], pz - F[i, 2, 3]
            J[0, i] = zy * rz - zz * ry
            J[1, i] = zz * rx - zx * rz
            J[2, i] = zx * ry - zy * rx
            J[3, i] = zx
            J[4, i] = zy
            J[5, i] = zz
        else:
            J[0, i] = zx
            J[1, i] = zy
            J[2, i] = zz
            J[3, i] = 0.0
            J[4, i] = 0.0
            J[5, i] = 0.0


@_njit
def cholesky_solve(A, b, out):
    """Solve A out = b for a symmetric positive definite A (k, k), in place (A is overwritten
    by its Cholesky factor). A non-positive pivot (numerically singular A) is floored at
    1e-300 of the largest diagonal so the step stays finite."""
    k = b.size
    dmax = 0.0
    for a in range(k):
        dmax = max(dmax, A[a, a])
    floor = max(dmax * 1e-300, 1e-300)
    for j in range(k):
        s = A[j, j]
        for t in range(j):
            s -= A[j, t] * A[j, t]
        if s < floor:
            s = floor
        d = np.sqrt(s)
        A[j, j] = d
        for i in range(j + 1, k):
            s = A[i, j]
            for t in range(j):
                s -= A[i, t] * A[j, t]
            A[i, j] = s / d
    for i in range(k):  # L y = b
        s = b[i]
        for t in range(i):
            s -= A[i, t] * out[t]
        out[i] = s / A[i, i]
    for i in range(k - 1, -1, -1):  # L^T out = y
        s = out[i]
        for t in range(i + 1, k):
            s -= A[t, i] * out[t]
        out[i] = s / A[i, i]


@_njit
def lm_step(J, x, wr, q, lo, hi, lam, mu, g, H, A, step, blk):
    """One Marquardt step (step (k,), to subtract from q) from J (6, k), x (6,), weights wr:
    g = J^T W x, H = J^T W J, joints on a limit whose gradient points outward frozen,
    (H + lam (diag H + mu I)) step = g. Returns ||g|| (projected)."""
    k = q.size
    for a in range(k):
        acc = 0.0
        for i in range(6):
            acc += J[i, a] * wr[i] * x[i]
        g[a] = acc
    for a in range(k):
        blk[a] = (q[a] <= lo[a] + 1e-12 and g[a] > 0.0) or (q[a] >= hi[a] - 1e-12 and g[a] < 0.0)
        for b in range(a, k):
            acc = 0.0
            for i in range(6):
                acc += J[i, a] * wr[i] * J[i, b]
            H[a, b] = acc
            H[b, a] = acc
    for a in range(k):
        if blk[a]:
            g[a] = 0.0
            for b in range(k):
                H[a, b] = 0.0
                H[b, a] = 0.0
            H[a, a] = 1.0
    gn = 0.0
    for a in range(k):
        gn += g[a] * g[a]
    for a in range(k):
        for b in range(k):
            A[a, b] = H[a, b]
        A[a, a] += lam * (H[a, a] + mu)
    cholesky_solve(A, g, step)
    return np.sqrt(gn)


@_njit
def half_wsq(wr, x):
    """E = 1/2 x^T W x for a diagonal W (kim1995 Eq. (9))."""
    e = 0.0
    for i in range(6):
        e += 0.5 * wr[i] * x[i] * x[i]
    return e


@_njit
def lm_decide(f, fn, ok, lam, step, f_abs):
    """Keep a step that lowers E (lambda / 10) or reject it (lambda x 4); whether the row is
    finished: E below f_abs, a kept step gaining less than 1e-14 E, or a rejected step shorter
    than 1e-13 or lambda above 1e10. Returns (accept, lambda, finished)."""
    if ok and fn < f:
        return True, max(lam * 0.1, 1e-12), fn < f_abs or f - fn <= 1e-14 * max(fn, 1e-300)
    sn = 0.0
    for a in range(step.size):
        sn += step[a] * step[a]
    lam *= 4.0
    return False, lam, np.sqrt(sn) < 1e-13 or lam > 1e10


@_njit
def project(q, lo, hi, cont, lower, upper):
    """Clamp q onto [lo, hi]; a continuous joint (``cont``, limits [lower, upper] spanning a
    full turn) inside its limits is kept, outside moved by the fewest whole turns into them
    (as :func:`mechkin.solvers.ik.kernel.wrap_into`)."""
    two_pi = 2.0 * np.pi
    for j in range(q.size):
        if cont[j]:
            if q[j] < lower[j]:
                q[j] += two_pi * np.ceil((lower[j] - q[j]) / two_pi)
            if q[j] > upper[j]:
                q[j] -= two_pi * np.ceil((q[j] - upper[j]) / two_pi)
        elif q[j] < lo[j]:
            q[j] = lo[j]
        elif q[j] > hi[j]:
            q[j] = hi[j]


@_njit
def lm(q0, F0, w, Pc, Ps, Pd, P0, rev, lo, hi, cont, lower, upper, f_abs, grad_tol, max_iter,
       stall, mu, stop_first, q, f, iters, done, gnorm, hist):
    """Rows one after another; with ``stop_first`` (several starts for one target) the rows
    after the first that converges (E < f_abs) are not run: their E is inf, 0 iterations."""
    m, k = q0.shape
    F = np.empty((k + 1, 4, 4))
    x = np.empty(6)
    J = np.empty((6, k))
    xn = np.empty(6)
    Jn = np.empty((6, k))
    g = np.empty(k)
    H = np.empty((k, k))
    step = np.empty(k)
    qn = np.empty(k)
    blk = np.zeros(k, dtype=np.bool_)
    A = np.empty((k, k))
    keep_hist = hist.shape[0] > 0
    for r in range(m):
        qr = q[r]
        for a in range(k):
            qr[a] = q0[r, a]
        project(qr, lo, hi, cont, lower, upper)
        evaluate(qr, F0[r], Pc, Ps, Pd, P0, rev, F, x, J)
        fr = half_wsq(w[r], x)
        if keep_hist:
            hist[r, 0] = fr
        lam = 1e-2
        fref = fr
        fin = fr < f_abs
        it = 0
        gn = 0.0
        while not fin and it < max_iter:
            gn = lm_step(J, x, w[r], qr, lo, hi, lam, mu, g, H, A, step, blk)
            if gn < grad_tol:  # ||grad E|| below tolerances.grad: stationary
                fin = True
                break
            for a in range(k):
                qn[a] = qr[a] - step[a]
            project(qn, lo, hi, cont, lower, upper)
            evaluate(qn, F0[r], Pc, Ps, Pd, P0, rev, F, xn, Jn)
            fn = half_wsq(w[r], xn)
            it += 1
            accept, lam, fin = lm_decide(fr, fn, True, lam, step, f_abs)
            if accept:
                for a in range(k):
                    qr[a] = qn[a]
                    for i in range(6):
                        J[i, a] = Jn[i, a]
                for i in range(6):
                    x[i] = xn[i]
                fr = fn
            if keep_hist:
                hist[r, it] = fr
            if stall > 0 and it % stall == 0:
                if fr > 0.5 * fref:
                    fin = True
                fref = fr
        f[r] = fr
        iters[r] = it
        done[r] = fin
        gnorm[r] = gn
        if stop_first and fr < f_abs:
            for rr in range(r + 1, m):
                for a in range(k):
                    q[rr, a] = q0[rr, a]
                project(q[rr], lo, hi, cont, lower, upper)
                f[rr] = np.inf
                iters[rr] = 0
                done[rr] = False
                gnorm[rr] = 0.0
            break


def lm_serial(q0: np.ndarray, F0: np.ndarray, w: np.ndarray, chain, lo: np.ndarray,
              hi: np.ndarray, cont: np.ndarray, lower: np.ndarray, upper: np.ndarray, *,
              f_abs: float, max_iter: int, stall: int, mu: float, history: bool,
              stop_first: bool = False, grad_tol: float = 0.0):
    """Run the compiled lm on every row; returns q (m, k), f, iters, done, gnorm, hist.

    ``chain`` is a :class:`mechkin.model.serial.SerialChain`; q0 (m, k) are its joints; F0
    (m, 4, 4) its first frame in each precision point; w (m, 6) the weights; lo, hi, cont,
    lower, upper (k,) the bounds, continuous flags and the limits of the chain's joints.
    ``stop_first``: the rows are starts for one target; stop at the first that converges.
    ``grad_tol``: a row also stops when ||J^T W x|| (free joints) is below it.
    """
    m, k = q0.shape
    q = np.empty((m, k))
    f = np.empty(m)
    iters = np.zeros(m, dtype=np.int64)
    done = np.zeros(m, dtype=np.bool_)
    gnorm = np.zeros(m)
    hist = np.full((m, max_iter + 1) if history else (0, 0), np.nan)
    args = (np.ascontiguousarray(q0, dtype=np.float64), np.ascontiguousarray(F0),
            np.ascontiguousarray(w, dtype=np.float64))
    cc = chain.__dict__.get("_jit_consts")
    if cc is None:
        cc = chain.__dict__["_jit_consts"] = (
            chain.Pc[:, 0].copy(), chain.Ps[:, 0].copy(), chain.Pd[:, 0].copy(),
            chain.P0[:, 0].copy(), chain.rev.copy())
    consts = (*cc, *(np.ascontiguousarray(a) for a in (lo, hi, cont, lower, upper)),
              float(f_abs), float(grad_tol), int(max_iter), int(stall), float(mu),
              bool(stop_first))
    outs = (q, f, iters, done, gnorm, hist)

    def run(sl: slice) -> None:
        lm(*(a[sl] for a in args), *consts,
           *(o[sl] if o.shape[0] else o for o in outs))

    workers = 1 if stop_first else min(_CPUS, m // PARALLEL_ROWS)
    if workers <= 1:
        run(slice(None))
    else:
        # the kernel releases the GIL (nogil): row blocks on threads, no numba threading layer
        bounds = np.linspace(0, m, workers + 1).astype(int)
        with ThreadPoolExecutor(workers) as ex:
            list(ex.map(run, [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:],
                                                             strict=True)]))
    return q, f, iters, done, gnorm, hist


@_njit
def nearest_turn_one(q, ref, cont, lower, upper):
    """Continuous joints of q (k,) moved by whole turns to the representative within their
    limits nearest ``ref`` (as :meth:`mechkin.solvers.ik.kernel.IkKernel.nearest_turn`), in
    place."""
    two_pi = 2.0 * np.pi
    for j in range(q.size):
        if cont[j]:
            t = q[j] + two_pi * np.round((ref[j] - q[j]) / two_pi)
            if t < lower[j]:
                t = t + two_pi * np.ceil((lower[j] - t) / two_pi)
            if t > upper[j]:
                t = t - two_pi * np.ceil((t - upper[j]) / two_pi)
            q[j] = t


@_njit
def pose_errors_one(T_E, T_P, w, out):
    """out[0:4] = position and orientation errors of T_E to T_P, all components, then the
    weighted ones only (as :func:`mechkin.solvers.ik.results.pose_and_weighted_errors`):
    ``x_p = R_P^T (p_E - p_P)``, ``x_o`` = rotation vector of ``R_P^T R_E``."""
    M = np.empty((3, 4))
    for a in range(3):
        for b in range(4):
            acc = 0.0
            for t in range(3):
                acc += T_P[t, a] * T_E[t, b]
            M[a, b] = acc
    x = np.empty(6)
    for a in range(3):
        acc = 0.0
        for t in range(3):
            acc += T_P[t, a] * T_P[t, 3]
        x[a] = M[a, 3] - acc
    rotation_vector(M, x)
    pe = oe = wpe = woe = 0.0
    for a in range(3):
        pe += x[a] * x[a]
        oe += x[3 + a] * x[3 + a]
        if w[a] > 0.0:
            wpe += x[a] * x[a]
        if w[3 + a] > 0.0:
            woe += x[3 + a] * x[3 + a]
    out[0] = np.sqrt(pe)
    out[1] = np.sqrt(oe)
    out[2] = np.sqrt(wpe)
    out[3] = np.sqrt(woe)


@_njit
def solve_rows(q0, F0, w1, Pc, Ps, Pd, P0, rev, A0, lo, hi, cont, lower, upper, f_abs,
               grad_tol, max_iter, stall, mu, stop_first, home, ref, T_P, q_out, hist_out,
               at_out, info):
    """One attempt of :func:`mechkin.solvers.ik.solve.solve_ik` on an open chain whose joints
    are q_v in order: :func:`lm` on the starts q0 (m, k) for the one target (F0 (1, 4, 4) its
    first frame in {P}, w1 (6,) the weights), the best row (lowest E; the first NaN, as
    ``np.argmin``), its joints made finite (``home``) and moved to the whole turn nearest
    ``ref``, then verified by forward kinematics in the base frame (F_0 = A0).

    Writes q_out (k,), hist_out (max_iter + 1,) (E per iteration of the best row, NaN after),
    at_out (k,) (joints within 1e-9 of a limit ``lower`` / ``upper``) and info: [f, iters of
    the best row, most iterations of a row, evaluations (sum of iters + 1), ||g||, converged,
    position error, orientation error, weighted position error, weighted orientation error,
    a joint on a bound ``lo`` / ``hi`` (1e-9), all joints finite]."""
    m, k = q0.shape
    F0s = np.empty((m, 4, 4))
    W = np.empty((m, 6))
    for r in range(m):
        for a in range(4):
            for b in range(4):
                F0s[r, a, b] = F0[0, a, b]
        for a in range(6):
            W[r, a] = w1[a]
    q = np.empty((m, k))
    f = np.empty(m)
    iters = np.zeros(m, dtype=np.int64)
    done = np.zeros(m, dtype=np.bool_)
    gnorm = np.zeros(m)
    hist = np.full((m, max_iter + 1), np.nan)
    lm(q0, F0s, W, Pc, Ps, Pd, P0, rev, lo, hi, cont, lower, upper, f_abs, grad_tol,
       max_iter, stall, mu, stop_first, q, f, iters, done, gnorm, hist)
    b = 0
    if m > 1:
        any_finite = False
        for r in range(m):
            if np.isfinite(f[r]):
                any_finite = True
        if any_finite:  # np.argmin: the first NaN, else the first minimum
            fb = f[0]
            for r in range(1, m):
                if np.isnan(fb):
                    break
                if np.isnan(f[r]) or f[r] < fb:
                    b = r
                    fb = f[r]
    for a in range(k):
        v = q[b, a]
        q_out[a] = v if np.isfinite(v) else home[a]
    nearest_turn_one(q_out, ref, cont, lower, upper)
    for a in range(max_iter + 1):
        hist_out[a] = hist[b, a]
    F = np.empty((k + 1, 4, 4))
    chain_frames(q_out, A0, Pc, Ps, Pd, P0, rev, F)
    errs = np.empty(4)
    pose_errors_one(F[k], T_P, w1, errs)
    onb = False
    fin = True
    for a in range(k):
        at_out[a] = (q_out[a] <= lower[a] + 1e-9) or (q_out[a] >= upper[a] - 1e-9)
        onb = onb or (q_out[a] <= lo[a] + 1e-9) or (q_out[a] >= hi[a] - 1e-9)
        fin = fin and np.isfinite(q_out[a])
    imax = 0
    nev = 0
    for r in range(m):
        imax = max(imax, iters[r])
        nev += iters[r] + 1
    info[0] = f[b]
    info[1] = iters[b]
    info[2] = imax
    info[3] = nev
    info[4] = gnorm[b]
    info[5] = 1.0 if done[b] else 0.0
    info[6] = errs[0]
    info[7] = errs[1]
    info[8] = errs[2]
    info[9] = errs[3]
    info[10] = 1.0 if onb else 0.0
    info[11] = 1.0 if fin else 0.0


@_njit
def verify_rows(q, A0, Pc, Ps, Pd, P0, rev, T_P, w, out):
    """Forward kinematics of rows q (m, k) in the base frame (F_0 = A0) and their errors to
    the targets T_P (m, 4, 4) with weights w (m, 6): out (m, 4) as :func:`pose_errors_one`
    (position, orientation, weighted position, weighted orientation)."""
    m, k = q.shape
    F = np.empty((k + 1, 4, 4))
    for r in range(m):
        chain_frames(q[r], A0, Pc, Ps, Pd, P0, rev, F)
        pose_errors_one(F[k], T_P[r], w[r], out[r])


@_njit
def nearest_turn_rows(q, ref, cont, lower, upper):
    """:func:`nearest_turn_one` on every row of q (m, k) with references ref (m, k), in
    place."""
    for r in range(q.shape[0]):
        nearest_turn_one(q[r], ref[r], cont, lower, upper)


@_njit
def lm_verify(q0, F0, w, Pc, Ps, Pd, P0, rev, A0, lo, hi, cont, lower, upper, f_abs, grad_tol,
              max_iter, stall, mu, T_P, q, f, iters, done, gnorm, err):
    """:func:`lm` on rows q0 (m, k) (one target each, no history), then :func:`verify_rows`
    of the results into err (m, 4): one call per attempt of a small batch."""
    hist = np.empty((0, 0))
    lm(q0, F0, w, Pc, Ps, Pd, P0, rev, lo, hi, cont, lower, upper, f_abs, grad_tol, max_iter,
       stall, mu, False, q, f, iters, done, gnorm, hist)
    verify_rows(q, A0, Pc, Ps, Pd, P0, rev, T_P, w, err)
