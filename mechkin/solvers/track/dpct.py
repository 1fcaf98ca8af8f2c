r"""DPCT: conveyor tracking by dynamic programming in the phase plane (park §3-§4).

The hand moves on a straight line, ``X_h = X_h(t_0) + r [X_h(t_r) - X_h(t_0)]`` (park Eq. (7)), so
the planning state is ``(x1, x2) = (r, r')`` (Eq. (14)-(15)). The part on the belt, mapped onto
the same line, is the reference ``x~1(t) = r0 + x~2 t``, ``x~2 = const`` (Eq. (16)-(17)). The DP
searches an ``N1 x N2`` grid of the phase plane backwards from the end point, minimising the
tracking cost of Eq. (22)/(28) under the torque limits (Eq. (3)) and the smoothness limits on joint
velocity, acceleration and jerk (Eq. (4)-(6), discretised by Eq. (31)-(35)). ``objective="time"``
replaces the cost by the transition time and plans from rest to rest.

How each ambiguous step of park §4 is read (these readings reproduce the §5 numbers that the
stated model can reproduce, see PAPER_NOTES):

1. **Grid** (Eq. (23)-(24)). ``x1[i] = i / N1`` (i = 0..N1) and ``x2[j] = j x~2 / N_t`` (j = 0..N2)
   with ``N_t = round(0.8 N2)``: §4.2 puts N_t at 80-90 % of N2; §5.1's "N1 is 80 % of N2" is OCR
   damage for N_t. The grid top ``x2[N2] = x~2 N2 / N_t`` leaves room for overshoot.
2. **Transition time** (Eq. (26)). ``dt = 2 dx1 / (x2[j] + x2[l])``: Eq. (21) integrated with a
   constant ``r''`` over the transition. It equals Eq. (26)'s ``dx1 / x2[j]`` whenever ``j = l``
   (so the steady state keeps exactly the belt's timing) and, unlike Eq. (26), stays finite when
   the hand leaves rest (``j = 0``); read literally, Eq. (26) also under-estimates the time of a
   decelerating step, which would let the time-optimal DP beat the true optimum. A transition
   between two zero-speed states never advances and is excluded. ``DPOptions(step_time=
   "euler")`` selects the literal Eq. (26) with the forward-Euler ``r'' = (x2[l] - x2[j]) / dt``
   of Eq. (21) (leaving rest keeps the step above: Eq. (26) is infinite there); on park §5 it
   gives the torque-only t_a 0.85 s (default 0.90 s, printed 0.8 s) but 2.95 s with all limits
   (printed 1.1 s): an accelerating step from a low speed takes ``dx1 / x2[j]``.
3. **Torque** (Eq. (12), (21), (3)). ``U = a r'' + b x2[j]^2 + g`` at node ``(x1[i], x2[j])`` with
   ``r'' = (x2[l]^2 - x2[j]^2) / (2 dx1)``; every joint is checked on every transition (§4.3),
   and at the end node with ``r'' = 0`` (the steady state goes on; at rest the arm holds).
4. **Time-to-go bookkeeping** (Eq. (27)). The end node ``(N1, N_t)`` is at ``t_f``, the time
   the reference reaches ``r = 1``; ``t(i, j) = t(i+1, l) - dt``. The part's state in Eq. (28)
   is taken at ``t(i, j)``. The start time ``t(0, 0)`` is therefore an outcome: the hand waits at
   rest at ``r = 0`` until then (the wait lies before the first DP node and is not costed), but it
   may not start before ``t_0 = 0`` (Eq. (2)): transitions whose time would be negative are
   excluded. ``DPOptions(wait_cost=True)`` costs the wait as Eq. (18) integrates from ``t_0``
   (:func:`wait_cost`, added at stage 0 to each candidate start time): park's unconstrained
   peaks become -2.80 / -0.61 N m (default -5.88 / -1.27, printed -1.342 / -0.406).
5. **Cost** (Eq. (22), (28)-(30)). ``J = dt [(x1[i] - x~1(t(i,j)))^2 + (x2[j] - x~2)^2]``, the
   left-point rectangle rule of Eq. (18); ``J*(i,j) = min_l J + J*(i+1,l)``.
6. **Smoothness** (Eq. (4)'-(6)', (31)-(35)). Node velocities ``qd = f'(x1) x2`` (Eq. (10),
   (4)'); ``qdd(k) = (qd(k+1) - qd(k)) / dt`` (Eq. (32), (5)'; the printed (5)' has A_min in
   both bounds: the left one is A_max); ``jerk(k) = (qdd(k+1) - qdd(k)) / dt`` (Eq. (33), (6)')
   where ``qdd(k+1)`` is the acceleration of the transition already chosen for ``(i+1, l)``: this
   is why Eq. (35)'s admissible range of ``x2[j]`` depends on ``x1[i], x1[i+1], x2[l]``. The last
   transition has no successor and the departure from rest no predecessor, so neither has a jerk
   check (``DPOptions(jerk_ends=True)`` checks both: from rest with qdd = 0, into the motion
   after the end node with ``qdd = f''(1) x2_end^2``). With jerk limits the backward recursion
   is optimal given the stored successors (as in the paper), not over all jerk-feasible paths.
7. **Steady state** (§2, §5). ``t_a`` is the time of the first node after which the hand stays on
   the part (``|x1 - x~1| <= 1e-9`` and ``x2 = x~2``); with reading 2 the steady state has zero
   tracking error, and ``t_a`` lies on the grid ``t_f - m dx1 / x~2``.
8. **Joint positions.** ``q = f(r)`` (Eq. (9)) depends on the stage alone, so a node
   ``(x1[i], x2[j])`` whose ``q(x1[i])`` is outside the joint limits is infeasible for every
   ``j``, and one such stage makes the problem infeasible before the search (the message names
   the joint and r). The limits are checked at the nodes, like the others; their usage is the
   distance from the middle of each joint's range as a fraction of its half width.
9. **A part that starts ahead of the hand** (``r~(0) > 0``). The rule ``t >= 0`` of reading 4
   is a bound on the plan's total duration, ``t_f - t(0, 0) <= t_f``, and Bellman's principle
   does not hold for it: a node's time is not part of the state, so each node keeps only its
   cost-optimal tail, and with it a single time. When the part starts ahead, the tails that are
   cost-optimal (they stay close to the part's phase-plane line late in the plan) are slower
   than the hand must be to catch the part, every stage's times then come out negative, and the
   DP -- with no state that remembers a faster tail -- reports the start rule as blocking, even
   without any limit. The bound is therefore relaxed into the cost with a Lagrange multiplier,
   ``J + mu sum dt`` (Eq. (28) plus ``mu dt`` per transition), and the smallest ``mu`` whose
   plan starts at ``t(0, 0) >= 0`` is found by bisection (``time_penalty`` in the result; the
   reported cost is the tracking cost alone). That plan is optimal for ``J + mu T`` among the
   grid's plans, not necessarily for ``J`` alone under ``t >= 0`` (that would need the time in
   the state). When no ``mu`` helps, the grid cannot catch the part by ``r = 1``: its top
   speed ``x2[N2] = x~2 N2 / N_t`` is too low (the message says so).
10. **Intercept** (``objective="intercept"``): the same grid, end node and limits as tracking,
    but the stage cost is the time spent off the part, ``dt [not on the part at (i, j)]``
    (on: ``|x1 - x~1(t)| <= 1e-9`` and ``x2 = x~2``, reading 7), plus the initial wait
    ``t(0, 0)`` at stage 0, so ``J*(0, 0) = t_a``: the earliest steady tracking the grid and
    the limits allow. ``1e-6`` times the tracking cost of Eq. (28) breaks ties between plans
    with the same ``t_a``. Not in park; ``t_a`` of the tracking objective is an upper bound.
11. **Intercept by decomposition**
    (:func:`mechkin.solvers.track.intercept_dp.plan_intercept_dp`, chosen by
    :func:`mechkin.solvers.track.plan.plan_track` when the part starts ahead of the hand or
    the belt accelerates, ``ConveyorReference.belt_acceleration``): reading 10's single pass
    keeps one time per node (reading 9's caveat) and no grid state holds an accelerating
    part's speed. Instead, for an intercept stage the DP's minimum time from rest to the
    part's speed there (this recursion with cost ``dt``, the part's speed exactly on its r'
    grid) is compared with the part's arrival time; the part's own motion from there to
    ``r = 1`` is checked with the same limit model; the earliest qualifying stage is found by
    bisection, then the point inside it. The hand waits at rest for the difference.

The recursion is vectorised over all ``(j, l)`` state pairs of a stage; Python loops run over
stages only. With numba installed, stages ``i >= 1`` run compiled
(:mod:`mechkin.solvers.track.dp_jit`, rent or buy: :func:`use_compiled_dp`), the same tables
bit for bit. ``objective="time"`` then refines r' in a band around the optimal curve
(:func:`_refine_time`, ``refine=False`` turns it off); the tracking and intercept objectives of
park §5 never do. :func:`limit_curve` gives the phase plane's limit curve (the largest ``r'`` the
torque and velocity limits admit at each ``r``) that the realised trajectory carries for the
plots.

References
----------
park_conveyor_tracking_dp, §2-§4, Eq. (1)-(35); §5 for the reproduced cases.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from mechkin.errors import ConfigError
from mechkin.records.track import TrackTrajectory  # re-exported: the realised plan
from mechkin.solvers.dynamics.open_chain import InverseDynamics
from mechkin.solvers.track.dp_limits import (
    _describe,
    _slack,
    _diagnose,
    _joint_names,
    _position_block,
    _reachable_x2_max,
    _Stage,
    _transition_checks,
    _within,
    limit_curve,
    limit_usage,
    position_limit_message,
)
from mechkin.solvers.track.dp_problem import (
    DEFAULT_DP,
    INTERCEPT_TIE,
    LIMIT_RTOL,
    MU_BISECTIONS,
    NT_FRACTION,
    STEADY_TOL,
    ConveyorReference,
    DPGrid,
    DPOptions,
    PartMotion,
    TrackLimits,
    TrackResult,
    TrackStatus,
    resolve_planner,
    step_arrays,
    wait_cost,
)
from mechkin.solvers.track.path import JointPath, PhaseCoefficients, phase_coefficients

# problem records: dp_problem; limit model: dp_limits; public names re-exported from here
__all__ = [
    "DEFAULT_DP", "LIMIT_RTOL", "NT_FRACTION", "ConveyorReference", "DPGrid", "DPOptions",
    "PartMotion", "TrackLimits", "TrackResult", "TrackStatus", "TrackTrajectory", "limit_curve",
    "limit_usage", "position_limit_message", "resolve_planner", "solve_conveyor_tracking",
    "step_arrays", "wait_cost",
]

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


def _time_penalty_search(
    pc: PhaseCoefficients,
    limits: dict[str, tuple[np.ndarray, np.ndarray]],
    x2: np.ndarray,
    j_end: int,
    t_end: float,
    reference: tuple[float, float],
    intercept: bool = False,
    opts: DPOptions = DEFAULT_DP,
) -> tuple[_DPTables, float]:
    """Reading 9: the smallest time penalty ``mu`` (stage cost ``+ mu dt``) whose DP starts at
    ``t(0, 0) >= 0``: a decade scan of ``mu``, then a bisection on ``log mu``. Returns the
    feasible tables and mu, or the tables of the largest mu tried (still blocked) and 0."""
    r0, rd = reference
    scale = r0 * r0 + rd * rd + 1e-12  # the tracking cost per second at the start
    lo, last = 0.0, None
    for k in range(-3, 9):
        mu = scale * 10.0**k
        tab = _run_dp(pc, limits, x2, j_end, t_end, reference, mu, intercept, opts)
        if tab.blocked is None and np.isfinite(tab.V[0, 0]):
            hi, best = mu, tab
            for _ in range(MU_BISECTIONS):
                mid = np.sqrt(lo * hi) if lo > 0.0 else hi / 10.0
                t_mid = _run_dp(pc, limits, x2, j_end, t_end, reference, mid, intercept, opts)
                if t_mid.blocked is None and np.isfinite(t_mid.V[0, 0]):
                    hi, best = mid, t_mid
                else:
                    lo = mid
            return best, hi
        lo, last = mu, tab
    assert last is not None
    return last, 0.0


#: Band refinement of ``objective="time"`` (:func:`_refine_time`): per pass, the half width of
#: the band in its own steps and the factor by which the pass divides the r' step. Chosen on
#: park's torque and torque+qd+qdd cases at 50 x 500 (benchmarks/bench_topp_vs_toppra.py):
#: +1.43 / +0.39 % over TOPP-RA N = 4000 before, +0.47 / +0.07 % after (the torque case's
#: remaining gap is the 50 stages: TOPP-RA at N = 50 is +0.45 %); wider bands or more passes
#: gained < 0.02 %.
REFINE = ((64, 4), (32, 4), (32, 4))


def _path_states(x2: np.ndarray, tab: _DPTables) -> np.ndarray:
    """r' at every stage of the optimal path of ``tab`` (NP followed from (0, 0))."""
    N1 = tab.NP.shape[0]
    js = np.zeros(N1 + 1, dtype=np.int64)
    for i in range(N1):
        js[i + 1] = tab.NP[i, js[i]]
    return x2[np.arange(N1 + 1), js] if x2.ndim == 2 else x2[js]


def _refine_time(
    pc: PhaseCoefficients,
    limits: dict[str, tuple[np.ndarray, np.ndarray]],
    x2: np.ndarray,
    tab: _DPTables,
    opts: DPOptions,
    schedule: Sequence[tuple[int, int]] = REFINE,
) -> tuple[np.ndarray, _DPTables, int]:
    """Minimum time on finer r' grids in a band around the optimal curve (objective time).

    On a uniform r' grid each accelerating or decelerating step rounds its end state to the
    grid and the losses add up along the path (50 x 500 on park's torque case: +1.4 % over
    TOPP-RA). Each pass ``(half, factor)`` divides the r' step by ``factor`` and searches, at
    every stage, the ``2 half + 1`` states ``c_i + h (k - m_i)`` around the previous pass's
    curve ``c_i`` (``m_i <= half`` keeps the band at ``r' >= 0``; ``k = m_i`` is ``c_i``
    itself, so the previous path stays on the grid and a pass can only shorten the time).
    Same recursion, limits and readings as the uniform grid. Returns the per-stage grid
    ``(N1+1, 2 half + 1)`` of the last pass kept (or ``x2``), its tables and the number of
    passes kept."""
    h = float(x2[1] - x2[0])
    kept = 0
    for half, factor in schedule:
        c = _path_states(x2, tab)
        h /= factor
        k = np.arange(2 * half + 1, dtype=np.float64)
        m = np.minimum(half, np.floor(c / h))
        band = np.maximum(c[:, None] + h * (k[None, :] - m[:, None]), 0.0)
        new = _run_dp(pc, limits, band, 0, 0.0, None, 0.0, False, opts)
        if new.blocked is not None or not new.V[0, 0] <= tab.V[0, 0]:
            break
        x2, tab, kept = band, new, kept + 1
    return x2, tab, kept


def _realise(
    pc: PhaseCoefficients,
    path: JointPath,
    x2: np.ndarray,
    tab: _DPTables,
    objective: str,
    reference: ConveyorReference | None,
    opts: DPOptions = DEFAULT_DP,
    limits: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
) -> tuple[TrackTrajectory, np.ndarray | None]:
    """Follow NP from (0, 0) and evaluate the trajectory at the nodes (Eq. (9)-(12), (31)-(33)).

    Returns the trajectory and, with ``opts.jerk_ends``, the jerks ``(n,)`` of the step from
    rest (they belong to no node when the hand does not wait; with a wait they are the wait
    node's jerk too), else None.
    """
    N1 = pc.r.shape[0] - 1
    dx1 = 1.0 / N1
    js = np.zeros(N1 + 1, dtype=np.int64)
    for i in range(N1):
        js[i + 1] = tab.NP[i, js[i]]
    t = tab.T[np.arange(N1 + 1), js]
    if objective == "time":
        t = t - t[0]
    r = pc.r.copy()
    rd = x2[np.arange(N1 + 1), js] if x2.ndim == 2 else x2[js]
    dt, _, rdd_steps = step_arrays(rd[:-1], rd[1:], dx1, opts.step_time)
    rdd = np.append(rdd_steps, 0.0)
    q = pc.q.copy()
    qd = pc.dq * rd[:, None]  # park Eq. (10)
    qdd = np.full_like(qd, np.nan)
    qdd[:-1] = (qd[1:] - qd[:-1]) / dt[:, None]  # park Eq. (32)
    jerk = np.full_like(qd, np.nan)
    jerk[:-2] = (qdd[1:-1] - qdd[:-2]) / dt[:-1, None]  # park Eq. (33)
    jerk_start = None
    if opts.jerk_ends:  # the first and last steps (DPOptions.jerk_ends)
        jerk[-2] = (pc.ddq[-1] * rd[-1] ** 2 - qdd[-2]) / dt[-1]
        jerk_start = qdd[0] / dt[0]
    torque = pc.torque(rd, rdd)  # park Eq. (12)
    rd_lim = limit_curve(pc, limits or {})
    if t[0] > 1e-12:  # the hand waits at rest until t(0, 0)
        t = np.append(0.0, t)
        r = np.append(0.0, r)
        rd = np.append(0.0, rd)
        rdd = np.append(0.0, rdd)
        q = np.vstack([q[:1], q])
        qd = np.vstack([np.zeros_like(qd[:1]), qd])
        qdd = np.vstack([np.zeros_like(qdd[:1]), qdd])
        jerk = np.vstack([np.full_like(jerk[:1], np.nan) if jerk_start is None
                          else jerk_start[None, :], jerk])
        torque = np.vstack([pc.g[:1], torque])
        rd_lim = np.append(rd_lim[:1], rd_lim)
    hand = path.hand(r)
    part = err = None
    if reference is not None:
        part = reference.position(t, path)
        err = hand - part
    return (TrackTrajectory(t, r, rd, rdd, q, qd, qdd, jerk, torque, hand, part, err,
                            rd_limit=rd_lim), jerk_start)


def solve_conveyor_tracking(
    *,
    dynamics: InverseDynamics,
    path: JointPath,
    reference: ConveyorReference | None = None,
    limits: TrackLimits | None = None,
    N1: int = 50,
    N2: int = 100,
    objective: Literal["tracking", "time", "intercept"] = "tracking",
    nt_fraction: float = NT_FRACTION,
    x2_max: float | None = None,
    joint_names: Sequence[str] | None = None,
    dp: DPOptions | None = None,
    refine: bool = True,
) -> TrackResult:
    r"""Plan the hand's motion along the path by DP in the phase plane (park §4).

    :func:`mechkin.solvers.track.plan.plan_track` chooses between this DP, the DP intercept
    by decomposition (reading 11) and TOPP-RA (``planner`` auto / dp / topp).

    ``objective="tracking"``: DPCT, the tracking cost of Eq. (22)/(28) against ``reference``
    (Eq. (16)-(17)), from rest at ``r = 0`` to the part's state at ``r = 1`` at ``t_f``.
    ``objective="intercept"``: the same problem, cost the time until the hand is on the part
    (reading 10). ``objective="time"``: the same recursion with cost ``dt`` (minimum time), from
    rest to rest
    (``r' = 0`` at both ends), with the same limits, jerk included.

    Parameters
    ----------
    dynamics : InverseDynamics
        Inverse dynamics ``U = M qdd + h`` (park Eq. (8)).
    path : JointPath
        Hand line and its joint map ``q = f(r)`` (park Eq. (7), (9)-(11)).
    reference : ConveyorReference, optional
        The part on the belt (park Eq. (1)); required for tracking, optional for time (then
        ``part`` and ``tracking_error`` are reported too when given).
    limits : TrackLimits, optional
        Torque (Eq. (3)), velocity, acceleration and jerk limits (Eq. (4)-(6)), joint
        position limits ``q`` (reading 8 of the module docstring).
    N1, N2 : int
        Stages (along r) and states (along r'); park §5 uses 30x50, 50x100, 100x200.
    objective : {"tracking", "time", "intercept"}
    nt_fraction : float
        ``N_t = round(nt_fraction N2)``, the state of the part's speed (tracking only).
    x2_max : float, optional
        Top of the r' grid for ``objective="time"`` [1/s]; default: the largest r' reachable
        from rest that can still stop (torque and velocity limits).
    joint_names : sequence of str, optional
        Names of the joints for the message of a joint position limit.
    dp : DPOptions, optional
        Readings of the DP stage (step time, wait cost, jerk on the end steps); default
        :data:`DEFAULT_DP`, the readings 2, 4 and 6 of the module docstring.

    refine : bool
        ``objective="time"`` only: after the uniform grid, search finer r' grids in a band
        around its optimal curve (:data:`REFINE`, :func:`_refine_time`); the time can only
        shrink. False: the uniform grid alone (the result before issue 29). The tracking and
        intercept objectives (park §5) never refine.

    Returns
    -------
    TrackResult
        ``status`` INFEASIBLE when no grid path meets the limits; the message names the limit
        and the r interval where the search dies.

    Raises
    ------
    ConfigError
        Inconsistent problem data (grid sizes, a part off the hand's line, an unbounded
        time-optimal problem).

    References
    ----------
    park_conveyor_tracking_dp, Eq. (16)-(35); the module docstring lists the readings.
    """
    t_start = time.perf_counter()
    if objective not in ("tracking", "time", "intercept"):
        raise ConfigError("objective: expected 'tracking', 'time' or 'intercept', got "
                          f"{objective!r}")
    if reference is not None and reference.accelerating and objective != "time":
        raise ConfigError(
            f"conveyor.belt_acceleration: the {objective} objective of the single-pass DP "
            "cannot follow an accelerating belt (its r' grid holds the part's speed at the "
            "single state N_t, park Eq. (24), and time is not a DP state); use objective "
            "intercept through mechkin.solvers.track.plan.plan_track (TOPP-RA, or the DP by "
            "decomposition, reading 11)")
    intercept = objective == "intercept"
    opts = DEFAULT_DP if dp is None else dp
    if opts.wait_cost and objective != "tracking":
        raise ConfigError(f"dp.wait_cost: only for objective tracking (objective {objective} "
                          + ("already costs the wait as time off the part)" if intercept
                             else "starts at t = 0: there is no wait)"))
    if N1 < 1 or N2 < 1:
        raise ConfigError(f"grid: expected N1, N2 >= 1, got {N1} x {N2}")
    limits = limits or TrackLimits()
    n = dynamics.n_joints
    lim = limits.checked(n)

    x1 = np.linspace(0.0, 1.0, N1 + 1)
    pc = phase_coefficients(dynamics, path, x1)  # park Eq. (9)-(12) at every stage
    ref_phase: tuple[float, float] | None = None
    if objective != "time":
        if reference is None:
            raise ConfigError(f"objective {objective}: a conveyor reference is required")
        ref_phase = reference.phase(path)
        r0, rd_ref = ref_phase
        Nt = int(round(nt_fraction * N2))
        if not 1 <= Nt <= N2:
            raise ConfigError(f"nt_fraction: N_t = {Nt} is outside 1..N2 = {N2}")
        t_f = (1.0 - r0) / rd_ref  # park Eq. (17): x~1(t_f) = 1
        if t_f <= 0.0:
            raise ConfigError("conveyor: the part is already past the end of the hand's line")
        x2 = rd_ref * np.arange(N2 + 1) / Nt  # park Eq. (24)
        x2[Nt] = rd_ref  # exactly, so the steady state has exactly the belt's timing
        grid = DPGrid(N1=N1, N2=N2, Nt=Nt, x2_max=float(x2[-1]))
        j_end, t_end = Nt, t_f
    else:
        top = x2_max if x2_max is not None else _reachable_x2_max(pc, lim, 1.0 / N1)
        if not np.isfinite(top) or top <= 0.0:
            raise ConfigError(f"x2_max: expected a positive number, got {top}")
        x2 = top * np.arange(N2 + 1) / N2
        grid = DPGrid(N1=N1, N2=N2, Nt=None, x2_max=float(top))
        j_end, t_end = 0, 0.0

    blocked_q = _position_block(pc, lim["q"]) if "q" in lim else None
    if blocked_q is not None:  # no state of that stage is admissible: nothing to search
        i_b = blocked_q[0]
        message, names = position_limit_message(pc, path, lim["q"], blocked_q, joint_names)
        logger.info(message)
        return TrackResult(
            status=TrackStatus.INFEASIBLE, message=message, objective=objective, t_a_s=None,
            t_start_s=None, duration_s=None, peak_torque=None, limits_ok=False,
            active_limits=(), limit_usage={}, grid=grid, cost=float("inf"),
            solve_time_s=time.perf_counter() - t_start,
            blocked_at_r=(float(x1[i_b]), float(x1[i_b])), blocking_limits=tuple(names),
            dp=opts)

    tab = _run_dp(pc, lim, x2, j_end, t_end, ref_phase, 0.0, intercept, opts)
    feasible = tab.blocked is None and np.isfinite(tab.V[0, 0])
    passes = 0
    if feasible and objective == "time" and refine and N2 >= 2:
        x2, tab, passes = _refine_time(pc, lim, x2, tab, opts)
    mu = 0.0
    blocked_by_start = tab.blocked is not None and "start" in tab.blocked[1]
    if not feasible and blocked_by_start:  # reading 9: relax t(0, 0) >= 0 into the cost
        tab, mu = _time_penalty_search(pc, lim, x2, j_end, t_end, ref_phase, intercept, opts)
        feasible = tab.blocked is None and np.isfinite(tab.V[0, 0])
    if not feasible:
        i_b, names = tab.blocked if tab.blocked is not None else (0, [])
        where = (float(x1[i_b]), float(x1[min(i_b + 1, N1)]))
        p_lo, p_hi = path.hand(np.array(where))
        if i_b == N1:
            loc = f"at the end r = 1 (hand at {np.round(p_lo, 4).tolist()} m)"
        else:
            loc = (
                f"between r = {where[0]:.4g} and r = {where[1]:.4g} "
                f"(hand from {np.round(p_lo, 4).tolist()} to {np.round(p_hi, 4).tolist()} m)"
            )
        what = _describe(names) if names else "the limits"
        message = f"infeasible: {what} blocks the motion {loc} on the {N1}x{N2} grid"
        if "start" in names and ref_phase is not None and ref_phase[0] > 0.0:
            message += (
                f"; the part starts ahead of the hand (r~(0) = {ref_phase[0]:.4g}) and no "
                f"plan on this grid reaches it by r = 1 at t_f = {t_end:.4g} s, even with a "
                "time penalty (reading 9): the r' grid tops at "
                f"{grid.x2_max:.4g} /s = {grid.x2_max / ref_phase[1]:.3g} x the part's r'; a "
                "smaller nt_fraction lets the hand go faster")
        if any(nm.startswith("jerk") for nm in names):
            message += "; a finer r' grid (larger N2 / N1) represents smaller jerks"
        logger.info(message)
        return TrackResult(
            status=TrackStatus.INFEASIBLE,
            message=message,
            objective=objective,
            t_a_s=None,
            t_start_s=None,
            duration_s=None,
            peak_torque=None,
            limits_ok=False,
            active_limits=(),
            limit_usage={},
            grid=grid,
            cost=float("inf"),
            solve_time_s=time.perf_counter() - t_start,
            blocked_at_r=where,
            blocking_limits=tuple(names),
            dp=opts,
        )

    traj, jerk_start = _realise(pc, path, x2, tab, objective, reference, opts, lim)
    values = {"torque": traj.torque, "qd": traj.qd, "qdd": traj.qdd, "jerk": traj.jerk,
              "q": traj.q}
    if jerk_start is not None:  # the step from rest (DPOptions.jerk_ends), also without a wait
        values["jerk"] = np.vstack([jerk_start[None, :], traj.jerk])
    usage, limits_ok, active = limit_usage(values, lim)
    peak_idx = np.argmax(np.abs(traj.torque), axis=0)
    peak = traj.torque[peak_idx, np.arange(n)]

    t_a: float | None = None
    if objective != "time":
        r0, rd_ref = ref_phase  # type: ignore[misc]
        on_part = (np.abs(traj.r - (r0 + rd_ref * traj.t)) <= STEADY_TOL) & (
            np.abs(traj.rd - rd_ref) <= STEADY_TOL
        )
        k = on_part.shape[0] - 1
        while k > 0 and on_part[k - 1]:
            k -= 1
        t_a = float(traj.t[k])
        t_move = float(tab.T[0, 0])
        duration = float(traj.t[-1])
        what = "intercepts the part at" if intercept else "steady tracking from"
        message = f"ok: {what} t_a = {t_a:.4g} s on the {N1}x{N2} grid" + (
            "" if limits_ok else " (a limit is exceeded on the realised trajectory)"
        )
        if mu > 0.0:
            message += (f"; the part starts ahead of the hand: a time penalty mu = {mu:.3g} "
                        "on the cost keeps the start at t >= 0 (reading 9)")
    else:
        t_move = 0.0
        duration = float(traj.t[-1])
        message = f"ok: rest-to-rest time {duration:.4g} s on the {N1}x{N2} grid" + (
            f" (r' refined in a band, {passes} passes)" if passes else "")
    return TrackResult(
        status=TrackStatus.OK,
        message=message,
        objective=objective,
        t_a_s=t_a,
        t_start_s=t_move,
        duration_s=duration,
        peak_torque=peak,
        limits_ok=limits_ok,
        active_limits=active,
        limit_usage=usage,
        grid=grid,
        cost=float(tab.V[0, 0]) - (mu * (t_end - float(tab.T[0, 0])) if mu > 0.0 else 0.0),
        solve_time_s=time.perf_counter() - t_start,
        time_penalty=mu,
        trajectory=traj,
        dp=opts,
    )
