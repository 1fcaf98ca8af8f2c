r"""Independent closed forms of the bundled non-paper mechanisms, typed in for the tests.

DESIGN: nothing here imports mechkin. Each function restates the geometry of one file in
mechanisms/ (the constants below are copied from the file's comment, not read from it) and
solves its position kinematics by hand, so that the tests compare two derivations: the
general cut-link solver of mechkin (loop closure, lm) and the textbook closed form.

Five-bar (mechanisms/five_bar.yaml)
-----------------------------------
Base pivots A1 = (-d/2, 0), A2 = (d/2, 0), proximal links l1, distal links l2, meeting at the
tool point P, all in the plane z = 0; u(t) = (cos t, sin t). Elbows E_i = A_i + l1 u(q_i).

FK: P is the intersection of the circles |P - E1| = l2 and |P - E2| = l2. With
e = E2 - E1, c = |e|, the midpoint M = (E1 + E2)/2 and h = sqrt(l2^2 - c^2/4),
P = M + h n with n = e^perp / c = (-e_y, e_x)/c, i.e. the intersection on the left of
E1 -> E2 (the "upper" assembly mode of the file's home).

IK: for arm i, with r_i = P - A_i, rho = |r_i|, the triangle A_i E_i P gives the angle at
A_i between r_i and the proximal link: gamma = acos((rho^2 + l1^2 - l2^2) / (2 l1 rho)).
q1 = atan2(r_1) + gamma (left elbow out), q2 = atan2(r_2) - gamma (right elbow out).

3-RRR (mechanisms/planar_3rrr.yaml)
-----------------------------------
Base pivots B_i = R_b u(beta_i), beta_i = 90, 210, 330 deg; platform points
P_i = p + R(phi) c_i with c_i = r_p u(beta_i) in the platform frame; proximal l1, distal l2.
IK per leg (the same triangle as the five-bar): d_i = P_i - B_i,
q_i = atan2(d_i) + acos((|d_i|^2 + l1^2 - l2^2) / (2 l1 |d_i|)) (every elbow on the
same, counter-clockwise side). FK has no closed form in general (up to six assembly modes, a
sextic); the tests cross-check it numerically (three distance equations
|P_i - E_i(q_i)| = l2 solved by scipy) and by IK after FK.

Delta (mechanisms/delta.yaml, Clavel's Delta as a 3-RUU translational equivalent)
---------------------------------------------------------------------------------
Arm i at azimuth phi_i = 0, 120, 240 deg: e_r = (cos phi_i, sin phi_i, 0), z = (0, 0, 1).
Actuated axis at A_i = R e_r, along the tangent e_t = z x e_r; q_i is the upper arm's angle
below the horizontal: elbow E_i = A_i + L_a (cos q_i e_r - sin q_i z). The platform translates
only; its attachment (the forearm's lower end) is W_i = p + r e_r, and |W_i - E_i| = L_b.

FK (intersection of three spheres): with C_i = E_i - r e_i the sphere centres,
|p - C_i| = L_b. Subtracting sphere 1 from spheres 2, 3 gives two linear equations
2 (C_i - C_1) . p = |C_i|^2 - |C_1|^2 (i = 2, 3); their solution line is p = p0 + t w with
w = (C_2 - C_1) x (C_3 - C_1) and p0 the minimum-norm solution; substituting into sphere 1
gives t^2 |w|^2 + 2 t w.(p0 - C_1) + |p0 - C_1|^2 - L_b^2 = 0; the root with the lower z is
the Delta's working mode (platform below the base).

IK (the classic per-arm solution): D = p + (r - R) e_r is A_i -> W_i; |D - L_a (cos q e_r -
sin q z)|^2 = L_b^2 gives A cos q + B sin q = K with A = D.e_r, B = -D.z,
K = (|D|^2 + L_a^2 - L_b^2) / (2 L_a), so q = atan2(B, A) - acos(K / sqrt(A^2 + B^2)) for
the elbow-out branch (elbow outside the cylinder through A_i).

UR5 (mechanisms/ur5.yaml)
-------------------------
Standard D-H, T = prod_i Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i) with Universal Robots'
published UR5 values d = (0.089159, 0, 0, 0.10915, 0.09465, 0.0823),
a = (0, -0.425, -0.39225, 0, 0, 0), alpha = (pi/2, 0, 0, pi/2, -pi/2, 0).
"""

from __future__ import annotations

import numpy as np

# --- five-bar ---------------------------------------------------------------------------------
FB_D, FB_L1, FB_L2 = 0.2, 0.25, 0.35
FB_A = np.array([[-0.1, 0.0], [0.1, 0.0]])


def _u(t):
    t = np.asarray(t, float)
    return np.stack([np.cos(t), np.sin(t)], axis=-1)


def five_bar_fk(q):
    """Tool point P (m, 2) from the motor angles q (m, 2) [rad] (circle intersection)."""
    q = np.atleast_2d(q)
    E1 = FB_A[0] + FB_L1 * _u(q[:, 0])
    E2 = FB_A[1] + FB_L1 * _u(q[:, 1])
    e = E2 - E1
    c = np.linalg.norm(e, axis=-1, keepdims=True)
    h = np.sqrt(FB_L2**2 - c**2 / 4)
    n = np.stack([-e[:, 1], e[:, 0]], axis=-1) / c
    return (E1 + E2) / 2 + h * n


def _triangle_angle(rho, l1, l2):
    return np.arccos((rho**2 + l1**2 - l2**2) / (2 * l1 * rho))


def five_bar_ik(P):
    """Motor angles (m, 2) [rad] of the file's working mode from tool points P (m, 2)."""
    P = np.atleast_2d(P)
    r1, r2 = P - FB_A[0], P - FB_A[1]
    g1 = _triangle_angle(np.linalg.norm(r1, axis=-1), FB_L1, FB_L2)
    g2 = _triangle_angle(np.linalg.norm(r2, axis=-1), FB_L1, FB_L2)
    return np.stack([np.arctan2(r1[:, 1], r1[:, 0]) + g1,
                     np.arctan2(r2[:, 1], r2[:, 0]) - g2], axis=-1)


# --- 3-RRR ------------------------------------------------------------------------------------
RRR_RB, RRR_RP, RRR_L1, RRR_L2 = 0.5, 0.1, 0.3, 0.25
RRR_BETA = np.deg2rad([90.0, 210.0, 330.0])
RRR_B = RRR_RB * _u(RRR_BETA)
RRR_C = RRR_RP * _u(RRR_BETA)


def rrr_platform_points(x):
    """Platform points P_i (m, 3, 2) of poses x = (px, py, phi) (m, 3)."""
    x = np.atleast_2d(x)
    c, s = np.cos(x[:, 2]), np.sin(x[:, 2])
    R = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (m, 2, 2)
    return x[:, None, :2] + np.einsum("mij,kj->mki", R, RRR_C)


def rrr_ik(x):
    """Motor angles (m, 3) [rad] from platform poses x = (px, py, phi) (m, 3)."""
    d = rrr_platform_points(x) - RRR_B[None]
    rho = np.linalg.norm(d, axis=-1)
    return np.arctan2(d[..., 1], d[..., 0]) + _triangle_angle(rho, RRR_L1, RRR_L2)


def rrr_fk_numerical(q, x0):
    """Platform pose (3,) from motor angles q (3,) by scipy's root finder on the three distance
    equations |P_i(x) - E_i(q_i)|^2 = l2^2, started at x0."""
    from scipy.optimize import fsolve

    E = RRR_B + RRR_L1 * _u(q)

    def f(x):
        P = rrr_platform_points(x)[0]
        return np.sum((P - E) ** 2, axis=-1) - RRR_L2**2

    x = fsolve(f, x0, xtol=1e-13)
    assert np.abs(f(x)).max() < 1e-14, "no assembly found"
    return x


# --- Delta ------------------------------------------------------------------------------------
DELTA_R, DELTA_r, DELTA_LA, DELTA_LB = 0.2, 0.05, 0.3, 0.8
DELTA_PHI = np.deg2rad([0.0, 120.0, 240.0])
_ER = np.stack([np.cos(DELTA_PHI), np.sin(DELTA_PHI), np.zeros(3)], axis=-1)  # (3, 3) rows e_r
_Z = np.array([0.0, 0.0, 1.0])


def delta_elbows(q):
    """Elbow centres E_i (m, 3, 3) from the motor angles q (m, 3)."""
    q = np.atleast_2d(q)
    return (DELTA_R * _ER[None] + DELTA_LA * (np.cos(q)[..., None] * _ER[None]
                                                - np.sin(q)[..., None] * _Z))


def delta_fk(q):
    """Platform centre p (m, 3) from the motor angles q (m, 3): three spheres, lower root."""
    C = delta_elbows(q) - DELTA_r * _ER[None]  # sphere centres (m, 3, 3)
    out = []
    for Ck in C:
        M = 2 * np.array([Ck[1] - Ck[0], Ck[2] - Ck[0]])
        rhs = np.array([Ck[1] @ Ck[1] - Ck[0] @ Ck[0], Ck[2] @ Ck[2] - Ck[0] @ Ck[0]])
        p0 = np.linalg.lstsq(M, rhs, rcond=None)[0]  # minimum-norm point of the line
        w = np.cross(Ck[1] - Ck[0], Ck[2] - Ck[0])
        d0 = p0 - Ck[0]
        a, b, c = w @ w, 2 * w @ d0, d0 @ d0 - DELTA_LB**2
        disc = b * b - 4 * a * c
        assert disc >= 0, "outside the Delta's workspace"
        ts = np.array([(-b + np.sqrt(disc)) / (2 * a), (-b - np.sqrt(disc)) / (2 * a)])
        ps = p0[None] + ts[:, None] * w[None]
        out.append(ps[np.argmin(ps[:, 2])])
    return np.array(out)


def delta_ik(p):
    """Motor angles (m, 3) [rad] from platform centres p (m, 3), elbow-out branch."""
    p = np.atleast_2d(p)
    D = p[:, None, :] + (DELTA_r - DELTA_R) * _ER[None]  # (m, 3, 3)
    A = np.einsum("mkj,kj->mk", D, _ER)
    B = -D[..., 2]
    K = (np.sum(D * D, axis=-1) + DELTA_LA**2 - DELTA_LB**2) / (2 * DELTA_LA)
    return np.arctan2(B, A) - np.arccos(K / np.hypot(A, B))


# --- UR5 --------------------------------------------------------------------------------------
UR5_D = (0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823)
UR5_A = (0.0, -0.425, -0.39225, 0.0, 0.0, 0.0)
UR5_ALPHA = (np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0)


def _dh_standard(theta, d, a, alpha):
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct],
                     [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d],
                     [0.0, 0.0, 0.0, 1.0]])


def ur5_fk(q):
    """T_0_6 (4, 4) of the UR5 from q (6,) [rad]: the product of the six D-H matrices."""
    T = np.eye(4)
    for i in range(6):
        T = T @ _dh_standard(q[i], UR5_D[i], UR5_A[i], UR5_ALPHA[i])
    return T
