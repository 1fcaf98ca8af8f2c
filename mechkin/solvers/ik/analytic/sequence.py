r"""A warm-started sequence of targets in one compiled loop (the ik task's batched route).

Each target of ``Ts (m, 4, 4)`` is solved by :func:`mechkin.solvers.ik.analytic.finish.
solve_one` (the call :func:`mechkin.solvers.ik.analytic.dispatch.analytic_ik` makes for one
target) from the previous target's answer (``warm``; else every target from ``ref0``), so
every answer, error and joint-at-limit mask is bit for bit the one of the per-target route;
only the Python work per target is gone. The loop stops at the first target it cannot settle
alone (no solution within the tolerances, or a target flagged ``skip``): the caller solves
that one by the general route (``auto``: lm; its answer may become the next guess) and calls
again from the next target.

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy and the package's compiled
``finish``; never ``io/``, ``tasks/`` or ``cli/``.
"""

from __future__ import annotations

import numpy as np

from mechkin.solvers.ik.analytic.finish import C_HI, C_LO, solve_one
from mechkin.solvers.ik.analytic.jit import jit


@jit
def solve_sequence_into(c: np.ndarray, Ts: np.ndarray, ref0: np.ndarray, skip: np.ndarray,
                        tol_pos: float, tol_ori: float, warm: bool, start: int,
                        q_out: np.ndarray, e_out: np.ndarray, mask_out: np.ndarray) -> int:
    """Targets ``start, start + 1, ...`` of the chain with packed constants ``c`` (chain order,
    an identity 6R chain): the first solution nearest the guess (``ref0`` (6,), then the
    previous answer when ``warm``) into q_out (m, 6), its (position error, orientation error,
    distance) into e_out (m, 3) and its at-limit bit mask (bit j: joint j within 1e-9 of a
    limit) into mask_out (m,). Returns the index of the first target not settled (``skip``
    set, no solution, or errors above ``tol_pos`` / ``tol_ori``), or m when all are."""
    m = Ts.shape[0]
    ref = ref0.copy()
    for r in range(start, m):
        if skip[r]:
            return r
        n, q, e = solve_one(c, Ts[r], ref)
        if n == 0 or e[0, 0] > tol_pos or e[0, 1] > tol_ori:
            return r
        mask = 0
        for j in range(6):
            q_out[r, j] = q[0, j]
            if abs(q[0, j] - c[C_LO + j]) < 1e-9 or abs(q[0, j] - c[C_HI + j]) < 1e-9:
                mask |= 1 << j
        e_out[r, 0], e_out[r, 1], e_out[r, 2] = e[0, 0], e[0, 1], e[0, 2]
        mask_out[r] = mask
        if warm:
            for j in range(6):
                ref[j] = q[0, j]
    return m
