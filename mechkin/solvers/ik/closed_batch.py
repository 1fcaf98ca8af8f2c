"""The lone target's restarts inside a batch of closed-chain targets (issue 24).

:func:`mechkin.solvers.ik.solve.solve_ik` restarts a closed-chain target from a seeded jitter
of its start (random joints seldom assemble); :func:`mechkin.solvers.ik.solve.solve_ik_batch`
restarts failed rows from seeded random joints within the limits. So that a target gets the
same status alone and in a batch, the batch also runs the lone jitter on the rows still failed
(:func:`jitter_pass`), and a lone target that still fails runs the batch's restarts
(:func:`mechkin.solvers.ik.chain.solve_ik_warm`); each keeps the better answer (a better
status, then a lower f: :func:`mechkin.solvers.ik.results.better`). The batch's random restart
k starts every row from the same joints (:func:`random_start`), so a row's restarts do not
depend on which other rows failed.

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. May import
:mod:`mechkin.solvers.ik.kernel`, :mod:`mechkin.solvers.ik.lm` and
:mod:`mechkin.solvers.ik.results`; never ``io/``, ``cli/`` or ``tasks/``.
"""

from __future__ import annotations

import numpy as np

from mechkin.solvers.ik.kernel import IkKernel
from mechkin.solvers.ik.lm import lm_batch
from mechkin.solvers.ik.results import IkOptions, better

JITTER = 0.02  # share of each independent joint's range (at most a turn) of the lone jitter


def _ranges(kern: IkKernel) -> tuple[np.ndarray, np.ndarray]:
    lo = np.where(np.isfinite(kern.lower_v), kern.lower_v, -np.pi)
    hi = np.where(np.isfinite(kern.upper_v), kern.upper_v, np.pi)
    return lo, hi


def jitter_starts(kern: IkKernel, q_v0: np.ndarray, seed: int, k: int) -> np.ndarray:
    """(k, n_v): the lone lm restarts of a closed chain about ``q_v0`` (the draws of
    :func:`mechkin.solvers.ik.solve.solve_ik`: ``default_rng(seed).normal(0, JITTER, (k,
    n_v))`` times each range, projected onto the limits)."""
    lo, hi = _ranges(kern)
    d = np.random.default_rng(seed).normal(0.0, JITTER, size=(k, kern.iv.size))
    return kern.project(q_v0 + d * np.minimum(hi - lo, 2 * np.pi))


def random_start(kern: IkKernel, seed: int, k: int) -> np.ndarray:
    """(n_v,): the start of a closed-chain batch's random restart ``k``, within the limits,
    the same for every row."""
    lo, hi = _ranges(kern)
    return np.random.default_rng([seed, k]).uniform(lo, hi)


def jitter_pass(kern: IkKernel, q_v0: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
                w: np.ndarray, opts: IkOptions) -> dict:
    """The lone jitter restarts of rows (m,) of a batch, all in one lm call: per row the
    restart of lowest f among those whose loops close (as the lone solve picks it). Returns
    the lm fields (q, f, converged, closed, gnorm) of the chosen rows and the iterations."""
    m, k = T_P.shape[0], opts.restarts
    starts = np.concatenate([jitter_starts(kern, q_v0[i], opts.seed, k) for i in range(m)])
    rep = np.repeat(np.arange(m), k)
    r = lm_batch(kern, starts, q_w0[rep], T_P[rep], w[rep], opts)
    fr = np.where(r["closed"], r["f"], np.inf).reshape(m, k)
    b = np.where(np.isfinite(fr).any(axis=1), np.argmin(fr, axis=1), 0) + k * np.arange(m)
    out = {key: r[key][b] for key in ("q", "f", "converged", "closed", "gnorm")}
    out["iters"] = r["iters"].reshape(m, k).max(axis=1)
    return out


def better_rows(st_new: np.ndarray, f_new: np.ndarray, st_old: np.ndarray, f_old: np.ndarray
                ) -> np.ndarray:
    """(m,) bool: rows whose new answer beats the old (:func:`mechkin.solvers.ik.results.
    better`: a better status, then a lower f)."""
    return np.array([better({"status": a, "f": fa}, {"status": b, "f": fb})
                     for a, fa, b, fb in zip(st_new, f_new, st_old, f_old, strict=True)],
                    dtype=bool)
