r"""Batched analytic IK: every branch of many poses, wrapped into the limits, verified, merged.

:func:`analytic_batch` runs the compiled subproblem solver
(:func:`mechkin.solvers.ik.analytic.solve6r.solve_batch`) on targets ``T (m, 4, 4)``, each
branch verified by forward kinematics (product of exponentials of the model's axes at q = 0),
then :func:`mechkin.solvers.ik.analytic.finish.finish_batch` puts revolute joints at the
representative nearest the guess within the limits, keeps the branches within
:data:`TOL_POS` / :data:`TOL_ORI`, orders them from the guess and merges coinciding ones.

For a chain that decomposes in closed form the list is complete (the 1-D search's,
:mod:`mechkin.solvers.ik.analytic.search1d`, is not proved so: ``chain.complete``): every
solution of the pose within the limits, one per branch (a singular pose has a continuum; its
representative keeps the free joint at its guess: wrist q5 = 0 keeps q4 and solves the sum
q4 + q6, a wrist centre on the first axis keeps q1).

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy, :mod:`mechkin.model` and the
package's kernels; never ``io/``, ``tasks/`` or ``cli/``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.accel import announce
from mechkin.solvers.ik.analytic.arm5r import arm5r_branches
from mechkin.solvers.ik.analytic.arm5w import WRIST5_BASE, wrist5_branches
from mechkin.solvers.ik.analytic.classify import AnalyticChain
from mechkin.solvers.ik.analytic.finish import (
    SAME_TOL,
    TOL_ORI,
    TOL_POS,
    finish_batch,
    solve_finish,
    solve_one,
)
from mechkin.solvers.ik.analytic.scara import scara_branches
from mechkin.solvers.ik.analytic.search1d import MAX_SOLUTIONS, N_SAMPLES, search_batch
from mechkin.solvers.ik.analytic.solve6r import (
    KIND_ARM5,
    KIND_SCARA,
    KIND_SEARCH,
    MAX_BRANCHES,
    solve_batch,
)


@dataclass(frozen=True)
class AnalyticBatch:
    """Every solution of m targets, padded to 8 per target (16 for the 1-D search).

    q_v : (m, 8, n_v) independent joints (in ``mech.independent`` order), the solutions of
    target i in rows ``[:count[i]]``, nearest the reference first; position_error,
    orientation_error : (m, 8) [m], [rad] by FK; distance : (m, 8) joint distance from the
    reference; count : (m,).
    Rows past ``count`` hold NaN (joints) and inf (errors, distance).
    """

    q_v: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    distance: np.ndarray
    count: np.ndarray


def chain_branches(chain: AnalyticChain, Ts: np.ndarray, guess: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raw branches of targets Ts (m, 4, 4) from guesses (m, 6) in chain order: q (m, 8, 6)
    (chain order), count (m,), err (m, 8, 2). No limits, no merging."""
    m = Ts.shape[0]
    out = np.full((m, MAX_BRANCHES, 6), np.nan)
    count = np.zeros(m, dtype=np.int64)
    err = np.full((m, MAX_BRANCHES, 2), np.inf)
    solve_batch(chain.kind, chain.pos_kind, chain.reversed, chain.H, chain.P, chain.M,
                chain.point, chain.point2, chain.Hf, chain.Pf, chain.Mf,
                np.ascontiguousarray(Ts, dtype=np.float64),
                np.ascontiguousarray(guess, dtype=np.float64), out, count, err)
    return out, count, err


def analytic_batch(mech: Mechanism, chain: AnalyticChain, Ts: np.ndarray, ref: np.ndarray, *,
                   same_tol: float = SAME_TOL, tol_pos: float = TOL_POS,
                   tol_ori: float = TOL_ORI) -> AnalyticBatch:
    """Every solution within the limits of each target Ts (m, 4, 4), ordered from the
    reference ref ((m, n_v) or (n_v,), independent joints; also the guess of free joints at
    singular poses). See the module docstring for the rules. ``mech`` is the mechanism
    ``chain`` was classified from."""
    Ts = np.ascontiguousarray(Ts, dtype=np.float64).reshape(-1, 4, 4)
    m = Ts.shape[0]
    ref = np.asarray(ref, dtype=np.float64)
    announce(solve_finish, "analytic IK (finish.solve_finish)")
    if not chain.identity:
        ref = ref[..., chain.order]
    if chain.kind in (KIND_SCARA, KIND_ARM5, KIND_SEARCH):
        return _numpy_batch(chain, Ts, ref, tol_pos, tol_ori, same_tol)
    if m == 1 and ref.ndim == 1 and (tol_pos, tol_ori, same_tol) == (TOL_POS, TOL_ORI,
                                                                      SAME_TOL):
        n1, q1, e = solve_one(chain.packed, Ts[0], ref)  # one pose: the shortest call
        if not chain.identity:
            q1 = full_qv(chain, q1, len(mech.independent))
        return AnalyticBatch(q_v=q1[None], position_error=e[None, :, 0],
                             orientation_error=e[None, :, 1], distance=e[None, :, 2],
                             count=np.array([n1]))
    ref = np.ascontiguousarray(np.broadcast_to(ref, (m, 6)))
    q = np.empty((m, MAX_BRANCHES, 6))
    pe = np.empty((m, MAX_BRANCHES))
    oe = np.empty((m, MAX_BRANCHES))
    dist = np.empty((m, MAX_BRANCHES))
    n = np.empty(m, dtype=np.int64)
    solve_finish(chain.packed, Ts, ref, np.array((tol_pos, tol_ori, same_tol)), q, pe, oe,
                 dist, n)
    if not chain.identity:
        q = full_qv(chain, q, len(mech.independent))
    return AnalyticBatch(q_v=q, position_error=pe, orientation_error=oe, distance=dist,
                         count=n)


def full_qv(chain: AnalyticChain, q: np.ndarray, nv: int) -> np.ndarray:
    """Independent joints (..., n_v) from chain-order joints q (..., k): the chain's joints
    in their columns, held joints (``fixed``) at their values (NaN where q is NaN)."""
    out = np.empty(q.shape[:-1] + (nv,))
    out[..., chain.order] = q
    if chain.fixed_cols.size:
        absent = np.isnan(q[..., :1])
        out[..., chain.fixed_cols] = np.where(absent, np.nan, chain.fixed_values)
    return out


def _numpy_batch(chain: AnalyticChain, Ts: np.ndarray, ref: np.ndarray, tol_pos: float,
                 tol_ori: float, same_tol: float) -> AnalyticBatch:
    """:func:`analytic_batch` of a SCARA or a 5R arm (numpy branches; ref in chain order)."""
    m, nv = Ts.shape[0], len(chain.joints)
    ref = np.ascontiguousarray(np.broadcast_to(ref, (m, nv)))
    if chain.kind == KIND_SCARA:
        q_ch, count, err = scara_branches(chain.H, chain.P, chain.M, chain.pos_kind, Ts)
    elif chain.kind == KIND_SEARCH:
        q_ch = np.full((m, MAX_SOLUTIONS, 6), np.nan)
        count = np.zeros(m, dtype=np.int64)
        err = np.full((m, MAX_SOLUTIONS, 2), np.inf)
        search_batch(chain.H, chain.P, chain.M, chain.point, chain.Hf, chain.Pf, chain.Mf,
                     chain.reversed, Ts, np.ascontiguousarray(ref), N_SAMPLES, q_ch, count,
                     err)
    elif chain.pos_kind >= WRIST5_BASE:
        q_ch, count, err = wrist5_branches(chain.H, chain.P, chain.M, chain.pos_kind,
                                           chain.point, chain.point2, Ts, ref)
    else:
        q_ch, count, err = arm5r_branches(chain.H, chain.P, chain.M, Ts)
    nb = q_ch.shape[1]
    q = np.empty((m, nb, nv))
    pe, oe, dist = (np.empty((m, nb)) for _ in range(3))
    n = np.empty(m, dtype=np.int64)
    lo = np.array([chain.limits[0][i] for i in chain.order], dtype=np.float64)
    hi = np.array([chain.limits[1][i] for i in chain.order], dtype=np.float64)
    rev = np.arange(nv) != chain.pos_kind
    finish_batch(np.ascontiguousarray(q_ch), count, np.ascontiguousarray(err), ref, lo, hi,
                 rev, tol_pos, tol_ori, same_tol, q, pe, oe, dist, n)
    if not chain.identity:
        q = full_qv(chain, q, len(chain.limits[0]))
    return AnalyticBatch(q_v=q, position_error=pe, orientation_error=oe, distance=dist, count=n)
