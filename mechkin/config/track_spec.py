"""``track:`` section of scenario files: conveyor tracking by DP in the phase plane (park §2-§5).

Registered with :func:`mechkin.config.scenario.register_task_section` on import. Numbers are in
the scenario's ``units``: path points, the part and the belt in the length unit (m/s for the
belt in that unit per second); joint velocity, acceleration and jerk limits in the angle unit
per s, s^2, s^3 for revolute joints (length unit for prismatic ones); torques always in N m
(forces in N). :func:`limits_si` and :func:`point_si` convert to SI.

Example (park §5.3, all limits)::

    track:
      objective: tracking
      path: {start: [-0.8, 1.732, 0], end: [-0.3, 1.732, 0]}
      ik: {branch: {q2: positive}}
      conveyor: {part_start: [-0.9, 1.732, 0], belt_velocity: [0.2, 0, 0]}
      grid: {N1: 50, N2: 100, nt_fraction: 0.8}
      limits: {torque: [0.5, 0.2], qd: [0.2, 0.2], qdd: [0.3, 0.3], jerk: [2.3, 2.0]}
      dynamics: rnea
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, model_validator

from mechkin.config.scenario import register_task_section
from mechkin.config.schema import Name, Num, PosNum, Spec, Units
from mechkin.config.units import angle_factor, length_factor

Point = Annotated[list[Num], Field(min_length=2, max_length=3)]
GridInt = Annotated[int, Field(strict=True, ge=1, le=5000)]
Fraction = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0, le=1)]


Component = Literal["x", "y", "z", "rx", "ry", "rz"]
COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")


Rpy = Annotated[list[Num], Field(min_length=3, max_length=3)]


class PathSpec(Spec):
    """Hand path, parametrised by normalised arc length ``r`` in [0, 1] (park Eq. (7) for the
    line), and the hand ``frame`` (default: the end effector). Points in the length unit (2
    values: z = 0; all points with the same number of values).

    ``type``: ``line`` (default; ``start``, ``end``), ``arc`` (the circular arc from ``start``
    through ``via`` to ``end``; three points not on one line) or ``spline`` (a C2 natural cubic
    spline through ``points``, at least 3, ends included, re-parametrised by arc length).

    ``orientation``: ``fixed`` holds the hand's orientation along the whole path, at the start
    orientation (that of the ``ik.initial_guess`` configuration) or at the one orientation in
    ``orientations``; ``slerp`` interpolates it along the geodesic between the
    ``orientations`` (two: at the start and the end; for a spline also one per point, at the
    points); ``free`` lets it turn (position-only task). Default: ``fixed`` for an arm with 6
    or more joints, ``free`` for fewer (a planar 2R arm such as park's cannot hold an
    orientation besides its position). ``orientations`` are URDF roll-pitch-yaw angles
    ``[roll, pitch, yaw]`` (``R = Rz(yaw) Ry(pitch) Rx(roll)``, base frame) in the scenario's
    angle unit. ``orientation_blend``: ``linear`` (constant angular rate between two
    orientations: slerp) or ``smooth`` (quintic in r: the angular rate and acceleration are
    zero at every given orientation, so they stay continuous across via points).
    ``mask`` names the task components instead, like the ik weights (``x, y, z`` position,
    ``rx, ry, rz`` orientation about the base axes), e.g. ``[x, y, z, rz]`` for a tool that may
    tilt but not turn about z (with ``slerp``: the components held to the interpolated
    orientation, e.g. ``[x, y, rz]`` for a planar arm); it must hold every position component
    the path moves along.
    """

    type: Literal["line", "arc", "spline"] = "line"
    start: Point | None = None
    via: Point | None = None
    end: Point | None = None
    points: Annotated[list[Point], Field(min_length=3, max_length=1000)] | None = None
    frame: Name | None = None
    orientation: Literal["fixed", "free", "slerp"] | None = None
    orientations: Annotated[list[Rpy], Field(min_length=1, max_length=1000)] | None = None
    orientation_blend: Literal["linear", "smooth"] = "linear"
    mask: Annotated[list[Component], Field(min_length=1, max_length=6)] | None = None

    def all_points(self) -> list[list[float]]:
        """The points that define the path, in the order given."""
        if self.type == "spline":
            return list(self.points or [])
        return [p for p in (self.start, self.via, self.end) if p is not None]

    @model_validator(mode="after")
    def _check(self) -> PathSpec:
        need = {"line": ("start", "end"), "arc": ("start", "via", "end"),
                "spline": ("points",)}[self.type]
        missing = [k for k in need if getattr(self, k) is None]
        if missing:
            raise ValueError(f"type {self.type} needs {', '.join(missing)}")
        extra = [k for k in ("start", "via", "end", "points")
                 if k not in need and getattr(self, k) is not None]
        if extra:
            raise ValueError(f"type {self.type} takes no {', '.join(extra)} (a "
                             f"{self.type} is given by {', '.join(need)})")
        pts = self.all_points()
        if len({len(p) for p in pts}) != 1:
            what = "start and end" if self.type == "line" else "all points"
            raise ValueError(f"{what} need the same number of coordinates")
        P = np.zeros((len(pts), 3))
        P[:, : len(pts[0])] = np.asarray(pts, dtype=float)
        if self.type == "line" and np.linalg.norm(P[1] - P[0]) == 0.0:
            raise ValueError("start and end are the same point")
        if self.type == "arc":
            u, v = P[1] - P[0], P[2] - P[0]
            scale = max(float(u @ u), float(v @ v), float((P[2] - P[1]) @ (P[2] - P[1])))
            if not np.linalg.norm(np.cross(u, v)) > 1e-9 * scale:
                raise ValueError("start, via and end of the arc are on one line (or two "
                                 "coincide): give three points of the circle, or use a line")
        if self.type == "spline":
            chord = np.linalg.norm(np.diff(P, axis=0), axis=1)
            if np.any(chord == 0.0):
                i = int(np.argmin(chord))
                raise ValueError(f"points {i} and {i + 1} are the same point")
        n_or = None if self.orientations is None else len(self.orientations)
        if self.orientation == "slerp":
            allowed = {2} | ({len(pts)} if self.type == "spline" else set())
            if n_or not in allowed:
                per = " or one per point" if self.type == "spline" else ""
                raise ValueError(f"orientation slerp needs orientations: two (start, end){per}, "
                                 f"got {n_or or 'none'}")
        elif n_or is not None and (self.orientation != "fixed" or n_or != 1):
            raise ValueError(f"orientations ({n_or} given) go with orientation slerp, or one "
                             "orientation with orientation fixed")
        if self.mask is not None:
            if len(set(self.mask)) != len(self.mask):
                raise ValueError(f"mask: a component is named twice in {self.mask}")
            rot = [c for c in self.mask if c.startswith("r")]
            if self.orientation == "free" and rot:
                raise ValueError(f"mask names {', '.join(rot)} but orientation is free")
            if self.orientation in ("fixed", "slerp") and not rot:
                raise ValueError(f"orientation {self.orientation} needs rx, ry or rz in the mask")
            moves = np.ptp(P, axis=0) != 0.0
            free = [a for a, m in zip("xyz", moves, strict=True) if m and a not in self.mask]
            if free:
                raise ValueError(f"mask: the {self.type} moves along {', '.join(free)}, which "
                                 "the mask leaves free; add it")
        return self


def path_mask(path: PathSpec, n_joints: int) -> tuple[str, ...]:
    """The task components of the path IK: ``mask`` if given, else all six for a held or
    interpolated orientation and ``x, y, z`` for a free one (default orientation: fixed when
    the arm has at least 6 joints, free otherwise; :class:`PathSpec`)."""
    if path.mask is not None:
        return tuple(c for c in COMPONENTS if c in path.mask)
    orientation = path.orientation or ("fixed" if n_joints >= 6 else "free")
    return COMPONENTS if orientation in ("fixed", "slerp") else COMPONENTS[:3]


class IkBranchSpec(Spec):
    """Inverse kinematics along the line (park Eq. (9)): Newton's method on the hand's task
    (``path.mask``; with a null-space posture term for a redundant arm), continued along the
    path from ``initial_guess`` (joint values by name in the file's units; default the
    mechanism's home). ``branch`` fixes signs of joints (``{q2: positive}``, park's elbow
    q2 > 0): the start solution and the whole path must keep them. ``tolerance`` [length unit]
    and ``orientation_tolerance`` [rad] bound the task error of every solution."""

    initial_guess: dict[Name, Num] | None = None
    branch: dict[Name, Literal["positive", "negative"]] | None = None
    tolerance: PosNum = 1e-12
    orientation_tolerance: PosNum = 1e-12


class ConveyorSpec(Spec):
    """The part on the belt (park Eq. (1)): ``X_p(t) = part_start + belt_velocity t +
    belt_acceleration t^2 / 2`` (the constant acceleration of park §6, default none); the
    part is drawn as a box of ``part_size`` [length unit]. An accelerating belt needs
    ``objective: intercept`` (or ``time``, which ignores the part)."""

    part_start: Point
    belt_velocity: Point
    belt_acceleration: Point | None = None
    part_size: Annotated[list[PosNum], Field(min_length=3, max_length=3)] = Field(
        default_factory=lambda: [0.08, 0.08, 0.04])


class GridSpec(Spec):
    """Phase-plane grid (park Eq. (23)-(24)): ``N1`` stages in r, ``N2`` states in r';
    ``N_t = round(nt_fraction N2)`` is the part's speed (tracking); ``x2_max`` [1/s] the top of
    the r' grid for ``objective: time`` (default: a reachability bound)."""

    N1: GridInt = 50
    N2: GridInt = 100
    nt_fraction: Fraction = 0.8
    x2_max: PosNum | None = None


class LimitPairSpec(Spec):
    """Asymmetric limits: per joint ``min <= value <= max``."""

    min: list[Num]
    max: list[Num]

    @model_validator(mode="after")
    def _check(self) -> LimitPairSpec:
        if len(self.min) != len(self.max):
            raise ValueError("min and max need one value per joint each")
        if any(a > b for a, b in zip(self.min, self.max, strict=True)):
            raise ValueError("expected min <= max for every joint")
        return self


Limit = list[PosNum] | LimitPairSpec


class LimitsSpec(Spec):
    """Joint limits (park Eq. (3)-(6)); a list is symmetric magnitudes per joint (-x <= . <= x).

    ``torque`` [N m | N]; ``qd``, ``qdd``, ``jerk`` in the angle unit per s, s^2, s^3; ``q``
    joint positions in the angle unit (length unit for prismatic joints). The joint position
    limits are always DP constraints: by default the mechanism's ``limits`` (strokes), ``q``
    replaces them.
    """

    torque: Limit | None = None
    qd: Limit | None = None
    qdd: Limit | None = None
    jerk: Limit | None = None
    q: Limit | None = None


class DpSpec(Spec):
    """How the DP stage reads park §4 where the text allows two readings (the defaults are
    mechkin's readings; README "park: readings"). ``step_time``: ``trapezoid`` (``dt = 2 dx1 /
    (x2[j] + x2[l])``, Eq. (21) with a constant r'') or ``euler`` (the literal Eq. (26) ``dt =
    dx1 / x2[j]`` with the forward-Euler Eq. (21)). ``wait_cost``: the wait at rest before the
    hand starts is costed as Eq. (18) integrates from t_0 (objective tracking only).
    ``jerk_ends``: the jerk of the first step (from rest) and of the last step (into the
    steady state or rest) is checked too."""

    step_time: Literal["trapezoid", "euler"] = "trapezoid"
    wait_cost: bool = False
    jerk_ends: bool = False


class CaseSpec(Spec):
    """One case of ``cases`` (park §5.3 compares three): a ``name`` (the legend) and the
    ``limits`` and ``dp`` readings that replace the scenario's for this case (absent: the
    scenario's; ``limits: {}``: only the mechanism's joint positions)."""

    name: Annotated[str, Field(min_length=1, max_length=60)]
    limits: LimitsSpec | None = None
    dp: DpSpec | None = None


class TrackSpec(Spec):
    """``track:`` section.

    ``objective``: ``tracking`` (DPCT, park §4: follow the part on the belt), ``intercept``
    (minimum time from rest to the part's position and velocity, then on the part: the
    earliest t_a) or ``time`` (minimum time from rest to rest along the same path, same
    limits). ``planner``: ``dp`` (the phase-plane DP, every objective and limit), ``topp``
    (TOPP-RA, O(N1): ``time`` and ``intercept`` without a jerk limit, on the ``N1 + 1`` points
    of the grid's r axis) or ``auto`` (default: ``topp`` for ``time``/``intercept`` with
    torque, velocity or acceleration limits and no jerk limit, else ``dp``). ``grid_study`` solves
    the same problem on several grids (park §5.2) and reports one record per grid; the outputs
    (CSV, plots, MCAP) are those of ``grid``. ``dynamics``: ``rnea`` (recursive Newton-Euler
    from the mechanism's inertial parameters) or ``closed_form_2link`` (park Table 1, for a
    planar 2R arm; its parameters are read from the same inertials). ``dp`` selects the
    readings of park §4 (:class:`DpSpec`); ``cases`` plans several limit sets / readings on the
    same grid for the overlays of park Figs. 5-8 (:class:`CaseSpec`; the CSV and MCAP stay the
    scenario's own plan).
    """

    objective: Literal["tracking", "time", "intercept"] = "tracking"
    path: PathSpec
    ik: IkBranchSpec = Field(default_factory=IkBranchSpec)
    conveyor: ConveyorSpec | None = None
    grid: GridSpec = Field(default_factory=GridSpec)
    grid_study: list[GridSpec] | None = None
    limits: LimitsSpec = Field(default_factory=LimitsSpec)
    dynamics: Literal["rnea", "closed_form_2link"] = "rnea"
    dp: DpSpec = Field(default_factory=DpSpec)
    cases: Annotated[list[CaseSpec], Field(min_length=1, max_length=12)] | None = None
    planner: Literal["auto", "dp", "topp"] = "auto"

    def resolved_planner(self) -> str:
        """``planner`` with ``auto`` resolved (see the class docstring)."""
        lim = self.limits
        if self.planner != "auto":
            return self.planner
        rates = any(getattr(lim, k) is not None for k in ("torque", "qd", "qdd"))
        ok = self.objective in ("time", "intercept") and rates and lim.jerk is None
        return "topp" if ok else "dp"

    @model_validator(mode="after")
    def _check(self) -> TrackSpec:
        _check_dp_cases(self)
        if self.objective != "time" and self.conveyor is None:
            raise ValueError(f"objective {self.objective} needs a conveyor: "
                             "{part_start, belt_velocity}")
        if self.planner == "topp" and self.objective == "tracking":
            raise ValueError("planner topp plans the time and intercept objectives; tracking "
                             "(park's cost, Eq. (28)) needs planner dp or auto")
        if self.planner == "topp" and self.limits.jerk is not None:
            raise ValueError("planner topp (TOPP-RA) cannot impose jerk limits (limits.jerk); "
                             "use planner dp or auto")
        acc = self.conveyor.belt_acceleration if self.conveyor is not None else None
        if acc is not None and any(a != 0 for a in acc) and self.objective == "tracking":
            raise ValueError(
                "conveyor.belt_acceleration: the tracking objective cannot follow an "
                "accelerating belt (the DP's r' grid holds the part's speed at one state, park "
                "Eq. (24), and time is not a DP state); use objective intercept (TOPP-RA, or "
                "the DP by decomposition)")
        if self.resolved_planner() == "topp" and self.dp != DpSpec():
            raise ValueError("dp: the DP readings (step_time, wait_cost, jerk_ends) apply to the "
                             "phase-plane DP; this scenario plans with TOPP-RA (planner "
                             f"{self.planner}); set planner: dp or remove dp")
        if self.grid_study is not None and not self.grid_study:
            raise ValueError("grid_study: give at least one grid")
        return self


def _check_dp_cases(spec: TrackSpec) -> None:
    """``dp.wait_cost`` needs objective tracking; case names are distinct."""
    for where, dp in [("dp", spec.dp)] + [(f"cases: {c.name}: dp", c.dp) for c in spec.cases or []]:
        if dp is not None and dp.wait_cost and spec.objective != "tracking":
            raise ValueError(f"{where}.wait_cost needs objective tracking ({spec.objective} "
                             + ("already costs the wait)" if spec.objective == "intercept"
                                else "starts at t = 0: no wait)"))
    names = [c.name for c in spec.cases or []]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"cases: the name {dup[0]!r} is used twice")


def point_si(p: list[float], units: Units) -> np.ndarray:
    """A point or velocity [length unit] -> (3,) [m]; two coordinates get z = 0."""
    a = np.zeros(3)
    a[: len(p)] = np.asarray(p, dtype=float) * length_factor(units.length)
    return a


def limits_si(
    spec: LimitsSpec, units: Units, prismatic: np.ndarray,
    independent: Sequence[int] | None = None,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``name -> (lo (n,), hi (n,))`` in SI; q/qd/qdd/jerk of revolute joints scaled by the
    angle unit, of prismatic joints by the length unit; torques as given (N m | N).

    ``independent`` (a closed chain's independent joints): a list with one value per
    independent joint is accepted too and widened to every joint, the dependent (passive)
    joints unbounded (their torque is 0; their position limits come from the mechanism).
    A list of any other length is returned as given (the caller names the count)."""
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    pris = np.asarray(prismatic, dtype=bool)
    motion = np.where(pris, length_factor(units.length), angle_factor(units.angle))
    iv = None if independent is None else np.asarray(independent, dtype=int)
    for name in ("torque", "qd", "qdd", "jerk", "q"):
        lim = getattr(spec, name)
        if lim is None:
            continue
        if isinstance(lim, LimitPairSpec):
            lo, hi = np.asarray(lim.min, dtype=float), np.asarray(lim.max, dtype=float)
        else:
            hi = np.asarray(lim, dtype=float)
            lo = -hi
        if iv is not None and lo.shape == iv.shape and lo.shape != motion.shape:
            wide_lo, wide_hi = np.full(motion.shape, -np.inf), np.full(motion.shape, np.inf)
            wide_lo[iv], wide_hi[iv] = lo, hi
            lo, hi = wide_lo, wide_hi
        if name != "torque" and lo.shape == motion.shape:
            lo, hi = lo * motion, hi * motion
        out[name] = (lo, hi)
    return out


def limit_count_message(mech: Any, got: int) -> str:
    """What a limits list of the wrong length should have been (one per joint, or for a
    closed chain one per independent joint)."""
    names = list(mech.joint_names)
    short = ", ".join(names) if len(names) <= 8 else ", ".join(names[:6]) + f", ... ({len(names)})"
    msg = f"expected {mech.n} values (one per joint: {short})"
    if getattr(mech, "is_closed", False) and len(mech.dependent):
        iv = [names[j] for j in mech.independent]
        msg += f" or {len(iv)} (one per independent joint: {', '.join(iv)})"
    return f"{msg}, got {got}"


def mechanism_limits_si(spec: LimitsSpec, units: Units, mech: Any
                        ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """:func:`limits_si` for ``mech`` (independent-joint lists of a closed chain widened)."""
    closed = getattr(mech, "is_closed", False) and len(mech.dependent)
    return limits_si(spec, units, np.asarray(mech.s) == 1,
                     independent=mech.independent if closed else None)


register_task_section("track", TrackSpec)
