r"""Canonical geometric subproblems of inverse kinematics (Paden-Kahan 1-3, IK-Geo 4).

Every function solves one subproblem for one set of 3-vectors (tuples ``(x, y, z)`` of
floats, so that compiled code keeps them on the stack; unit axes ``k``; 3x3 matrices are
tuples of three rows) and is written as plain scalar code so that numba compiles it into
the chain solvers (:mod:`mechkin.solvers.ik.analytic.solve6r`); without numba the same code runs
as Python. ``R(k, theta)`` is the rotation by ``theta`` about the unit axis ``k`` (Rodrigues):

.. math:: R(k,\theta)\,p = p\cos\theta + (k\times p)\sin\theta + k\,(k\cdot p)(1-\cos\theta)

Subproblems with up to two solutions return ``(n, theta_a, theta_b)``: ``n`` in {0, 1, 2} the
number of solutions (``n = 1``: ``theta_b = theta_a``). A subproblem whose solution set is a
continuum (a vector on the rotation axis) returns ``default`` (the caller passes the guess of
that joint), so singular poses get a finite, documented answer and never NaN. Feasibility is
tested with a relative tolerance :data:`FEAS_TOL`: a cosine up to ``1 + FEAS_TOL`` is clamped
(the tangent case at the boundary of the workspace, reached only to round-off).

References
----------
Paden, B. (1986) "Kinematics and control of robot manipulators", PhD thesis, UC Berkeley,
ch. 3 (subproblems 1-3); Murray, Li & Sastry (1994) "A mathematical introduction to robotic
manipulation", §3.2.2-3.2.3 (Paden-Kahan subproblems 1-3: Eq. (3.36)-(3.42));
Elias & Wen (2022/2024) "IK-Geo: unified robot inverse kinematics using subproblem
decomposition", arXiv 2211.05737, §III Subproblems 1-4 (Eq. numbers of §III-A..D).
"""

from __future__ import annotations

import math

import numpy as np

from mechkin.solvers.ik.analytic.jit import jit

FEAS_TOL = 1e-9  # relative excess of a cosine (or squared length) clamped as round-off
DEGEN_TOL = 1e-12  # [m or 1] length below which a projection is a point (continuum)

Vec = tuple[float, float, float]
Mat = tuple[Vec, Vec, Vec]


@jit
def vec(a: np.ndarray) -> Vec:
    """The 3-vector a[0:3] as a tuple."""
    return (a[0], a[1], a[2])


@jit
def add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@jit
def sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@jit
def scale(s: float, a: Vec) -> Vec:
    return (s * a[0], s * a[1], s * a[2])


@jit
def cross(a: Vec, b: Vec) -> Vec:
    """a x b."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@jit
def dot(a: Vec, b: Vec) -> float:
    """a . b."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@jit
def norm(a: Vec) -> float:
    return math.sqrt(dot(a, a))


@jit
def rot(k: Vec, theta: float, p: Vec) -> Vec:
    """R(k, theta) p by Rodrigues' formula (Murray, Li & Sastry Eq. (2.14))."""
    c, s = math.cos(theta), math.sin(theta)
    kp = dot(k, p) * (1.0 - c)
    kx = cross(k, p)
    return (p[0] * c + kx[0] * s + k[0] * kp, p[1] * c + kx[1] * s + k[1] * kp,
            p[2] * c + kx[2] * s + k[2] * kp)


@jit
def rotmat(k: Vec, theta: float) -> Mat:
    """R(k, theta) (3 rows) (Murray, Li & Sastry Eq. (2.14))."""
    c, s = math.cos(theta), math.sin(theta)
    v = 1.0 - c
    x, y, z = k[0], k[1], k[2]
    return ((c + x * x * v, x * y * v - z * s, x * z * v + y * s),
            (y * x * v + z * s, c + y * y * v, y * z * v - x * s),
            (z * x * v - y * s, z * y * v + x * s, c + z * z * v))


@jit
def mat(a: np.ndarray) -> Mat:
    """The upper-left 3x3 of a as rows."""
    return ((a[0, 0], a[0, 1], a[0, 2]), (a[1, 0], a[1, 1], a[1, 2]),
            (a[2, 0], a[2, 1], a[2, 2]))


@jit
def mv(R: Mat, v: Vec) -> Vec:
    """R v."""
    return (dot(R[0], v), dot(R[1], v), dot(R[2], v))


@jit
def mtv(R: Mat, v: Vec) -> Vec:
    """R^T v."""
    return (R[0][0] * v[0] + R[1][0] * v[1] + R[2][0] * v[2],
            R[0][1] * v[0] + R[1][1] * v[1] + R[2][1] * v[2],
            R[0][2] * v[0] + R[1][2] * v[1] + R[2][2] * v[2])


@jit
def transpose(A: Mat) -> Mat:
    return ((A[0][0], A[1][0], A[2][0]), (A[0][1], A[1][1], A[2][1]),
            (A[0][2], A[1][2], A[2][2]))


@jit
def mm(A: Mat, B: Mat) -> Mat:
    """A B."""
    Bt = transpose(B)
    return ((dot(A[0], Bt[0]), dot(A[0], Bt[1]), dot(A[0], Bt[2])),
            (dot(A[1], Bt[0]), dot(A[1], Bt[1]), dot(A[1], Bt[2])),
            (dot(A[2], Bt[0]), dot(A[2], Bt[1]), dot(A[2], Bt[2])))


@jit
def mtm(A: Mat, B: Mat) -> Mat:
    """A^T B."""
    return mm(transpose(A), B)


@jit
def sp1(k: Vec, p1: Vec, p2: Vec, default: float) -> float:
    r"""Subproblem 1: theta with R(k, theta) p1 = p2.

    .. math:: \theta = \operatorname{atan2}\big(k\cdot(p_1'\times p_2'),\ p_1'\cdot p_2'\big),
              \quad p' = p - k(k\cdot p)

    (Paden-Kahan 1, Murray-Li-Sastry Eq. (3.37); IK-Geo §III-A, the least-squares solution when
    the lengths differ). ``default`` when p1' or p2' is a point (every theta fits).
    """
    u = sub(p1, scale(dot(k, p1), k))
    v = sub(p2, scale(dot(k, p2), k))
    if dot(u, u) < DEGEN_TOL * DEGEN_TOL or dot(v, v) < DEGEN_TOL * DEGEN_TOL:
        return default
    return math.atan2(dot(k, cross(u, v)), dot(u, v))


@jit
def sp4(h: Vec, k: Vec, p: Vec, d: float, default: float) -> tuple[int, float, float]:
    r"""Subproblem 4: theta with h^T R(k, theta) p = d.

    With A = h.(p - k(k.p)), B = h.(k x p), C = d - (h.k)(k.p):

    .. math:: A\cos\theta + B\sin\theta = C,\quad
              \theta = \operatorname{atan2}(B, A) \pm \arccos\frac{C}{\sqrt{A^2+B^2}}

    (IK-Geo §III-D, Subproblem 4). ``A = B = 0``: the continuum (``default``) when C = 0 to
    round-off, else no solution.
    """
    kp = dot(k, p)
    hk = dot(h, k)
    A = dot(h, p) - hk * kp
    B = dot(h, cross(k, p))
    C = d - hk * kp
    rho = math.sqrt(A * A + B * B)
    size = max(rho, abs(d), abs(hk * kp), 1.0)
    if rho < DEGEN_TOL * size:
        if abs(C) < FEAS_TOL * size:
            return 1, default, default
        return 0, default, default
    c = C / rho
    phi = math.atan2(B, A)
    if c > 1.0 + FEAS_TOL or c < -1.0 - FEAS_TOL:
        return 0, phi, phi
    if c >= 1.0:
        return 1, phi, phi
    if c <= -1.0:
        return 1, phi + math.pi, phi + math.pi
    g = math.acos(c)
    return 2, phi + g, phi - g


@jit
def sp3(k: Vec, p1: Vec, p2: Vec, delta: float, default: float) -> tuple[int, float, float]:
    r"""Subproblem 3: theta with ||R(k, theta) p1 - p2|| = delta.

    Squaring gives Subproblem 4 (IK-Geo §III-C):

    .. math:: -2\,p_2^T R(k,\theta)\,p_1 = \delta^2 - \|p_1\|^2 - \|p_2\|^2

    (Paden-Kahan 3, Murray-Li-Sastry Eq. (3.40)-(3.42)).
    """
    d = -0.5 * (delta * delta - dot(p1, p1) - dot(p2, p2))
    return sp4(p2, k, p1, d, default)


@jit
def sp2(k1: Vec, k2: Vec, p: Vec, q: Vec, default1: float, default2: float
        ) -> tuple[int, float, float, float, float]:
    r"""Subproblem 2: theta1, theta2 with R(k1, theta1) R(k2, theta2) p = q (k1 not parallel
    to k2), returning ``(n, theta1_a, theta2_a, theta1_b, theta2_b)``.

    The intermediate point c = R(k2, theta2) p = R(k1, -theta1) q is
    c = alpha k1 + beta k2 + gamma (k1 x k2) with

    .. math:: \alpha = \frac{(k_1\cdot k_2)(k_2\cdot p) - k_1\cdot q}{(k_1\cdot k_2)^2 - 1},\quad
              \beta = \frac{(k_1\cdot k_2)(k_1\cdot q) - k_2\cdot p}{(k_1\cdot k_2)^2 - 1},

    .. math:: \gamma^2 = \frac{\|p\|^2 - \alpha^2 - \beta^2 - 2\alpha\beta\,k_1\cdot k_2}
              {\|k_1\times k_2\|^2}

    then theta2 = SP1(k2, p, c), theta1 = SP1(k1, c, q) (Paden-Kahan 2, Murray-Li-Sastry
    Eq. (3.38)-(3.39); IK-Geo §III-B). gamma^2 < 0 beyond round-off: no solution. A c on k1
    (q along k1) leaves theta1 free: ``default1``.
    """
    k12 = dot(k1, k2)
    den = k12 * k12 - 1.0
    alpha = (k12 * dot(k2, p) - dot(k1, q)) / den
    beta = (k12 * dot(k1, q) - dot(k2, p)) / den
    kx = cross(k1, k2)
    nkx = dot(kx, kx)
    pp = dot(p, p)
    g2 = (pp - alpha * alpha - beta * beta - 2.0 * alpha * beta * k12) / nkx
    if g2 < -FEAS_TOL * max(pp, 1e-300) / nkx:
        return 0, default1, default2, default1, default2
    n = 2
    if g2 <= 0.0:
        g2 = 0.0
        n = 1
    gamma = math.sqrt(g2)
    base = add(scale(alpha, k1), scale(beta, k2))
    c = add(base, scale(gamma, kx))
    t2a = sp1(k2, p, c, default2)
    t1a = sp1(k1, c, q, default1)
    c = sub(base, scale(gamma, kx))
    t2b = sp1(k2, p, c, default2)
    t1b = sp1(k1, c, q, default1)
    return n, t1a, t2a, t1b, t2b
