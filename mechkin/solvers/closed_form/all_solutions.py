"""Every closed-form solution of one precision point, verified like the numerical ones.

Every branch of :func:`mechkin.solvers.closed_form.recognise.closed_form_solutions` (direct
drive: every sign of kim1995's appendix; Stewart and lee: the leg lengths), each closed by the
loop closure and verified, merged and ordered by
:mod:`mechkin.solvers.ik.all_solutions` (same tolerances, same :class:`IkSolutions`).

Design
------
Part of the closed-form room :mod:`mechkin.solvers.closed_form`, which builds on the IK room:
may import :mod:`mechkin.solvers.ik` and :mod:`mechkin.model`; never ``io/``, ``cli/`` or
``tasks/``.

References
----------
kim1995_complex_chain_ik §5.2 and appendix 1 (direct drive), §6.2 (Stewart).
"""

from __future__ import annotations

import time

import numpy as np

from mechkin.model.closure import solve_closure
from mechkin.model.mechanism import Mechanism
from mechkin.solvers.closed_form.recognise import closed_form_solutions
from mechkin.solvers.ik.all_solutions import (
    SAME_TOL,
    TOL_ORI_ALL,
    TOL_POS_ALL,
    IkSolutions,
    _finish,
)

__all__ = ["IkSolutions", "closed_form_all"]


def closed_form_all(mech: Mechanism, T_P: np.ndarray, kind: str, *,
                    q_w0: np.ndarray | None = None, ref: np.ndarray | None = None,
                    extra: np.ndarray | None = None, weights: np.ndarray | None = None,
                    tol_pos: float = TOL_POS_ALL, tol_ori: float = TOL_ORI_ALL,
                    same_tol: float = SAME_TOL) -> IkSolutions:
    """Every closed-form solution of T_P (4, 4) (closed form ``kind``), loops closed from
    ``q_w0`` (default home), verified, merged and ordered from ``ref`` (default home);
    ``extra`` (k, n) are further candidates (e.g. the primary solution)."""
    t0 = time.perf_counter()
    iv, iw = mech.independent, mech.dependent
    T_P = np.asarray(T_P, dtype=np.float64).reshape(4, 4)
    qw0 = mech.home[iw] if q_w0 is None else np.asarray(q_w0, float)
    ref = mech.home[iv] if ref is None else np.asarray(ref, float)
    w = np.ones(6) if weights is None else np.asarray(weights, float)
    qv = closed_form_solutions(mech, T_P[None], kind, tol=1e-6)[0]
    cands = [np.zeros((0, mech.n))]
    if len(qv):
        res = solve_closure(mech, qv, np.broadcast_to(qw0, (len(qv), iw.size)))
        cands.append(res.q)
    if extra is not None:
        cands.append(np.asarray(extra, float).reshape(-1, mech.n))
    q = np.vstack(cands)
    return _finish(mech, q, T_P, w, ref, tol_pos, tol_ori, same_tol, "closed-form", len(q), t0)
