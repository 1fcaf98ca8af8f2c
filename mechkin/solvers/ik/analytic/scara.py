r"""4-DOF SCARA arms by subproblems, vectorised numpy: three revolute axes parallel to d and one
prismatic joint along d, in any order.

A translation along d commutes with rotations about axes parallel to d, so (product of
exponentials, :mod:`mechkin.solvers.ik.analytic.solve6r`) with G = T M^{-1}:

.. math:: G = \mathrm{Tr}(q_p k_p)\, e^{\hat\xi_a q_a} e^{\hat\xi_b q_b} e^{\hat\xi_c q_c}

* the prismatic joint from the d-component of the point x on axis c (rotations about axes
  parallel to d keep d^T x): ``q_p = d^T (G x - x) / d^T k_p``;
* q_b by Subproblem 3 (``||e^{xi_b q_b} x - p_a|| = ||y - p_a||``, y = G x - q_p k_p), up to two
  branches (elbow left / right), q_a by Subproblem 1;
* q_c from the rotation of G about d (Subproblem 1 on a vector normal to d):
  ``s_a q_a + s_b q_b + s_c q_c = theta`` with ``s_i = h_i^T d = +-1``.

A target outside the 4-DOF family (a tilt off d) has no solution: every branch fails the FK
verification. References: IK-Geo §III (Subproblems 1, 3, 4), arXiv 2211.05737; Murray, Li &
Sastry §3.3 (the SCARA example, Eq. (3.21)).

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; numpy only, plus the compiled finishing.
"""

from __future__ import annotations

import numpy as np


def _rot(k: np.ndarray, th: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(k, th) v for k (3,), th (...,), v (..., 3) (Rodrigues)."""
    c, s = np.cos(th)[..., None], np.sin(th)[..., None]
    return v * c + np.cross(k, v) * s + k * (v @ k)[..., None] * (1 - c)


def _sp1(k: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """Subproblem 1 (IK-Geo §III-A), vectorised: theta with R(k, theta) p1 = p2."""
    u = p1 - (p1 @ k)[..., None] * k
    v = p2 - (p2 @ k)[..., None] * k
    return np.arctan2(np.cross(u, v) @ k, np.sum(u * v, axis=-1))


def _sp3(k: np.ndarray, p1: np.ndarray, p2: np.ndarray, delta: np.ndarray
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Subproblem 3 by Subproblem 4 (IK-Geo §III-C, D), vectorised: theta with
    ||R(k, theta) p1 - p2|| = delta: (theta_a, theta_b, feasible)."""
    d = -0.5 * (delta**2 - np.sum(p1 * p1, -1) - np.sum(p2 * p2, -1))
    kp = p1 @ k
    hk = p2 @ k
    A = np.sum(p2 * p1, -1) - hk * kp
    B = np.sum(p2 * np.cross(k, p1), -1)
    C = d - hk * kp
    rho = np.hypot(A, B)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = C / rho
    ok = np.isfinite(c) & (np.abs(c) <= 1 + 1e-9)
    g = np.arccos(np.clip(c, -1, 1))
    phi = np.arctan2(B, A)
    return phi + g, phi - g, ok


def scara_branches(H: np.ndarray, P: np.ndarray, M: np.ndarray, prismatic: int,
                   Ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Both branches of targets Ts (m, 4, 4): q (m, 2, k) (chain order), count (m,) and the FK
    errors err (m, 2, 2) (position [m], orientation [rad]). ``prismatic`` -1: a planar 3R
    chain (three parallel revolute axes; k = 3)."""
    k = len(H)
    rev = [i for i in range(k) if i != prismatic]
    a, b, c = rev
    d = H[a]
    RG = Ts[:, :3, :3] @ M[:3, :3].T
    pG = Ts[:, :3, 3] - RG @ M[:3, 3]
    x = P[c]
    Gx = RG @ x + pG
    if prismatic >= 0:
        kp = H[prismatic]
        qp = (Gx - x) @ d / (kp @ d)
        y = Gx - qp[:, None] * kp
    else:
        y = Gx
    qb1, qb2, ok = _sp3(H[b], np.broadcast_to(x - P[b], y.shape),
                        np.broadcast_to(P[a] - P[b], y.shape), np.linalg.norm(y - P[a], axis=-1))
    v = np.cross(d, [1.0, 0, 0] if abs(d[0]) < 0.9 else [0, 1.0, 0])
    v /= np.linalg.norm(v)
    theta = _sp1(d, np.broadcast_to(v, y.shape), RG @ v)
    m = len(Ts)
    q = np.empty((m, 2, k))
    for j, qb in enumerate((qb1, qb2)):
        e = _rot(H[b], qb, np.broadcast_to(x - P[b], y.shape)) + P[b]
        qa = _sp1(H[a], e - P[a], y - P[a])
        q[:, j, a], q[:, j, b] = qa, qb
        if prismatic >= 0:
            q[:, j, prismatic] = qp
        q[:, j, c] = (H[c] @ d) * (theta - (H[a] @ d) * qa - (H[b] @ d) * qb)
    err = np.full((m, 2, 2), np.inf)
    for j in range(2):
        T = poe_fk(H, P, M, prismatic, q[:, j])
        err[:, j, 0] = np.linalg.norm(T[:, :3, 3] - Ts[:, :3, 3], axis=-1)
        err[:, j, 1] = np.linalg.norm(T[:, :3, :3] - Ts[:, :3, :3], axis=(1, 2)) / np.sqrt(2)
    err[~ok] = np.inf
    count = np.where(ok, 2, 0)
    return q, count, err


def poe_fk(H: np.ndarray, P: np.ndarray, M: np.ndarray, prismatic: int, q: np.ndarray
           ) -> np.ndarray:
    """T(q) (m, 4, 4) = prod e^{xi_i q_i} M for q (m, n), joint ``prismatic`` a translation."""
    m = len(q)
    T = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
    for i in range(q.shape[1]):
        E = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
        if i == prismatic:
            E[:, :3, 3] = q[:, i, None] * H[i]
        else:
            k = H[i]
            K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
            s, c = np.sin(q[:, i])[:, None, None], np.cos(q[:, i])[:, None, None]
            R = np.eye(3) + s * K + (1 - c) * (K @ K)
            E[:, :3, :3] = R
            E[:, :3, 3] = P[i] - R @ P[i]
        T = T @ E
    return T @ M


def point2r_branches(H: np.ndarray, P: np.ndarray, x0: np.ndarray, pts: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A planar 2R chain (parallel axes) putting its point x0 (at q = 0) on the points pts
    (m, 3): q2 by Subproblem 3 (the distance from axis 1), q1 by Subproblem 1. Returns q
    (m, 2, 2), count (m,) and the position errors err (m, 2, 2) (orientation column 0)."""
    m = len(pts)
    qb1, qb2, ok = _sp3(H[1], np.broadcast_to(x0 - P[1], pts.shape),
                        np.broadcast_to(P[0] - P[1], pts.shape),
                        np.linalg.norm(pts - P[0], axis=-1))
    q = np.empty((m, 2, 2))
    err = np.zeros((m, 2, 2))
    for j, qb in enumerate((qb1, qb2)):
        e = _rot(H[1], qb, np.broadcast_to(x0 - P[1], pts.shape)) + P[1]
        qa = _sp1(H[0], e - P[0], pts - P[0])
        q[:, j, 0], q[:, j, 1] = qa, qb
        reach = _rot(H[0], qa, e - P[0]) + P[0]
        err[:, j, 0] = np.linalg.norm(reach - pts, axis=-1)
    err[~ok] = np.inf
    return q, np.where(ok, 2, 0), err
