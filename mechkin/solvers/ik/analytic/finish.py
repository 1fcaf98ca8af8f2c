r"""From raw branches to solutions: limits, verification, order and merging (compiled).

For each target (rows of ``q (m, 8, n_v)``, ``count (m,)`` branches, FK errors ``err (m, 8,
2)``), in one compiled loop:

1. each revolute joint goes to the representative ``q + 2 pi k`` nearest the reference
   ``ref`` (the guess) that lies within its limits; a branch with a joint that has none is
   dropped;
2. a branch counts when its FK errors are within ``tol_pos`` [m] and ``tol_ori`` [rad];
3. branches are ordered by their joint distance from the reference (revolute joints modulo
   2 pi; ties broken lexicographically by q, both rounded to 1e-9);
4. a branch within ``same_tol`` (max-abs difference, revolute joints modulo 2 pi) of an
   earlier kept one is the same solution (tangent and singular poses).

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy, math and the package's jit.
"""

from __future__ import annotations

import math

import numpy as np

from mechkin.solvers.ik.analytic.jit import jit
from mechkin.solvers.ik.analytic.solve6r import MAX_BRANCHES, solve_batch

TWO_PI = 2.0 * math.pi
TOL_POS = 1e-8  # [m] a branch is a solution when FK puts {E} this close to the target ...
TOL_ORI = 1e-8  # [rad] ... in position and orientation (exact branches: ~1e-15)
SAME_TOL = 1e-3  # [rad | m] two branches closer than this (max-abs, mod 2 pi) are one


@jit
def _wrap(d: float) -> float:
    """d wrapped into [-pi, pi)."""
    return (d + math.pi) % TWO_PI - math.pi


@jit
def _before(da: float, qa: np.ndarray, db: float, qb: np.ndarray) -> bool:
    """Whether (distance da, joints qa) orders before (db, qb)."""
    ra, rb = round(da * 1e9), round(db * 1e9)
    if ra != rb:
        return ra < rb
    for j in range(qa.size):
        a, b = round(qa[j] * 1e9), round(qb[j] * 1e9)
        if a != b:
            return a < b
    return False


@jit
def finish_batch(q: np.ndarray, count: np.ndarray, err: np.ndarray, ref: np.ndarray,
                 lo: np.ndarray, hi: np.ndarray, rev: np.ndarray, tol_pos: float,
                 tol_ori: float, same_tol: float, q_out: np.ndarray, pe_out: np.ndarray,
                 oe_out: np.ndarray, dist_out: np.ndarray, n_out: np.ndarray) -> None:
    """Solutions of each target (module docstring): q_out (m, 8, n_v), pe_out, oe_out,
    dist_out (m, 8), n_out (m,); rows past n_out[i] are NaN (joints) and inf."""
    m, nb, nv = q.shape
    cand = np.empty((nb, nv))
    cpe = np.empty(nb)
    coe = np.empty(nb)
    cd = np.empty(nb)
    idx = np.empty(nb, dtype=np.int64)
    for r in range(m):
        k = 0
        for b in range(count[r]):
            if err[r, b, 0] > tol_pos or err[r, b, 1] > tol_ori:
                continue
            inside = True
            d2 = 0.0
            for j in range(nv):
                x = q[r, b, j]
                if rev[j]:
                    x = ref[r, j] + _wrap(x - ref[r, j])
                    if x < lo[j] - 1e-12 or x > hi[j] + 1e-12:
                        x += TWO_PI
                        if x < lo[j] - 1e-12 or x > hi[j] + 1e-12:
                            x -= 2.0 * TWO_PI
                    dj = _wrap(x - ref[r, j])
                else:
                    dj = x - ref[r, j]
                if x < lo[j] - 1e-12 or x > hi[j] + 1e-12:
                    inside = False
                    break
                cand[k, j] = min(max(x, lo[j]), hi[j])
                d2 += dj * dj
            if not inside:
                continue
            cpe[k] = err[r, b, 0]
            coe[k] = err[r, b, 1]
            cd[k] = math.sqrt(d2)
            k += 1
        # insertion sort of 0..k-1 by (distance, q)
        for i in range(k):
            idx[i] = i
        for i in range(1, k):
            t = idx[i]
            j = i - 1
            while j >= 0 and _before(cd[t], cand[t], cd[idx[j]], cand[idx[j]]):
                idx[j + 1] = idx[j]
                j -= 1
            idx[j + 1] = t
        n = 0
        for i in range(k):
            a = idx[i]
            dup = False
            for s in range(n):
                big = 0.0
                for j in range(nv):
                    dj = cand[a, j] - q_out[r, s, j]
                    if rev[j]:
                        dj = _wrap(dj)
                    big = max(big, abs(dj))
                if big < same_tol:
                    dup = True
                    break
            if dup:
                continue
            for j in range(nv):
                q_out[r, n, j] = cand[a, j]
            pe_out[r, n] = cpe[a]
            oe_out[r, n] = coe[a]
            dist_out[r, n] = cd[a]
            n += 1
        n_out[r] = n
        for i in range(n, nb):
            for j in range(nv):
                q_out[r, i, j] = np.nan
            pe_out[r, i] = np.inf
            oe_out[r, i] = np.inf
            dist_out[r, i] = np.inf


# Layout of the packed constants of a chain (one float64 vector, so that a compiled call takes
# few arguments): kind, pos_kind, reversed, H, P, M, point, point2, Hf, Pf, Mf, lower, upper,
# revolute (joints in chain order).
C_H, C_P, C_M, C_PT, C_PT2, C_HF, C_PF, C_MF = 3, 21, 39, 55, 58, 61, 79, 97
C_LO, C_HI, C_REV, C_SIZE = 113, 119, 125, 131


@jit
def solve_finish(c: np.ndarray, Ts: np.ndarray, ref: np.ndarray, tol: np.ndarray,
                 q_out: np.ndarray, pe: np.ndarray, oe: np.ndarray, dist: np.ndarray,
                 n_out: np.ndarray) -> None:
    """Every solution of each target Ts (m, 4, 4) of the chain with packed constants c,
    reference ref (m, 6) (chain order), tol = (tol_pos, tol_ori, same_tol): the branches of
    :func:`mechkin.solvers.ik.analytic.solve6r.solve_batch` through :func:`finish_batch`."""
    m = Ts.shape[0]
    q = np.empty((m, MAX_BRANCHES, 6))
    count = np.zeros(m, dtype=np.int64)
    err = np.empty((m, MAX_BRANCHES, 2))
    solve_batch(int(c[0]), int(c[1]), c[2] != 0.0, c[C_H:C_P].reshape(6, 3),
                c[C_P:C_M].reshape(6, 3), c[C_M:C_PT].reshape(4, 4), c[C_PT:C_PT2],
                c[C_PT2:C_HF], c[C_HF:C_PF].reshape(6, 3), c[C_PF:C_MF].reshape(6, 3),
                c[C_MF:C_LO].reshape(4, 4), Ts, ref, q, count, err)
    finish_batch(q, count, err, ref, c[C_LO:C_HI], c[C_HI:C_REV], c[C_REV:C_SIZE] != 0.0,
                 tol[0], tol[1], tol[2], q_out, pe, oe, dist, n_out)


@jit
def solve_one(c: np.ndarray, T: np.ndarray, ref: np.ndarray) -> tuple[int, np.ndarray,
                                                                     np.ndarray]:
    """:func:`solve_finish` of one target T (4, 4) from ref (6,) (chain order) with the
    default tolerances (:data:`TOL_POS`, :data:`TOL_ORI`, :data:`SAME_TOL`): (n, q (8, 6),
    e (8, 3)) with e = (position error, orientation error, distance) per solution."""
    Ts = np.empty((1, 4, 4))
    Ts[0] = T
    refs = np.empty((1, 6))
    refs[0] = ref
    tol = np.empty(3)
    tol[0], tol[1], tol[2] = TOL_POS, TOL_ORI, SAME_TOL
    q = np.empty((1, MAX_BRANCHES, 6))
    pe = np.empty((1, MAX_BRANCHES))
    oe = np.empty((1, MAX_BRANCHES))
    dist = np.empty((1, MAX_BRANCHES))
    n = np.empty(1, dtype=np.int64)
    solve_finish(c, Ts, refs, tol, q, pe, oe, dist, n)
    e = np.empty((MAX_BRANCHES, 3))
    for i in range(MAX_BRANCHES):
        e[i, 0], e[i, 1], e[i, 2] = pe[0, i], oe[0, i], dist[0, i]
    return n[0], q[0], e


@jit
def solve_one_into(c: np.ndarray, T: np.ndarray, ref: np.ndarray, out: np.ndarray
                   ) -> tuple[int, int]:
    """:func:`solve_one` writing into out (8, 9) (q (6), position and orientation error,
    distance per solution); returns (n, mask): mask has bit j set when joint j of the first
    solution sits on a limit (within 1e-9)."""
    n, q, e = solve_one(c, T, ref)
    for i in range(MAX_BRANCHES):
        for j in range(6):
            out[i, j] = q[i, j]
        out[i, 6], out[i, 7], out[i, 8] = e[i, 0], e[i, 1], e[i, 2]
    mask = 0
    if n > 0:
        for j in range(6):
            if abs(q[0, j] - c[C_LO + j]) < 1e-9 or abs(q[0, j] - c[C_HI + j]) < 1e-9:
                mask |= 1 << j
    return n, mask
