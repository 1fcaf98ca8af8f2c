r"""Time-optimal and intercept plans of the track task by TOPP-RA (Pham & Pham 2018).

DESIGN: the ``planner: topp`` back-end of :func:`mechkin.solvers.track.dpct.solve_conveyor_tracking`
for ``objective: time`` (rest to rest) and ``objective: intercept`` (rest to the part's position
and velocity, then on the part to the end of the line) under torque, joint-velocity,
joint-acceleration and joint-position limits (no jerk: TOPP-RA's stage constraints are linear in
``(s_ddot, s_dot^2)``, a jerk is not). It evaluates the path (``q, q', q''``) and the torque
coefficients of park Eq. (12) on the grid ``r_i = i / N`` (:func:`phase_coefficients`), plans
with :func:`mechkin.solvers.track.topp.plan_time_optimal` and returns the same
:class:`~mechkin.solvers.track.dpct.TrackResult` (and :class:`TrackTrajectory` at the nodes) as the
DP, so the writer's CSV, plots and MCAP are unchanged.

**Joint positions.** The path is fixed, so ``q(r)`` is checked at every grid point before any
planning (dpct reading 8); a stage outside the limits is infeasible with a message naming the
joint and r.

**Intercept.** The part moves as ``r~(t) = r0 + rd t + ra t^2 / 2`` (park Eq. (16)-(17); the
constant belt acceleration ``ra`` of park §6), so when it is at ``s`` its speed is
``v(s) = sqrt(rd^2 + 2 ra (s - r0))`` and the time is ``T_part(s) = 2 (s - r0) / (rd + v(s))``.
For an intercept point ``s*`` TOPP-RA gives ``T_fast(s*)``, the fastest arrival at ``s*`` from
rest with ``s_dot = v(s*)``. A plan that meets the part at ``s*`` exists iff

1. ``T_fast(s*) <= T_part(s*)``: **any slower arrival is achievable** -- the hand waits at rest
   at ``r = 0`` for ``T_part(s*) - T_fast(s*)`` and then runs the fastest plan (the start is at
   rest, and holding still at ``r = 0`` is checked: the static torque there must be within the
   limits); and
2. the tail ``[s*, 1]`` on the part is admissible: ``s_dot^2 = v(s)^2``, ``s_ddot = ra`` meets
   every limit at each grid point (exactly the discrete dynamics ``x_{i+1} = x_i + 2 Δ u``, as
   ``v^2`` is linear in s).

The set of such ``s*`` is an interval ``[s_min, 1]``: a plan that meets the part at ``s1`` and
stays on it passes ``s2 > s1`` at ``T_part(s2)`` with the part's speed, so ``s2`` qualifies too
(on the grid: TOPP-RA's plan is optimal for the discrete problem, and "fastest to s1, then the
tail" is a discrete plan to ``s2``, so ``T_fast(s2) - T_part(s2) <= T_fast(s1) - T_part(s1)``).
The intercept time is ``T_part(s_min)``, the smallest ``T`` with ``T_fast(s*) <= T_part(s*)``:
found by bisection over the grid points, then refined inside the last segment (the grid
``r_0..r_{k-1}, s*``): two levels of 31 points each, the path evaluated at all of them in one
vectorised call and bisected over (the intercept point to 1/1024 of a segment). The part may start
ahead of the hand (``r0 > 0``: then ``s* > r0``) or behind it (``r0 < 0``). If ``s = 1``
itself does not qualify, no plan exists (every qualifying ``s*`` would make ``1`` qualify) and
the message says which condition fails and by how much.

The realised trajectory: a rest node at ``t = 0`` if the hand waits, the TOPP-RA nodes (times
shifted by the wait), the intercept node ``s*``, then the grid nodes of the tail at the part's
times. ``rdd`` (and the torque) at a node belong to the segment leaving it; ``qdd = q' r'' +
q'' r'^2`` there (TOPP-RA §III, not park's forward difference Eq. (32)); ``jerk`` is the
forward difference of ``qdd`` (informative: no jerk limit applies), NaN across the wait and at
the last node.

**The DP intercept by decomposition**
(:func:`mechkin.solvers.track.intercept_dp.plan_intercept_dp`, dpct reading 11) applies the
same argument to the phase-plane DP: its minimum-time recursion from rest to the part's speed
at an intercept stage (on an r' grid that holds that speed exactly, topped by the time
objective's reachability bound), the part's motion after it checked with the DP's limit model
(Eq. (3), (4)', (32)-(33)), bisection on the stage and then inside it.

Imports: numpy, mechkin.errors, mechkin.records.track, mechkin.solvers (dpct, dynamics, path,
topp).

References
----------
H. Pham, Q.-C. Pham, "A new approach to time-optimal path parameterization based on
reachability analysis", IEEE Trans. Robotics 34(3), 2018 (§III-§IV); park_conveyor_tracking_dp
Eq. (1), (9)-(12), (16)-(17), §6 (accelerating belt).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mechkin.errors import ConfigError
from mechkin.records.track import TrackTrajectory
from mechkin.solvers.dynamics.open_chain import InverseDynamics
from mechkin.solvers.track.dpct import (
    LIMIT_RTOL,
    ConveyorReference,
    DPGrid,
    PartMotion,
    TrackLimits,
    TrackResult,
    TrackStatus,
    _describe,
    _position_block,
    limit_usage,
    position_limit_message,
)
from mechkin.solvers.track.path import JointPath, PhaseCoefficients, phase_coefficients
from mechkin.solvers.track.topp import ToppResult, plan_time_optimal

#: Relative tolerance of the intercept condition ``T_fast <= T_part`` (round-off).
TIME_RTOL = 1e-12
#: The refined intercept point is found to this width of its bracket in r.
S_TOL = 1e-12
#: Refinement inside the intercept segment: levels of batches of path points (each batch one
#: vectorised path evaluation and a bisection over its points): width / 32^2.
REFINE_LEVELS = 2
REFINE_POINTS = 32


@dataclass(frozen=True)
class _Nodes:
    """Path data at some path points: r, q, q', q'' and torque ``a u + b x + g`` (Eq. (12))."""

    r: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    a: np.ndarray
    b: np.ndarray
    g: np.ndarray

    @classmethod
    def of(cls, pc: PhaseCoefficients) -> _Nodes:
        return cls(pc.r, pc.q, pc.dq, pc.ddq, pc.a, pc.b, pc.g)

    def head(self, k: int, extra: _Nodes | None = None) -> _Nodes:
        """Points ``0..k`` (``extra`` None) or ``0..k-1`` followed by ``extra``."""
        if extra is None:
            return _Nodes(*(x[: k + 1] for x in self._arrays()))
        return _Nodes(*(np.concatenate([x[:k], y]) for x, y in
                        zip(self._arrays(), extra._arrays(), strict=True)))

    def tail(self, k: int) -> _Nodes:
        return _Nodes(*(x[k:] for x in self._arrays()))

    def _arrays(self) -> tuple[np.ndarray, ...]:
        return self.r, self.q, self.dq, self.ddq, self.a, self.b, self.g


def _topp(nd: _Nodes, lim: dict[str, tuple[np.ndarray, np.ndarray]], sd_end: float,
          diagnose: bool) -> ToppResult:
    """TOPP-RA from rest at ``nd.r[0]`` to ``s_dot = sd_end`` at ``nd.r[-1]``."""
    return plan_time_optimal(
        nd.r, nd.dq, nd.ddq, torque=lim.get("torque"),
        torque_coeffs=(nd.a, nd.b, nd.g) if "torque" in lim else None,
        qd=lim.get("qd"), qdd=lim.get("qdd"), sd_start=0.0, sd_end=sd_end, diagnose=diagnose)


def _state_violations(nd: _Nodes, lim: dict[str, tuple[np.ndarray, np.ndarray]],
                      rd: np.ndarray, rdd: np.ndarray) -> dict[str, np.ndarray]:
    """Per limit family, ``(K, n)`` masks of the limits that the states ``(r', r'')`` break at
    the points (torque Eq. (12), velocity Eq. (10), acceleration Eq. (11))."""
    out = {}
    vals = {
        "torque": nd.a * rdd[:, None] + nd.b * (rd**2)[:, None] + nd.g,  # park Eq. (12)
        "qd": nd.dq * rd[:, None],  # park Eq. (10)
        "qdd": nd.dq * rdd[:, None] + nd.ddq * (rd**2)[:, None],  # park Eq. (11)
    }
    for name, v in vals.items():
        if name in lim:
            lo, hi = lim[name]
            out[name] = (v < lo - LIMIT_RTOL * np.maximum(np.abs(lo), 1.0)) | (
                v > hi + LIMIT_RTOL * np.maximum(np.abs(hi), 1.0))
    return out


def _bad_names(masks: dict[str, np.ndarray], rows: np.ndarray | slice) -> list[str]:
    names = []
    for fam, m in masks.items():
        names += [f"{fam}_{k + 1}" for k in np.flatnonzero(np.any(m[rows], axis=0))]
    return names


def _with_wait(r0: float, g0: np.ndarray, t: np.ndarray, r: np.ndarray, rd: np.ndarray,
               rdd: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
               jerk: np.ndarray, torque: np.ndarray) -> tuple[np.ndarray, ...]:
    """The samples with a first one at ``t = 0``: the hand at rest at ``r0`` during the wait
    before the start, holding the torque ``g0 (n,)`` (jerk undefined across the wait)."""
    return (np.append(0.0, t), np.append(r0, r), np.append(0.0, rd), np.append(0.0, rdd),
            np.vstack([q[:1], q]), np.vstack([np.zeros_like(qd[:1]), qd]),
            np.vstack([np.zeros_like(qdd[:1]), qdd]),
            np.vstack([np.full_like(jerk[:1], np.nan), jerk]), np.vstack([g0[None], torque]))


def _trajectory(nd: _Nodes, t: np.ndarray, rd: np.ndarray, rdd: np.ndarray, wait: bool,
                path: JointPath, reference: ConveyorReference | None) -> TrackTrajectory:
    """The trajectory at the nodes (module docstring): ``rdd`` of the segment leaving each."""
    q = nd.q.copy()
    qd = nd.dq * rd[:, None]  # park Eq. (10)
    qdd = nd.dq * rdd[:, None] + nd.ddq * (rd**2)[:, None]  # park Eq. (11)
    torque = nd.a * rdd[:, None] + nd.b * (rd**2)[:, None] + nd.g  # park Eq. (12)
    jerk = np.full_like(qd, np.nan)
    dt = np.diff(t)
    with np.errstate(divide="ignore", invalid="ignore"):
        jerk[:-1] = np.where(dt[:, None] > 0, np.diff(qdd, axis=0) / dt[:, None], np.nan)
    r = nd.r.copy()
    if wait:  # the hand waits at rest at r = 0 (holding: torque g, checked by the caller)
        t, r, rd, rdd, q, qd, qdd, jerk, torque = _with_wait(
            r[0], nd.g[0], t, r, rd, rdd, q, qd, qdd, jerk, torque)
    hand = path.hand(r)
    part = err = None
    if reference is not None:
        part = reference.position(t)
        err = hand - part
    return TrackTrajectory(t, r, rd, rdd, q, qd, qdd, jerk, torque, hand, part, err)


def _usage_of(traj: TrackTrajectory, lim: dict[str, tuple[np.ndarray, np.ndarray]],
              extra: dict[str, float]) -> tuple[dict[str, float], bool, tuple[str, ...]]:
    """Limit usage at the nodes (as the DP reports it), merged with TOPP-RA's own usage of the
    moving segment (``extra``: its interpolation rows too)."""
    values = {"torque": traj.torque, "qd": traj.qd, "qdd": traj.qdd, "q": traj.q}
    return limit_usage(values, lim, extra)


def _infeasible(message: str, objective: str, grid: DPGrid, t0: float,
                where: tuple[float, float] | None, names: Sequence[str],
                planner: str = "topp") -> TrackResult:
    return TrackResult(
        status=TrackStatus.INFEASIBLE, message=message, objective=objective, t_a_s=None,
        t_start_s=None, duration_s=None, peak_torque=None, limits_ok=False, active_limits=(),
        limit_usage={}, grid=grid, cost=float("inf"), solve_time_s=time.perf_counter() - t0,
        blocked_at_r=where, blocking_limits=tuple(names), planner=planner)


def _ok(message: str, objective: str, grid: DPGrid, t0: float, traj: TrackTrajectory,
        lim: dict[str, tuple[np.ndarray, np.ndarray]], topp_usage: dict[str, float],
        t_a: float | None, t_start: float, duration: float, cost: float,
        intercept_r: float | None) -> TrackResult:
    usage, ok, active = _usage_of(traj, lim, topp_usage)
    n = traj.torque.shape[1]
    peak = traj.torque[np.argmax(np.abs(traj.torque), axis=0), np.arange(n)]
    if not ok:
        message += " (a limit is exceeded on the realised trajectory)"
    return TrackResult(
        status=TrackStatus.OK, message=message, objective=objective, t_a_s=t_a,
        t_start_s=t_start, duration_s=duration, peak_torque=peak, limits_ok=ok,
        active_limits=active, limit_usage=usage, grid=grid, cost=cost,
        solve_time_s=time.perf_counter() - t0, trajectory=traj, planner="topp",
        intercept_r=intercept_r)


def plan_track_topp(
    *,
    dynamics: InverseDynamics,
    path: JointPath,
    reference: ConveyorReference | None,
    limits: TrackLimits | None,
    N: int,
    objective: str,
    joint_names: Sequence[str] | None = None,
) -> TrackResult:
    """Minimum time (rest to rest) or intercept (module docstring) by TOPP-RA on ``N + 1``
    points ``r = i / N``.

    Parameters
    ----------
    dynamics : InverseDynamics
    path : JointPath
        Hand path and joint map ``q = f(r)`` (park Eq. (7), (9)-(11)).
    reference : ConveyorReference or None
        The part (required for ``intercept``; drawn only for ``time``).
    limits : TrackLimits or None
        Torque, velocity, acceleration and joint-position limits; a jerk limit is refused.
    N : int
        Number of segments of the grid.
    objective : {"time", "intercept"}
    joint_names : sequence of str, optional
        For the message of a joint position limit.

    Returns
    -------
    TrackResult
        ``planner = "topp"``; ``grid = DPGrid(N, 0, None, max r')``.

    Raises
    ------
    ConfigError
        A jerk limit, the tracking objective, no reference for intercept, a part already
        past the end or stopped by the belt before it, limits that do not bound the speed.
    """
    t0 = time.perf_counter()
    if objective not in ("time", "intercept"):
        raise ConfigError(f"planner: topp plans the time and intercept objectives, not "
                          f"{objective!r}")
    if N < 1:
        raise ConfigError(f"grid: expected N1 >= 1, got {N}")
    limits = limits or TrackLimits()
    if limits.jerk is not None:
        raise ConfigError("planner: topp (TOPP-RA) cannot impose jerk limits (limits.jerk); "
                          "use planner dp")
    n = dynamics.n_joints
    lim = limits.checked(n)
    s = np.linspace(0.0, 1.0, N + 1)
    pc = phase_coefficients(dynamics, path, s)
    grid0 = DPGrid(N1=N, N2=0, Nt=None, x2_max=0.0)
    blocked = _position_block(pc, lim["q"]) if "q" in lim else None
    if blocked is not None:
        msg, names = position_limit_message(pc, path, lim["q"], blocked, joint_names)
        r_b = float(s[blocked[0]])
        return _infeasible(msg, objective, grid0, t0, (r_b, r_b), names)
    nd = _Nodes.of(pc)
    if objective == "time":
        return _time(nd, lim, path, reference, objective, t0)
    if reference is None:
        raise ConfigError("objective intercept: a conveyor reference is required")
    return _intercept(nd, lim, path, reference, reference.motion(path), t0, dynamics)


def _time(nd: _Nodes, lim: dict[str, tuple[np.ndarray, np.ndarray]], path: JointPath,
          reference: ConveyorReference | None, objective: str, t0: float) -> TrackResult:
    N = nd.r.shape[0] - 1
    res = _topp(nd, lim, 0.0, diagnose=True)
    if res.status is not TrackStatus.OK or res.sd is None or res.t is None:
        return _infeasible(res.message + f" (TOPP-RA on {N + 1} points)", objective,
                           DPGrid(N, 0, None, 0.0), t0, res.blocked_at_s, res.blocking_limits)
    rdd = np.append(res.sdd, 0.0)  # at rest at the end the arm holds
    traj = _trajectory(nd, res.t, res.sd, rdd, False, path, reference)
    T = float(res.duration_s)
    grid = DPGrid(N, 0, None, float(np.max(res.sd)))
    return _ok(f"ok: rest-to-rest time {T:.4g} s by TOPP-RA on {N + 1} points", objective,
               grid, t0, traj, lim, res.limit_usage, None, 0.0, T, T, None)


def _intercept(nd: _Nodes, lim: dict[str, tuple[np.ndarray, np.ndarray]], path: JointPath,
               reference: ConveyorReference, pm: PartMotion, t0: float,
               dynamics: InverseDynamics) -> TrackResult:
    N = nd.r.shape[0] - 1
    s = nd.r
    objective = "intercept"
    grid0 = DPGrid(N, 0, None, 0.0)
    if pm.r0 >= 1.0:
        raise ConfigError("conveyor: the part is already past the end of the hand's line")
    v_end = float(pm.speed_at(1.0))
    if not math.isfinite(v_end) or v_end <= 0.0 or pm.stop_time() <= float(pm.time_at(1.0)):
        r_stop = pm.r0 + pm.rd**2 / (2.0 * -pm.ra)
        raise ConfigError(f"conveyor.belt_acceleration: the belt stops the part at r = "
                          f"{r_stop:.4g} (t = {pm.stop_time():.4g} s), before the end of the "
                          "hand's line (r = 1)")
    t_f = float(pm.time_at(1.0))
    lo_r = max(pm.r0, 0.0)  # the intercept lies ahead of both the hand and the part

    # the tail on the part: admissible from grid point k on (upward closed)
    v = pm.speed_at(s)
    on_line = s >= lo_r
    tail_masks = _state_violations(nd, lim, np.where(on_line, v, 0.0), np.full(N + 1, pm.ra))
    bad = np.zeros(N + 1, dtype=bool)
    for m in tail_masks.values():
        bad |= np.any(m, axis=1)
    bad |= ~on_line
    if bad[N]:
        names = _bad_names(tail_masks, slice(N, N + 1))
        return _infeasible(
            f"infeasible: the hand cannot move with the part at the end of the line r = 1 "
            f"(r' = {v_end:.4g} /s, r'' = {pm.ra:.4g} /s^2): {_describe(names)} would be "
            "exceeded", objective, grid0, t0, (1.0, 1.0), names)
    k_tail = int(np.flatnonzero(bad)[-1]) + 1 if np.any(bad) else 0
    g_static = nd.g[0]

    def fastest(k: int, extra: _Nodes | None = None, diagnose: bool = False) -> ToppResult:
        sub = nd.head(k, extra)
        return _topp(sub, lim, float(pm.speed_at(sub.r[-1])), diagnose)

    def gap(res: ToppResult, r: float) -> float:
        """``T_fast - T_part`` (inf if no plan reaches the part's state at r; a plan that
        needs the round-off slack of the controllable sets to exceed a limit counts as none:
        near the reachability frontier the refinement would otherwise settle there)."""
        if (res.status is not TrackStatus.OK or res.duration_s is None
                or max(res.limit_usage.values(), default=0.0) > 1.0 + LIMIT_RTOL):
            return math.inf
        return float(res.duration_s) - float(pm.time_at(r))

    def qualifies(g: float, r: float) -> bool:
        return g <= TIME_RTOL * max(float(pm.time_at(r)), 1.0)

    # 1. s* = 1: if it does not qualify, nothing does (module docstring)
    res_end = fastest(N, diagnose=True)
    g_end = gap(res_end, 1.0)
    if not qualifies(g_end, 1.0):
        if not math.isfinite(g_end):
            return _infeasible(
                f"{res_end.message}: no plan from rest reaches the part's state at the end of "
                f"the line (r = 1, r' = {v_end:.4g} /s; TOPP-RA on {N + 1} points)",
                objective, grid0, t0, res_end.blocked_at_s, res_end.blocking_limits)
        act = ", ".join(res_end.active_limits) or "none"
        return _infeasible(
            f"infeasible: the hand cannot catch the part on this line: the part reaches the "
            f"end r = 1 at t_f = {t_f:.4g} s, the fastest arrival there with the part's speed "
            f"r' = {v_end:.4g} /s takes {res_end.duration_s:.4g} s (active limits: {act}; "
            f"TOPP-RA on {N + 1} points)", objective, grid0, t0, (0.0, 1.0),
            res_end.active_limits)
    # 2. bisection over the grid points k in (k_lo, N]: the smallest qualifying one
    k_lo = max(k_tail, int(np.searchsorted(s, lo_r, side="right")))  # first candidate
    hi_k, best = N, res_end
    lo_k = k_lo - 1  # not qualifying (or not a candidate)
    if k_lo <= N - 1:
        r_k = fastest(k_lo)
        if qualifies(gap(r_k, s[k_lo]), s[k_lo]):
            hi_k, best = k_lo, r_k
    while hi_k - lo_k > 1:
        mid = (hi_k + lo_k) // 2
        r_m = fastest(mid)
        if qualifies(gap(r_m, s[mid]), s[mid]):
            hi_k, best = mid, r_m
        else:
            lo_k = mid
    # 3. refine inside (s[hi_k - 1], s[hi_k]] unless the bracket's low end is excluded outright
    k = hi_k
    s_star, extra = float(s[k]), None
    left = max(float(s[k - 1]), lo_r) if k >= 1 else lo_r
    a_s, b_s = left, float(s[k])
    for _ in range(REFINE_LEVELS if k >= 1 else 0):  # batches of path points inside
        cs = np.linspace(a_s, b_s, REFINE_POINTS + 1)[1:-1]
        if cs.size == 0 or b_s - a_s <= S_TOL:
            break
        batch = _Nodes.of(phase_coefficients(dynamics, path, cs))  # one vectorised call
        bad_c = np.zeros(cs.shape[0], dtype=bool)
        for m in _state_violations(batch, lim, pm.speed_at(cs),
                                   np.full(cs.shape[0], pm.ra)).values():
            bad_c |= np.any(m, axis=1)  # the tail condition at s* itself
        lo_j, hi_j = -1, cs.shape[0]  # hi_j = len(cs): b_s, which qualifies
        while hi_j - lo_j > 1:
            mid = (lo_j + hi_j) // 2
            ex = _Nodes(*(x[mid:mid + 1] for x in batch._arrays()))
            r_c = fastest(k, ex) if not bad_c[mid] else None
            if r_c is not None and qualifies(gap(r_c, float(cs[mid])), float(cs[mid])):
                hi_j, best, extra = mid, r_c, ex
            else:
                lo_j = mid
        a_s = float(cs[lo_j]) if lo_j >= 0 else a_s
        b_s = float(cs[hi_j]) if hi_j < cs.shape[0] else b_s
    s_star = b_s
    # 4. the plan: wait, fastest arrival, then the tail on the part
    assert best.sd is not None and best.t is not None and best.sdd is not None
    t_a = float(pm.time_at(s_star))
    wait = max(t_a - float(best.duration_s), 0.0)
    if wait > 0.0 and "torque" in lim:
        lo, hi = lim["torque"]
        bad_hold = (g_static < lo) | (g_static > hi)
        if np.any(bad_hold):
            names = [f"torque_{j + 1}" for j in np.flatnonzero(bad_hold)]
            return _infeasible(
                f"infeasible: the intercept at r = {s_star:.4g} needs the hand to wait "
                f"{wait:.4g} s at rest at r = 0, but the arm cannot hold still there "
                f"({_describe(names)}: the static torque exceeds the limit)", objective, grid0,
                t0, (0.0, 0.0), names)
    head = nd.head(k, extra)  # points up to s*
    tail = nd.tail(k if extra is not None else k + 1)  # grid points after s*
    nodes = _Nodes(*(np.concatenate([x, y]) for x, y in
                     zip(head._arrays(), tail._arrays(), strict=True)))
    t_tail = pm.time_at(tail.r)
    t_all = np.concatenate([best.t + wait, t_tail])  # wait >= 0: t starts at exactly 0
    t_all[head.r.shape[0] - 1] = t_a
    rd_all = np.concatenate([best.sd, pm.speed_at(tail.r)])
    rd_all[head.r.shape[0] - 1] = float(pm.speed_at(s_star))
    rdd_all = np.concatenate([best.sdd, np.full(tail.r.shape[0] + 1, pm.ra)])
    traj = _trajectory(nodes, t_all, rd_all, rdd_all, wait > 1e-12, path, reference)
    grid = DPGrid(N, 0, None, float(np.max(rd_all)))
    where = "ahead of" if pm.r0 > 0 else "behind"
    msg = (f"ok: intercepts the part at t_a = {t_a:.4g} s (r = {s_star:.4g}, r' = "
           f"{float(pm.speed_at(s_star)):.4g} /s) by TOPP-RA on {N + 1} points; the part "
           f"starts {where} the hand (r~(0) = {pm.r0:.4g})")
    if wait > 1e-12:
        msg += f"; the hand waits {wait:.4g} s at rest"
    return _ok(msg, objective, grid, t0, traj, lim, best.limit_usage, t_a, wait, t_f, t_a,
               s_star)
