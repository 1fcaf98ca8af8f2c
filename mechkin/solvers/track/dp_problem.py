"""The DPCT problem records (park §2-§4): options, the part's reference, limits, grid, result.

What :func:`mechkin.solvers.track.dpct.solve_conveyor_tracking` is given and returns: the
DP's options and readings (:class:`DPOptions`; the readings are listed in
:mod:`mechkin.solvers.track.dpct`), the part on the belt (:class:`ConveyorReference`, park
Eq. (16)-(17); :class:`PartMotion` for an accelerating belt), the limits (:class:`TrackLimits`,
Eq. (3)-(6)), the phase-plane grid (:class:`DPGrid`, Eq. (23)-(24), reading 1) and the result
(:class:`TrackResult`). Split out of ``dpct.py`` (issue 23: modules that fit in a head).

Design
------
Part of the track room :mod:`mechkin.solvers.track`; may import :mod:`mechkin.records.track`,
:mod:`mechkin.solvers.track.path` and :mod:`mechkin.solvers.result`; never ``io/``, ``cli/``
or ``tasks/``.

References
----------
park_conveyor_tracking_dp, §2-§4, Eq. (1)-(35).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from mechkin.errors import ConfigError
from mechkin.records.track import TrackTrajectory
from mechkin.solvers.result import Status
from mechkin.solvers.track.path import JointPath

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
