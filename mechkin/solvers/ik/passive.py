r"""Passive-joint limits of closed chains as constraints of every IK answer (issue 24).

The lm iteration (:mod:`mechkin.solvers.ik.lm`, numpy and compiled) holds the dependent
(passive) joints on their limits to first order and accepts trials whose loop closure lands up
to ``PASSIVE_BAND`` of a range beyond one. :func:`restore_onto_limits` then brings such an
answer back onto the limits exactly: Newton steps in q_v on the crossed joints alone (Rosen's
restoration, Arora 1989 §11),

.. math:: S_{act}\,\delta = q_{w,act} - q_{w,lim},\qquad q_v \leftarrow q_v + \delta

(minimum-norm ``delta``, each step moving an independent joint by at most
:data:`MAX_STEP_RESTORE`; ``dq_w/dq_v = -S``, kim1995 Eq. (10)), the loop closure re-solved
after each step, until every passive joint is within its limits to :data:`TOL_RESTORE`. A row
that cannot be restored (a locked passive chain, an independent joint at its own limit) is
reported, never returned as inside.

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. May import
:mod:`mechkin.solvers.ik.kernel` and :mod:`mechkin.model`; never ``io/``, ``cli/`` or
``tasks/``.
"""

from __future__ import annotations

import numpy as np

from mechkin.model.continuation import within_limits
from mechkin.solvers.ik.kernel import IkKernel, evaluate

TOL_RESTORE = 1e-11  # [rad | m] a restored passive joint is this close to (or inside) its limit
MAX_ITER_RESTORE = 30
MAX_STEP_RESTORE = 0.2  # largest move of an independent joint per step [rad, or x L for m]


def passive_violation(kern: IkKernel, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per row of q (m, n): q with revolute passive joints moved by whole turns into their
    limits where possible, and the signed excess (m, n_w) of each passive joint beyond its
    limits (positive: above the upper limit; negative: below the lower; 0 inside)."""
    qm, _ = within_limits(kern.mech, q, tol=0.0)
    x = qm[:, kern.iw]
    with np.errstate(invalid="ignore"):
        ex = np.where(x > kern.hi_w, x - kern.hi_w, np.where(x < kern.lo_w, x - kern.lo_w, 0.0))
    return qm, np.nan_to_num(ex, nan=np.inf)


def restore_onto_limits(kern: IkKernel, q: np.ndarray, T_P: np.ndarray, closed: np.ndarray,
                        tol_phi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows of q (m, n) (loops closed where ``closed``) whose passive joints are beyond their
    limits brought onto them (see the module docstring).

    Returns
    -------
    q (m, n), x (m, 6) or None, inside (m,) bool
        The restored joints, the Euler-parameter residual of {E} to T_P at the restored rows
        (None when no row moved; rows not restored keep NaN), and per row whether every passive
        joint is within its limits (to ``TOL_RESTORE``) with the loops closed.
    """
    q = np.array(q, dtype=np.float64)
    m = q.shape[0]
    if not kern.passive_bounded or m == 0:
        return q, None, closed.copy()
    qm, ex = passive_violation(kern, q)
    bad = closed & (np.abs(ex) > TOL_RESTORE).any(axis=1)
    inside = closed & ~bad
    if not bad.any():
        return q, None, inside
    rows = np.flatnonzero(bad)
    qr = qm[rows]
    act = np.abs(ex[rows]) > TOL_RESTORE
    x_all = np.full((m, 6), np.nan)
    q_out = q.copy()
    lo_v, hi_v = kern.bound_lo, kern.bound_hi
    from mechkin.model.singularity import characteristic_length

    unit = np.where(kern.mech.s[kern.iv] == 1, characteristic_length(kern.mech), 1.0)
    for _ in range(MAX_ITER_RESTORE):
        ev = evaluate(kern, qr[:, kern.iv], qr[:, kern.iw], T_P[rows], tol_phi=tol_phi)
        qr = np.where(ev.closed[:, None], ev.q, qr)
        qr_m, exr = passive_violation(kern, qr)
        qr = qr_m
        act |= np.abs(exr) > TOL_RESTORE
        done = ev.closed & ~(np.abs(exr) > TOL_RESTORE).any(axis=1)
        x_all[rows[done]] = ev.x[done]
        q_out[rows[done]] = qr[done]
        inside[rows[done]] = True
        keep = ~done & ev.closed
        if not keep.any():
            break
        rows, qr, act, exr, S = rows[keep], qr[keep], act[keep], exr[keep], ev.S[keep]
        qv = qr[:, kern.iv]
        for i in range(rows.size):
            a = act[i]
            lim = np.where(exr[i] > 0, kern.hi_w, kern.lo_w)
            cur = qr[i, kern.iw]
            # joints active but now inside stay where they are
            tgt = np.where(exr[i] != 0, lim, np.clip(cur, kern.lo_w, kern.hi_w))
            # independent joints on their own limits keep still where the step pushes them out
            free = np.ones(kern.iv.size, dtype=bool)
            d = np.zeros(kern.iv.size)
            for _ in range(kern.iv.size):
                d[:] = 0.0
                d[free] = np.linalg.lstsq(S[i][a][:, free], (cur - tgt)[a], rcond=None)[0]
                out = free & (((qv[i] <= lo_v) & (d < 0)) | ((qv[i] >= hi_v) & (d > 0)))
                if not out.any():
                    break
                free &= ~out
                if not free.any():
                    d[:] = 0.0
                    break
            big = np.max(np.abs(d) / unit) / MAX_STEP_RESTORE
            if big > 1.0:  # far from the limit (a flat closure): capped steps, not a jump
                d /= big
            qv[i] = np.clip(qv[i] + d, lo_v, hi_v)
            qr[i, kern.iw] = cur - S[i] @ d  # first-order predictor of the closure
        qr[:, kern.iv] = qv
    return q_out, x_all, inside


def restore_one(kern: IkKernel, qv: np.ndarray, qw: np.ndarray, T_P: np.ndarray,
                w: np.ndarray, f: float, tol_phi: float
                ) -> tuple[np.ndarray, np.ndarray, float, bool]:
    """One answer (q_v (n_v,), q_w (n_w,)) with objective f brought onto its passive limits
    (:func:`restore_onto_limits`): (q_v, q_w, f, inside)."""
    q = np.empty(kern.n)
    q[kern.iv], q[kern.iw] = qv, qw
    qr, x, inside = restore_onto_limits(kern, q[None], T_P[None], np.array([True]), tol_phi)
    if x is not None and np.isfinite(x[0]).all():
        f = 0.5 * float(x[0] @ (w * x[0]))
    return qr[0, kern.iv], qr[0, kern.iw], f, bool(inside[0])
