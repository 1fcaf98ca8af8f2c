r"""Compiled lm for closed and complex chains (optional accelerator, needs ``numba``).

The numpy ``lm`` of :mod:`mechkin.solvers.ik.lm` on a mechanism with cut joints, written as
loops over one configuration and compiled by numba (``pip install "mechkin[fast]"``). Each
evaluation is what the numpy path does with :mod:`mechkin.model`:

* tree forward kinematics (kim1995 Eq. (2)), joint axes;
* loop closure phi_R(q_v, q_w) = 0 by Newton-Raphson (kim1995 §5.1, as
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
:mod:`mechkin.solvers.ik.serial_jit` (shared loop kernels); never ``io/``, ``cli/`` or
``tasks/``.
"""

from __future__ import annotations

from mechkin.solvers.ik.accel import configure_numba_cache

configure_numba_cache()  # before numba reads NUMBA_CACHE_DIR (a read-only install: user cache)

import numba  # noqa: E402
import numpy as np  # noqa: E402

from mechkin.solvers.ik.serial_jit import (  # noqa: E402
    cholesky_solve,
    half_wsq,
    lm_decide,
    lm_step,
    project,
)

_njit = numba.njit(cache=True, nogil=True)


@_njit
def tree_fk(q, order, jp, jc, Pc, Ps, Pd, P0, rev, T):
    """Link poses T (n_links, 4, 4) of one configuration (joints in tree order)."""
    for a in range(4):
        for b in range(4):
            T[0, a, b] = 1.0 if a == b else 0.0
    for idx in range(order.size):
        j = order[idx]
        if rev[j]:
            c, s, d = np.cos(q[j]), np.sin(q[j]), 0.0
        else:
            c, s, d = 0.0, 0.0, q[j]
        p, ch = jp[j], jc[j]
        for a in range(3):
            for b in range(4):
                acc = 0.0
                for t in range(4):
                    acc += T[p, a, t] * (c * Pc[j, t, b] + s * Ps[j, t, b] + d * Pd[j, t, b]
                                         + P0[j, t, b])
                T[ch, a, b] = acc
        T[ch, 3, 0] = 0.0
        T[ch, 3, 1] = 0.0
        T[ch, 3, 2] = 0.0
        T[ch, 3, 3] = 1.0


@_njit
def tree_axes(q, T, jp, az, ao, rev, z, o):
    """Joint axes z (n, 3) and points o (n, 3) on them, in the base frame."""
    for j in range(q.size):
        p = jp[j]
        d = 0.0 if rev[j] else q[j]
        for a in range(3):
            zz = 0.0
            oo = T[p, a, 3]
            for t in range(3):
                zz += T[p, a, t] * az[j, t]
                oo += T[p, a, t] * (ao[j, t] + az[j, t] * d)
            z[j, a] = zz
            o[j, a] = oo


@_njit
def frame_pose(T, link, off, out):
    for a in range(3):
        for b in range(4):
            acc = 0.0
            for t in range(4):
                acc += T[link, a, t] * off[t, b]
            out[a, b] = acc
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


@_njit
def rel_res_jac(Ta, Tb, sig, z, o, rev, x, J, jac):
    """x (6,): R_a^T (p_b - p_a) and the vector part of the Euler parameters of R_a^T R_b
    (e0 >= 0, Shepperd); J (6, n): its exact Jacobian over the joints with sig != 0."""
    M = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            acc = 0.0
            for t in range(3):
                acc += Ta[t, a] * Tb[t, b]
            M[a, b] = acc
    for a in range(3):
        acc = 0.0
        for t in range(3):
            acc += Ta[t, a] * (Tb[t, 3] - Ta[t, 3])
        x[a] = acc
    tr = M[0, 0] + M[1, 1] + M[2, 2]
    if tr >= M[0, 0] and tr >= M[1, 1] and tr >= M[2, 2]:
        s0 = 2.0 * np.sqrt(max(1.0 + tr, 0.0))
        e0, e1 = 0.25 * s0, (M[2, 1] - M[1, 2]) / s0
        e2, e3 = (M[0, 2] - M[2, 0]) / s0, (M[1, 0] - M[0, 1]) / s0
    elif M[0, 0] >= M[1, 1] and M[0, 0] >= M[2, 2]:
        s1 = 2.0 * np.sqrt(max(1.0 + M[0, 0] - M[1, 1] - M[2, 2], 0.0))
        e0, e1 = (M[2, 1] - M[1, 2]) / s1, 0.25 * s1
        e2, e3 = (M[0, 1] + M[1, 0]) / s1, (M[0, 2] + M[2, 0]) / s1
    elif M[1, 1] >= M[2, 2]:
        s2 = 2.0 * np.sqrt(max(1.0 + M[1, 1] - M[0, 0] - M[2, 2], 0.0))
        e0, e1 = (M[0, 2] - M[2, 0]) / s2, (M[0, 1] + M[1, 0]) / s2
        e2, e3 = 0.25 * s2, (M[1, 2] + M[2, 1]) / s2
    else:
        s3 = 2.0 * np.sqrt(max(1.0 + M[2, 2] - M[0, 0] - M[1, 1], 0.0))
        e0, e1 = (M[1, 0] - M[0, 1]) / s3, (M[0, 2] + M[2, 0]) / s3
        e2, e3 = (M[1, 2] + M[2, 1]) / s3, 0.25 * s3
    nrm = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
    if e0 < 0.0:
        nrm = -nrm
    e0, e1, e2, e3 = e0 / nrm, e1 / nrm, e2 / nrm, e3 / nrm
    x[3], x[4], x[5] = e1, e2, e3
    if not jac:
        return
    pbx, pby, pbz = Tb[0, 3], Tb[1, 3], Tb[2, 3]
    for j in range(sig.size):
        sg = sig[j]
        if sg == 0.0:
            for a in range(6):
                J[a, j] = 0.0
            continue
        zx, zy, zz = z[j, 0] * sg, z[j, 1] * sg, z[j, 2] * sg
        if rev[j]:
            rx, ry, rz = pbx - o[j, 0], pby - o[j, 1], pbz - o[j, 2]
            vx, vy, vz = zy * rz - zz * ry, zz * rx - zx * rz, zx * ry - zy * rx
            wx, wy, wz = zx, zy, zz
        else:
            vx, vy, vz = zx, zy, zz
            wx, wy, wz = 0.0, 0.0, 0.0
        # R_a^T v, R_a^T w
        jp0 = Ta[0, 0] * vx + Ta[1, 0] * vy + Ta[2, 0] * vz
        jp1 = Ta[0, 1] * vx + Ta[1, 1] * vy + Ta[2, 1] * vz
        jp2 = Ta[0, 2] * vx + Ta[1, 2] * vy + Ta[2, 2] * vz
        w0 = Ta[0, 0] * wx + Ta[1, 0] * wy + Ta[2, 0] * wz
        w1 = Ta[0, 1] * wx + Ta[1, 1] * wy + Ta[2, 1] * wz
        w2 = Ta[0, 2] * wx + Ta[1, 2] * wy + Ta[2, 2] * wz
        J[0, j], J[1, j], J[2, j] = jp0, jp1, jp2
        # de = 1/2 (e0 I - [e]x) w
        J[3, j] = 0.5 * (e0 * w0 - (e2 * w2 - e3 * w1))
        J[4, j] = 0.5 * (e0 * w1 - (e3 * w0 - e1 * w2))
        J[5, j] = 0.5 * (e0 * w2 - (e1 * w1 - e2 * w0))


@_njit
def lstsq_solve(A, B, X):
    """X (n, r) = A^+ B for A (k, n) of full column rank, B (k, r): LU with partial pivoting
    when square, normal equations (Cholesky) when tall. Returns False when A is numerically
    rank deficient (a pivot below 1e-13 of the largest)."""
    k, n = A.shape
    r = B.shape[1]
    if k == n:
        M = A.copy()
        Y = B.copy()
        big = 0.0
        for i in range(n):
            for t in range(n):
                big = max(big, abs(M[i, t]))
        for c in range(n):
            piv = c
            for i in range(c + 1, n):
                if abs(M[i, c]) > abs(M[piv, c]):
                    piv = i
            if abs(M[piv, c]) <= 1e-13 * big:
                return False
            if piv != c:
                for t in range(n):
                    M[c, t], M[piv, t] = M[piv, t], M[c, t]
                for t in range(r):
                    Y[c, t], Y[piv, t] = Y[piv, t], Y[c, t]
            for i in range(c + 1, n):
                fct = M[i, c] / M[c, c]
                if fct != 0.0:
                    for t in range(c, n):
                        M[i, t] -= fct * M[c, t]
                    for t in range(r):
                        Y[i, t] -= fct * Y[c, t]
        for t in range(r):
            for i in range(n - 1, -1, -1):
                acc = Y[i, t]
                for u in range(i + 1, n):
                    acc -= M[i, u] * X[u, t]
                X[i, t] = acc / M[i, i]
        return True
    N = np.zeros((n, n))
    for a in range(n):
        for b in range(a, n):
            acc = 0.0
            for i in range(k):
                acc += A[i, a] * A[i, b]
            N[a, b] = acc
            N[b, a] = acc
    dmax = 0.0
    for a in range(n):
        dmax = max(dmax, N[a, a])
    rhs = np.empty(n)
    out = np.empty(n)
    L = np.empty((n, n))
    for t in range(r):
        for a in range(n):
            acc = 0.0
            for i in range(k):
                acc += A[i, a] * B[i, t]
            rhs[a] = acc
        for a in range(n):
            for b in range(n):
                L[a, b] = N[a, b]
        cholesky_solve(L, rhs, out)
        for a in range(n):
            if L[a, a] * L[a, a] <= 1e-26 * dmax:
                return False
            X[a, t] = out[a]
    return True


@_njit
def closure_eval(q, K, T, z, o, phi, Phi, Ta, Tb, x6, J6, jac):
    """phi_R (n_eq,) and d(phi_R)/dq (n_eq, n) at q (kim1995 Eq. (4)); T, z, o filled."""
    (order, jp, jc, Pc, Ps, Pd, P0, rev, az, ao, flink, foff, cut_a, cut_b, mask, sig) = K
    tree_fk(q, order, jp, jc, Pc, Ps, Pd, P0, rev, T)
    if jac:
        tree_axes(q, T, jp, az, ao, rev, z, o)
    e = 0
    for c in range(cut_a.size):
        frame_pose(T, flink[cut_a[c]], foff[cut_a[c]], Ta)
        frame_pose(T, flink[cut_b[c]], foff[cut_b[c]], Tb)
        rel_res_jac(Ta, Tb, sig[c], z, o, rev, x6, J6, jac)
        for comp in range(6):
            if mask[c, comp]:
                phi[e] = x6[comp]
                if jac:
                    for j in range(q.size):
                        Phi[e, j] = J6[comp, j]
                e += 1


@_njit
def solve_closure1(q, iv, iw, K, tol_phi, tol_dq, max_iter, T, z, o, phi, Phi, Ta, Tb, x6, J6):
    """Dependent joints q[iw] from q[iv] (in place) by Newton-Raphson (kim1995 §5.1), as
    mechkin.model.closure.solve_closure. True when converged; T, z, o, Phi are then those of
    the returned q."""
    nw = iw.size
    neq = phi.size
    rev = K[7]
    qw0 = np.empty(nw)
    for i in range(nw):
        qw0[i] = q[iw[i]]
    Pw = np.empty((neq, nw))
    rhs = np.empty((neq, 1))
    step = np.empty((nw, 1))
    prev_step = np.zeros(nw)
    prev_res = np.inf
    shrink = 1.0
    iters = 0
    ok = False
    while True:
        closure_eval(q, K, T, z, o, phi, Phi, Ta, Tb, x6, J6, True)
        nphi = 0.0
        for e in range(neq):
            nphi += phi[e] * phi[e]
        nphi = np.sqrt(nphi)
        if not np.isfinite(nphi):
            break
        if nphi > prev_res * (1.0 + 1e-9) and shrink > 1e-3 and nphi > 1e-13:
            # the last step raised ||phi||: retry it at half length
            shrink *= 0.5
            for i in range(nw):
                q[iw[i]] += 0.5 * prev_step[i]
                prev_step[i] *= 0.5
            iters += 1
            if iters >= max_iter:
                break
            continue
        for e in range(neq):
            rhs[e, 0] = phi[e]
            for i in range(nw):
                Pw[e, i] = Phi[e, iw[i]]
        if not lstsq_solve(Pw, rhs, step):
            break
        ndq = 0.0
        for i in range(nw):
            ndq += step[i, 0] * step[i, 0]
        ndq = np.sqrt(ndq)
        if nphi < tol_phi and (ndq < tol_dq or nphi < 1e-14):
            ok = True
            break
        if iters >= max_iter:
            break
        sc = min(1.0, 0.5 / max(ndq, 1e-300))  # trust region 0.5 (rad or m)
        prev_res = nphi
        shrink = 1.0
        for i in range(nw):
            prev_step[i] = step[i, 0] * sc
            q[iw[i]] -= prev_step[i]
        iters += 1
    for i in range(nw):  # the branch nearest the guess for revolute dependents
        j = iw[i]
        if rev[j]:
            q[j] -= 2.0 * np.pi * np.round((q[j] - qw0[i]) / (2.0 * np.pi))
    return ok


@_njit
def evaluate_closed(q, iv, iw, K, fe_link, fe_off, sigE, TP, tol_phi, tol_dq, max_iter,
                    x, Jr, S, W):
    """Closure at q (q[iv] given, q[iw] the guess; in place), then x (6,) of {E} relative to
    {P} = TP (kim1995 Eq. (8)), the reduced Jacobian Jr (6, n_v) (Eq. (10)) and
    S = (dphi/dq_w)^+ dphi/dq_v (n_w, n_v). W: workspace tuple. False when the closure fails."""
    T, z, o, phi, Phi, Ta, Tb, x6, J6, TE, Jq, Pw, Pv = W
    if not solve_closure1(q, iv, iw, K, tol_phi, tol_dq, max_iter, T, z, o, phi, Phi, Ta, Tb,
                          x6, J6):
        return False
    frame_pose(T, fe_link, fe_off, TE)
    rel_res_jac(TP, TE, sigE, z, o, K[7], x, Jq, True)
    nv, nw = iv.size, iw.size
    for e in range(phi.size):
        for i in range(nw):
            Pw[e, i] = Phi[e, iw[i]]
        for i in range(nv):
            Pv[e, i] = Phi[e, iv[i]]
    if not lstsq_solve(Pw, Pv, S):
        return False
    for a in range(6):
        for b in range(nv):
            acc = Jq[a, iv[b]]
            for i in range(nw):
                acc -= Jq[a, iw[i]] * S[i, b]
            Jr[a, b] = acc
    return True


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
def equation_count(mask):
    """Number of loop-closure equations: the kept components of every cut."""
    neq = 0
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
    neq = equation_count(K[14])
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
    neq = equation_count(K[14])
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
         fa.astype(np.int64), fb.astype(np.int64), np.ascontiguousarray(mask), sig)
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
