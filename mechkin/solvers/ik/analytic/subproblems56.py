r"""IK-Geo subproblems 5 and 6 (compiled), both reduced to one equation on the unit circle.

Subproblem 5 (three cones) and 6 (four cones) of Elias & Wen, IK-Geo (arXiv 2211.05737,
§III-E and §III-F) are both solved here through the same core: with
``x = (sin theta, cos theta)`` the rotation of a vector is affine in x (IK-Geo §III, the form
behind every subproblem):

.. math:: R(k,\theta)\,p = k k^T p + A\,x,\qquad A = [\,k\times p,\ -k\times(k\times p)\,]

so each subproblem is a linear system in the (sin, cos) pairs of two angles, one pair is
eliminated by a 2x2 solve and the unit-norm condition of the other leaves

.. math:: f(\theta) = \|u + V x(\theta)\|^2 - 1 = 0,

a trigonometric polynomial of degree 2 (at most 4 roots: IK-Geo's quartic; in SP6 it is the
intersection of two ellipses of IK-Geo §III-F, in SP5 the quartic in the height ``H`` of
§III-E). Its roots are found by the half-angle substitution on two bounded, overlapping
intervals (``t = tan(theta / 2)`` and ``s = cot(theta / 2)``, each in [-1.2, 1.2], so no root
is lost at infinity or at their common ends) as the real roots of a quartic, isolated between
the roots of its derivatives (each polynomial is monotone between them) and refined by
safeguarded Newton steps to round-off; a double root (tangency) is also kept at the critical
point where the polynomial vanishes to round-off (accurate to eps where the split pair of
roots is accurate to sqrt(eps); the caller's FK check and merging decide). An identically
vanishing f (a continuum of solutions: a degenerate circle, e.g. the wrist centre on the first
axis) returns ``default`` for the free angle, so singular
poses get a finite answer. Of the two eliminations the better-conditioned 2x2 block is used;
when both blocks are singular (both pairs of cones degenerate at once, a measure-zero set of
targets) no solution is returned.

Functions write their solutions into ``out`` (at least (8, 3)) and return how many.

References
----------
Elias, A. J., Wen, J. T. (2025) "IK-Geo: Unified robot inverse kinematics using subproblem
decomposition", Mechanism and Machine Theory; arXiv 2211.05737, §III-E (Subproblem 5:
p0 + R(k1, t1) p1 = R(k2, t2)(p2 + R(k3, t3) p3)) and §III-F (Subproblem 6:
h_i^T R(k_i, t) p_i sums).
"""

from __future__ import annotations

import math

import numpy as np

from mechkin.solvers.ik.analytic.jit import jit
from mechkin.solvers.ik.analytic.subproblems import Vec, cross, dot, scale, sp1

ZERO_TOL = 1e-11  # relative size of f (or of a polynomial) taken as zero (round-off)
COND_TOL = 1e-10  # normalised |det| below which a 2x2 block is singular
MAX_SOL = 8  # roots kept per call (4 generic; critical points added only at tangencies)
OVERLAP = 1.2  # |t| and |1/t| searched up to this: the two intervals overlap, so a root at
# theta = +-pi/2 (t = +-1, where round-off can put it just outside either) is not lost


@jit
def _poly(c: np.ndarray, n: int, t: float) -> tuple[float, float]:
    """(p(t), p'(t)) of p = sum c[i] t^i, degree n (Horner)."""
    p = c[n]
    dp = 0.0
    for i in range(n - 1, -1, -1):
        dp = dp * t + p
        p = p * t + c[i]
    return p, dp


@jit
def _bracketed(c: np.ndarray, n: int, a: float, b: float, fa: float) -> float:
    """The root of p (degree n) in [a, b], where p is monotone and changes sign:
    Newton steps kept inside the bracket, else bisection."""
    lo, hi, flo = a, b, fa
    x = 0.5 * (a + b)
    for _ in range(100):
        f, df = _poly(c, n, x)
        if f == 0.0:
            return x
        if (f > 0.0) == (flo > 0.0):
            lo, flo = x, f
        else:
            hi = x
        xn = x - f / df if df != 0.0 else 0.5 * (lo + hi)
        if not lo < xn < hi:
            xn = 0.5 * (lo + hi)
        if abs(xn - x) <= 1e-16 * (1.0 + abs(x)) or hi - lo <= 1e-16 * (1.0 + abs(x)):
            return xn
        x = xn
    return x


@jit
def _segment_roots(c: np.ndarray, n: int, brk: np.ndarray, nb: int, out: np.ndarray,
                   tangents: bool) -> int:
    """Roots of p (degree n) in [brk[0], brk[nb-1]], p monotone between consecutive breakpoints
    (sorted); ``tangents``: also interior breakpoints (critical points) where p vanishes to
    round-off: a double root, which round-off either lifts off zero or splits into two close
    roots known only to ~sqrt(eps), while the critical point is known to ~eps. Writes sorted
    roots into out; returns the count."""
    k = 0
    fa, _ = _poly(c, n, brk[0])
    if fa == 0.0:
        out[k] = brk[0]
        k += 1
    for i in range(nb - 1):
        a, b = brk[i], brk[i + 1]
        fb, _ = _poly(c, n, b)
        if fa != 0.0 and fb != 0.0 and (fa > 0.0) != (fb > 0.0):
            out[k] = _bracketed(c, n, a, b, fa)
            k += 1
        elif fb == 0.0:
            out[k] = b
            k += 1
        elif tangents and 0 < i + 1 < nb - 1:
            mag = 0.0  # the coefficients' size: c[0] is a difference of larger terms
            for j in range(n + 1):
                mag += abs(c[j]) * max(1.0, abs(b)) ** j
            if abs(fb) <= ZERO_TOL * mag:
                out[k] = b  # also beside a split pair: its value is the accurate one
                k += 1
        fa = fb
    return k


@jit
def quartic_roots_pm1(c: np.ndarray, out: np.ndarray, L: float = 1.0) -> int:
    """Real roots in [-L, L] of c[0] + c[1] t + ... + c[4] t^4 (any leading coefficients,
    also zero), sorted, into out (>= 8); returns the count. Each derivative's roots bound the
    monotone pieces of the one above it (p''' linear, p'', p', p)."""
    d = np.empty((4, 5))
    for i in range(5):
        d[0, i] = c[i]
    for lev in range(1, 4):  # derivatives: d[lev] has degree 4 - lev
        for i in range(5 - lev):
            d[lev, i] = (i + 1) * d[lev - 1, i + 1]
    brk = np.empty(8)
    roots = np.empty(8)
    brk[0], brk[1] = -L, L
    nb = 2
    for lev in range(3, -1, -1):
        n = 4 - lev
        k = _segment_roots(d[lev], n, brk, nb, roots, lev == 0)
        if lev == 0:
            m = 0
            for i in range(k):
                if m == 0 or roots[i] - out[m - 1] > 1e-12:
                    out[m] = roots[i]
                    m += 1
            return m
        nb = 0
        brk[nb] = -L
        nb += 1
        for i in range(k):
            if -L < roots[i] < L and roots[i] > brk[nb - 1]:
                brk[nb] = roots[i]
                nb += 1
        brk[nb] = L
        nb += 1
    return 0


@jit
def unit_circle_roots(u0: float, u1: float, v00: float, v01: float, v10: float, v11: float,
                      default: float, out: np.ndarray) -> int:
    r"""Every theta with ||u + V x(theta)|| = 1, x = (sin theta, cos theta), u (2,), V (2, 2)
    given by entries; into out (>= 8), returns the count. With W = V^T V, w = V^T u,
    e = u^T u - 1 and t = tan(theta / 2), (1 + t^2)^2 f is the quartic

    .. math:: (W_{22} - 2w_2 + e)t^4 + 4(w_1 - W_{12})t^3 + (4W_{11} - 2W_{22} + 2e)t^2
              + 4(W_{12} + w_1)t + (W_{22} + 2w_2 + e)

    solved for |t| <= :data:`OVERLAP` and, reversed, for s = 1/t with |s| <= OVERLAP (roots
    found twice are merged). f identically zero to
    round-off: one solution, ``default``."""
    W11 = v00 * v00 + v10 * v10
    W12 = v00 * v01 + v10 * v11
    W22 = v01 * v01 + v11 * v11
    w1 = v00 * u0 + v10 * u1
    w2 = v01 * u0 + v11 * u1
    e = u0 * u0 + u1 * u1 - 1.0
    c = np.empty(5)
    c[4] = W22 - 2.0 * w2 + e
    c[3] = 4.0 * (w1 - W12)
    c[2] = 4.0 * W11 - 2.0 * W22 + 2.0 * e
    c[1] = 4.0 * (W12 + w1)
    c[0] = W22 + 2.0 * w2 + e
    size = 1.0 + u0 * u0 + u1 * u1 + W11 + W22
    big = 0.0
    for i in range(5):
        big = max(big, abs(c[i]))
    if big <= ZERO_TOL * size:
        out[0] = default
        return 1
    r = np.empty(8)
    k = quartic_roots_pm1(c, r, OVERLAP)
    n = 0
    for i in range(min(k, MAX_SOL)):
        out[n] = 2.0 * math.atan(r[i])
        n += 1
    rc = np.empty(5)
    for i in range(5):
        rc[i] = c[4 - i]
    k = quartic_roots_pm1(rc, r, OVERLAP)
    for i in range(k):
        th = 2.0 * math.atan2(1.0, r[i])
        dup = False
        for j in range(n):
            dd = (th - out[j] + math.pi) % (2.0 * math.pi) - math.pi
            if abs(dd) < 1e-9:
                dup = True
        if not dup and n < MAX_SOL:
            out[n] = th
            n += 1
    return n


@jit
def _affine(k: Vec, p: Vec) -> tuple[Vec, Vec, Vec]:
    """(k k^T p, k x p, -k x (k x p)): R(k, theta) p = first + sin theta second +
    cos theta third."""
    kp = cross(k, p)
    return scale(dot(k, p), k), kp, scale(-1.0, cross(k, kp))


@jit
def _ncond(A: np.ndarray, j: int) -> float:
    """|det| of the 2x2 block A[:, j:j+2] over the product of the norms of A's full rows
    (0: singular; a row that is round-off in this block but not in the other counts as
    singular here, however orthogonal its noise looks)."""
    r = math.sqrt((A[0, 0] ** 2 + A[0, 1] ** 2 + A[0, 2] ** 2 + A[0, 3] ** 2)
                  * (A[1, 0] ** 2 + A[1, 1] ** 2 + A[1, 2] ** 2 + A[1, 3] ** 2))
    return abs(A[0, j] * A[1, j + 1] - A[0, j + 1] * A[1, j]) / r if r > 0.0 else 0.0


@jit
def _eliminate(A: np.ndarray, b0: float, b1: float, free_first: bool, default: float,
               out: np.ndarray, sol: np.ndarray) -> int:
    """Solutions of A (2, 4) [x1; x2] = b with x1, x2 unit (sin, cos) pairs: the pair not
    eliminated is ``x1`` when ``free_first`` (x2 = B^{-1}(b - A_1 x1)), else ``x2``.
    Writes (theta_1, theta_2) rows into sol; returns the count."""
    if free_first:
        f0, g0 = 0, 2
    else:
        f0, g0 = 2, 0
    a00, a01, a10, a11 = A[0, g0], A[0, g0 + 1], A[1, g0], A[1, g0 + 1]
    det = a00 * a11 - a01 * a10
    i00, i01, i10, i11 = a11 / det, -a01 / det, -a10 / det, a00 / det
    u0 = i00 * b0 + i01 * b1
    u1 = i10 * b0 + i11 * b1
    v00 = -(i00 * A[0, f0] + i01 * A[1, f0])
    v01 = -(i00 * A[0, f0 + 1] + i01 * A[1, f0 + 1])
    v10 = -(i10 * A[0, f0] + i11 * A[1, f0])
    v11 = -(i10 * A[0, f0 + 1] + i11 * A[1, f0 + 1])
    n = unit_circle_roots(u0, u1, v00, v01, v10, v11, default, out)
    for i in range(n):
        th = out[i]
        s, c = math.sin(th), math.cos(th)
        y0 = u0 + v00 * s + v01 * c
        y1 = u1 + v10 * s + v11 * c
        other = math.atan2(y0, y1)
        if free_first:
            sol[i, 0], sol[i, 1] = th, other
        else:
            sol[i, 0], sol[i, 1] = other, th
    return n


@jit
def sp5(p0: Vec, p1: Vec, p2: Vec, p3: Vec, k1: Vec, k2: Vec, k3: Vec, default1: float,
        default2: float, default3: float, out: np.ndarray) -> int:
    r"""Subproblem 5 (IK-Geo §III-E, three cones): every (theta1, theta2, theta3) with

    .. math:: p_0 + R(k_1,\theta_1)\,p_1 = R(k_2,\theta_2)\,(p_2 + R(k_3,\theta_3)\,p_3)

    written into out rows (theta1, theta2, theta3); returns the count (up to 4; a tangency can
    add near-duplicates). With v1 = p0 + R1 p1 = c1 + A1 x1 and v3 = p2 + R3 p3 = c3 + A3 x3,
    R2 maps v3 to v1 iff k2^T v3 = k2^T v1 and ||v3||^2 = ||v1||^2; both are linear in x1 and
    x3 (||A x||^2 = ||k x p||^2 for unit x), so one pair is eliminated and the other solves
    ||u + V x|| = 1 (:func:`unit_circle_roots`, IK-Geo's quartic). theta2 by Subproblem 1
    (``default2`` when v1 lies on k2; a degenerate circle, p1 on k1 or p3 on k3, leaves its
    angle free: ``default1`` / ``default3``).
    """
    s1, a1, b1 = _affine(k1, p1)
    s3, a3, b3 = _affine(k3, p3)
    c1 = (p0[0] + s1[0], p0[1] + s1[1], p0[2] + s1[2])
    c3 = (p2[0] + s3[0], p2[1] + s3[1], p2[2] + s3[2])
    r1 = dot(a1, a1)
    r3 = dot(a3, a3)
    A = np.empty((2, 4))  # [height; squared norm] in [x1; x3]
    A[0, 0], A[0, 1] = -dot(k2, a1), -dot(k2, b1)
    A[0, 2], A[0, 3] = dot(k2, a3), dot(k2, b3)
    A[1, 0], A[1, 1] = -2.0 * dot(c1, a1), -2.0 * dot(c1, b1)
    A[1, 2], A[1, 3] = 2.0 * dot(c3, a3), 2.0 * dot(c3, b3)
    h0 = dot(k2, c1) - dot(k2, c3)
    h1 = dot(c1, c1) + r1 - dot(c3, c3) - r3
    q1 = _ncond(A, 0)
    q3 = _ncond(A, 2)
    th = np.empty(8)
    sol = np.empty((8, 2))
    if max(q1, q3) < COND_TOL:
        if r1 < 1e-24 * (1.0 + dot(c1, c1)) and r3 < 1e-24 * (1.0 + dot(c3, c3)):
            n = 1  # both circles are points: the one configuration, if any
            sol[0, 0], sol[0, 1] = default1, default3
        else:
            return 0
    else:
        n = _eliminate(A, h0, h1, q3 >= q1, default1 if q3 >= q1 else default3, th, sol)
    m = 0
    for i in range(n):
        t1, t3 = sol[i, 0], sol[i, 1]
        if r1 < 1e-24 * (1.0 + dot(c1, c1)):
            t1 = default1
        if r3 < 1e-24 * (1.0 + dot(c3, c3)):
            t3 = default3
        s, c = math.sin(t1), math.cos(t1)
        v1 = (c1[0] + s * a1[0] + c * b1[0], c1[1] + s * a1[1] + c * b1[1],
              c1[2] + s * a1[2] + c * b1[2])
        s, c = math.sin(t3), math.cos(t3)
        v3 = (c3[0] + s * a3[0] + c * b3[0], c3[1] + s * a3[1] + c * b3[1],
              c3[2] + s * a3[2] + c * b3[2])
        out[m, 0], out[m, 1], out[m, 2] = t1, sp1(k2, v3, v1, default2), t3
        m += 1
    return m


@jit
def sp6(h1: Vec, h2: Vec, h3: Vec, h4: Vec, k1: Vec, k2: Vec, k3: Vec, k4: Vec, p1: Vec,
        p2: Vec, p3: Vec, p4: Vec, d1: float, d2: float, default1: float, default2: float,
        out: np.ndarray) -> int:
    r"""Subproblem 6 (IK-Geo §III-F, four cones): every (theta1, theta2) with

    .. math:: h_1^T R(k_1,\theta_1) p_1 + h_2^T R(k_2,\theta_2) p_2 = d_1,\quad
              h_3^T R(k_3,\theta_1) p_3 + h_4^T R(k_4,\theta_2) p_4 = d_2

    written into out rows (theta1, theta2); returns the count (up to 4). Both equations are
    linear in x1 = (sin theta1, cos theta1) and x2; eliminating one pair leaves
    ||u + V x|| = 1 for the other (the two-ellipse intersection of IK-Geo, as a quartic on
    the circle: :func:`unit_circle_roots`).
    """
    sa, aa, ba = _affine(k1, p1)
    sb, ab, bb = _affine(k2, p2)
    sc, ac, bc = _affine(k3, p3)
    sd, ad, bd = _affine(k4, p4)
    A = np.empty((2, 4))
    A[0, 0], A[0, 1], A[0, 2], A[0, 3] = dot(h1, aa), dot(h1, ba), dot(h2, ab), dot(h2, bb)
    A[1, 0], A[1, 1], A[1, 2], A[1, 3] = dot(h3, ac), dot(h3, bc), dot(h4, ad), dot(h4, bd)
    b0 = d1 - dot(h1, sa) - dot(h2, sb)
    b1 = d2 - dot(h3, sc) - dot(h4, sd)
    q1 = _ncond(A, 0)
    q2 = _ncond(A, 2)
    if max(q1, q2) < COND_TOL:
        return 0
    th = np.empty(8)
    return _eliminate(A, b0, b1, q2 >= q1, default1 if q2 >= q1 else default2, th, out)


__all__ = ["quartic_roots_pm1", "sp5", "sp6", "unit_circle_roots"]

