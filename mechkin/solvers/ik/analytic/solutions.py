r"""Batched analytic IK: every branch of many poses, wrapped into the limits, verified, merged.

:func:`analytic_batch` runs the compiled subproblem solver
(:func:`mechkin.solvers.ik.analytic.solve6r.solve_batch`) on targets ``T (m, 4, 4)``, then, all
vectorised over the m targets and their (up to 8) branches:

1. each revolute joint goes to the representative ``q + 2 pi k`` nearest the reference (the
   guess) that lies within its limits (a branch with a joint that has none is dropped);
2. a branch counts when forward kinematics (product of exponentials of the model's axes at
   q = 0) puts {E} within :data:`TOL_POS` and :data:`TOL_ORI` of the target;
3. branches are ordered by their joint distance from the reference (revolute joints modulo
   2 pi), then lexicographically; a branch within ``same_tol`` (max-abs, modulo 2 pi) of an
   earlier kept one is the same solution (tangent and singular poses, where two branches
   coincide).

For a chain that decomposes the list is complete: every solution of the pose within the
limits, one per branch (a singular pose has a continuum; its representative keeps the free
joint at its guess: wrist q5 = 0 keeps q4 and solves the sum q4 + q6, a wrist centre on the
first axis keeps q1).

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy, :mod:`mechkin.model` and the
package's kernels; never ``io/``, ``tasks/`` or ``cli/``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.analytic.classify import AnalyticChain
from mechkin.solvers.ik.analytic.solve6r import MAX_BRANCHES, solve_batch

TOL_POS = 1e-8  # [m] a branch is a solution when FK puts {E} this close to the target ...
TOL_ORI = 1e-8  # [rad] ... in position and orientation (exact branches: ~1e-15)
SAME_TOL = 1e-3  # [rad | m] two branches closer than this (max-abs, mod 2 pi) are one


@dataclass(frozen=True)
class AnalyticBatch:
    """Every solution of m targets, padded to 8 per target.

    q_v : (m, 8, n_v) independent joints (in ``mech.independent`` order), the solutions of
    target i in rows ``[:count[i]]``, nearest the reference first; position_error,
    orientation_error : (m, 8) [m], [rad] by FK; distance : (m, 8) joint distance from the
    reference; count : (m,); branches : (m,) branches before the limits and merging.
    Rows past ``count`` hold NaN (joints) and inf (errors, distance).
    """

    q_v: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    distance: np.ndarray
    count: np.ndarray
    branches: np.ndarray


def wrap_near(q: np.ndarray, ref: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              rev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Revolute entries of q (..., n) at the 2 pi representative nearest ref (..., n) within
    [lo, hi] (n,); returns (q, inside (...,) all joints within the limits)."""
    tol = 1e-12
    base = ref + (q - ref + np.pi) % (2 * np.pi) - np.pi
    out = np.where(rev, base, q)
    for shift in (2 * np.pi, -2 * np.pi):
        bad = rev & ((out < lo - tol) | (out > hi + tol))
        out = np.where(bad, base + shift, out)
    inside = np.all((out >= lo - tol) & (out <= hi + tol), axis=-1)
    return np.clip(out, lo, hi), inside


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
    singular poses). See the module docstring for the rules."""
    Ts = np.asarray(Ts, dtype=np.float64).reshape(-1, 4, 4)
    m = Ts.shape[0]
    nv = len(mech.independent)
    ref = np.broadcast_to(np.asarray(ref, dtype=np.float64), (m, nv))
    order = chain.order
    q_ch, count, err = chain_branches(chain, Ts, ref[:, order])
    q = np.full((m, MAX_BRANCHES, nv), np.nan)
    q[:, :, order] = q_ch
    iv = mech.independent
    lo, hi, rev = mech.lower[iv], mech.upper[iv], mech.s[iv] == 0
    present = np.arange(MAX_BRANCHES)[None] < count[:, None]
    with np.errstate(invalid="ignore"):
        q, inside = wrap_near(q, ref[:, None], lo, hi, rev)
    ok = present & inside & (err[..., 0] <= tol_pos) & (err[..., 1] <= tol_ori)
    d = (q - ref[:, None] + np.pi) % (2 * np.pi) - np.pi
    d = np.where(rev, d, q - ref[:, None])
    dist = np.where(ok, np.linalg.norm(np.where(ok[..., None], d, 0.0), axis=-1), np.inf)
    # order: distance, then q_v lexicographically (both rounded so that ties are exact)
    keys = [np.round(np.where(ok[..., None], q, 0.0)[..., j], 9) for j in range(nv - 1, -1, -1)]
    idx = np.lexsort(keys + [np.round(dist, 9)], axis=-1)
    take = np.take_along_axis
    q = take(q, idx[..., None], axis=1)
    ok = take(ok, idx, axis=1)
    dist = take(dist, idx, axis=1)
    pe = take(err[..., 0], idx, axis=1)
    oe = take(err[..., 1], idx, axis=1)
    # merge: a branch within same_tol of an earlier valid one is the same solution
    diff = q[:, :, None] - q[:, None, :]
    diff = np.where(rev, (diff + np.pi) % (2 * np.pi) - np.pi, diff)
    with np.errstate(invalid="ignore"):
        close = np.abs(diff).max(axis=-1) < same_tol
    earlier = np.tril(np.ones((MAX_BRANCHES, MAX_BRANCHES), dtype=bool), -1)
    dup = np.any(close & earlier[None] & ok[:, None, :], axis=-1)
    keep = ok & ~dup
    # compact the kept rows to the front, preserving the order
    pos = np.argsort(~keep, axis=1, kind="stable")
    q = take(q, pos[..., None], axis=1)
    keep_s = take(keep, pos, axis=1)
    q = np.where(keep_s[..., None], q, np.nan)
    inf = np.inf
    return AnalyticBatch(q_v=q, position_error=np.where(keep_s, take(pe, pos, axis=1), inf),
                         orientation_error=np.where(keep_s, take(oe, pos, axis=1), inf),
                         distance=np.where(keep_s, take(dist, pos, axis=1), inf),
                         count=keep.sum(axis=1), branches=count)
