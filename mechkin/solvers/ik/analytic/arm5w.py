r"""5R arms whose last two axes meet (a two-axis wrist at w), by the 6R spherical-wrist solver.

A 5-DOF arm reaches a 5-D family of poses. With h4 and h5 meeting at the wrist point w, add a
virtual sixth revolute joint about ``h6 = h4 x h5 / |h4 x h5|`` through w, at the end of the
chain: axes 4, 5, 6 then meet at w (a spherical wrist), and the 5R arm is the 6R arm with
q6 = 0. Every 5R solution of a pose is therefore a 6R solution with q6 = 0, and the 6R
spherical-wrist solver (:func:`mechkin.solvers.ik.analytic.solve6r.solve_batch`: the wrist
centre from the first three joints by the position case their axes admit, then (q4, q5) by
Subproblem 2 on h6 and q6 by Subproblem 1; IK-Geo §IV-A) finds all of them; the 6R branches
with q6 = 0 (to :data:`Q6_TOL`) are kept and verified by the 5R forward kinematics. A target
outside the 5-D family gives q6 != 0 on every branch: no solution.

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy and the package's kernels.

References
----------
Elias & Wen, IK-Geo, arXiv 2211.05737, §IV (spherical wrist); Pieper (1968).
"""

from __future__ import annotations

import numpy as np

from mechkin.solvers.ik.analytic.scara import poe_fk
from mechkin.solvers.ik.analytic.solve6r import KIND_SPHERICAL, MAX_BRANCHES, solve_batch

Q6_TOL = 1e-7  # [rad] |q6| of a 6R branch that is a 5R solution (exact ones: ~1e-12)
WRIST5_BASE = 100  # pos_kind of a 5R wrist chain = WRIST5_BASE + the 6R position case


def virtual_six(H: np.ndarray, P: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(H (6, 3), P (6, 3)): the 5R chain with the virtual sixth axis h4 x h5 through w."""
    h6 = np.cross(H[3], H[4])
    h6 = h6 / np.linalg.norm(h6)
    return (np.ascontiguousarray(np.vstack([H, h6])),
            np.ascontiguousarray(np.vstack([P, w])))


def wrist5_branches(H: np.ndarray, P: np.ndarray, M: np.ndarray, pos_kind: int,
                    w: np.ndarray, pt2: np.ndarray, Ts: np.ndarray, guess: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every 5R branch of targets Ts (m, 4, 4) from guesses (m, 5): q (m, 8, 5), count (m,),
    FK errors err (m, 8, 2) (position [m], orientation [rad]; rows past count are inf)."""
    m = len(Ts)
    H6, P6 = virtual_six(H, P, w)
    Ts = np.ascontiguousarray(Ts, dtype=np.float64)
    G6 = np.ascontiguousarray(np.hstack([guess, np.zeros((m, 1))]))
    raw = np.full((m, MAX_BRANCHES, 6), np.nan)
    cnt = np.zeros(m, dtype=np.int64)
    e6 = np.full((m, MAX_BRANCHES, 2), np.inf)
    w_ = np.ascontiguousarray(w, dtype=np.float64)
    pt2_ = np.ascontiguousarray(pt2, dtype=np.float64)
    solve_batch(KIND_SPHERICAL, pos_kind - WRIST5_BASE, False, H6, P6, M, w_, pt2_, H6, P6,
                M, Ts, G6, raw, cnt, e6)
    valid = np.arange(MAX_BRANCHES)[None] < cnt[:, None]
    q6 = np.where(valid, raw[..., 5], np.pi)
    keep = valid & (np.abs((q6 + np.pi) % (2 * np.pi) - np.pi) < Q6_TOL)
    q = np.where(keep[..., None], raw[..., :5], 0.0)
    err = np.full((m, MAX_BRANCHES, 2), np.inf)
    for j in range(MAX_BRANCHES):
        if not keep[:, j].any():
            continue
        T = poe_fk(H, P, M, -1, q[:, j])
        pe = np.linalg.norm(T[:, :3, 3] - Ts[:, :3, 3], axis=-1)
        oe = np.linalg.norm(T[:, :3, :3] - Ts[:, :3, :3], axis=(1, 2)) / np.sqrt(2)
        err[:, j, 0] = np.where(keep[:, j], pe, np.inf)
        err[:, j, 1] = np.where(keep[:, j], oe, np.inf)
    # compact the kept branches to the front of each row
    order = np.argsort(~keep, axis=1, kind="stable")
    q = np.take_along_axis(q, order[..., None], axis=1)
    err = np.take_along_axis(err, order[..., None], axis=1)
    return q, keep.sum(axis=1).astype(np.int64), err
