"""Continuation of the path inverse kinematics in blocks (park Eq. (9)-(10); issue 29).

:class:`mechkin.solvers.track.path_ik.HandPathIK` tabulates ``q = f(r)`` on ``r = -0.02 ..
1.02`` by continuation from the start solution. Point by point, each table point costs a
tangent, a Newton solve and a singularity check on one configuration (about five task
evaluations of one row each: numpy's per-call cost dominates). Here the next ``block`` points
are predicted along the tangent ``f'`` at the last solved point and corrected together by one
batched Newton (:func:`newton_rows`, each row stopping once it converged), so a block costs
about as many evaluations as one point did. The leading points that converge, stay within
``drift`` of their prediction (the branch is kept: another branch lies far from the tangent),
move less than ``max_jump`` from their neighbour and keep ``sigma_m / sigma_1`` above
``singular_rtol`` are kept; at the first point that does not, the point-by-point step solves
it (or raises the located :class:`PathIKError`) and the blocks go on from there. The table
equals the point-by-point one to the IK tolerance (tests/solvers/test_path_ik_blocks.py).

Imports: numpy only (the hooks are the caller's methods).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def newton_rows(ik, q: np.ndarray, r: np.ndarray, max_iter: int, null_tol: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Newton's method on ``G(q, r) = 0`` (the hooks ``ik._residual``, ``ik._errors``,
    ``ik._D``) row by row, a row stopping once it converged: q (m, n), converged (m,), task
    error (m,) and sigma_m / sigma_1 (m,) at the q returned."""
    q = np.array(q, dtype=float)
    m = q.shape[0]
    ok = np.zeros(m, dtype=bool)
    err = np.full(m, np.inf)
    ratio = np.zeros(m)
    act = np.arange(m)
    for it in range(max_iter + 1):
        e, P, g, rat = ik._residual(q[act], r[act])
        pos, rot = ik._errors(e)
        conv = (pos <= ik.tol) & (rot <= ik.tol_rot)
        if g is not None:
            conv &= np.max(np.abs(g), axis=1) <= null_tol
        err[act] = np.maximum(pos, rot)
        ratio[act] = rat
        ok[act[conv]] = True
        if it == max_iter or conv.all():
            break
        keep = ~conv
        act, e, P = act[keep], e[keep], P[keep]
        step = np.einsum("mij,mj->mi", P, e)
        if g is not None:
            M = np.eye(ik.n) - ik._D(q[act], r[act])
            step = np.linalg.solve(M, (step + g[keep])[..., None])[..., 0]
        big = np.max(np.abs(step), axis=1, keepdims=True)
        q[act] += step * np.minimum(1.0, 0.5 / np.maximum(big, 1e-300))
    return q, ok, err, ratio


def continue_blocks(ik, tab: np.ndarray, i0: int, idx: list[int],
                    step: Callable[[int, int], None], *, max_iter: int, max_jump: float,
                    drift: float, singular_rtol: float, null_tol: float) -> None:
    """Fill ``tab[idx]`` (in that order, away from the solved point ``i0``) in blocks of
    ``ik.BLOCK`` points (module docstring); ``step(prev, i)`` solves point ``i`` alone from
    ``prev`` or raises."""
    prev, pos = i0, 0
    while pos < len(idx):
        blk = np.asarray(idx[pos:pos + ik.BLOCK])
        f1 = ik.dq_of(tab[prev][None, :], ik.r_tab[prev:prev + 1])[0]
        r = ik.r_tab[blk]
        guess = tab[prev] + (r - ik.r_tab[prev])[:, None] * f1
        k = 0
        if np.all(np.isfinite(guess)):
            q, ok, _, ratio = newton_rows(ik, guess, r, max_iter, null_tol)
            before = np.vstack([tab[prev][None, :], q[:-1]])
            good = (ok & (np.max(np.abs(q - before), axis=1) <= max_jump)
                    & (np.max(np.abs(q - guess), axis=1) <= drift)
                    & (ratio >= singular_rtol))
            k = len(good) if good.all() else int(np.argmin(good))
            tab[blk[:k]] = q[:k]
        if k == 0:
            step(prev, int(blk[0]))
            k = 1
        prev = int(blk[k - 1])
        pos += k
