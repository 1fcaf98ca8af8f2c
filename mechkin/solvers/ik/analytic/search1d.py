r"""6R arms whose last two axes meet, without a spherical wrist: a 1-D search (compiled).

IK-Geo's ``IK_2_intersecting`` (Elias & Wen, arXiv 2211.05737, §IV, Table "1D search"): h5
and h6 meet at o56, any other axes (e.g. two intersecting pairs, h1 meeting h2 and h5 meeting
h6, or a Franka Panda with one joint held; the reversed chain takes h1 meeting h2). With
``G = T M^{-1} = e^{xi_1 q_1} ... e^{xi_6 q_6}`` the point o56 is fixed by joints 5 and 6, so

.. math:: e^{\xi_1 q_1} e^{\xi_2 q_2} e^{\xi_3 q_3}\,(R(h_4, q_4)(o_{56} - p_4) + p_4)
          = G\,o_{56}

is, for each q4, IK-Geo's Subproblem 5 in (q1, q2, q3) (up to 4 branches,
:func:`mechkin.solvers.ik.analytic.subproblems56.sp5`). The orientation is reachable by joints
5 and 6 iff :math:`R_{46} = R_{04}^T R_G` keeps the angle between h5 and h6:

.. math:: e(q_4) = h_5^T R_{04}(q_4)^T R_G\,h_6 - h_5^T h_6 = 0

The search samples q4 on ``N`` points of the circle, tracks each branch from one sample to
the next (nearest (q1, q2, q3)), brackets every sign change of e, refines the bracket by the
Illinois method (regula falsi, the branch tracked), finishes (q5, q6) by Subproblem 1 and
polishes the six joints by damped Newton steps on the pose error (spatial Jacobian of the
product of exponentials) so that each solution is exact to round-off. A sampled search misses
double (tangent) roots and two roots of one branch closer than the grid: the list is not
proved complete (``complete: false``).

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy, math and the package's
subproblems; every function is compiled by :func:`mechkin.solvers.ik.analytic.jit.jit`.

References
----------
Elias & Wen, IK-Geo, arXiv 2211.05737, §III-E (Subproblem 5), §IV (1-D search classes), and
its reference code ``IK_2_intersecting.m`` / ``search_1D.m`` (rpiRobotics/ik-geo).
"""

from __future__ import annotations

import math

import numpy as np

from mechkin.solvers.ik.analytic.jit import jit
from mechkin.solvers.ik.analytic.solve6r import _inverse, fk_error
from mechkin.solvers.ik.analytic.subproblems import (
    Mat,
    Vec,
    add,
    cross,
    dot,
    mat,
    mm,
    mtm,
    mtv,
    mv,
    rot,
    rotmat,
    sp1,
    sub,
    vec,
)
from mechkin.solvers.ik.analytic.subproblems56 import sp5

SEARCH_INT56 = 0  # h5 meets h6: search over q4, (q1, q2, q3) by Subproblem 5
N_SAMPLES = 200  # grid points of the searched angle on the circle
REFINE = 4  # an odd count (a root missed, or a singular pose) is searched again, this finer
MAX_SOLUTIONS = 16  # a 6R arm has at most 16 solutions
NEWTON_STEPS = 8
MATCH_DIST = 0.5  # [rad] a branch moves less than this between samples, else it is lost
DIP_E = 0.05  # |e| below which a local minimum of |e| is examined (two close roots)
DOUBLE_E = 1e-7  # |e| at a local minimum taken as a (near-)double root
FOLD_E = 0.5  # |e| of the branches Newton starts from at a fold
TWO_PI = 2.0 * math.pi


@jit
def _wrap(d: float) -> float:
    return (d + math.pi) % TWO_PI - math.pi


@jit
def _branches(H: np.ndarray, P: np.ndarray, o: Vec, x: Vec, RG: Mat, q4: float,
              g: np.ndarray, out: np.ndarray) -> int:
    """Rows (q1, q2, q3, e) of every Subproblem-5 branch at q4 (module docstring) into out
    (8, 4); returns the count."""
    h1, h2, h3, h4 = vec(H[0]), vec(H[1]), vec(H[2]), vec(H[3])
    h5, h6 = vec(H[4]), vec(H[5])
    p1, p2, p3, p4 = vec(P[0]), vec(P[1]), vec(P[2]), vec(P[3])
    y = add(rot(h4, q4, sub(o, p4)), p4)
    s5 = np.empty((8, 3))
    # R1^T (x - p1) + p1 - p2 = R2 (p3 - p2 + R3 (y - p3))
    m = sp5(sub(p1, p2), sub(x, p1), sub(p3, p2), sub(y, p3), h1, h2, h3, -g[0], g[1], g[2],
            s5)
    v6 = mv(RG, h6)
    c56 = dot(h5, h6)
    for i in range(m):
        q1, q2, q3 = -s5[i, 0], s5[i, 1], s5[i, 2]
        R04 = mm(mm(mm(rotmat(h1, q1), rotmat(h2, q2)), rotmat(h3, q3)), rotmat(h4, q4))
        out[i, 0], out[i, 1], out[i, 2] = q1, q2, q3
        out[i, 3] = dot(mv(R04, h5), v6) - c56
    return m


@jit
def _nearest(B: np.ndarray, m: int, ref: np.ndarray) -> tuple[int, float]:
    """Row of B[:m] (q1, q2, q3, e) nearest ref (3,) (max-abs, modulo 2 pi), and the
    distance."""
    best, bd = -1, 1e300
    for i in range(m):
        d = max(abs(_wrap(B[i, 0] - ref[0])), abs(_wrap(B[i, 1] - ref[1])),
                abs(_wrap(B[i, 2] - ref[2])))
        if d < bd:
            best, bd = i, d
    return best, bd


@jit
def _finish56(H: np.ndarray, RG: Mat, q: np.ndarray, g: np.ndarray) -> None:
    """q5, q6 into q[4], q[5] from q1..q4 (Subproblem 1 on h6, then on h5)."""
    R04 = mm(mm(mm(rotmat(vec(H[0]), q[0]), rotmat(vec(H[1]), q[1])),
                rotmat(vec(H[2]), q[2])), rotmat(vec(H[3]), q[3]))
    R46 = mtm(R04, RG)  # = R(h5, q5) R(h6, q6)
    h5, h6 = vec(H[4]), vec(H[5])
    q[4] = sp1(h5, h6, mv(R46, h6), g[4])
    q[5] = sp1(h6, mtv(R46, h5), h5, g[5])


@jit
def _pose_error(H: np.ndarray, P: np.ndarray, M: np.ndarray, q: np.ndarray, T: np.ndarray,
                J: np.ndarray, r: np.ndarray) -> float:
    """Spatial Jacobian J (6, 6) of the product of exponentials at q and the error
    r = (log(R_T R(q)^T), p_T - p(q)) (6,); returns ||r||."""
    R = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    t = (0.0, 0.0, 0.0)
    W = np.empty((6, 3))
    C = np.empty((6, 3))
    for i in range(6):
        h, p = vec(H[i]), vec(P[i])
        w = mv(R, h)
        c = add(mv(R, p), t)
        for k in range(3):
            W[i, k], C[i, k] = w[k], c[k]
        Ri = rotmat(h, q[i])
        t = add(t, mv(R, sub(p, mv(Ri, p))))
        R = mm(R, Ri)
    RE = mm(R, mat(M))
    pE = add(mv(R, (M[0, 3], M[1, 3], M[2, 3])), t)
    RT = mat(T)
    E = ((dot(RT[0], RE[0]), dot(RT[0], RE[1]), dot(RT[0], RE[2])),  # R_T RE^T
         (dot(RT[1], RE[0]), dot(RT[1], RE[1]), dot(RT[1], RE[2])),
         (dot(RT[2], RE[0]), dot(RT[2], RE[1]), dot(RT[2], RE[2])))
    v = (0.5 * (E[2][1] - E[1][2]), 0.5 * (E[0][2] - E[2][0]), 0.5 * (E[1][0] - E[0][1]))
    s = math.sqrt(dot(v, v))
    c = 0.5 * (E[0][0] + E[1][1] + E[2][2] - 1.0)
    ang = math.atan2(s, c)
    f = ang / s if s > 1e-12 else 1.0
    for k in range(3):
        r[k] = f * v[k]
        r[3 + k] = T[k, 3] - pE[k]
    for i in range(6):
        w = (W[i, 0], W[i, 1], W[i, 2])
        lin = cross(w, sub(pE, (C[i, 0], C[i, 1], C[i, 2])))
        for k in range(3):
            J[k, i] = w[k]
            J[3 + k, i] = lin[k]
    return math.sqrt(dot((r[0], r[1], r[2]), (r[0], r[1], r[2]))
                     + dot((r[3], r[4], r[5]), (r[3], r[4], r[5])))


@jit
def polish(H: np.ndarray, P: np.ndarray, M: np.ndarray, q: np.ndarray, T: np.ndarray,
           steps: int) -> float:
    """Damped Newton steps on the pose error of the product of exponentials from q (6,)
    (changed in place); returns the final ||error||."""
    J = np.empty((6, 6))
    r = np.empty(6)
    e = _pose_error(H, P, M, q, T, J, r)
    for _ in range(steps):
        if e < 1e-15 or not math.isfinite(e):
            break
        A = J @ J.T
        lam = 1e-14 * (1.0 + np.trace(A))
        for k in range(6):
            A[k, k] += lam
        dq = J.T @ np.linalg.solve(A, r)
        Jn = np.empty((6, 6))
        rn = np.empty(6)
        step = 1.0
        better = False
        for _h in range(6):  # backtracking: halve the step until the error drops
            qn = q + step * dq
            en = _pose_error(H, P, M, qn, T, Jn, rn)
            if en < e:
                better = True
                break
            step *= 0.5
        if not better:
            break
        q[:] = qn
        J[:, :], r[:], e = Jn, rn, en
    return e


@jit
def _refine(H: np.ndarray, P: np.ndarray, o: Vec, x: Vec, RG: Mat, g: np.ndarray,
            a: float, ea: float, b: float, eb: float, ref: np.ndarray, q: np.ndarray) -> bool:
    """The root of the tracked branch's e in [a, b] (signs of ea, eb differ) by the Illinois
    method; its (q1..q4) into q[:4], the branch tracked from ref (3,). False when the branch is
    lost (no Subproblem-5 solution near the bracket)."""
    B = np.empty((8, 4))
    cur = ref.copy()
    side = 0
    c = a
    for _ in range(40):
        c = b - eb * (b - a) / (eb - ea) if eb != ea else 0.5 * (a + b)
        if not (min(a, b) <= c <= max(a, b)):
            c = 0.5 * (a + b)
        m = _branches(H, P, o, x, RG, c, g, B)
        k, dist = _nearest(B, m, cur)
        if k < 0:
            return False
        cur[0], cur[1], cur[2] = B[k, 0], B[k, 1], B[k, 2]
        ec = B[k, 3]
        if ec == 0.0 or abs(b - a) < 1e-13:
            break
        if (ec > 0.0) == (eb > 0.0):
            b, eb = c, ec
            if side == -1:
                ea *= 0.5
            side = -1
        else:
            a, ea = c, ec
            if side == 1:
                eb *= 0.5
            side = 1
        if abs(ec) < 1e-15:
            break
    q[0], q[1], q[2], q[3] = cur[0], cur[1], cur[2], c
    return True


@jit
def _keep(H: np.ndarray, P: np.ndarray, M: np.ndarray, RG: Mat, T: np.ndarray, g: np.ndarray,
          q: np.ndarray, size: float, steps: int, out: np.ndarray, n: int) -> int:
    """Finish (q5, q6) from q[:4], polish, and append q to out[:n] when it is exact and new;
    returns the new count."""
    _finish56(H, RG, q, g)
    err = polish(H, P, M, q, T, steps)
    if not err < 1e-12 * size:
        return n
    for k in range(6):
        q[k] = _wrap(q[k])
    for r in range(n):
        big = 0.0
        for k in range(6):
            big = max(big, abs(_wrap(q[k] - out[r, k])))
        if big < 1e-7:
            return n
    if n < out.shape[0]:
        out[n] = q
        n += 1
    return n


@jit
def _track(H: np.ndarray, P: np.ndarray, o: Vec, x: Vec, RG: Mat, g: np.ndarray, q4: float,
           ref: np.ndarray) -> float:
    """e of the branch nearest ref (3,) at q4 (ref moved to it); inf when there is none."""
    B = np.empty((8, 4))
    m = _branches(H, P, o, x, RG, q4, g, B)
    k, dist = _nearest(B, m, ref)
    if k < 0 or dist > MATCH_DIST:
        return math.inf
    ref[0], ref[1], ref[2] = B[k, 0], B[k, 1], B[k, 2]
    return B[k, 3]


@jit
def _dip(H: np.ndarray, P: np.ndarray, M: np.ndarray, o: Vec, x: Vec, RG: Mat,
         T: np.ndarray, g: np.ndarray, a: float, ea: float, b: float, eb: float,
         ref_a: np.ndarray, size: float, out: np.ndarray, n: int) -> int:
    """A branch with e of one sign at both ends of [a, b] (ea at a, the branch there ref_a
    (3,); eb at b) that comes close to zero in between: minimise |e| (golden section, the
    branch tracked); a crossing at the minimum gives two roots (two brackets), a touch (|e|
    at round-off) a double root. Appends what it finds (:func:`_keep`); returns the new
    count."""
    sg = 1.0 if ea > 0.0 else -1.0
    a0, b0 = a, b
    gr = 0.5 * (math.sqrt(5.0) - 1.0)
    c, d = b - gr * (b - a), a + gr * (b - a)
    rc, rd = ref_a.copy(), ref_a.copy()
    fc = sg * _track(H, P, o, x, RG, g, c, rc)
    fd = sg * _track(H, P, o, x, RG, g, d, rd)
    for _ in range(60):
        if fc < 0.0 or fd < 0.0 or abs(b - a) < 1e-12:
            break
        if fc < fd:
            b, d, fd, rd = d, c, fc, rc.copy()
            c = b - gr * (b - a)
            rc = rd.copy()
            fc = sg * _track(H, P, o, x, RG, g, c, rc)
        else:
            a, c, fc, rc = c, d, fd, rd.copy()
            d = a + gr * (b - a)
            rd = rc.copy()
            fd = sg * _track(H, P, o, x, RG, g, d, rd)
    tm, fm, rm = (c, fc, rc) if fc < fd else (d, fd, rd)
    q = np.empty(6)
    if not math.isfinite(fm):
        return n
    if fm < 0.0:  # two roots: one each side of the minimum
        r0 = ref_a.copy()
        if _refine(H, P, o, x, RG, g, a0, ea, tm, sg * fm, r0, q):
            n = _keep(H, P, M, RG, T, g, q, size, NEWTON_STEPS, out, n)
        r1 = rm.copy()
        if _refine(H, P, o, x, RG, g, tm, sg * fm, b0, eb, r1, q):
            n = _keep(H, P, M, RG, T, g, q, size, NEWTON_STEPS, out, n)
    elif fm < DOUBLE_E:  # a double root, or two roots too close to separate
        q[0], q[1], q[2], q[3] = rm[0], rm[1], rm[2], tm
        n = _keep(H, P, M, RG, T, g, q, size, 3 * NEWTON_STEPS, out, n)
    return n


@jit
def _fold(H: np.ndarray, P: np.ndarray, M: np.ndarray, o: Vec, x: Vec, RG: Mat,
          T: np.ndarray, g: np.ndarray, S: np.ndarray, cnt: np.ndarray, th: np.ndarray,
          s: int, size: float, out: np.ndarray, n: int) -> int:
    """Branches of Subproblem 5 die (or are born) between samples s and s + 1: bisect for the
    fold (where the count changes), then bracket each branch between its sample and the fold
    when e changes sign on the way (the two branches meet at the fold, so a root on the arc
    through it is on one of them). Appends what it finds; returns the new count."""
    B = np.empty((8, 4))
    die = cnt[s] > cnt[s + 1]
    full = max(cnt[s], cnt[s + 1])
    lo, hi = th[s], th[s + 1]
    for _ in range(45):
        mid = 0.5 * (lo + hi)
        k = _branches(H, P, o, x, RG, mid, g, B)
        if (k >= full) == die:
            lo = mid
        else:
            hi = mid
    tf = lo if die else hi
    side = s if die else s + 1
    mf = _branches(H, P, o, x, RG, tf, g, B)
    ref = np.empty(3)
    q = np.empty(6)
    for i in range(cnt[side]):
        for k in range(3):
            ref[k] = S[side, i, k]
        j, dist = _nearest(B, mf, ref)
        if j < 0:
            continue
        ea, ef = S[side, i, 3], B[j, 3]
        if (ea > 0.0) == (ef > 0.0) and ea != 0.0 and ef != 0.0:
            if abs(ea) < DIP_E:  # two roots between the sample and the fold?
                a, b, e0, e1 = (th[side], tf, ea, ef) if die else (tf, th[side], ef, ea)
                r0 = ref.copy()
                if not die:
                    for k in range(3):
                        r0[k] = B[j, k]
                n = _dip(H, P, M, o, x, RG, T, g, a, e0, b, e1, r0, size, out, n)
            continue
        if _refine(H, P, o, x, RG, g, th[side], ea, tf, ef, ref, q):
            n = _keep(H, P, M, RG, T, g, q, size, NEWTON_STEPS, out, n)
    return n


@jit
def search_int56(H: np.ndarray, P: np.ndarray, M: np.ndarray, o_: np.ndarray, T: np.ndarray,
                 g: np.ndarray, nsamp: int, out: np.ndarray) -> int:
    """Every solution the 1-D search finds for the target T (4, 4) of the chain (H, P, M)
    whose h5 and h6 meet at o (module docstring); guess g (6,) for continua. Writes
    out[:n] (16, 6), polished to round-off and distinct; returns n."""
    RG = mm(mat(T), ((M[0, 0], M[1, 0], M[2, 0]), (M[0, 1], M[1, 1], M[2, 1]),
                     (M[0, 2], M[1, 2], M[2, 2])))
    pG = sub((T[0, 3], T[1, 3], T[2, 3]), mv(RG, (M[0, 3], M[1, 3], M[2, 3])))
    o = vec(o_)
    x = add(mv(RG, o), pG)
    n = _pass(H, P, M, o, x, RG, T, g, nsamp, out, 0)
    if n % 2 == 1:  # real solutions come in even numbers except at singular poses: look closer
        n = _pass(H, P, M, o, x, RG, T, g, REFINE * nsamp, out, n)
    return n


@jit
def _pass(H: np.ndarray, P: np.ndarray, M: np.ndarray, o: Vec, x: Vec, RG: Mat,
          T: np.ndarray, g: np.ndarray, nsamp: int, out: np.ndarray, n: int) -> int:
    """One sweep of the search on nsamp samples, appending to out[:n]; returns the count."""
    S = np.empty((nsamp + 1, 8, 4))
    cnt = np.zeros(nsamp + 1, dtype=np.int64)
    th = np.empty(nsamp + 1)
    for s in range(nsamp):
        th[s] = -math.pi + TWO_PI * s / nsamp
        cnt[s] = _branches(H, P, o, x, RG, th[s], g, S[s])
    th[nsamp] = math.pi  # the first sample again, one turn on
    cnt[nsamp] = cnt[0]
    S[nsamp] = S[0]
    size = 1.0
    for i in range(6):
        size = max(size, abs(P[i, 0]), abs(P[i, 1]), abs(P[i, 2]))
    q = np.empty(6)
    ref = np.empty(3)
    hit = np.zeros(8, dtype=np.int64)
    ref2 = np.empty(3)
    for s in range(nsamp):
        # a fold of Subproblem 5 between the samples (branches born or dying) can hide a root
        # on the arc through it: Newton from every branch at both ends
        irregular = cnt[s] != cnt[s + 1]
        for j in range(cnt[s + 1]):
            hit[j] = 0
        for i in range(cnt[s]):
            ea = S[s, i, 3]
            for k in range(3):
                ref[k] = S[s, i, k]
            j, dist = _nearest(S[s + 1], cnt[s + 1], ref)
            if j < 0 or dist > MATCH_DIST:
                irregular = True
                continue
            hit[j] += 1
            eb = S[s + 1, j, 3]
            if (ea > 0.0) == (eb > 0.0) and ea != 0.0:
                if abs(eb) < abs(ea) and abs(eb) < DIP_E and s + 2 <= nsamp:
                    # a local minimum of |e| at s + 1 (the branch turns back by s + 2)?
                    for k in range(3):
                        ref2[k] = S[s + 1, j, k]
                    j2, dist2 = _nearest(S[s + 2], cnt[s + 2], ref2)
                    if j2 >= 0 and dist2 <= MATCH_DIST and abs(S[s + 2, j2, 3]) > abs(eb) \
                            and (S[s + 2, j2, 3] > 0.0) == (eb > 0.0):
                        n = _dip(H, P, M, o, x, RG, T, g, th[s], ea, th[s + 2],
                                 S[s + 2, j2, 3], ref, size, out, n)
                continue
            if not _refine(H, P, o, x, RG, g, th[s], ea, th[s + 1], eb, ref, q):
                continue
            n = _keep(H, P, M, RG, T, g, q, size, NEWTON_STEPS, out, n)
        for j in range(cnt[s + 1]):
            if hit[j] != 1:
                irregular = True
        if cnt[s] != cnt[s + 1]:
            n = _fold(H, P, M, o, x, RG, T, g, S, cnt, th, s, size, out, n)
        if irregular:
            for e in range(2):
                for i in range(cnt[s + e]):
                    if abs(S[s + e, i, 3]) > FOLD_E:
                        continue
                    q[0], q[1], q[2], q[3] = S[s + e, i, 0], S[s + e, i, 1], S[s + e, i, 2], \
                        th[s + e]
                    n = _keep(H, P, M, RG, T, g, q, size, 3 * NEWTON_STEPS, out, n)
    return n


@jit
def search_batch(H: np.ndarray, P: np.ndarray, M: np.ndarray, pt: np.ndarray,
                 Hf: np.ndarray, Pf: np.ndarray, Mf: np.ndarray, reverse: bool,
                 Ts: np.ndarray, G: np.ndarray, nsamp: int, out: np.ndarray,
                 count: np.ndarray, err: np.ndarray) -> None:
    """:func:`search_int56` for each target Ts (m, 4, 4), guesses G (m, 6) (chain order, base
    first); ``reverse``: (H, P, M) is the reversed chain, solved for T^{-1} (answers back in
    forward order). Each solution verified by the forward chain's FK (Hf, Pf, Mf). Writes
    out (m, 16, 6), count (m,), err (m, 16, 2) (position [m], orientation [rad] error)."""
    tmp = np.empty((MAX_SOLUTIONS, 6))
    g = np.empty(6)
    for r in range(Ts.shape[0]):
        T = Ts[r]
        if reverse:
            Tc = _inverse(T)
            for i in range(6):
                g[i] = G[r, 5 - i]
        else:
            Tc = T
            for i in range(6):
                g[i] = G[r, i]
        n = search_int56(H, P, M, pt, Tc, g, nsamp, tmp)
        for k in range(n):
            for i in range(6):
                out[r, k, i] = tmp[k, 5 - i] if reverse else tmp[k, i]
            pe, oe = fk_error(Hf, Pf, Mf, out[r, k], T, 0)
            err[r, k, 0], err[r, k, 1] = pe, oe
        count[r] = n


__all__ = ["MAX_SOLUTIONS", "N_SAMPLES", "SEARCH_INT56", "polish", "search_batch",
           "search_int56"]
