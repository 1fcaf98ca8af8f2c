"""The DP intercept by decomposition (dpct reading 11; park Eq. (3), (4)', (25)-(33)).

:func:`plan_intercept_dp`: for an intercept stage, the phase-plane DP's minimum time from rest
to the part's speed there, the part's own motion from there to ``r = 1`` checked with the DP's
limit model, bisection on the stage and then inside it; the hand waits at rest for the
difference. The argument (why the qualifying intercept points form an interval) is the one of
:mod:`mechkin.solvers.track.intercept`, whose TOPP-RA intercept applies it to TOPP-RA. Split out
of ``intercept.py`` (issue 23: modules that fit in a head).

Design
------
Part of the track room :mod:`mechkin.solvers.track`; may import :mod:`mechkin.solvers.track`'s
dpct, dp_problem, dp_limits, intercept and path; never ``io/``, ``cli/`` or ``tasks/``.

References
----------
park_conveyor_tracking_dp Eq. (1), (3)-(6), (9)-(12), (16)-(17), (25)-(33), §6 (accelerating
belt).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

from mechkin.errors import ConfigError
from mechkin.records.track import TrackTrajectory
from mechkin.solvers.dynamics.open_chain import InverseDynamics
from mechkin.solvers.track.dpct import (
    LIMIT_RTOL,
    ConveyorReference,
    DPGrid,
    TrackLimits,
    TrackResult,
    TrackStatus,
    _describe,
    _position_block,
    limit_usage,
    position_limit_message,
)
from mechkin.solvers.track.intercept import (
    TIME_RTOL,
    _infeasible,
    _Nodes,
    _state_violations,
    _with_wait,
)
from mechkin.solvers.track.path import JointPath, PhaseCoefficients, phase_coefficients

# ------------------------------------------------------------------------------------------
# The DP intercept by the same decomposition (dpct reading 11)
# ------------------------------------------------------------------------------------------


def plan_intercept_dp(
    *,
    dynamics: InverseDynamics,
    path: JointPath,
    reference: ConveyorReference,
    limits: TrackLimits | None,
    N1: int,
    N2: int,
    nt_fraction: float,
    joint_names: Sequence[str] | None = None,
) -> TrackResult:
    r"""The DP intercept by decomposition (dpct reading 11): for an intercept stage ``i*``,
    the phase-plane DP's minimum time from rest to the part's speed at ``x1[i*]`` (the time
    objective of park's recursion, Eq. (25)-(30) with cost ``dt``, ending at the state ``N_t``
    of an r' grid ``x2[j] = v(x1[i*]) j / N_t``), and the part's own motion from ``x1[i*]`` to
    ``r = 1`` checked with the DP's limits (Eq. (3), (4)', (32)/(5)', (33)/(6)'). The earliest
    ``i*`` with ``T_DP(i*) <= T_part(x1[i*])`` is found by bisection (the module docstring's
    interval argument), and the hand waits at rest at ``r = 0`` for the difference.

    Used by :func:`mechkin.solvers.track.dpct.solve_conveyor_tracking` for ``objective="intercept"``
    with ``planner="dp"`` when the part starts ahead of the hand or the belt accelerates: the
    single backward pass of reading 10 keeps one time per node and no grid state holds an
    accelerating part's speed. The jerk of the one transition where the fastest leg joins the
    part is not a constraint (reading 6: the last transition of a DP has no jerk check); it is
    reported in the limit usage like every other.
    """
    from mechkin.solvers.track.dpct import _reachable_x2_max, _run_dp

    t0 = time.perf_counter()
    if N1 < 1 or N2 < 1:
        raise ConfigError(f"grid: expected N1, N2 >= 1, got {N1} x {N2}")
    Nt = int(round(nt_fraction * N2))
    if not 1 <= Nt <= N2:
        raise ConfigError(f"nt_fraction: N_t = {Nt} is outside 1..N2 = {N2}")
    limits = limits or TrackLimits()
    n = dynamics.n_joints
    lim = limits.checked(n)
    pm = reference.motion(path)
    objective = "intercept"
    if pm.r0 >= 1.0:
        raise ConfigError("conveyor: the part is already past the end of the hand's line")
    t_f = float(pm.time_at(1.0))
    if not math.isfinite(t_f) or pm.stop_time() <= t_f:
        raise ConfigError(f"conveyor.belt_acceleration: the belt stops the part at t = "
                          f"{pm.stop_time():.4g} s, before the end of the hand's line (r = 1)")
    x1 = np.linspace(0.0, 1.0, N1 + 1)
    pc = phase_coefficients(dynamics, path, x1)
    grid = DPGrid(N1=N1, N2=N2, Nt=Nt, x2_max=float(pm.speed_at(1.0)) * N2 / Nt)
    blocked = _position_block(pc, lim["q"]) if "q" in lim else None
    if blocked is not None:
        msg, names = position_limit_message(pc, path, lim["q"], blocked, joint_names)
        r_b = float(x1[blocked[0]])
        return _infeasible(msg, objective, grid, t0, (r_b, r_b), names, "dp")
    lo_r = max(pm.r0, 0.0)
    v = np.where(x1 >= lo_r, pm.speed_at(np.maximum(x1, lo_r)), np.nan)
    t_p = np.where(x1 >= lo_r, pm.time_at(np.maximum(x1, lo_r)), np.nan)

    # the tail on the part, in the DP's model: ok_from[i] = the part's motion from x1[i] on
    # meets every limit (nodes, transitions and the jerk of consecutive tail transitions)
    dx = 1.0 / N1
    rdd = np.full(N1 + 1, pm.ra)
    vv = np.nan_to_num(v)
    node_bad = np.zeros(N1 + 1, dtype=bool)
    vals = {"torque": pc.torque(vv, rdd), "qd": pc.dq * vv[:, None]}
    with np.errstate(divide="ignore", invalid="ignore"):
        dt = 2.0 * dx / (vv[:-1] + vv[1:])
        qdd = (pc.dq[1:] * vv[1:, None] - pc.dq[:-1] * vv[:-1, None]) / dt[:, None]
        jerk = (qdd[1:] - qdd[:-1]) / dt[:-1, None]
    trans = {"qdd": qdd, "jerk": jerk}

    def breaks(name: str, x: np.ndarray) -> np.ndarray:
        lo, hi = lim[name]
        return np.any((x < lo - LIMIT_RTOL * np.maximum(np.abs(lo), 1.0))
                      | (x > hi + LIMIT_RTOL * np.maximum(np.abs(hi), 1.0))
                      | np.isnan(x), axis=1)

    for name, x in vals.items():
        if name in lim:
            node_bad |= breaks(name, x)
    node_bad |= np.isnan(v)
    bad_from = node_bad.copy()  # a limit broken at node i or on a tail transition leaving it
    for name, x in trans.items():
        if name in lim:
            bad_from[: x.shape[0]] |= breaks(name, x)
    ok_from = np.flip(np.cumsum(np.flip(bad_from)) == 0)
    if not ok_from[N1]:
        names = []
        for nm, x in vals.items():
            if nm in lim:
                lo, hi = lim[nm]
                out = (x[N1] < lo - LIMIT_RTOL * np.maximum(np.abs(lo), 1.0)) | (
                    x[N1] > hi + LIMIT_RTOL * np.maximum(np.abs(hi), 1.0))
                names += [f"{nm}_{j + 1}" for j in np.flatnonzero(out)]
        return _infeasible(
            f"infeasible: the hand cannot move with the part at the end of the line r = 1 "
            f"(r' = {pm.speed_at(1.0):.4g} /s): {_describe(names)} would be exceeded there",
            objective, grid, t0, (1.0, 1.0), names, "dp")

    try:  # the time objective's grid top (dpct): the leg may have to outrun the part
        reach = _reachable_x2_max(pc, lim, dx)
    except ConfigError:
        reach = 0.0

    def leg(pcl: PhaseCoefficients, vk: float) -> tuple[float, object, np.ndarray] | None:
        """The DP's fastest motion from rest to the end of ``pcl`` (stages ``0..k`` of
        ``[0, r*]``) at the part's speed ``vk``, or None: an r' grid with ``vk`` exactly at a
        state and its top at least the time objective's reachability bound and
        ``vk / nt_fraction``."""
        k = pcl.r.shape[0] - 1
        top = max(vk * N2 / Nt, reach)
        nt_k = max(1, min(Nt, int(math.floor(N2 * vk / top))))
        x2 = vk * np.arange(N2 + 1) / nt_k
        x2[nt_k] = vk
        L = float(pcl.r[k])
        sub = PhaseCoefficients(r=pcl.r / L, q=pcl.q, dq=pcl.dq * L, ddq=pcl.ddq * L * L,
                                a=pcl.a * L, b=pcl.b * L * L, g=pcl.g)  # r = L rho
        x2s = x2 / L  # rho' = r' / L
        tab = _run_dp(sub, lim, x2s, nt_k, 0.0, None)
        if tab.blocked is not None or not np.isfinite(tab.V[0, 0]):
            return None
        return float(tab.V[0, 0]), tab, x2s * L

    def junction_bad(pcl: PhaseCoefficients, k: int, r_s: float, v_s: float) -> bool:
        """The part's motion from ``r_s`` (between grid points, ``x1[k-1] < r_s < x1[k]``)
        to ``x1[k]``: the node at r_s, that transition, and its jerk into the next one."""
        end = _Nodes(np.array([r_s]), pcl.q[-1:], pcl.dq[-1:], pcl.ddq[-1:], pcl.a[-1:],
                     pcl.b[-1:], pcl.g[-1:])
        masks = _state_violations(end, lim, np.array([v_s]), np.array([pm.ra]))
        if any(np.any(m) for m in masks.values()):
            return True
        dt0 = 2.0 * (x1[k] - r_s) / (v_s + vv[k])
        qdd0 = (pc.dq[k] * vv[k] - pcl.dq[-1] * v_s) / dt0
        if "qdd" in lim and breaks("qdd", qdd0[None])[0]:
            return True
        if "jerk" in lim and k < N1:
            j0 = (qdd[k] - qdd0) / dt0
            if breaks("jerk", j0[None])[0]:
                return True
        return False

    def probe(k: int, r_s: float | None = None) -> tuple[bool, object]:
        """Does the intercept at ``x1[k]`` (``r_s`` None) or at ``r_s`` in
        ``(x1[k-1], x1[k])`` qualify? Returns it and ``(T_leg, tab, x2, pc_leg, r*)``."""
        if r_s is None:
            if not ok_from[k]:
                return False, None
            pcl, r_star, vk, tk = _head(pc, k), float(x1[k]), float(v[k]), float(t_p[k])
        else:
            if not ok_from[k]:
                return False, None
            pcl = phase_coefficients(dynamics, path, np.linspace(0.0, r_s, k + 1))
            r_star, vk, tk = r_s, float(pm.speed_at(r_s)), float(pm.time_at(r_s))
            if junction_bad(pcl, k, r_s, vk):
                return False, None
        out = leg(pcl, vk)
        if out is None:
            return False, None
        ok = out[0] <= tk * (1.0 + TIME_RTOL) + 1e-12
        return ok, (*out, pcl, r_star)

    ok_end, best = probe(N1)
    if not ok_end:
        what = ("no plan on this grid reaches the part's state at r = 1" if best is None else
                "the fastest arrival there is later than the part")
        return _infeasible(
            f"infeasible: the hand cannot catch the part on the {N1}x{N2} grid: {what} "
            f"(the part reaches r = 1 at t_f = {t_f:.4g} s with r' = {pm.speed_at(1.0):.4g} "
            "/s)", objective, grid, t0, (0.0, 1.0), (), "dp")
    k_lo = int(np.searchsorted(x1, lo_r, side="right"))
    lo_k, hi_k = k_lo - 1, N1
    while hi_k - lo_k > 1:
        mid = (lo_k + hi_k) // 2
        ok, out = probe(mid)
        if ok:
            hi_k, best = mid, out
        else:
            lo_k = mid
    k = hi_k
    # refine the intercept point inside (x1[k-1], x1[k]) (bisection; the DP on [0, r*])
    a_r, b_r = max(float(x1[k - 1]), lo_r), float(x1[k])
    if k >= 1 and a_r < b_r:
        for _ in range(DP_REFINE):
            c = 0.5 * (a_r + b_r)
            if c <= a_r or c >= b_r:
                break
            ok, out = probe(k, c)
            if ok:
                b_r, best = c, out
            else:
                a_r = c
    T_leg, tab, x2, pcl, r_star = best  # type: ignore[misc]
    kk = pcl.r.shape[0] - 1
    js = np.zeros(kk + 1, dtype=np.int64)
    for i in range(kk):
        js[i + 1] = tab.NP[i, js[i]]
    t_leg = tab.T[np.arange(kk + 1), js]
    t_leg = t_leg - t_leg[0]
    first_tail = k if r_star < x1[k] else k + 1
    rows = _concat_pc(pcl, pc, first_tail)
    t_a = float(pm.time_at(r_star))
    rd = np.concatenate([x2[js], v[first_tail:]])
    rd[kk] = float(pm.speed_at(r_star))
    wait = max(t_a - T_leg, 0.0)
    t = np.concatenate([t_leg + wait, t_p[first_tail:]])
    t[kk] = t_a
    traj = _dp_trajectory(rows, path, t, rd, pm.ra, wait > 1e-12, reference)
    values = {"torque": traj.torque, "qd": traj.qd, "qdd": traj.qdd, "jerk": traj.jerk,
              "q": traj.q}
    usage, ok, active = limit_usage(values, lim)
    peak = traj.torque[np.argmax(np.abs(traj.torque), axis=0), np.arange(n)]
    where = "ahead of" if pm.r0 > 0 else "behind"
    msg = (f"ok: intercepts the part at t_a = {t_a:.4g} s on the {N1}x{N2} grid (r = "
           f"{r_star:.4g}; fastest DP leg {T_leg:.4g} s, then on the part; reading 11); the "
           f"part starts {where} the hand (r~(0) = {pm.r0:.4g})")
    if not ok:
        msg += " (a limit is exceeded on the realised trajectory)"
    grid = DPGrid(N1=N1, N2=N2, Nt=Nt, x2_max=float(x2[-1]))
    return TrackResult(
        status=TrackStatus.OK, message=msg, objective=objective, t_a_s=t_a, t_start_s=wait,
        duration_s=t_f, peak_torque=peak, limits_ok=ok, active_limits=active,
        limit_usage=usage, grid=grid, cost=t_a, solve_time_s=time.perf_counter() - t0,
        trajectory=traj, planner="dp", intercept_r=r_star)


def _head(pc: PhaseCoefficients, k: int) -> PhaseCoefficients:
    return PhaseCoefficients(*(getattr(pc, f)[: k + 1] for f in _PC_FIELDS))


def _concat_pc(a: PhaseCoefficients, b: PhaseCoefficients, k: int) -> PhaseCoefficients:
    """All rows of ``a`` followed by the rows ``k..`` of ``b``."""
    return PhaseCoefficients(*(np.concatenate([getattr(a, f), getattr(b, f)[k:]])
                               for f in _PC_FIELDS))


_PC_FIELDS = ("r", "q", "dq", "ddq", "a", "b", "g")
#: Bisection steps of the DP intercept point inside its stage (each one DP run).
DP_REFINE = 12


def _dp_trajectory(pc: PhaseCoefficients, path: JointPath, t: np.ndarray, rd: np.ndarray,
                   ra: float, wait: bool, reference: ConveyorReference) -> TrackTrajectory:
    """The DP-style trajectory at the nodes ``pc.r`` (as dpct ``_realise``: Eq. (9)-(12),
    (31)-(33); the spacing may change at the intercept point), the last node's r'' that of
    the part."""
    r = pc.r.copy()
    rdd = np.append((rd[1:] ** 2 - rd[:-1] ** 2) / (2.0 * np.diff(r)), ra)
    dt = np.diff(t)
    q = pc.q.copy()
    qd = pc.dq * rd[:, None]  # park Eq. (10)
    qdd = np.full_like(qd, np.nan)
    qdd[:-1] = (qd[1:] - qd[:-1]) / dt[:, None]  # park Eq. (32)
    jerk = np.full_like(qd, np.nan)
    jerk[:-2] = (qdd[1:-1] - qdd[:-2]) / dt[:-1, None]  # park Eq. (33)
    torque = pc.torque(rd, rdd)  # park Eq. (12)
    if wait:
        t, r, rd, rdd, q, qd, qdd, jerk, torque = _with_wait(
            0.0, pc.g[0], t, r, rd, rdd, q, qd, qdd, jerk, torque)
    hand = path.hand(r)
    part = reference.position(t)
    return TrackTrajectory(t, r, rd, rdd, q, qd, qdd, jerk, torque, hand, part, hand - part)
