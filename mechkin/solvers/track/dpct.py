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
11. **Intercept by decomposition** (:func:`mechkin.solvers.track.intercept.plan_intercept_dp`, chosen
    by :func:`mechkin.solvers.track.plan.plan_track` when the part starts ahead of the hand or
    the belt accelerates, ``ConveyorReference.belt_acceleration``): reading 10's single pass
    keeps one time per node (reading 9's caveat) and no grid state holds an accelerating
    part's speed. Instead, for an intercept stage the DP's minimum time from rest to the
    part's speed there (this recursion with cost ``dt``, the part's speed exactly on its r'
    grid) is compared with the part's arrival time; the part's own motion from there to
    ``r = 1`` is checked with the same limit model; the earliest qualifying stage is found by
    bisection, then the point inside it. The hand waits at rest for the difference.

The recursion is vectorised over all ``(j, l)`` state pairs of a stage; Python loops run over
stages only. :func:`limit_curve` gives the phase plane's limit curve (the largest ``r'`` the
torque and velocity limits admit at each ``r``) that the realised trajectory carries for the
plots.

References
----------
park_conveyor_tracking_dp, §2-§4, Eq. (1)-(35); §5 for the reproduced cases.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from mechkin.errors import ConfigError
from mechkin.records.track import TrackTrajectory  # re-exported: the realised plan
from mechkin.solvers.dynamics.open_chain import InverseDynamics
from mechkin.solvers.track.path import JointPath, PhaseCoefficients, phase_coefficients
from mechkin.solvers.result import Status

logger = logging.getLogger(__name__)

#: Tracking error below which the hand counts as on the part [in r, i.e. fraction of the line].
STEADY_TOL = 1e-9
#: A limit is reported active when the trajectory uses at least this fraction of it.
ACTIVE_FRACTION = 0.98
#: Relative slack when checking limits (round-off only).
LIMIT_RTOL = 1e-9
#: Default N_t / N2 (park §4.2: 80-90 %; PAPER_NOTES: 80 %).
NT_FRACTION = 0.8
#: Samples of r'^2 per stage in the reachability bound of the time-optimal grid.
_REACH_SAMPLES = 2048
#: Relative margin on the sampled reachability bound of r'.
_REACH_MARGIN = 0.01

_FAMILIES = ("torque", "qd", "qdd", "jerk", "q")
#: Weight of the tracking cost that breaks ties of the intercept objective (reading 10).
INTERCEPT_TIE = 1e-6
#: Bisection steps on log(mu) of the time penalty (reading 9).
MU_BISECTIONS = 12


TrackStatus = Status  # ok or infeasible (mechkin.solvers.result)

StepTime = Literal["trapezoid", "euler"]


@dataclass(frozen=True)
class DPOptions:
    """How the DP stage reads park §4 where the text allows two readings (readings 2, 4, 6).

    Attributes
    ----------
    step_time : {"trapezoid", "euler"}
        ``trapezoid`` (default, reading 2): ``dt = 2 dx1 / (x2[j] + x2[l])`` and
        ``r'' = (x2[l]^2 - x2[j]^2) / (2 dx1)`` (Eq. (21) integrated with a constant r'').
        ``euler``: the literal Eq. (26) ``dt = dx1 / x2[j]`` with the forward-Euler Eq. (21)
        ``r'' = (x2[l] - x2[j]) / dt``; leaving rest (``j = 0``, where Eq. (26) is infinite)
        keeps the trapezoid step ``dt = 2 dx1 / x2[l]``, the only finite time of a start from rest.
    wait_cost : bool
        False (default, reading 4): the wait at rest at ``r = 0`` before ``t(0, 0)`` is not
        costed. True: it is costed as Eq. (18) integrates from ``t_0 = 0``, exactly:
        ``int_0^ts (r~(t)^2 + x~2^2) dt = ((r0 + x~2 ts)^3 - r0^3) / (3 x~2) + x~2^2 ts``, added
        at stage 0 (tracking objective only; ``intercept`` already costs the wait).
    jerk_ends : bool
        False (default, reading 6): no jerk check on the first and last step. True: the first
        step's jerk ``(qdd_0 - 0) / dt_0`` (from rest, where qdd = 0) and the last step's
        ``(qdd_after - qdd_last) / dt_last`` are checked too, with ``qdd_after`` the motion
        after the end node: ``f''(1) x~2^2`` on the part (Eq. (11) with r'' = 0), 0 at rest.
    """

    step_time: StepTime = "trapezoid"
    wait_cost: bool = False
    jerk_ends: bool = False

    def __post_init__(self) -> None:
        if self.step_time not in ("trapezoid", "euler"):
            raise ConfigError(f"dp.step_time: expected 'trapezoid' or 'euler', got "
                              f"{self.step_time!r}")


DEFAULT_DP = DPOptions()


def step_arrays(
    x_from: np.ndarray, x_to: np.ndarray, dx1: float, step_time: StepTime = "trapezoid"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(dt, 1/dt, r'')`` of the transitions ``x2 = x_from -> x_to`` over one stage ``dx1``
    (broadcast), by reading 2 (``trapezoid``) or the literal Eq. (21)/(26) (``euler``,
    :class:`DPOptions`). Two rest states give ``dt = inf`` (excluded by the DP)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        if step_time == "trapezoid":
            dt = 2.0 * dx1 / (x_from + x_to)  # reading 2 of the module docstring
            inv_dt = (x_from + x_to) / (2.0 * dx1)
            rdd = (x_to**2 - x_from**2) / (2.0 * dx1)  # constant r'' per transition
            return dt, inv_dt, rdd
        x_from, x_to = np.broadcast_arrays(x_from, x_to)
        rest = x_from == 0.0
        dt = np.where(rest, 2.0 * dx1 / (x_from + x_to), dx1 / x_from)  # park Eq. (26)
        inv_dt = np.where(rest, (x_from + x_to) / (2.0 * dx1), x_from / dx1)
        rdd = np.where(rest, (x_to**2 - x_from**2) / (2.0 * dx1),
                       (x_to - x_from) * inv_dt)  # park Eq. (21), forward Euler
    return dt, inv_dt, rdd


def wait_cost(t_start: np.ndarray, r0: float, rd: float) -> np.ndarray:
    """Eq. (18) over the wait at rest at ``r = 0`` from ``t_0 = 0`` to ``t_start`` (exact):
    ``((r0 + rd ts)^3 - r0^3) / (3 rd) + rd^2 ts``; 0 for ``ts <= 0``."""
    ts = np.maximum(np.asarray(t_start, dtype=np.float64), 0.0)
    return ((r0 + rd * ts) ** 3 - r0**3) / (3.0 * rd) + rd * rd * ts


@dataclass(frozen=True)
class PartMotion:
    r"""The part's motion in the path parameter: ``r~(t) = r0 + rd t + ra t^2 / 2``.

    Park Eq. (16)-(17) with the constant belt acceleration of park §6 (``ra = 0``: park's
    constant-speed belt). ``rd > 0`` (the belt carries the part towards ``r = 1``).
    """

    r0: float
    rd: float
    ra: float = 0.0

    def position(self, t: np.ndarray | float) -> np.ndarray:
        """``r~(t)``."""
        t = np.asarray(t, dtype=np.float64)
        return self.r0 + self.rd * t + 0.5 * self.ra * t * t

    def speed(self, t: np.ndarray | float) -> np.ndarray:
        """``r~'(t)``."""
        return self.rd + self.ra * np.asarray(t, dtype=np.float64)

    def speed_at(self, r: np.ndarray | float) -> np.ndarray:
        """The part's speed when it is at ``r``: ``sqrt(rd^2 + 2 ra (r - r0))`` (NaN where the
        part never gets there moving forwards)."""
        v2 = self.rd * self.rd + 2.0 * self.ra * (np.asarray(r, dtype=np.float64) - self.r0)
        with np.errstate(invalid="ignore"):
            return np.where(v2 > 0.0, np.sqrt(np.maximum(v2, 0.0)), np.nan)

    def time_at(self, r: np.ndarray | float) -> np.ndarray:
        """When the part is at ``r``: ``(v(r) - rd) / ra`` (``(r - r0) / rd`` for ``ra = 0``),
        written ``2 (r - r0) / (rd + v(r))`` so it holds for both (NaN where it never is)."""
        return 2.0 * (np.asarray(r, dtype=np.float64) - self.r0) / (self.rd + self.speed_at(r))

    def stop_time(self) -> float:
        """When a decelerating belt stops the part (``inf`` if it never does)."""
        return -self.rd / self.ra if self.ra < 0.0 else float("inf")


@dataclass(frozen=True)
class ConveyorReference:
    """The part on the belt: ``X_p(t) = part_start + belt_velocity t + belt_acceleration t^2/2``
    (park Eq. (1); the acceleration term is park §6's accelerating belt, zero by default).

    Parameters
    ----------
    part_start : array, shape (d,)
        ``X_p(t_0)`` [m].
    belt_velocity : array, shape (d,)
        ``V_b`` [m/s].
    belt_acceleration : array, shape (d,), optional
        Constant belt acceleration [m/s^2]; default zero.
    """

    part_start: np.ndarray
    belt_velocity: np.ndarray
    belt_acceleration: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.belt_acceleration is None:
            object.__setattr__(self, "belt_acceleration",
                               np.zeros_like(np.asarray(self.belt_velocity, dtype=np.float64)))
        for name in ("part_start", "belt_velocity", "belt_acceleration"):
            a = np.asarray(getattr(self, name), dtype=np.float64)
            if a.ndim != 1 or not np.all(np.isfinite(a)):
                raise ValueError(f"{name}: expected a finite vector, got {a!r}")
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def accelerating(self) -> bool:
        """The belt has a nonzero acceleration."""
        return bool(np.any(self.belt_acceleration != 0.0))

    def position(self, t: np.ndarray, path: JointPath | None = None) -> np.ndarray:
        """``X_p(t) (m, d)`` for ``t (m,)`` (park Eq. (1), plus ``a t^2 / 2``); on a curved
        ``path`` the part moves along the path by arc length, ``X_p = p(r0 + rd t)``
        (:meth:`phase`; an accelerating belt on a curved path is refused by :meth:`motion`)."""
        geometry = getattr(path, "geometry", None)
        if geometry is not None and not geometry.straight:
            r0, rd = geometry.conveyor_phase(self.part_start, self.belt_velocity)
            return geometry.position(r0 + rd * np.asarray(t, dtype=np.float64))
        t = np.asarray(t, dtype=np.float64)[:, None]
        return self.part_start + t * self.belt_velocity + 0.5 * t * t * self.belt_acceleration

    def phase(self, path: JointPath) -> tuple[float, float]:
        r"""``(r0, rd)`` with ``x~1(t) = r0 + rd t``, ``x~2 = rd`` (park Eq. (16)-(17)).

        Eq. (17) divides by one component of ``X_h(t_f) - X_h(t_0)``; the largest is used, and
        the part must move on the hand's line (else no steady state with zero error exists).

        On a curved path (``path.geometry``, :mod:`mechkin.solvers.track.path_geometry`, not
        straight) the part moves along the path itself: ``r0`` is the path parameter (normalised
        arc length) of ``part_start`` and ``rd = V_b . t(r0) / L``
        (:meth:`~mechkin.solvers.track.path_geometry.PathGeometry.conveyor_phase`).

        Raises
        ------
        ConfigError
            If the belt does not carry the part along the hand's line, or carries it backwards.
        """
        geometry = getattr(path, "geometry", None)
        if geometry is not None and not geometry.straight:
            return geometry.conveyor_phase(self.part_start, self.belt_velocity)
        p0 = path.hand(np.zeros(1))[0]
        dp = path.hand(np.ones(1))[0] - p0
        if dp.shape != self.part_start.shape or dp.shape != self.belt_velocity.shape:
            raise ConfigError(
                f"conveyor: expected {dp.shape[0]}-vectors like the hand path, got "
                f"part_start {self.part_start.shape}, belt_velocity {self.belt_velocity.shape}"
            )
        k = int(np.argmax(np.abs(dp)))
        r0 = float((self.part_start[k] - p0[k]) / dp[k])  # park Eq. (17)
        rd = float(self.belt_velocity[k] / dp[k])  # park Eq. (17)
        scale = float(np.linalg.norm(dp))
        off = max(
            float(np.linalg.norm(self.part_start - (p0 + r0 * dp))),
            float(np.linalg.norm(self.belt_velocity - rd * dp)),
        )
        if off > 1e-9 * max(scale, 1.0):
            raise ConfigError(
                "conveyor: the part does not move along the hand's straight line "
                f"(off by {off:.3g} m or m/s); park Eq. (16) needs it on the line"
            )
        if rd <= 0.0:
            raise ConfigError(
                f"conveyor: the belt moves the part away from the path's end (r' = {rd:.3g} /s)"
            )
        return r0, rd

    def motion(self, path: JointPath) -> PartMotion:
        r"""The part in the path parameter, ``r~(t) = r0 + rd t + ra t^2 / 2``.

        ``(r0, rd)`` from :meth:`phase`; ``ra`` maps the belt acceleration onto the line the
        same way (park Eq. (17) applied to ``d^2 X_p / dt^2``).

        Raises
        ------
        ConfigError
            As :meth:`phase`; also if the acceleration is not along the hand's line or the
            shape differs.
        """
        r0, rd = self.phase(path)
        acc = self.belt_acceleration
        if not self.accelerating:
            return PartMotion(r0, rd, 0.0)
        geometry = getattr(path, "geometry", None)
        if geometry is not None and not geometry.straight:
            raise ConfigError("conveyor: belt_acceleration on a curved path is not supported "
                              "(the part moves along the path at a constant speed there)")
        p0 = path.hand(np.zeros(1))[0]
        dp = path.hand(np.ones(1))[0] - p0
        if acc.shape != dp.shape:
            raise ConfigError(f"conveyor: expected a {dp.shape[0]}-vector belt_acceleration "
                              f"like the hand path, got {acc.shape}")
        k = int(np.argmax(np.abs(dp)))
        ra = float(acc[k] / dp[k])
        off = float(np.linalg.norm(acc - ra * dp))
        if off > 1e-9 * max(float(np.linalg.norm(dp)), 1.0):
            raise ConfigError("conveyor: the belt acceleration is not along the hand's line "
                              f"(off by {off:.3g} m/s^2)")
        return PartMotion(r0, rd, ra)


def resolve_planner(planner: str, objective: str, limits: TrackLimits | None) -> str:
    """``auto`` -> ``topp`` for ``time`` / ``intercept`` with torque, velocity or acceleration
    limits and no jerk limit, else ``dp``;
    ``topp`` where it cannot plan (tracking, a jerk limit) is a ConfigError."""
    if planner not in ("auto", "dp", "topp"):
        raise ConfigError(f"planner: expected 'auto', 'dp' or 'topp', got {planner!r}")
    jerk = limits is not None and limits.jerk is not None
    bounded = limits is not None and any(
        getattr(limits, k) is not None for k in ("torque", "qd", "qdd"))
    if planner == "auto":  # without any rate limit TOPP-RA has no finite speed to plan
        return "topp" if objective in ("time", "intercept") and bounded and not jerk else "dp"
    if planner == "topp" and objective == "tracking":
        raise ConfigError("planner: topp plans the time and intercept objectives; tracking "
                          "(park's cost, Eq. (28)) needs planner dp")
    if planner == "topp" and jerk:
        raise ConfigError("planner: topp (TOPP-RA) cannot impose jerk limits (limits.jerk); "
                          "use planner dp or auto")
    return planner


def _limit_pair(
    lo: np.ndarray | None, hi: np.ndarray | None, name: str
) -> tuple[np.ndarray, np.ndarray] | None:
    if lo is None and hi is None:
        return None
    if lo is None or hi is None:
        raise ValueError(f"{name}: give both bounds or neither")
    lo_a = np.asarray(lo, dtype=np.float64)
    hi_a = np.asarray(hi, dtype=np.float64)
    if lo_a.shape != hi_a.shape or lo_a.ndim != 1:
        raise ValueError(f"{name}: expected two (n,) vectors, got {lo_a.shape} and {hi_a.shape}")
    if np.any(np.isnan(lo_a)) or np.any(np.isnan(hi_a)) or np.any(lo_a > hi_a):
        raise ValueError(f"{name}: expected lo <= hi, got {lo_a} and {hi_a}")
    lo_a.setflags(write=False)
    hi_a.setflags(write=False)
    return lo_a, hi_a


@dataclass(frozen=True)
class TrackLimits:
    """Joint limits of park Eq. (3)-(6); each pair is ``(lo (n,), hi (n,))`` or None (no limit).

    Units: torque [N m | N], qd [rad/s | m/s], qdd [rad/s^2], jerk [rad/s^3], q (joint
    positions, the mechanism's limits or strokes) [rad | m]. Infinite bounds are allowed per
    joint.
    """

    torque: tuple[np.ndarray, np.ndarray] | None = None
    qd: tuple[np.ndarray, np.ndarray] | None = None
    qdd: tuple[np.ndarray, np.ndarray] | None = None
    jerk: tuple[np.ndarray, np.ndarray] | None = None
    q: tuple[np.ndarray, np.ndarray] | None = None

    def __post_init__(self) -> None:
        for name in _FAMILIES:
            pair = getattr(self, name)
            if pair is not None:
                object.__setattr__(self, name, _limit_pair(pair[0], pair[1], name))

    @classmethod
    def symmetric(
        cls,
        *,
        torque: np.ndarray | None = None,
        qd: np.ndarray | None = None,
        qdd: np.ndarray | None = None,
        jerk: np.ndarray | None = None,
    ) -> TrackLimits:
        """Limits ``-x <= . <= x`` from magnitudes ``x (n,)`` (park Eq. (36)-(37))."""

        def pair(x: np.ndarray | None) -> tuple[np.ndarray, np.ndarray] | None:
            if x is None:
                return None
            a = np.asarray(x, dtype=np.float64)
            return -a, a

        return cls(torque=pair(torque), qd=pair(qd), qdd=pair(qdd), jerk=pair(jerk))

    def families(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """The limit families that are set, by name."""
        return {k: getattr(self, k) for k in _FAMILIES if getattr(self, k) is not None}

    def checked(self, n: int) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """:meth:`families`, each with one value per joint of an ``n``-joint path.

        Raises
        ------
        ConfigError
            ``limits.<name>: expected n values`` for a family of another length.
        """
        lim = self.families()
        for name, (lo, _) in lim.items():
            if lo.shape != (n,):
                raise ConfigError(f"limits.{name}: expected {n} values, got {lo.shape[0]}")
        return lim


@dataclass(frozen=True)
class DPGrid:
    """The phase-plane grid (park Eq. (23)-(24)).

    ``x1[i] = i / N1``; ``x2[j] = j dx2`` for ``j = 0..N2``; tracking puts ``x~2`` at ``j = Nt``;
    the time-optimal mode has ``Nt = None`` and its top ``x2_max`` from a reachability bound.
    """

    N1: int
    N2: int
    Nt: int | None
    x2_max: float

    @property
    def dx1(self) -> float:
        """Stage spacing in r."""
        return 1.0 / self.N1

    @property
    def dx2(self) -> float:
        """State spacing in r' [1/s]."""
        return self.x2_max / self.N2


@dataclass(frozen=True)
class TrackResult:
    """Result of :func:`solve_conveyor_tracking`.

    Attributes
    ----------
    status : TrackStatus
    message : str
        One line; for an infeasible problem it names the limit and where on the path it blocks.
    objective : {"tracking", "time"}
    t_a_s : float or None
        End of the transient (park §2), tracking only [s].
    t_start_s : float or None
        When the hand leaves rest [s] (tracking: the DP's ``t(0, 0)``; time: 0).
    duration_s : float or None
        Tracking: ``t_f`` (the plan spans ``[0, t_f]``); time: the rest-to-rest motion time [s].
    peak_torque : array, shape (n,), or None
        Signed torque of largest magnitude per joint.
    limits_ok : bool
        Every set limit holds on the realised trajectory (``LIMIT_RTOL`` slack).
    active_limits : tuple of str
        ``"torque_1"``, ``"qd_2"``, ...: limits used to at least ``ACTIVE_FRACTION``.
    limit_usage : dict
        Largest fraction of each limit used, by the same names.
    grid : DPGrid
    cost : float
        ``J*(0, 0)`` (Eq. (30)); the duration for the time objective.
    solve_time_s : float
    blocked_at_r : tuple of float or None
        For an infeasible problem, the r interval where the search dies.
    blocking_limits : tuple of str
        For an infeasible problem, the limit families that block.
    time_penalty : float
        The multiplier ``mu`` of reading 9 (0 unless the part starts ahead of the hand).
    trajectory : TrackTrajectory or None
    dp : DPOptions
        The readings of the DP stage the plan was made with.
    planner : {"dp", "topp"}
        The phase-plane DP of this module or the TOPP-RA planner of
        :mod:`mechkin.solvers.track.intercept` (``grid.N2 = 0``: it has no r' grid).
    intercept_r : float or None
        TOPP intercept only: the path parameter where the hand meets the part.
    """

    status: TrackStatus
    message: str
    objective: str
    t_a_s: float | None
    t_start_s: float | None
    duration_s: float | None
    peak_torque: np.ndarray | None
    limits_ok: bool
    active_limits: tuple[str, ...]
    limit_usage: dict[str, float]
    grid: DPGrid
    cost: float
    solve_time_s: float
    blocked_at_r: tuple[float, float] | None = None
    blocking_limits: tuple[str, ...] = ()
    time_penalty: float = 0.0
    trajectory: TrackTrajectory | None = field(default=None, repr=False)
    dp: DPOptions = DEFAULT_DP
    planner: str = "dp"
    intercept_r: float | None = None

    def summary(self) -> dict[str, object]:
        """JSON-ready key figures (no trajectory arrays) for ``summary.json``."""
        return {
            "status": self.status.value,
            "message": self.message,
            "objective": self.objective,
            "t_a_s": self.t_a_s,
            "t_start_s": self.t_start_s,
            "duration_s": self.duration_s,
            "peak_torque": None if self.peak_torque is None else self.peak_torque.tolist(),
            "limits_ok": self.limits_ok,
            "active_limits": list(self.active_limits),
            "limit_usage": dict(self.limit_usage),
            "grid": {
                "N1": self.grid.N1,
                "N2": self.grid.N2,
                "Nt": self.grid.Nt,
                "x2_max_1_s": self.grid.x2_max,
            },
            "cost": self.cost if np.isfinite(self.cost) else None,
            "solve_time_s": self.solve_time_s,
            "blocked_at_r": None if self.blocked_at_r is None else list(self.blocked_at_r),
            "blocking_limits": list(self.blocking_limits),
            "time_penalty": self.time_penalty,
            "dp": {"step_time": self.dp.step_time, "wait_cost": self.dp.wait_cost,
                   "jerk_ends": self.dp.jerk_ends},
            "planner": self.planner,
            "intercept_r": self.intercept_r,
        }


def _slack(b: np.ndarray) -> np.ndarray:
    """Round-off slack of a bound (``LIMIT_RTOL``, absolute below 1)."""
    return LIMIT_RTOL * np.maximum(np.abs(b), 1.0)


def _within(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``lo <= x <= hi`` per joint (last axis) with round-off slack; NaN counts as inside."""
    return ~((x < lo - _slack(lo)) | (x > hi + _slack(hi)))


@dataclass
class _Stage:
    """Stage-independent arrays of all ``(j, l)`` transitions (module docstring, reading 2)."""

    x2: np.ndarray  # (N2+1,)
    dt: np.ndarray  # (N2+1, N2+1) 2 dx1 / (x2[j] + x2[l]); inf between two rest states
    inv_dt: np.ndarray  # (N2+1, N2+1)
    rdd: np.ndarray  # (N2+1, N2+1) (x2[l]^2 - x2[j]^2) / (2 dx1)


def _transition_checks(
    limits: dict[str, tuple[np.ndarray, np.ndarray]],
    pc: PhaseCoefficients,
    i: int,
    rows: slice,
    st: _Stage,
    qdd_next: np.ndarray,
    per_family: bool,
    qdd_prev: np.ndarray | None = None,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Limit checks of all transitions ``(i, j) -> (i+1, l)``, ``j`` in ``rows``.

    Returns ``ok (J, L)``, true where every limit holds, and (with ``per_family``) per-joint
    masks ``"torque_1" -> (J, L)`` for the diagnosis of a blocked stage. Torque (Eq. (3), (12))
    is checked as an interval of r'', velocity (Eq. (4)') per row, acceleration (Eq. (32),
    (5)') and jerk (Eq. (33), (6)', with the successor's stored ``qdd_next``) per pair;
    ``qdd_prev (n,)`` (the departure from rest, ``DPOptions.jerk_ends``) adds the jerk
    ``(qdd - qdd_prev) / dt`` of the step itself.
    """
    x2j = st.x2[rows]
    inv_dt = st.inv_dt[rows]
    rdd = st.rdd[rows]
    ok = np.ones(inv_dt.shape, dtype=bool)
    masks: dict[str, np.ndarray] = {}

    def keep(name: str, m: np.ndarray) -> None:
        ok[...] &= m
        if per_family:
            masks[name] = np.broadcast_to(m, ok.shape)

    for k in range(pc.a.shape[1]):
        if "torque" in limits:
            lo, hi = limits["torque"][0][k], limits["torque"][1][k]
            c = pc.b[i, k] * x2j**2 + pc.g[i, k]  # park Eq. (12) without the r'' term
            a = pc.a[i, k]
            if a == 0.0:
                keep(f"torque_{k + 1}", ((c >= lo - _slack(lo)) & (c <= hi + _slack(hi)))[:, None])
            else:
                b1 = (lo - _slack(lo) - c) / a
                b2 = (hi + _slack(hi) - c) / a
                r_lo, r_hi = np.minimum(b1, b2), np.maximum(b1, b2)
                keep(f"torque_{k + 1}", (rdd >= r_lo[:, None]) & (rdd <= r_hi[:, None]))
        qd_j = pc.dq[i, k] * x2j  # park Eq. (10), (4)'
        if "qd" in limits:
            lo, hi = limits["qd"][0][k], limits["qd"][1][k]
            keep(f"qd_{k + 1}", ((qd_j >= lo - _slack(lo)) & (qd_j <= hi + _slack(hi)))[:, None])
        if "qdd" in limits or "jerk" in limits:
            qdd = (pc.dq[i + 1, k] * st.x2[None, :] - qd_j[:, None]) * inv_dt  # park Eq. (32)
            if "qdd" in limits:
                lo, hi = limits["qdd"][0][k], limits["qdd"][1][k]
                keep(f"qdd_{k + 1}", (qdd >= lo - _slack(lo)) & (qdd <= hi + _slack(hi)))
            if "jerk" in limits:
                lo, hi = limits["jerk"][0][k], limits["jerk"][1][k]
                jerk = (qdd_next[None, :, k] - qdd) * inv_dt  # park Eq. (33)
                keep(f"jerk_{k + 1}", ~((jerk < lo - _slack(lo)) | (jerk > hi + _slack(hi))))
                if qdd_prev is not None:  # the step from rest (DPOptions.jerk_ends)
                    jerk = (qdd - qdd_prev[k]) * inv_dt
                    keep(f"jerk_{k + 1}", (jerk >= lo - _slack(lo)) & (jerk <= hi + _slack(hi)))
    return ok, masks


def _reachable_x2_max(
    pc: PhaseCoefficients, limits: dict[str, tuple[np.ndarray, np.ndarray]], dx1: float
) -> float:
    """Largest r' reachable from rest that can still stop at r = 1 (time-optimal grid top).

    A sampled forward/backward reachability pass on ``x = r'^2`` with the collocated torque and
    node-velocity limits (``x_{i+1} = x_i + 2 dx1 r''_i``); acceleration and jerk limits only
    shrink the true set, so the bound stays an upper bound of every feasible DP path.
    """
    K = pc.r.shape[0]
    x_cap = np.full(K, np.inf)
    if "qd" in limits:
        lo, hi = limits["qd"]
        f1 = pc.dq
        with np.errstate(divide="ignore", invalid="ignore"):
            cap = np.where(f1 > 0, hi / f1, np.where(f1 < 0, lo / f1, np.inf))
        x_cap = np.minimum(x_cap, np.min(cap, axis=1) ** 2)

    def u_range(i: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        u_lo = np.full(x.shape, -np.inf)
        u_hi = np.full(x.shape, np.inf)
        if "torque" in limits:
            lo, hi = limits["torque"]
            for k in range(pc.a.shape[1]):
                c = pc.b[i, k] * x + pc.g[i, k]
                a = pc.a[i, k]
                if a == 0.0:
                    bad = (c < lo[k]) | (c > hi[k])
                    u_lo = np.where(bad, np.inf, u_lo)
                    continue
                b1, b2 = (lo[k] - c) / a, (hi[k] - c) / a
                u_lo = np.maximum(u_lo, np.minimum(b1, b2))
                u_hi = np.minimum(u_hi, np.maximum(b1, b2))
        return u_lo, u_hi

    fwd = np.zeros(K)  # largest x reachable from rest
    for i in range(K - 1):
        top_i = min(fwd[i], x_cap[i])
        if not np.isfinite(top_i):
            fwd[i + 1] = np.inf
            continue
        x = np.linspace(0.0, top_i, _REACH_SAMPLES)
        u_lo, u_hi = u_range(i, x)
        ok = u_lo <= u_hi
        nxt = x[ok] + 2.0 * dx1 * u_hi[ok] if np.any(ok) else np.zeros(1)
        fwd[i + 1] = min(max(float(np.max(nxt)), 0.0), x_cap[i + 1])
    bwd = np.zeros(K)  # largest reachable x that can still come to rest at r = 1
    for i in range(K - 2, -1, -1):
        top_i = min(fwd[i], x_cap[i])
        if not np.isfinite(top_i):
            raise ConfigError(
                "objective time: the limits do not bound the path speed; "
                "give torque or velocity limits, or x2_max"
            )
        x = np.linspace(0.0, top_i, _REACH_SAMPLES)
        u_lo, u_hi = u_range(i, x)
        u_min = np.maximum(u_lo, -x / (2.0 * dx1))  # x_{i+1} = x + 2 dx1 u >= 0
        ok = (u_min <= u_hi) & (x + 2.0 * dx1 * u_min <= bwd[i + 1])
        bwd[i] = float(np.max(x[ok])) if np.any(ok) else 0.0
    top = float(np.max(bwd)) * (1.0 + _REACH_MARGIN) ** 2
    if not np.isfinite(top) or top <= 0.0:
        raise ConfigError(
            "objective time: the limits do not bound the path speed; "
            "give torque or velocity limits, or x2_max"
        )
    return float(np.sqrt(top))


def _joint_names(mask_fail: np.ndarray, family: str) -> list[str]:
    return [f"{family}_{k + 1}" for k in np.flatnonzero(mask_fail)]


def _diagnose(masks: dict[str, np.ndarray], base: np.ndarray) -> list[str]:
    """Which limits block a dead stage: those whose removal re-opens a transition.

    ``masks`` maps ``"torque_1"``-style names (and ``"start"``) to ``(J, L)`` masks; ``base``
    marks the transitions that reach a live state. Each limit is relaxed alone, and each family
    (all joints of one kind) together; the limits that fail on the re-opened transitions are
    named. If nothing re-opens, every limit that fails somewhere on ``base`` is named.
    """
    groups: dict[str, list[str]] = {}
    for name in masks:
        groups.setdefault(name.partition("_")[0], []).append(name)
    candidates = [[name] for name in masks] + [g for g in groups.values() if len(g) > 1]
    found: set[str] = set()
    for group in candidates:
        reopened = base.copy()
        for other, m in masks.items():
            if other not in group:
                reopened &= m
        if np.any(reopened):
            found.update(name for name in group if not np.all(masks[name][reopened]))
    if not found:
        found = {name for name, m in masks.items() if not np.all(m[base])}
    return [name for name in masks if name in found]


def _describe(names: list[str]) -> str:
    """``["torque_1", "jerk_1", "jerk_2"]`` -> a phrase naming the limits and joints."""
    words = {
        "torque": "torque limit",
        "qd": "joint velocity limit",
        "qdd": "joint acceleration limit",
        "jerk": "joint jerk limit",
        "start": "start no earlier than t_0 = 0",
        "q": "joint position limit",
    }
    joints: dict[str, list[str]] = {}
    for nm in names:
        fam, _, joint = nm.partition("_")
        joints.setdefault(fam, [])
        if joint:
            joints[fam].append(joint)
    out = []
    for fam, js in joints.items():
        w = words.get(fam, fam)
        if js:
            w += f" (joint{'s' if len(js) > 1 else ''} {', '.join(js)})"
        out.append(w)
    return ", ".join(out)


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
    N2 = x2.shape[0] - 1
    n = pc.a.shape[1]
    dx1 = 1.0 / N1
    V = np.full((N1 + 1, N2 + 1), np.inf)
    T = np.full((N1 + 1, N2 + 1), np.nan)
    NP = np.zeros((N1, N2 + 1), dtype=np.int64)

    # end node (park Eq. (23)): torque with r'' = 0 and velocity must hold there too
    end_fail: list[str] = []
    x_end = x2[j_end]
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

    dt, inv_dt, rdd = step_arrays(x2[:, None], x2[None, :], dx1, opts.step_time)
    st = _Stage(x2=x2, dt=dt, inv_dt=inv_dt, rdd=rdd)
    for i in range(N1 - 1, -1, -1):
        with np.errstate(invalid="ignore"):  # inf * 0 of rest-to-rest pairs, masked out
            out = _dp_stage(i, pc, limits, st, V, T, NP, qdd_next, reference, mu, intercept,
                            opts)
        if isinstance(out, list):
            return _DPTables(V, NP, T, (i, out))
        qdd_next = out
    return _DPTables(V, NP, T, None)


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
    dqd = pc.dq[i + 1] * st.x2[best][:, None] - pc.dq[i] * x2j[:, None]
    qdd_new[rows] = dqd * st.inv_dt[rows][jj, best][:, None]  # park Eq. (32), chosen transitions
    return qdd_new


def _usage(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Largest fraction of each joint's limit used, ``(n,)``; NaN samples ignored."""
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.where(hi > 0, x / hi, np.where(x > 0, np.inf, 0.0))
        dn = np.where(lo < 0, x / lo, np.where(x < 0, np.inf, 0.0))
    both = np.fmax(up, dn)
    both = np.where(np.isnan(x), -np.inf, both)
    return np.max(both, axis=0)


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


def _usage_interval(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Largest distance from the middle of ``[lo, hi]`` per joint as a fraction of the half
    width ``(n,)`` (1 at a bound; joint positions, whose interval need not contain 0); an
    unbounded side counts 0."""
    finite = np.isfinite(lo) & np.isfinite(hi)
    mid = np.where(finite, 0.5 * (lo + hi), 0.0)
    half = np.where(finite, 0.5 * (hi - lo), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(half > 0, np.abs(x - mid) / half, np.where(x == mid, 0.0, np.inf))
    one_side = ~finite & (np.isfinite(lo) | np.isfinite(hi))  # only one bound: 0 inside
    if np.any(one_side):
        out = (x < lo) | (x > hi)
        u = np.where(one_side, np.where(out, np.inf, 0.0), u)
    return np.max(np.where(np.isnan(x), -np.inf, u), axis=0)



def limit_usage(values: dict[str, np.ndarray], lim: dict[str, tuple[np.ndarray, np.ndarray]],
                extra: dict[str, float] | None = None
                ) -> tuple[dict[str, float], bool, tuple[str, ...]]:
    """Usage of every limit by the realised values (``values[name] (K, n)``; families without
    values are skipped): ``{"torque_1": u, ...}`` (1 = at the limit; joint positions by
    :func:`_usage_interval`, the others by :func:`_usage`), merged by maximum with ``extra``
    (another planner's own usage), whether all hold (within ``LIMIT_RTOL``) and the active
    ones (used to at least ``ACTIVE_FRACTION``)."""
    extra = extra or {}
    usage: dict[str, float] = {}
    for name, (lo, hi) in lim.items():
        if name not in values:
            continue
        use = _usage_interval if name == "q" else _usage
        for k, u in enumerate(use(values[name], lo, hi)):
            key = f"{name}_{k + 1}"
            usage[key] = max(float(u), extra.get(key, 0.0))
    ok = all(u <= 1.0 + LIMIT_RTOL for u in usage.values())
    active = tuple(k for k, u in usage.items() if u >= ACTIVE_FRACTION)
    return usage, ok, active


def _position_block(
    pc: PhaseCoefficients, q_lim: tuple[np.ndarray, np.ndarray]
) -> tuple[int, list[int]] | None:
    """First stage whose ``q(x1[i])`` leaves the joint position limits, and its joints (a node
    state ``(x1[i], x2[j])`` is infeasible for every ``j``: q depends on r alone, Eq. (9))."""
    lo, hi = q_lim
    bad = (pc.q < lo - _slack(lo)) | (pc.q > hi + _slack(hi))
    rows = np.flatnonzero(np.any(bad, axis=1))
    if rows.size == 0:
        return None
    i = int(rows[0])
    return i, [int(k) for k in np.flatnonzero(bad[i])]


def limit_curve(
    pc: PhaseCoefficients, limits: dict[str, tuple[np.ndarray, np.ndarray]]
) -> np.ndarray:
    r"""The phase plane's limit curve: the largest ``r'`` at each grid point ``r`` for which the
    torque limits (Eq. (3), (12)) admit some ``r''`` and the velocity limits (Eq. (4)') hold,
    ``(K,)`` [1/s]; inf where nothing bounds it, NaN where no ``r'`` is admissible.

    With ``s = r'^2`` every joint's torque interval ``lo <= a r'' + b s + g <= hi`` is an
    interval of ``r''`` whose ends are linear in ``s``; they intersect iff every lower end is at
    most every upper end, a set of linear inequalities ``c0 + c1 s <= 0``, so the admissible
    ``s`` form one interval and the curve is the square root of its top. Acceleration and jerk
    limits depend on the neighbouring nodes and are not part of it.
    """
    K, n = pc.a.shape
    c0: list[np.ndarray] = []
    c1: list[np.ndarray] = []
    if "torque" in limits:
        lo, hi = limits["torque"]
        with np.errstate(divide="ignore", invalid="ignore"):
            ends = []  # per joint: (lower r'' end, upper r'' end) as (const, slope in s)
            for k in range(n):
                a, b, g = pc.a[:, k], pc.b[:, k], pc.g[:, k]
                if np.all(a == 0.0):
                    c0 += [g - hi[k], lo[k] - g]  # b s + g <= hi, lo <= b s + g
                    c1 += [b, -b]
                    continue
                e_lo = ((lo[k] - g) / a, -b / a)
                e_hi = ((hi[k] - g) / a, -b / a)
                pos = a > 0
                ends.append(((np.where(pos, e_lo[0], e_hi[0]), np.where(pos, e_lo[1], e_hi[1])),
                             (np.where(pos, e_hi[0], e_lo[0]), np.where(pos, e_hi[1], e_lo[1]))))
            for (lk, _) in ends:
                for (_, um) in ends:
                    c0.append(lk[0] - um[0])
                    c1.append(lk[1] - um[1])
    s_hi = np.full(K, np.inf)
    s_lo = np.zeros(K)
    empty = np.zeros(K, dtype=bool)
    for a0, a1 in zip(c0, c1, strict=True):
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = -a0 / a1
        s_hi = np.where((a1 > 0) & ~np.isnan(bound), np.minimum(s_hi, bound), s_hi)
        s_lo = np.where((a1 < 0) & ~np.isnan(bound), np.maximum(s_lo, bound), s_lo)
        empty |= (a1 == 0) & (a0 > 0)
    if "qd" in limits:
        lo, hi = limits["qd"]
        with np.errstate(divide="ignore", invalid="ignore"):
            cap = np.where(pc.dq > 0, hi / pc.dq, np.where(pc.dq < 0, lo / pc.dq, np.inf))
        s_hi = np.minimum(s_hi, np.min(cap, axis=1) ** 2)
    top = np.sqrt(np.maximum(s_hi, 0.0))
    return np.where(empty | (s_lo > s_hi) | (s_hi < 0), np.nan, top)
def position_limit_message(
    pc: PhaseCoefficients,
    path: JointPath,
    q_lim: tuple[np.ndarray, np.ndarray],
    blocked: tuple[int, list[int]],
    joint_names: Sequence[str] | None,
) -> tuple[str, list[str]]:
    """The message of a joint position limit that blocks stage ``blocked[0]`` (reading 8),
    naming the joints, r and the hand point; and the limit names ``q_k``."""
    i_b, js = blocked
    lo, hi = q_lim
    n = pc.q.shape[1]
    names = [f"q_{k + 1}" for k in js]
    hand = np.round(path.hand(pc.r[i_b:i_b + 1])[0], 4).tolist()
    jn = list(joint_names) if joint_names is not None else [f"q{k + 1}" for k in range(n)]
    detail = "; ".join(f"{jn[k]} = {pc.q[i_b, k]:.4g} outside [{lo[k]:.4g}, {hi[k]:.4g}]"
                       for k in js)
    message = (f"infeasible: joint position limit (joint{'s' if len(js) > 1 else ''} "
               f"{', '.join(f'{k + 1} = {jn[k]}' for k in js)}) blocks the motion at r = "
               f"{pc.r[i_b]:.4g} (hand at {hand} m; {detail}, SI units): the path's inverse "
               "kinematics leaves the joint limits there")
    return message, names


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
    rd = x2[js]
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
        message = f"ok: rest-to-rest time {duration:.4g} s on the {N1}x{N2} grid"
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
