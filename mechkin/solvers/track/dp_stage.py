r"""One stage of the DPCT recursion and the backward pass over all stages (park Eq. (25)-(30)).

The numpy stage (``_dp_stage``), the compiled stage (``_dp_stage_compiled`` through
:mod:`mechkin.solvers.track.dp_jit`, the same tables bit for bit) with its rent-or-buy choice
(:func:`use_compiled_dp`), and the backward pass ``_run_dp`` that fills the cost-to-go, next-state
and node-time tables. The readings of park §4 that these implement are listed in
:mod:`mechkin.solvers.track.dpct`, which builds the problem and realises the plan.

Part of the track room :mod:`mechkin.solvers.track`; imports numpy, the track problem and limit
modules and, lazily, the compiled stage.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass

import numpy as np

from mechkin.solvers.result import stop_point
from mechkin.solvers.track.dp_limits import (
    _diagnose,
    _joint_names,
    _slack,
    _Stage,
    _transition_checks,
    _within,
)
from mechkin.solvers.track.dp_problem import (
    DEFAULT_DP,
    INTERCEPT_TIE,
    LIMIT_RTOL,
    STEADY_TOL,
    DPOptions,
    step_arrays,
    wait_cost,
)
from mechkin.solvers.track.path import PhaseCoefficients

logger = logging.getLogger(__name__)


@dataclass
class _DPTables:
    V: np.ndarray  # (N1+1, N2+1) cost-to-go J*
    NP: np.ndarray  # (N1, N2+1) next state
    T: np.ndarray  # (N1+1, N2+1) node time
    blocked: tuple[int, list[str]] | None


def _run_dp(
    pc: PhaseCoefficients,
    limits: dict[str, tuple[np.ndarray, np.ndarray]],
    x2: np.ndarray,
    j_end: int,
    t_end: float,
    reference: tuple[float, float] | None,
    mu: float = 0.0,
    intercept: bool = False,
    opts: DPOptions = DEFAULT_DP,
) -> _DPTables:
    """Backward recursion of park Eq. (25)-(30) with time-to-go bookkeeping (Eq. (27)).

    ``reference`` is ``(r0, x~2)`` for the tracking cost (Eq. (28)); None for minimum time.
    ``mu`` adds ``mu dt`` to the tracking cost (reading 9 of the module docstring);
    ``intercept`` replaces the cost by the time off the part (reading 10); ``opts`` selects the
    step time, the wait cost and the end jerk checks (:class:`DPOptions`).
    """
    N1 = pc.r.shape[0] - 1
    N2 = x2.shape[-1] - 1
    n = pc.a.shape[1]
    dx1 = 1.0 / N1
    band = x2.ndim == 2  # (N1+1, N2+1): each stage its own states (the time-optimal band)
    V = np.full((N1 + 1, N2 + 1), np.inf)
    T = np.full((N1 + 1, N2 + 1), np.nan)
    NP = np.zeros((N1, N2 + 1), dtype=np.int64)

    # end node (park Eq. (23)): torque with r'' = 0 and velocity must hold there too
    end_fail: list[str] = []
    x_end = x2[N1, j_end] if band else x2[j_end]
    if "torque" in limits:
        U = pc.b[N1] * x_end**2 + pc.g[N1]
        end_fail += _joint_names(~_within(U, *limits["torque"]), "torque")
    if "qd" in limits:
        end_fail += _joint_names(~_within(pc.dq[N1] * x_end, *limits["qd"]), "qd")
    if end_fail:
        return _DPTables(V, NP, T, (N1, end_fail))
    V[N1, j_end] = 0.0
    T[N1, j_end] = t_end
    qdd_next = np.full((N2 + 1, n), np.nan)  # no successor after the end node: no jerk check
    if opts.jerk_ends:  # the motion after the end node: on the part (r'' = 0) or at rest
        qdd_next[j_end] = pc.ddq[N1] * x_end**2  # park Eq. (11)

    compiled = N1 > 1 and use_compiled_dp((N1 - 1) * (N2 + 1) ** 2)

    def stage(x_from: np.ndarray, x_to: np.ndarray) -> _Stage:
        dt, inv_dt, rdd = step_arrays(x_from[:, None], x_to[None, :], dx1, opts.step_time)
        s = _Stage(x2=x_from, dt=dt, inv_dt=inv_dt, rdd=rdd, x2_to=x_to if band else None)
        if compiled:  # r'' grows with l on every row (x2 ascending): the kernel's window
            s.rdd_sorted = bool(np.all(np.diff(rdd, axis=1) >= 0.0))
        return s

    st = None if band else stage(x2, x2)
    for i in range(N1 - 1, -1, -1):
        stop_point()  # between two stages: the caller's --max-time
        if band:
            st = stage(x2[i], x2[i + 1])
        assert st is not None
        out = None
        if compiled and i >= 1:
            out = _dp_stage_compiled(i, pc, limits, st, V, T, NP, qdd_next, reference, mu,
                                     intercept)
        if out is None:  # numpy: stage 0, no numba, or a dead stage (the diagnosis)
            with np.errstate(invalid="ignore"):  # inf * 0 of rest-to-rest pairs, masked out
                out = _dp_stage(i, pc, limits, st, V, T, NP, qdd_next, reference, mu,
                                intercept, opts)
        if isinstance(out, list):
            return _DPTables(V, NP, T, (i, out))
        qdd_next = out
    return _DPTables(V, NP, T, None)


#: Rent or buy for the compiled DP stage (:mod:`mechkin.solvers.track.dp_jit`): the numpy
#: stage costs about ``NUMPY_PAIR_S`` per ``(j, l)`` pair (and joint limit family); loading the
#: compiled kernel (numba import and cache load) about ``COMPILED_LOAD_S`` once per process.
#: Measured 2026-12-03 (2 cores, load ~10, numba 0.68, warm cache): park time-optimal 50 x 500
#: (12.3 M pairs, torque limits) numpy 1.3 s; numba import + cache load ~0.4 s.
NUMPY_PAIR_S = 1.0e-7
COMPILED_LOAD_S = 0.5
_dp_spent = [0.0]  # estimated numpy DP seconds so far in this process
_dp_loaded = [False]


def use_compiled_dp(pairs: int) -> bool:
    """Whether a DP of ``pairs`` transition pairs (all stages) runs the compiled stage.

    False without numba or with ``MECHKIN_JIT=0``; True with ``MECHKIN_JIT=1`` or once the
    kernel is loaded in this process; else when the numpy DP time of this process so far plus
    this call's estimate exceeds the load cost (rent or buy; the estimate counts pairs, never
    measured time, so the choice does not depend on the machine's load). Both back ends give
    the same tables bit for bit, so the choice never changes a result."""
    from mechkin.solvers.ik import accel

    if not accel.compiled_lm_available():
        return False
    if _dp_loaded[0] or os.environ.get("MECHKIN_JIT") == "1":
        return True
    est = pairs * NUMPY_PAIR_S
    if _dp_spent[0] + est > COMPILED_LOAD_S:
        return True
    _dp_spent[0] += est
    return False


def _slackened(limits: dict[str, tuple[np.ndarray, np.ndarray]]
               ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each limit family's bounds with their round-off slack, ``lo - _slack(lo)`` and
    ``hi + _slack(hi)`` per joint (the numpy stage's expressions, element for element)."""
    return {fam: (np.asarray(lo) - _slack(np.asarray(lo)), np.asarray(hi) + _slack(np.asarray(hi)))
            for fam, (lo, hi) in limits.items()}


def _dp_stage_compiled(
    i: int,
    pc: PhaseCoefficients,
    limits: dict[str, tuple[np.ndarray, np.ndarray]],
    st: _Stage,
    V: np.ndarray,
    T: np.ndarray,
    NP: np.ndarray,
    qdd_next: np.ndarray,
    reference: tuple[float, float] | None,
    mu: float = 0.0,
    intercept: bool = False,
) -> np.ndarray | None:
    """:func:`_dp_stage` for a stage ``i >= 1`` by the compiled kernel (same tables bit for
    bit). The per-row bounds are computed here with the numpy stage's expressions. Returns the
    chosen accelerations, or None when no state survives (the numpy stage then redoes the
    stage and names the blocking limits)."""
    from mechkin.solvers.track import dp_jit

    _dp_loaded[0] = True
    x2 = st.x2
    J = x2.shape[0]
    n = pc.a.shape[1]
    row_ok = np.ones(J, dtype=np.bool_)
    tq_lo = np.zeros((J, n))
    tq_hi = np.zeros((J, n))
    tq_on = np.zeros(n, dtype=np.bool_)
    sl = _slackened(limits)
    z = np.zeros(n)
    qd_j = pc.dq[i][None, :] * x2[:, None]  # park Eq. (10), (4)'
    if "torque" in limits:
        lo, hi = sl["torque"]
        c = pc.b[i][None, :] * (x2**2)[:, None] + pc.g[i][None, :]  # Eq. (12) without r''
        a = pc.a[i]
        on = a != 0.0
        if np.any(~on):
            row_ok &= np.all((c[:, ~on] >= lo[~on]) & (c[:, ~on] <= hi[~on]), axis=1)
        if np.any(on):
            b1 = (lo[on] - c[:, on]) / a[on]
            b2 = (hi[on] - c[:, on]) / a[on]
            tq_lo[:, on], tq_hi[:, on] = np.minimum(b1, b2), np.maximum(b1, b2)
            tq_on[:] = on
    if "qd" in limits:
        lo, hi = sl["qd"]
        row_ok &= np.all((qd_j >= lo) & (qd_j <= hi), axis=1)
    bounds = {fam: sl.get(fam, (z, z)) for fam in ("qdd", "jerk")}
    if reference is None:
        mode, r0, rd_ref = dp_jit.MODE_TIME, 0.0, 0.0
    else:
        mode = dp_jit.MODE_INTERCEPT if intercept else dp_jit.MODE_TRACKING
        r0, rd_ref = reference
    V_i = np.empty(J)
    T_i = np.empty(J)
    NP_i = np.empty(J, dtype=np.int64)
    qdd_new = np.empty((J, n))
    alive = dp_jit.dp_stage(
        x2, st.x2c, st.dt, st.inv_dt, st.rdd, np.ascontiguousarray(V[i + 1]),
        np.ascontiguousarray(T[i + 1]), row_ok, tq_lo, tq_hi, tq_on, qd_j,
        np.ascontiguousarray(pc.dq[i + 1]), np.ascontiguousarray(pc.dq[i]), "qdd" in limits,
        bounds["qdd"][0], bounds["qdd"][1], "jerk" in limits, bounds["jerk"][0],
        bounds["jerk"][1], np.ascontiguousarray(qdd_next, dtype=np.float64), mode,
        float(pc.r[i]), float(r0), float(rd_ref), float(mu), -LIMIT_RTOL, STEADY_TOL,
        INTERCEPT_TIE, st.rdd_sorted, V_i, T_i, NP_i, qdd_new)
    if alive == 0:
        return None
    V[i] = V_i
    T[i] = T_i
    NP[i] = NP_i
    return qdd_new


def _dp_stage(
    i: int,
    pc: PhaseCoefficients,
    limits: dict[str, tuple[np.ndarray, np.ndarray]],
    st: _Stage,
    V: np.ndarray,
    T: np.ndarray,
    NP: np.ndarray,
    qdd_next: np.ndarray,
    reference: tuple[float, float] | None,
    mu: float = 0.0,
    intercept: bool = False,
    opts: DPOptions = DEFAULT_DP,
) -> np.ndarray | list[str]:
    """One stage of park Eq. (25)-(30), all ``(j, l)`` pairs at once; fills row i of V, T, NP.

    Returns the accelerations ``qdd (N2+1, n)`` of the chosen transitions (for the jerk check of
    stage i-1), or the names of the blocking limits if no state of stage i survives.
    """
    N2 = st.x2.shape[0] - 1
    rows = slice(0, 1) if i == 0 else slice(0, N2 + 1)  # stage 0: only the rest state
    x2j = st.x2[rows]
    dt = st.dt[rows]
    qdd_prev = np.zeros(pc.a.shape[1]) if (i == 0 and opts.jerk_ends) else None  # from rest
    ok, _ = _transition_checks(limits, pc, i, rows, st, qdd_next, False, qdd_prev)
    base = np.isfinite(V[i + 1])[None, :] & np.isfinite(dt)
    ok &= base
    t = T[i + 1][None, :] - dt  # park Eq. (27): time at (i, j) via (i+1, l)
    if reference is not None:
        r0, rd_ref = reference
        start_ok = t >= -LIMIT_RTOL  # no earlier than t_0 = 0 (park Eq. (2))
        ok &= start_ok
        e1 = pc.r[i] - (r0 + rd_ref * t)  # park Eq. (17) at t(i, j)
        e2 = (x2j - rd_ref)[:, None]
        stage_cost = dt * (e1 * e1 + e2 * e2 + mu)  # park Eq. (28) (+ mu dt, reading 9)
        if intercept:  # reading 10: time off the part, the tracking cost breaks ties
            on = (np.abs(e1) <= STEADY_TOL) & (np.abs(e2) <= STEADY_TOL)
            stage_cost = dt * (np.where(on, 0.0, 1.0) + mu) + INTERCEPT_TIE * stage_cost
            if i == 0:
                stage_cost = stage_cost + np.maximum(t, 0.0)  # the wait before t(0, 0)
        elif i == 0 and opts.wait_cost:  # Eq. (18) from t_0 = 0: the wait at rest is costed
            stage_cost = stage_cost + wait_cost(t, r0, rd_ref)
    else:
        stage_cost = dt  # minimum time
    cost = np.where(ok, stage_cost + V[i + 1][None, :], np.inf)  # park Eq. (29)
    best = np.argmin(cost, axis=1)  # park Eq. (30); NP(i, j)
    jj = np.arange(cost.shape[0])
    V[i, rows] = cost[jj, best]
    NP[i, rows] = best
    T[i, rows] = np.where(np.isfinite(V[i, rows]), t[jj, best], np.nan)
    if not np.any(np.isfinite(V[i, rows])):
        _, masks = _transition_checks(limits, pc, i, rows, st, qdd_next, True, qdd_prev)
        if reference is not None:
            masks["start"] = start_ok
        return _diagnose(masks, base)
    qdd_new = np.full((N2 + 1, pc.a.shape[1]), np.nan)
    dqd = pc.dq[i + 1] * st.x2c[best][:, None] - pc.dq[i] * x2j[:, None]
    qdd_new[rows] = dqd * st.inv_dt[rows][jj, best][:, None]  # park Eq. (32), chosen transitions
    return qdd_new
