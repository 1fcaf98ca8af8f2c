r"""Every inverse-kinematics branch of decomposable 6R chains, by subproblems (compiled kernels).

A chain is given in product-of-exponentials form at its zero configuration: unit axes
``H (6, 3)``, a point on each axis ``P (6, 3)`` and the end pose ``M (4, 4)``, so that

.. math:: T(q) = e^{\hat\xi_1 q_1}\cdots e^{\hat\xi_6 q_6} M,\qquad
          e^{\hat\xi_i q_i}x = R(h_i, q_i)(x - p_i) + p_i

(Murray, Li & Sastry Eq. (3.3); IK-Geo §II). With ``G = T_target M^{-1} = e^{\xi_1 q_1}\cdots
e^{\xi_6 q_6}``:

* ``KIND_SPHERICAL`` (axes 4, 5, 6 meet at the wrist centre c, Pieper): ``G c`` depends on
  q1..q3 only. Position: ``POS_PAR23`` (h2 || h3: q1 by SP4 from h2^T e^{-xi_1 q_1} G c =
  h2^T c, q3 by SP3, q2 by SP1; PUMA 560 by this too, ABB, KUKA, Fanuc) or ``POS_INT12``
  (h1, h2 meet at o: q3 by SP3 from ||G c - o||, (q1, q2) by SP2) or ``POS_INT12_P`` (the
  same with joint 3 prismatic: q3 from a quadratic, a U-P-S leg). Orientation: (q4, q5) by
  SP2 on h6, q6 by SP1. Up to 8 branches (IK-Geo §IV-A, "spherical wrist"). Further
  position cases (EAIK's spherical classes): ``POS_PAR12`` (h1 || h2: q3 by SP4 from
  h1^T e^{xi_3 q_3} c = h1^T G c, q2 by SP3, q1 by SP1), ``POS_INT23`` (h2, h3 meet at o: q1
  by SP3 from ||e^{-xi_1 q_1} G c - o|| = ||c - o||, (q2, q3) by SP2) and ``POS_GENERAL``
  (no parallel or meeting axes among h1..h3: (q1, q2, q3) by IK-Geo's Subproblem 5,
  :mod:`mechkin.solvers.ik.analytic.subproblems56`).
* ``KIND_PAR234`` (h2 || h3 || h4 = d, h5 and h6 meet at o56; UR family): q1 by SP4 from
  d^T e^{-xi_1 q_1} G o56 = d^T o56; q5 by SP4 on h6 (R_{234} keeps d); q6 by SP1; the sum
  q2 + q3 + q4 by SP1 about d; q3 by SP3 and q2 by SP1 in the plane of the parallel axes.
  Up to 8 branches (IK-Geo §IV-B, "three parallel axes"). With h5, h6 skew
  (``PAR_GENERAL``, EAIK's "three inner parallel"), (q1, q5) by IK-Geo's Subproblem 6, the
  rest as above.

A chain whose structure sits at its base instead (spherical wrist at the base, 3-4-5
parallel) is solved as the reversed chain (:mod:`mechkin.solvers.ik.analytic.classify`).
Subproblem continua (singular poses: wrist q5 = 0, wrist centre on the first axis) take the
guess of the free joint, so the answer is finite and the sum that is determined is exact.

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy, math and its subproblems; every
function is compiled by :func:`mechkin.solvers.ik.analytic.jit.jit`.

References
----------
Elias & Wen, IK-Geo, arXiv 2211.05737, §IV (6R solutions by subproblem decomposition);
Pieper (1968) (spherical wrist); Murray, Li & Sastry (1994) §3.3.
"""

from __future__ import annotations

import math

import numpy as np

from mechkin.solvers.ik.analytic.jit import jit
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
    norm,
    rot,
    rotmat,
    scale,
    sp1,
    sp2,
    sp3,
    sp4,
    sub,
    vec,
)
from mechkin.solvers.ik.analytic.subproblems56 import sp5, sp6

KIND_SPHERICAL = 0
KIND_PAR234 = 1
KIND_SCARA = 2  # mechkin.solvers.ik.analytic.scara (numpy)
KIND_ARM5 = 3  # mechkin.solvers.ik.analytic.arm5r (numpy)
KIND_SEARCH = 4  # mechkin.solvers.ik.analytic.search1d (1-D search, not proved complete)
POS_PAR23 = 0
POS_INT12 = 1
POS_INT12_P = 2  # h1 meets h2 at o, joint 3 prismatic (a U-P-S leg)
POS_PAR12 = 3  # h1 || h2 (IK-Geo / EAIK "spherical, first two parallel")
POS_INT23 = 4  # h2 meets h3 at o (EAIK "spherical, second two intersecting")
POS_GENERAL = 5  # no parallel, no meeting axes among h1..h3: Subproblem 5
PAR_MEET56 = 0  # KIND_PAR234 with h5 meeting h6 at o56 (UR family)
PAR_GENERAL = 1  # KIND_PAR234 with h5, h6 skew: (q1, q5) by Subproblem 6
POS_PPP = 6  # joints 1-3 prismatic (a gantry): a 3x3 linear solve
POS_RPP = 7  # revolute, then two prismatic (a cylindrical arm)
POS_PRR_INT = 8  # prismatic, then two revolute meeting at o
POS_PRR_PAR = 9  # prismatic, then two parallel revolute
MAX_BRANCHES = 8
RAW_BRANCHES = 16  # raw candidates per pose before verification (tangencies add near-copies)


@jit
def _perp(h: Vec) -> Vec:
    """A unit vector perpendicular to the unit vector h."""
    ax, ay, az = abs(h[0]), abs(h[1]), abs(h[2])
    if ax <= ay and ax <= az:
        a = (1.0, 0.0, 0.0)
    elif ay <= az:
        a = (0.0, 1.0, 0.0)
    else:
        a = (0.0, 0.0, 1.0)
    v = cross(h, a)
    return scale(1.0 / norm(v), v)


@jit
def _move(h: Vec, p: Vec, theta: float, x: Vec) -> Vec:
    """e^{xi theta} x: rotation of the point x by theta about the axis (h, p)."""
    return add(rot(h, theta, sub(x, p)), p)


@jit
def _target_G(M: np.ndarray, T: np.ndarray) -> tuple[Mat, Vec]:
    """G = T M^{-1}: rotation (rows) and translation."""
    RT = mat(T)
    RG = mm(RT, ((M[0, 0], M[1, 0], M[2, 0]), (M[0, 1], M[1, 1], M[2, 1]),
                 (M[0, 2], M[1, 2], M[2, 2])))
    pG = sub((T[0, 3], T[1, 3], T[2, 3]), mv(RG, (M[0, 3], M[1, 3], M[2, 3])))
    return RG, pG


@jit
def _store(out: np.ndarray, n: int, q1: float, q2: float, q3: float, q4: float, q5: float,
           q6: float) -> int:
    if n >= out.shape[0]:
        return n
    out[n, 0], out[n, 1], out[n, 2] = q1, q2, q3
    out[n, 3], out[n, 4], out[n, 5] = q4, q5, q6
    return n + 1


@jit
def _wrist(h4: Vec, h5: Vec, h6: Vec, R03: Mat, RG: Mat, g: np.ndarray, q1: float,
           q2: float, q3: float, out: np.ndarray, n: int) -> int:
    """Append the (up to 2) wrist branches to out (q4, q5 by SP2 on h6, q6 by SP1);
    returns the new count."""
    R456 = mtm(R03, RG)
    m, a4, a5, b4, b5 = sp2(h4, h5, h6, mv(R456, h6), g[3], g[4])
    v = _perp(h6)
    Rv = mv(R456, v)
    for k in range(m):
        q4 = a4 if k == 0 else b4
        q5 = a5 if k == 0 else b5
        q6 = sp1(h6, v, rot(h5, -q5, rot(h4, -q4, Rv)), g[5])
        n = _store(out, n, q1, q2, q3, q4, q5, q6)
    return n


@jit
def solve_spherical(H: np.ndarray, P: np.ndarray, M: np.ndarray, pos_kind: int,
                    c_: np.ndarray, o_: np.ndarray, T: np.ndarray, g: np.ndarray,
                    out: np.ndarray) -> int:
    """Every branch of a 6R arm with a spherical wrist (wrist centre c; ``o`` the meeting
    point of h1 and h2 for POS_INT12) for the target T (4, 4); guess g (6,) for continua.
    Writes out[:n] (8, 6); returns n."""
    RG, pG = _target_G(M, T)
    c = vec(c_)
    ct = add(mv(RG, c), pG)
    h1, h2, h3 = vec(H[0]), vec(H[1]), vec(H[2])
    h4, h5, h6 = vec(H[3]), vec(H[4]), vec(H[5])
    p1, p2, p3 = vec(P[0]), vec(P[1]), vec(P[2])
    n = 0
    if pos_kind == POS_PAR23:
        m1, a, b = sp4(h2, h1, sub(ct, p1), dot(h2, sub(c, p1)), -g[0])
        for i1 in range(m1):
            phi = a if i1 == 0 else b
            q1 = -phi
            y = _move(h1, p1, phi, ct)
            m3, c3, d3 = sp3(h3, sub(c, p3), sub(p2, p3), norm(sub(y, p2)), g[2])
            for i3 in range(m3):
                q3 = c3 if i3 == 0 else d3
                e3c = _move(h3, p3, q3, c)
                q2 = sp1(h2, sub(e3c, p2), sub(y, p2), g[1])
                R03 = mm(mm(rotmat(h1, q1), rotmat(h2, q2)), rotmat(h3, q3))
                n = _wrist(h4, h5, h6, R03, RG, g, q1, q2, q3, out, n)
    elif pos_kind == POS_INT12_P:
        # ||c - o + q3 h3|| = ||c_t - o||: q3^2 + 2 (h3.(c - o)) q3 + ||c - o||^2 - delta^2 = 0
        o = vec(o_)
        w = sub(ct, o)
        c0 = sub(c, o)
        bq = dot(h3, c0)
        disc = bq * bq - (dot(c0, c0) - dot(w, w))
        scale_ = max(dot(w, w), dot(c0, c0), 1e-300)
        if disc >= -1e-12 * scale_:
            r = math.sqrt(max(disc, 0.0))
            for i3 in range(1 if r == 0.0 else 2):
                q3 = -bq + r if i3 == 0 else -bq - r
                v = add(c0, scale(q3, h3))
                m12, a1, a2, b1, b2 = sp2(h1, h2, v, w, g[0], g[1])
                for i12 in range(m12):
                    q1 = a1 if i12 == 0 else b1
                    q2 = a2 if i12 == 0 else b2
                    R03 = mm(rotmat(h1, q1), rotmat(h2, q2))
                    n = _wrist(h4, h5, h6, R03, RG, g, q1, q2, q3, out, n)
    elif pos_kind == POS_PPP:
        # c_t = c + q1 h1 + q2 h2 + q3 h3 (Cramer's rule)
        w = sub(ct, c)
        den = dot(h1, cross(h2, h3))
        q1 = dot(w, cross(h2, h3)) / den
        q2 = dot(h1, cross(w, h3)) / den
        q3 = dot(h1, cross(h2, w)) / den
        eye = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
        n = _wrist(h4, h5, h6, eye, RG, g, q1, q2, q3, out, n)
    elif pos_kind == POS_RPP:
        # R1^T (c_t - p1) + p1 - c = q2 h2 + q3 h3 lies in span(h2, h3): q1 by SP4 on
        # nn = h2 x h3, then (q2, q3) from the 2x2 normal equations
        nn = cross(h2, h3)
        m1, a, b = sp4(nn, h1, sub(ct, p1), dot(nn, sub(c, p1)), -g[0])
        g22, g23, g33 = dot(h2, h2), dot(h2, h3), dot(h3, h3)
        den = g22 * g33 - g23 * g23
        for i1 in range(m1):
            q1 = -(a if i1 == 0 else b)
            w = sub(_move(h1, p1, -q1, ct), c)
            r2, r3 = dot(h2, w), dot(h3, w)
            q2 = (g33 * r2 - g23 * r3) / den
            q3 = (g22 * r3 - g23 * r2) / den
            n = _wrist(h4, h5, h6, rotmat(h1, q1), RG, g, q1, q2, q3, out, n)
    elif pos_kind == POS_PRR_INT:
        # ||c_t - q1 h1 - o|| = ||c - o||: q1 from a quadratic, then (q2, q3) by SP2
        o = vec(o_)
        w = sub(ct, o)
        c0 = sub(c, o)
        bq = dot(h1, w)
        disc = bq * bq - (dot(w, w) - dot(c0, c0))
        if disc >= -1e-12 * max(dot(w, w), dot(c0, c0), 1e-300):
            r = math.sqrt(max(disc, 0.0))
            for i1 in range(1 if r == 0.0 else 2):
                q1 = bq + r if i1 == 0 else bq - r
                m23, a2, a3, b2, b3 = sp2(h2, h3, c0, sub(w, scale(q1, h1)), g[1], g[2])
                for i23 in range(m23):
                    q2 = a2 if i23 == 0 else b2
                    q3 = a3 if i23 == 0 else b3
                    R03 = mm(rotmat(h2, q2), rotmat(h3, q3))
                    n = _wrist(h4, h5, h6, R03, RG, g, q1, q2, q3, out, n)
    elif pos_kind == POS_PRR_PAR:
        # h2^T (c_t - q1 h1) = h2^T c (rotations about axes || h2 keep it): q1, then the
        # planar 2R: q3 by SP3, q2 by SP1
        q1 = dot(h2, sub(ct, c)) / dot(h2, h1)
        y = sub(ct, scale(q1, h1))
        m3, c3, d3 = sp3(h3, sub(c, p3), sub(p2, p3), norm(sub(y, p2)), g[2])
        for i3 in range(m3):
            q3 = c3 if i3 == 0 else d3
            y3 = _move(h3, p3, q3, c)
            q2 = sp1(h2, sub(y3, p2), sub(y, p2), g[1])
            R03 = mm(rotmat(h2, q2), rotmat(h3, q3))
            n = _wrist(h4, h5, h6, R03, RG, g, q1, q2, q3, out, n)
    elif pos_kind == POS_PAR12:
        # h1^T (e3 c) = h1^T c_t (rotations about axes || h1 keep it): q3 by SP4, then
        # ||e2 e3 c - p1|| = ||c_t - p1||: q2 by SP3, q1 by SP1
        m3, c3, d3 = sp4(h1, h3, sub(c, p3), dot(h1, sub(ct, p3)), g[2])
        for i3 in range(m3):
            q3 = c3 if i3 == 0 else d3
            y3 = _move(h3, p3, q3, c)
            m2, c2, d2 = sp3(h2, sub(y3, p2), sub(p1, p2), norm(sub(ct, p1)), g[1])
            for i2 in range(m2):
                q2 = c2 if i2 == 0 else d2
                y2 = _move(h2, p2, q2, y3)
                q1 = sp1(h1, sub(y2, p1), sub(ct, p1), g[0])
                R03 = mm(mm(rotmat(h1, q1), rotmat(h2, q2)), rotmat(h3, q3))
                n = _wrist(h4, h5, h6, R03, RG, g, q1, q2, q3, out, n)
    elif pos_kind == POS_INT23:
        # ||e1^{-1} c_t - o23|| = ||c - o23||: q1 by SP3, then (q2, q3) by SP2
        o = vec(o_)
        m1, a, b = sp3(h1, sub(ct, p1), sub(o, p1), norm(sub(c, o)), -g[0])
        for i1 in range(m1):
            q1 = -(a if i1 == 0 else b)
            w = sub(_move(h1, p1, -q1, ct), o)
            m23, a2, a3, b2, b3 = sp2(h2, h3, sub(c, o), w, g[1], g[2])
            for i23 in range(m23):
                q2 = a2 if i23 == 0 else b2
                q3 = a3 if i23 == 0 else b3
                R03 = mm(mm(rotmat(h1, q1), rotmat(h2, q2)), rotmat(h3, q3))
                n = _wrist(h4, h5, h6, R03, RG, g, q1, q2, q3, out, n)
    elif pos_kind == POS_GENERAL:
        # R1^T (c_t - p1) + p1 - p2 = R2 (p3 - p2 + R3 (c - p3)): Subproblem 5 (IK-Geo §IV)
        s5 = np.empty((8, 3))
        m = sp5(sub(p1, p2), sub(ct, p1), sub(p3, p2), sub(c, p3), h1, h2, h3, -g[0], g[1],
                g[2], s5)
        for i in range(m):
            q1, q2, q3 = -s5[i, 0], s5[i, 1], s5[i, 2]
            R03 = mm(mm(rotmat(h1, q1), rotmat(h2, q2)), rotmat(h3, q3))
            n = _wrist(h4, h5, h6, R03, RG, g, q1, q2, q3, out, n)
    else:
        o = vec(o_)
        w = sub(ct, o)
        m3, c3, d3 = sp3(h3, sub(c, p3), sub(o, p3), norm(w), g[2])
        for i3 in range(m3):
            q3 = c3 if i3 == 0 else d3
            v = sub(_move(h3, p3, q3, c), o)
            m12, a1, a2, b1, b2 = sp2(h1, h2, v, w, g[0], g[1])
            for i12 in range(m12):
                q1 = a1 if i12 == 0 else b1
                q2 = a2 if i12 == 0 else b2
                R03 = mm(mm(rotmat(h1, q1), rotmat(h2, q2)), rotmat(h3, q3))
                n = _wrist(h4, h5, h6, R03, RG, g, q1, q2, q3, out, n)
    return n


@jit
def _free_q6(h3: Vec, p2: Vec, p3: Vec, p4: Vec, p5: Vec, p6: Vec, h5: Vec, h6: Vec, h1: Vec,
             p1: Vec, q1: float, q5: float, RG: Mat, pG: Vec, guess: float) -> float:
    """q6 where h6 is parallel to h2 || h3 || h4 (q6 and q2 + q3 + q4 turn about parallel
    axes: a continuum): the guess when it leaves the elbow within reach, else the q6 nearest
    to it that puts the elbow distance ||y - p2|| on the nearest end of its range (SP4 on
    ||y(q6) - p2||^2, y = e^{-xi_1 q_1} G e^{-xi_6 q_6} e^{-xi_5 q_5} p4)."""
    u = sub(p4, p3)
    w = sub(p2, p3)
    uh, wh = dot(u, h3), dot(w, h3)
    up = math.sqrt(max(dot(u, u) - uh * uh, 0.0))
    wp = math.sqrt(max(dot(w, w) - wh * wh, 0.0))
    base = dot(u, u) + dot(w, w) - 2.0 * uh * wh
    lo, hi = base - 2.0 * up * wp, base + 2.0 * up * wp
    A = mtm(rotmat(h1, q1), RG)  # R1^T RG
    vv = sub(_move(h5, p5, -q5, p4), p6)
    b0 = add(mtv(rotmat(h1, q1), sub(add(mv(RG, p6), pG), p1)), sub(p1, p2))
    y0 = add(mv(A, rot(h6, -guess, vv)), b0)
    dg = dot(y0, y0)
    if lo <= dg <= hi:
        return guess
    target = lo if dg < lo else hi
    hh = mtv(A, b0)
    m, a, b = sp4(hh, h6, vv, 0.5 * (target - dot(vv, vv) - dot(b0, b0)), -guess)
    if m == 0:
        return guess
    da = abs((-a - guess + math.pi) % (2.0 * math.pi) - math.pi)
    db = abs((-b - guess + math.pi) % (2.0 * math.pi) - math.pi)
    return -a if da <= db else -b


@jit
def solve_par234(H: np.ndarray, P: np.ndarray, M: np.ndarray, pos_kind: int,
                 pt_: np.ndarray, T: np.ndarray, g: np.ndarray, out: np.ndarray) -> int:
    r"""Every branch of a 6R arm with h2 || h3 || h4 = d for the target T (4, 4): ``PAR_MEET56``
    (h5, h6 meet at pt = o56; UR family): q1 by SP4 from d^T e^{-xi_1 q_1} G o56 = d^T o56, q5
    by SP4; ``PAR_GENERAL`` (pt a point on h6): (q1, q5) by Subproblem 6 from

    .. math:: d^T R_1^T (G p_6 - p_1) - d^T R_5 (p_6 - p_5) = d^T (p_5 - p_1),\quad
              d^T R_1^T R_G h_6 - d^T R_5 h_6 = 0

    (rotations about axes || d keep d^T x; IK-Geo §IV "three parallel axes"). Then q6 and the
    sum q2 + q3 + q4 by SP1, q3 by SP3, q2 by SP1. Guess g (6,) for continua. Writes out[:n];
    returns n."""
    RG, pG = _target_G(M, T)
    h1, h2, h3 = vec(H[0]), vec(H[1]), vec(H[2])
    h4, h5, h6 = vec(H[3]), vec(H[4]), vec(H[5])
    p1, p2, p3 = vec(P[0]), vec(P[1]), vec(P[2])
    p4, p5, p6 = vec(P[3]), vec(P[4]), vec(P[5])
    pt = vec(pt_)
    d = h2
    s3, s4 = dot(h3, d), dot(h4, d)
    x = add(mv(RG, pt), pG)
    v = _perp(d)
    n = 0
    q15 = np.empty((8, 2))
    k = 0
    if pos_kind == PAR_GENERAL:
        k = sp6(d, d, d, d, h1, h5, h1, h5, sub(x, p1), sub(p5, pt), mv(RG, h6),
                scale(-1.0, h6), dot(d, sub(p5, p1)), 0.0, -g[0], g[4], q15)
        for i in range(k):
            q15[i, 0] = -q15[i, 0]
    else:
        m1, a, b = sp4(d, h1, sub(x, p1), dot(d, sub(pt, p1)), -g[0])
        for i1 in range(m1):
            q1 = -(a if i1 == 0 else b)
            vd = mtv(mtm(rotmat(h1, q1), RG), d)
            m5, c5, d5 = sp4(h6, h5, d, dot(h6, vd), -g[4])
            for i5 in range(m5):
                q15[k, 0], q15[k, 1] = q1, -(c5 if i5 == 0 else d5)
                k += 1
    for i in range(k):
        q1, q5 = q15[i, 0], q15[i, 1]
        Rr = mtm(rotmat(h1, q1), RG)  # R_234 R_5 R_6
        vd = mtv(Rr, d)
        q6 = sp1(h6, vd, rot(h5, -q5, d), g[5])
        if norm(cross(h6, vd)) < 1e-9:  # h6 turned parallel to d: q6 is free
            q6 = _free_q6(h3, p2, p3, p4, p5, p6, h5, h6, h1, p1, q1, q5, RG, pG, g[5])
        w = mv(Rr, rot(h6, -q6, rot(h5, -q5, v)))  # R_234 v
        th = sp1(d, v, w, g[1] + s3 * g[2] + s4 * g[3])
        z = _move(h6, p6, -q6, _move(h5, p5, -q5, p4))
        y = _move(h1, p1, -q1, add(mv(RG, z), pG))
        m3, c3, d3 = sp3(h3, sub(p4, p3), sub(p2, p3), norm(sub(y, p2)), g[2])
        for i3 in range(m3):
            q3 = c3 if i3 == 0 else d3
            e3 = _move(h3, p3, q3, p4)
            q2 = sp1(h2, sub(e3, p2), sub(y, p2), g[1])
            n = _store(out, n, q1, q2, q3, s4 * (th - q2 - s3 * q3), q5, q6)
    return n


@jit
def pris_bits(kind: int, pos_kind: int) -> int:
    """Bit i set when chain joint i is prismatic (the spherical-wrist position cases)."""
    if kind != KIND_SPHERICAL:
        return 0
    if pos_kind == POS_INT12_P:
        return 4
    if pos_kind == POS_PPP:
        return 7
    if pos_kind == POS_RPP:
        return 6
    if pos_kind >= POS_PRR_INT:  # POS_PRR_INT, POS_PRR_PAR
        return 1
    return 0


@jit
def fk_error(H: np.ndarray, P: np.ndarray, M: np.ndarray, q: np.ndarray, T: np.ndarray,
             pris: int = 0) -> tuple[float, float]:
    """Position [m] and rotation-angle [rad] error of T(q) = prod e^{xi_i q_i} M (Murray, Li &
    Sastry Eq. (3.3)) from the target T (4, 4); joint i with bit i of ``pris`` set is a
    translation along its h (:func:`pris_bits`)."""
    R = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    t = (0.0, 0.0, 0.0)
    for i in range(q.size):
        if (pris >> i) & 1:
            t = add(t, mv(R, scale(q[i], vec(H[i]))))
            continue
        Ri = rotmat(vec(H[i]), q[i])
        p = vec(P[i])
        t = add(t, mv(R, sub(p, mv(Ri, p))))
        R = mm(R, Ri)
    RE = mm(R, mat(M))
    pE = add(mv(R, (M[0, 3], M[1, 3], M[2, 3])), t)
    e = sub(pE, (T[0, 3], T[1, 3], T[2, 3]))
    fro = 0.0
    tr = 0.0
    for i in range(3):
        for j in range(3):
            dd = RE[i][j] - T[i, j]
            fro += dd * dd
            tr += RE[i][j] * T[i, j]
    c = 0.5 * (tr - 1.0)
    # acos loses precision near 0: the Frobenius distance is 2 sqrt(2) sin(angle / 2)
    if c > 0.0:
        ang = 2.0 * math.asin(min(1.0, math.sqrt(fro) / (2.0 * math.sqrt(2.0))))
    else:
        ang = math.acos(max(-1.0, c))
    return norm(e), ang


@jit
def _inverse(T: np.ndarray) -> np.ndarray:
    """T^{-1} of a rigid transform (4, 4)."""
    Ti = np.eye(4)
    for i in range(3):
        for j in range(3):
            Ti[i, j] = T[j, i]
    for i in range(3):
        Ti[i, 3] = -(T[0, i] * T[0, 3] + T[1, i] * T[1, 3] + T[2, i] * T[2, 3])
    return Ti


@jit
def solve_batch(kind: int, pos_kind: int, reverse: bool, H: np.ndarray, P: np.ndarray,
                M: np.ndarray, pt: np.ndarray, pt2: np.ndarray, Hf: np.ndarray,
                Pf: np.ndarray, Mf: np.ndarray, Ts: np.ndarray, G: np.ndarray,
                out: np.ndarray, count: np.ndarray, err: np.ndarray) -> None:
    """Every branch for each target Ts (m, 4, 4), guesses G (m, 6) (chain order, base first).

    (H, P, M) is the chain the solver takes (``reverse``: the reversed chain, solved for
    T^{-1} with the guess and the answer in reversed order); (Hf, Pf, Mf) the forward chain,
    by whose FK each branch is verified. Writes out (m, 8, 6) (chain order), count (m,), err
    (m, 8, 2) (position [m] and orientation [rad] error of each branch).
    """
    tmp = np.empty((RAW_BRANCHES, 6))
    raw = np.empty((RAW_BRANCHES, 6))
    e = np.empty((RAW_BRANCHES, 2))
    used = np.zeros(RAW_BRANCHES, dtype=np.bool_)
    g = np.empty(6)
    pris = pris_bits(kind, pos_kind)
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
        if kind == KIND_SPHERICAL:
            n = solve_spherical(H, P, M, pos_kind, pt, pt2, Tc, g, tmp)
        else:
            n = solve_par234(H, P, M, pos_kind, pt, Tc, g, tmp)
        for k in range(n):
            for i in range(6):
                raw[k, i] = tmp[k, 5 - i] if reverse else tmp[k, i]
            pe, oe = fk_error(Hf, Pf, Mf, raw[k], T, pris)
            e[k, 0], e[k, 1] = pe, oe
        # keep the (at most 8) most accurate branches: exact ones (~1e-15) before the
        # near-copies a tangency can add
        cnt = 0
        for k in range(n):
            used[k] = False
        while cnt < min(n, MAX_BRANCHES):
            best = -1
            for k in range(n):
                if not used[k] and (best < 0 or e[k, 0] + e[k, 1] < e[best, 0] + e[best, 1]):
                    best = k
            used[best] = True
            for i in range(6):
                out[r, cnt, i] = raw[best, i]
            err[r, cnt, 0], err[r, cnt, 1] = e[best, 0], e[best, 1]
            cnt += 1
        count[r] = cnt
