r"""5R arms with three parallel axes (h2 || h3 || h4 = d; h1 and h5 not parallel to d), by
subproblems, vectorised numpy (a 5-DOF arm reaches a 5-D family of poses).

With G = T M^{-1} = e^{xi_1 q_1} ... e^{xi_5 q_5} (product of exponentials,
:mod:`mechkin.solvers.ik.analytic.solve6r`): the rotation R_234 keeps d, so

.. math:: R(h_1, -q_1)\, R(R_G h_5, -q_5)\, (R_G d) = d

is Subproblem 2 in (-q1, -q5) (IK-Geo §III-B; up to 2 branches). Then the point p5 on axis 5
is fixed by e^{xi_5 q_5}: ``y5 = e^{-xi_1 q_1} G p5`` is its image under the planar motion
e^{xi_2 q_2} e^{xi_3 q_3} e^{xi_4 q_4}, whose rotation angle theta about d follows from
R_234 (Subproblem 1); the image of p4 is ``y4 = y5 + R(d, theta)(p4 - p5)``, so q3 by
Subproblem 3 and q2 by Subproblem 1, as in the three-parallel 6R arms, and q4 from theta.
Up to 4 branches. A target outside the 5-D family fails the FK verification (no solution).

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; numpy only.
"""

from __future__ import annotations

import numpy as np

from mechkin.solvers.ik.analytic.scara import _rot, _sp1, _sp3, poe_fk


def _sp2(k1: np.ndarray, k2: np.ndarray, p: np.ndarray, q: np.ndarray
         ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Subproblem 2 (Paden-Kahan 2, IK-Geo §III-B), vectorised: R(k1, t1) R(k2, t2) p = q
    for k1 (3,), k2, p, q (m, 3): two (t1, t2, feasible) branches."""
    k12 = k2 @ k1
    den = k12 * k12 - 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = (k12 * np.sum(k2 * p, -1) - q @ k1) / den
        beta = (k12 * (q @ k1) - np.sum(k2 * p, -1)) / den
        kx = np.cross(k1, k2)
        nkx = np.sum(kx * kx, -1)
        pp = np.sum(p * p, -1)
        g2 = (pp - alpha**2 - beta**2 - 2 * alpha * beta * k12) / nkx
    ok = np.isfinite(g2) & (g2 >= -1e-9 * np.maximum(pp, 1e-300) / np.where(nkx > 0, nkx, 1))
    g = np.sqrt(np.clip(g2, 0, None))
    out = []
    for sgn in (1.0, -1.0):
        c = alpha[:, None] * k1 + beta[:, None] * k2 + (sgn * g)[:, None] * kx
        t2 = _sp1_rows(k2, p, c)
        t1 = _sp1(k1, c, q)
        out.append((t1, t2, ok))
    return out


def _sp1_rows(k: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """Subproblem 1 with a different axis per row: k, p1, p2 (m, 3)."""
    u = p1 - np.sum(p1 * k, -1)[:, None] * k
    v = p2 - np.sum(p2 * k, -1)[:, None] * k
    return np.arctan2(np.sum(np.cross(u, v) * k, -1), np.sum(u * v, -1))


def arm5r_branches(H: np.ndarray, P: np.ndarray, M: np.ndarray, Ts: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Up to 4 branches of targets Ts (m, 4, 4): q (m, 4, 5), count (m,) (4 where the
    subproblems are feasible, else 0; infeasible branches carry inf errors) and FK errors
    err (m, 4, 2) (position [m], orientation [rad])."""
    m = len(Ts)
    d = H[1]
    s3, s4 = H[2] @ d, H[3] @ d
    RG = Ts[:, :3, :3] @ M[:3, :3].T
    pG = Ts[:, :3, 3] - RG @ M[:3, 3]
    k5 = RG @ H[4]
    q = np.full((m, 4, 5), np.nan)
    feas = np.zeros((m, 4), dtype=bool)
    v = np.cross(d, [1.0, 0, 0] if abs(d[0]) < 0.9 else [0, 1.0, 0])
    v /= np.linalg.norm(v)
    j = 0
    for t1, t5, ok15 in _sp2(H[0], k5, RG @ d, np.broadcast_to(d, (m, 3)).copy()):
        q1, q5 = -t1, -t5
        # R_234 = R1^T R_G R5^T
        R1 = np.stack([_rot(H[0], q1, np.broadcast_to(e, (m, 3))) for e in np.eye(3)], -1)
        R5 = np.stack([_rot(H[4], q5, np.broadcast_to(e, (m, 3))) for e in np.eye(3)], -1)
        R234 = np.swapaxes(R1, 1, 2) @ RG @ np.swapaxes(R5, 1, 2)
        theta = _sp1(d, np.broadcast_to(v, (m, 3)), R234 @ v)
        y5 = _rot(H[0], -q1, (np.einsum("mij,j->mi", RG, P[4]) + pG) - P[0]) + P[0]
        y4 = y5 + _rot(d, theta, np.broadcast_to(P[3] - P[4], (m, 3)))
        qa, qb, ok3 = _sp3(H[2], np.broadcast_to(P[3] - P[2], (m, 3)),
                           np.broadcast_to(P[1] - P[2], (m, 3)),
                           np.linalg.norm(y4 - P[1], axis=-1))
        for q3 in (qa, qb):
            e3 = _rot(H[2], q3, np.broadcast_to(P[3] - P[2], (m, 3))) + P[2]
            q2 = _sp1(H[1], e3 - P[1], y4 - P[1])
            q[:, j] = np.stack([q1, q2, q3, s4 * (theta - q2 - s3 * q3), q5], -1)
            feas[:, j] = ok15 & ok3
            j += 1
    err = np.full((m, 4, 2), np.inf)
    for j in range(4):
        qq = np.where(feas[:, j, None], q[:, j], 0.0)
        T = poe_fk(H, P, M, -1, qq)
        pe = np.linalg.norm(T[:, :3, 3] - Ts[:, :3, 3], axis=-1)
        oe = np.linalg.norm(T[:, :3, :3] - Ts[:, :3, :3], axis=(1, 2)) / np.sqrt(2)
        err[:, j, 0] = np.where(feas[:, j], pe, np.inf)
        err[:, j, 1] = np.where(feas[:, j], oe, np.inf)
    q = np.where(feas[..., None], q, 0.0)
    return q, np.full(m, 4, dtype=np.int64), err


def uu_leg_branches(H: np.ndarray, P: np.ndarray, M: np.ndarray, o: np.ndarray,
                    w: np.ndarray, Ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 5R leg R-U-U (a Delta leg): h2, h3 meet at the elbow o, h4, h5 meet at the wrist w.
    With G = T M^{-1}: the wrist's image w_t = G w; q1 by Subproblem 3 (the elbow on the
    sphere of radius ||w - o|| about w_t), (q2, q3) by Subproblem 2 about o, q4 by
    Subproblem 1 on h5 and q5 by Subproblem 1. Up to 4 branches: q (m, 4, 5), count (m,),
    FK errors err (m, 4, 2) (a target the leg's orientation cannot take fails them)."""
    m = len(Ts)
    RG = Ts[:, :3, :3] @ M[:3, :3].T
    pG = Ts[:, :3, 3] - RG @ M[:3, 3]
    wt = RG @ w + pG
    L = np.linalg.norm(w - o)
    qa, qb, ok1 = _sp3(H[0], np.broadcast_to(o - P[0], (m, 3)), wt - P[0], np.full(m, L))
    q = np.zeros((m, 4, 5))
    feas = np.zeros((m, 4), dtype=bool)
    j = 0
    for q1 in (qa, qb):
        y = _rot(H[0], -q1, wt - P[0]) + P[0] - o
        for t2, t3, ok23 in _sp2(H[1], np.broadcast_to(H[2], (m, 3)).copy(),
                                 np.broadcast_to(w - o, (m, 3)).copy(), y):
            R123 = np.eye(3)[None]
            for k, t in ((0, q1), (1, t2), (2, t3)):
                Rk = np.stack([_rot(H[k], t, np.broadcast_to(e, (m, 3))) for e in np.eye(3)],
                              -1)
                R123 = R123 @ Rk
            Rt = np.swapaxes(R123, 1, 2) @ RG  # = R(h4, q4) R(h5, q5)
            q4 = _sp1(H[3], np.broadcast_to(H[4], (m, 3)), Rt @ H[4])
            v = np.cross(H[4], [1.0, 0, 0] if abs(H[4][0]) < 0.9 else [0, 1.0, 0])
            q5 = _sp1(H[4], np.broadcast_to(v, (m, 3)), _rot(H[3], -q4, Rt @ v))
            q[:, j] = np.stack([q1, t2, t3, q4, q5], -1)
            feas[:, j] = ok1 & ok23
            j += 1
    err = np.full((m, 4, 2), np.inf)
    for j in range(4):
        T = poe_fk(H, P, M, -1, np.where(feas[:, j, None], q[:, j], 0.0))
        err[:, j, 0] = np.where(feas[:, j], np.linalg.norm(T[:, :3, 3] - Ts[:, :3, 3], axis=-1),
                                np.inf)
        err[:, j, 1] = np.where(feas[:, j], np.linalg.norm(T[:, :3, :3] - Ts[:, :3, :3],
                                                           axis=(1, 2)) / np.sqrt(2), np.inf)
    return q, np.full(m, 4, dtype=np.int64), err


def spherical3_branches(H: np.ndarray, P: np.ndarray, M: np.ndarray, Ts: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three revolute axes meeting in a point (a spherical joint) reaching the orientation of
    Ts (m, 4, 4): (q1, q2) by Subproblem 2 on h3 (R(h1, q1) R(h2, q2) h3 = R_G h3), q3 by
    Subproblem 1. Two branches: q (m, 2, 3), count (m,), FK errors err (m, 2, 2)."""
    m = len(Ts)
    RG = Ts[:, :3, :3] @ M[:3, :3].T
    q = np.zeros((m, 2, 3))
    feas = np.zeros((m, 2), dtype=bool)
    v = np.cross(H[2], [1.0, 0, 0] if abs(H[2][0]) < 0.9 else [0, 1.0, 0])
    for j, (t1, t2, ok) in enumerate(_sp2(H[0], np.broadcast_to(H[1], (m, 3)).copy(),
                                          np.broadcast_to(H[2], (m, 3)).copy(), RG @ H[2])):
        w = _rot(H[1], -t2, _rot(H[0], -t1, RG @ v))
        q[:, j] = np.stack([t1, t2, _sp1(H[2], np.broadcast_to(v, (m, 3)), w)], -1)
        feas[:, j] = ok
    err = np.full((m, 2, 2), np.inf)
    for j in range(2):
        T = poe_fk(H, P, M, -1, np.where(feas[:, j, None], q[:, j], 0.0))
        err[:, j, 0] = np.where(feas[:, j], np.linalg.norm(T[:, :3, 3] - Ts[:, :3, 3], axis=-1),
                                np.inf)
        err[:, j, 1] = np.where(feas[:, j], np.linalg.norm(T[:, :3, :3] - Ts[:, :3, :3],
                                                           axis=(1, 2)) / np.sqrt(2), np.inf)
    return q, np.full(m, 2, dtype=np.int64), err
