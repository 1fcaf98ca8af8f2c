r"""Compiled tree kinematics and loop closure of one configuration (numba; used by tree_jit).

The loops of :mod:`mechkin.solvers.ik.tree_jit`'s closed-chain lm that evaluate one
configuration the way :mod:`mechkin.model` does: tree forward kinematics (kim1995 Eq. (2)) and
joint axes, frame poses, the residual x of {E} relative to {P} and its Jacobian (Eq. (8)), a
least-squares solve (LU for a square ``dphi/dq_w``, Cholesky of the normal equations for a tall
one), the loop closure phi_R(q_v, q_w) = 0 by Newton-Raphson (kim1995 §5.1; with a row per
joint coupling after the cuts' rows, as :mod:`mechkin.model.couplings`) and the evaluation
of a closed chain at one start (:func:`evaluate_closed`). Split out of ``tree_jit.py`` (issue
23: modules that fit in a head).

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
    """phi_R (n_eq,) and d(phi_R)/dq (n_eq, n) at q (kim1995 Eq. (4)), then one row per joint
    coupling (``q_j - m q_i - c``, as :mod:`mechkin.model.couplings`); T, z, o filled."""
    (order, jp, jc, Pc, Ps, Pd, P0, rev, az, ao, flink, foff, cut_a, cut_b, mask, sig,
     cp_j, cp_m, cp_mult, cp_off) = K
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
    # joint couplings q_j = m q_i + c: the rows after the cuts' (mechkin.model.couplings)
    for c in range(cp_j.size):
        phi[e] = q[cp_j[c]] - cp_mult[c] * q[cp_m[c]] - cp_off[c]
        if jac:
            for j in range(q.size):
                Phi[e, j] = 0.0
            Phi[e, cp_j[c]] += 1.0
            Phi[e, cp_m[c]] -= cp_mult[c]
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
