"""Starts of the IK searches: the seeded codebook of reachable poses and restart starts.

A solve without a guess starts from the nearest pose of a codebook of ``SEED_CODEBOOK`` seeded
random configurations within the limits (forward kinematics once, a KD-tree of the poses);
restarts take the next-nearest codebook poses, then seeded random joints within the limits.
Open chains only (closed chains seldom assemble at random joints; their restarts jitter the
given start); an open chain with joint couplings counts (its coupled joints follow their masters
in closed form, :mod:`mechkin.model.couplings`, and its codebook draws the masters within the
coupled joints' limits too).

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. May import
:mod:`mechkin.solvers.ik.kernel` and :mod:`mechkin.model`; never ``io/``, ``cli/`` or
``tasks/``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from mechkin.solvers.ik.kernel import IkKernel

SEED_CODEBOOK = 8192  # configurations searched for the start of a solve without a guess
SEED_RESTARTS = 8  # restarts that start from the next-nearest codebook poses


def seed_starts(kern: IkKernel, T_P: np.ndarray, w: np.ndarray, ranks=(0,),
                size: int = SEED_CODEBOOK) -> np.ndarray | None:
    """Initial independent joints (m, len(ranks), n_v) for targets T_P (m, 4, 4): the
    nearest poses of a seeded codebook of random configurations within the limits (open
    chains only; None for closed chains).

    Distance: position error [m] plus 0.5 m per unit of ``||R_P - R||_F`` (about 0.7 m per
    radian for small angles), each counted only where ``w`` weights it, so far targets
    start in the right region and LM needs few steps. ``ranks`` picks which neighbours
    (0 = the nearest; restarts take the next ones).
    """
    if not kern.open_path or (kern.iw.size and kern.coupling is None):
        return None
    ranks = np.asarray(ranks, dtype=int)
    m = T_P.shape[0]
    wp = (w[:, :3] > 0).any(axis=1)  # (m,)
    wo = (w[:, 3:] > 0).any(axis=1)
    out = np.empty((m, ranks.size, kern.iv.size))
    # features: position [m] and 0.5 m per unit of ||R_t - R||_F (= 2 sqrt(2) sin(theta/2))
    feats = np.empty((m, 12))
    feats[:, :3] = T_P[:, :3, 3]
    feats[:, 3:] = 0.5 * T_P[:, :3, :3].reshape(m, 9)
    modes = wp.astype(int) * 2 + wo.astype(int)
    for mode in (modes[0],) if m == 1 else np.unique(modes):
        rows = slice(None) if m == 1 else np.flatnonzero(modes == mode)
        cols = tuple(([0, 1, 2] if mode & 2 else []) + (list(range(3, 12)) if mode & 1
                                                        else []))
        if not cols:
            out[rows] = codebook(kern, size)[0][ranks]
            continue
        qs, tree = codebook(kern, size, cols)
        # approximate search (eps = 1: within twice the nearest distance) is as good a
        # start and 5x faster on large batches
        _, nearest = tree.query(feats[rows][:, cols], k=int(ranks.max()) + 1, eps=1.0,
                                workers=-1 if m >= 256 else 1)
        out[rows] = qs[nearest.reshape(len(feats[rows]), -1)[:, ranks]]
    return out


def seed_rows(kern: IkKernel, T_P: np.ndarray, w: np.ndarray, first: int, count: int,
              size: int = SEED_CODEBOOK) -> np.ndarray:
    """The same starts as ``seed_starts(kern, T_P[None], w[None], range(first, first +
    count))[0]`` for one target T_P (4, 4) with weights w (6,) on an open chain: (count, n_v),
    with fewer array calls (the single solve's path)."""
    wp = bool(w[0] > 0 or w[1] > 0 or w[2] > 0)
    wo = bool(w[3] > 0 or w[4] > 0 or w[5] > 0)
    cols = _COLS[wp * 2 + wo]
    if not cols:
        return codebook(kern, size)[0][first:first + count]
    feats = np.empty((1, 12))
    feats[0, :3] = T_P[:3, 3]
    feats[0, 3:] = 0.5 * T_P[:3, :3].reshape(9)
    qs, tree = codebook(kern, size, cols)
    _, nearest = tree.query(feats if len(cols) == 12 else feats[:, cols], k=first + count,
                            eps=1.0, workers=1)
    return qs[nearest.reshape(-1)[first:first + count]]


# the feature columns searched per weighting mode (2: position weighted, 1: orientation)
_COLS = {mode: tuple(([0, 1, 2] if mode & 2 else []) + (list(range(3, 12)) if mode & 1 else []))
         for mode in range(4)}


#: How the codebook is searched: ``"kdtree"`` (scipy's cKDTree, approximate with eps = 1; the
#: default, whose starts every released result follows) or ``"exact"`` (:class:`ExactSearch`,
#: numpy only: no ``scipy.spatial`` import, exact neighbours, so about 4 % of the nearest
#: starts and a third of the restart rank sets differ from the default's; measured in
#: issue 15, see benchmarks/bench_ik.py ``--seeds``).
SEARCH = "kdtree"


class ExactSearch:
    """Exact k nearest neighbours (Euclidean) of query rows among ``data`` (N, d), numpy only:
    squared distances ``|x|^2 - 2 x.c + |c|^2`` by one matrix product per block of queries,
    ``k + 8`` candidates per row by partial sort, then the candidates' distances recomputed
    directly and sorted (ties by index), so the answer is that of ``cKDTree.query`` with
    ``eps = 0`` (tested). Same call and return shapes as ``cKDTree.query``."""

    BLOCK = 512  # query rows per matrix product (memory: BLOCK x N doubles)

    def __init__(self, data: np.ndarray) -> None:
        self.data = np.ascontiguousarray(data, dtype=np.float64)
        self.norms = np.einsum("ij,ij->i", self.data, self.data)

    def query(self, x: np.ndarray, k: int = 1, eps: float = 0.0, workers: int = 1):
        """(distances, indices), shapes (m,) for k = 1, else (m, k); ``eps`` and ``workers``
        are accepted for cKDTree's signature and ignored (the search is exact)."""
        x = np.atleast_2d(np.asarray(x, dtype=np.float64))
        m, n = x.shape[0], self.data.shape[0]
        kc = min(n, k + 8)
        dist = np.empty((m, k))
        idx = np.empty((m, k), dtype=np.intp)
        for a in range(0, m, self.BLOCK):
            xb = x[a:a + self.BLOCK]
            d2 = self.norms[None, :] - 2.0 * (xb @ self.data.T)
            cand = (np.argpartition(d2, kc - 1, axis=1)[:, :kc] if kc < n
                    else np.broadcast_to(np.arange(n), (xb.shape[0], n)))
            diff = self.data[cand] - xb[:, None, :]
            dc = np.einsum("mkd,mkd->mk", diff, diff)
            order = np.lexsort((cand, dc), axis=1)[:, :k]
            idx[a:a + self.BLOCK] = np.take_along_axis(cand, order, axis=1)
            dist[a:a + self.BLOCK] = np.sqrt(np.take_along_axis(dc, order, axis=1))
        return (dist[:, 0], idx[:, 0]) if k == 1 else (dist, idx)


def codebook(kern: IkKernel, size: int, cols: tuple[int, ...] = tuple(range(12))):
    """Seeded random configurations within the limits and a search structure of their poses
    (:data:`SEARCH`)."""
    cache = kern.__dict__.setdefault("_codebooks", {})
    key = (size, cols) if SEARCH == "kdtree" else (size, cols, SEARCH)
    hit = cache.get(key)
    if hit is None:
        rng = np.random.default_rng(12345)
        lo = np.where(np.isfinite(kern.lower_v), kern.lower_v, -np.pi)
        hi = np.where(np.isfinite(kern.upper_v), kern.upper_v, np.pi)
        qs = rng.uniform(lo, hi, size=(size, kern.iv.size))
        if kern.coupling is not None:
            q = kern.coupling.full(qs)
        else:
            q = np.zeros((size, kern.n))
            q[:, kern.iv] = qs
        T = kern.end_effector(kern.kinematics(q))
        feats = np.concatenate([T[:, :3, 3], 0.5 * T[:, :3, :3].reshape(size, 9)], axis=1)
        if SEARCH == "kdtree":
            from scipy.spatial import cKDTree

            hit = (qs, cKDTree(feats[:, list(cols)]))
        else:
            hit = (qs, ExactSearch(feats[:, list(cols)]))
        cache[key] = hit
    return hit

