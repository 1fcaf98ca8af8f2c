r"""Compiled DP stage of the DPCT recursion (optional accelerator, needs ``numba``).

One stage ``i >= 1`` of :func:`mechkin.solvers.track.dpct._dp_stage` (park Eq. (25)-(30)) as
plain loops over the ``(j, l)`` transition pairs, compiled by numba
(``pip install "mechkin[fast]"``). The numpy stage builds ``(N2+1)^2`` arrays per limit and
per joint; this kernel visits each pair once, skips it at the first failed check and keeps the
running minimum; with torque limits it visits only the window of ``l`` whose ``r''`` the
torque admits (a binary search per row: ``r''`` grows with ``l``). It evaluates every quantity with
the same floating-point operations in the
same order as the numpy stage (no fast-math, no contraction), and breaks ties the way
``np.argmin`` does (the first minimum; a NaN cost wins at once), so the tables V, T, NP and the
chosen accelerations are bit for bit those of the numpy stage
(tests/solvers/test_dpct_jit.py checks it on every bundled DP case).

What stays numpy (:mod:`mechkin.solvers.track.dpct`): stage 0 (one row, the departure from
rest, the wait cost and the jerk from rest), the per-row bounds (torque as an interval of
``r''``, velocity and torque rows where ``a = 0``), and the diagnosis of a stage that dies.

Design
------
Part of the track room :mod:`mechkin.solvers.track`; imports numpy, numba and
:mod:`mechkin.solvers.ik.accel` (the shared cache folder); never ``io/``, ``cli/`` or
``tasks/``. Imported lazily by :mod:`mechkin.solvers.track.dpct` (rent or buy:
:func:`mechkin.solvers.track.dpct.use_compiled_dp`).
"""

from __future__ import annotations

from mechkin.solvers.ik.accel import configure_numba_cache

configure_numba_cache()  # before numba reads NUMBA_CACHE_DIR

import numba  # noqa: E402
import numpy as np  # noqa: E402

MODE_TIME, MODE_TRACKING, MODE_INTERCEPT = 0, 1, 2


@numba.njit(cache=True, nogil=True)
def dp_stage(x2, x2c, dt, inv_dt, rdd, Vn, Tn, row_ok, tq_lo, tq_hi, tq_on, qd_j, dq_next, dq_i,
             use_qdd, qdd_lo, qdd_hi, use_jerk, jerk_lo, jerk_hi, qdd_next, mode, r_i, r0,
             rd_ref, mu, start_tol, steady_tol, tie, sorted_rdd, V_out, T_out, NP_out, qdd_out):
    """All rows ``j`` of one stage: ``V_out[j] = min_l cost(j, l)``, its ``l`` (NP), the node
    time and the chosen transition's joint accelerations (park Eq. (27)-(30), (32)).

    ``x2 (J,)`` the states of stage i, ``x2c (L,)`` those of stage i+1 (the same array on the
    uniform grid; a band grid differs). ``row_ok (J,)``: the per-row checks (velocity, torque rows
    with ``a = 0``);
    ``tq_lo/tq_hi (J, n)``: the admissible ``r''`` interval per joint where ``tq_on[k]``;
    bounds already carry their round-off slack. ``sorted_rdd``: every row of ``rdd`` is
    non-decreasing in ``l`` (the caller checks it), so the pairs outside the torque window
    ``max_k tq_lo <= r'' <= min_k tq_hi`` (which fail the torque check) are never visited.
    Returns the number of rows with a finite V.
    """
    J = V_out.shape[0]
    L = Vn.shape[0]
    n = dq_i.shape[0]
    inf = np.inf
    alive = 0
    v_from, v_to = L, 0  # the successors with a finite cost-to-go: only they can be chosen
    for l in range(L):  # noqa: E741 (l: the successor index of the DP's notation)
        if np.isfinite(Vn[l]):
            v_from = min(v_from, l)
            v_to = l + 1
    for j in range(J):
        best = 0
        bestv = inf
        x2j = x2[j]
        e2 = x2j - rd_ref
        l_from, l_to = 0, L
        if sorted_rdd and row_ok[j]:  # the torque window of r'': a contiguous range of l
            lo_b = -inf
            hi_b = inf
            for k in range(n):
                if tq_on[k]:
                    lo_b = max(lo_b, tq_lo[j, k])
                    hi_b = min(hi_b, tq_hi[j, k])
            if lo_b == lo_b and hi_b == hi_b:  # no NaN bound: search the window
                a_, b_ = 0, L  # first l with rdd[j, l] >= lo_b
                while a_ < b_:
                    m = (a_ + b_) // 2
                    if rdd[j, m] >= lo_b:
                        b_ = m
                    else:
                        a_ = m + 1
                l_from = a_
                a_, b_ = l_from, L  # first l with rdd[j, l] > hi_b
                while a_ < b_:
                    m = (a_ + b_) // 2
                    if rdd[j, m] > hi_b:
                        b_ = m
                    else:
                        a_ = m + 1
                l_to = a_
        l_from = max(l_from, v_from)
        l_to = min(l_to, v_to)
        if row_ok[j]:
            for l in range(l_from, l_to):  # noqa: E741
                vn = Vn[l]
                d = dt[j, l]
                if not (np.isfinite(vn) and np.isfinite(d)):
                    continue
                a = rdd[j, l]
                ok = True
                for k in range(n):
                    if tq_on[k] and not (a >= tq_lo[j, k] and a <= tq_hi[j, k]):
                        ok = False
                        break
                if not ok:
                    continue
                if use_qdd or use_jerk:
                    w = inv_dt[j, l]
                    for k in range(n):
                        qdd = (dq_next[k] * x2c[l] - qd_j[j, k]) * w
                        if use_qdd and not (qdd >= qdd_lo[k] and qdd <= qdd_hi[k]):
                            ok = False
                            break
                        if use_jerk:
                            jerk = (qdd_next[l, k] - qdd) * w
                            if jerk < jerk_lo[k] or jerk > jerk_hi[k]:
                                ok = False
                                break
                    if not ok:
                        continue
                if mode == MODE_TIME:
                    c = d + vn
                else:
                    t = Tn[l] - d
                    if not (t >= start_tol):
                        continue
                    e1 = r_i - (r0 + rd_ref * t)
                    sc = d * (e1 * e1 + e2 * e2 + mu)
                    if mode == MODE_INTERCEPT:
                        on = abs(e1) <= steady_tol and abs(e2) <= steady_tol
                        sc = d * ((0.0 if on else 1.0) + mu) + tie * sc
                    c = sc + vn
                if c != c:  # np.argmin: the first NaN
                    best = l
                    bestv = c
                    break
                if c < bestv:
                    best = l
                    bestv = c
        V_out[j] = bestv
        NP_out[j] = best
        if np.isfinite(bestv):
            T_out[j] = Tn[best] - dt[j, best]
            alive += 1
        else:
            T_out[j] = np.nan
        w = inv_dt[j, best]
        for k in range(n):
            qdd_out[j, k] = (dq_next[k] * x2c[best] - dq_i[k] * x2j) * w
    return alive
