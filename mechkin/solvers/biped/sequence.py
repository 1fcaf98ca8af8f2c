"""Both legs of a hwang2023-type biped over a switching sequence (walk -> skate -> roll).

DESIGN: the solving half of ``mechkin ik`` with a ``biped:`` section. :func:`check_mechanism`
finds the two 6-joint legs in the mechanism model and checks them against the closed-form
chain (:mod:`mechkin.solvers.biped.leg`, hwang2023 Eq. 1) by forward kinematics;
:func:`solve_sequence` solves every step with the closed form of its class (§2.2 known pose,
§2.3 unknown blade tilt, §2.4 rolling without slipping) and animates roll steps frame by frame.
Inputs are plain SI values (:class:`BipedStep`, :class:`LegInput`); the scenario's units and
keys are converted by ``mechkin.tasks.biped``.

Imports: numpy, model (forward kinematics), solvers.biped.leg, spatial.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from mechkin.errors import ConfigError
from mechkin.model import Mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.biped.leg import (
    HWANG2023_ESTIMATED,
    STATUS_OK,
    STATUS_UNREACHABLE,
    BipedGeometry,
    InclinedPlane,
    LegSolution,
    LegTask,
    blade_contact,
    contact_below_hip,
    leg_fk,
    psi_from_ee_rotation,
    rolled_position,
    solve_known_pose,
    solve_leg_case,
)
from mechkin.spatial.euler_conventions import Side, contact_angles_from_matrix

__all__ = [
    "EE_FRAMES",
    "MODEL_TOL",
    "SIDES",
    "BipedFrame",
    "BipedModel",
    "BipedStep",
    "LegInput",
    "StepResult",
    "check_mechanism",
    "geometry_from_mechanism",
    "leg_joints",
    "interpolate_pose",
    "solve_sequence",
    "solve_step",
    "time_law",
]

SIDES: tuple[Side, Side] = ("right", "left")
EE_FRAMES = {"right": ("e6_r", "foot_r"), "left": ("e6_l", "foot_l")}
MODEL_TOL = 1e-9  # [m] mechanism file vs closed-form chain


# --------------------------------------------------------------------------- mechanism


def leg_joints(mech: Mechanism, frame: str) -> list[int]:
    """Joint indices from the body to ``frame``'s link, in chain order."""
    try:
        link = int(mech.frame_link[mech.frame_index(frame)])
    except KeyError as exc:
        raise ConfigError(f"{mech.source}: the biped needs a frame {frame!r}: {exc}") from None
    out: list[int] = []
    while mech.link_parent_joint[link] >= 0:
        j = int(mech.link_parent_joint[link])
        out.append(j)
        link = int(mech.joint_parent_link[j])
    return out[::-1]


AXIS_NAMES = ("Rz", "Ry", "Rx", "Rx", "Rx", "Ry")
# joint axes of the right leg in the body frame at q = 0 (hip frame diag(1, -1, -1), Eq. 1b)
RIGHT_AXES = np.array([[0.0, 0.0, -1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0],
                       [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
LEG_DOWN = np.array([0.0, 0.0, -1.0])  # z of the hip frames: the legs hang along -z at q = 0
WHEEL_FRAMES = {"right": "wheel_r", "left": "wheel_l"}
BLADE_FRAMES = {"right": "blade_r", "left": "blade_l"}
_S3 = np.diag([-1.0, 1.0, 1.0])


@dataclass(frozen=True)
class BipedModel:
    """The two legs found in a mechanism: the closed-form geometry (the right leg's, the left
    one is its mirror image), each leg's own joint ranges and the joint indices per side."""

    geometry: BipedGeometry
    legs: Mapping[str, BipedGeometry]
    joints: Mapping[str, list[int]]

    @property
    def estimated(self) -> bool:
        return bool(self.geometry.estimated)


def _vec(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:.6g}" for x in (np.where(np.abs(v) < 1e-12, 0.0, v))) + ")"


def _frame_point(mech: Mechanism, kin: Any, frame: str, side: str) -> np.ndarray:
    try:
        f = mech.frame_index(frame)
    except KeyError:
        raise ConfigError(f"{mech.source}: the biped needs a frame {frame!r} on the {side} "
                          "leg's last link") from None
    return kin.frames(mech, [f])[0, 0, :3, 3]


def _leg_geometry(mech: Mechanism, kin: Any, side: Side, joints: list[int]
                  ) -> tuple[list[float], np.ndarray, float, float]:
    """(l1..l6, hip offset, foot extension, wheel radius) of one leg, mirrored to the right
    for the left leg; ConfigError naming the joint, axis or frame that breaks the topology."""
    z, o = kin.axes()
    M = np.eye(3) if side == "right" else _S3
    src = mech.source
    topo = ("hwang2023 Eq. 1: Rz-Ry-Rx-Rx-Rx-Ry from hip to ankle, each Rot(axis, theta) "
            "Trans(0, 0, l_i) with the hip z down")
    axes, pts = [], []
    for i, j in enumerate(joints):
        name = mech.joint_names[j]
        if mech.s[j] != 0:
            raise ConfigError(f"{src}: the {side} leg's joint {i + 1} {name!r} is prismatic, "
                              f"expected a revolute joint ({AXIS_NAMES[i]}, {topo})")
        a = -(M @ z[0, j]) if side == "left" else z[0, j]
        want = RIGHT_AXES[i]
        if np.abs(a - want).max() > 1e-9:
            shown = -(M @ want) if side == "left" else want
            raise ConfigError(
                f"{src}: the {side} leg's joint {i + 1} {name!r} turns about "
                f"{_vec(z[0, j])} in the body frame at q = 0, expected {_vec(shown)} "
                f"({AXIS_NAMES[i]}; {topo}"
                + ("; the left leg mirrors the right in the body's y-z plane" if side == "left"
                   else "") + ")")
        axes.append(a)
        pts.append(M @ o[0, j])
    lengths = []
    tip = {k: M @ _frame_point(mech, kin, EE_FRAMES[side][k], side) for k in (0, 1)}
    chain = pts + [tip[0]]
    for i in range(6):
        d = chain[i + 1] - chain[i]
        along = float(d @ LEG_DOWN)
        off = d - along * LEG_DOWN
        what = (f"joint {i + 2} {mech.joint_names[joints[i + 1]]!r}" if i < 5
                else f"frame {EE_FRAMES[side][0]!r} (the blade point E)")
        if np.abs(off).max() > 1e-9:
            raise ConfigError(
                f"{src}: the {side} leg's {what} is {_vec(M @ off)} m off the leg's axis from "
                f"joint {i + 1} {mech.joint_names[joints[i]]!r} at q = 0, expected only "
                f"Trans(0, 0, l{i + 1}) along the hip z ({topo})")
        lengths.append(round(along, 12))  # sub-pm noise of mm -> m
    def along_leg(p: np.ndarray, what: str) -> float:
        d = p - chain[5]
        along = float(d @ LEG_DOWN)
        if np.abs(d - along * LEG_DOWN).max() > 1e-9:
            raise ConfigError(f"{src}: the {side} leg's {what} is off the shank axis by "
                              f"{_vec(M @ (d - along * LEG_DOWN))} m at q = 0, expected it on "
                              f"z of joint 6 {mech.joint_names[joints[5]]!r}")
        return along
    foot = along_leg(tip[1], f"frame {EE_FRAMES[side][1]!r} (the sole point)") - lengths[5]
    wheel = along_leg(M @ _frame_point(mech, kin, WHEEL_FRAMES[side], side),
                      f"frame {WHEEL_FRAMES[side]!r} (the wheel-profile centre)")
    try:
        bl = mech.frame_index(BLADE_FRAMES[side])
    except KeyError:
        bl = None
    if bl is not None:
        pb = M @ kin.frames(mech, [bl])[0, 0, :3, 3]
        if np.abs(pb - tip[0]).max() > 1e-9:
            raise ConfigError(f"{src}: the {side} leg's frame {BLADE_FRAMES[side]!r} is not at "
                              f"the blade point E (frame {EE_FRAMES[side][0]!r})")
    return lengths, np.round(pts[0], 12), round(foot, 12), round(lengths[5] - wheel, 12)


def geometry_from_mechanism(mech: Mechanism) -> BipedModel:
    """Read the closed-form geometry of hwang2023 Eq. (1) from a mechanism's two legs.

    Each leg runs from the base link (the body G) through six revolute joints Rz-Ry-Rx-Rx-Rx-Ry
    (axes at q = 0, body frame: right (0,0,-1), (0,-1,0), (1,0,0) x3, (0,-1,0); the left leg the
    mirror image) to a last link carrying ``e6_<s>`` (the blade point E), ``foot_<s>`` (the sole
    point) and ``wheel_<s>`` (the centre of the blade's wheel profile). Read at q = 0: the hip
    offset b_G0' (joint 1's origin), l1..l6 (joint origin to joint origin, then to E, along the
    hip z), the foot extension (E to the sole point) and the blade radius r_w (the wheel centre
    to E); the legs must be mirror images (same lengths, hips at (x, y, z) and (-x, y, z)). Each
    leg keeps its own joint ranges. A file that gives exactly :data:`HWANG2023_ESTIMATED` (the
    bundled ``hwang2023_biped.yaml``) gets that constant, marked estimated.
    """
    joints = {s: leg_joints(mech, EE_FRAMES[s][0]) for s in SIDES}
    bad = [s for s in SIDES if len(joints[s]) != 6]
    if bad:
        names = [mech.joint_names[j] for j in joints[bad[0]]]
        raise ConfigError(f"{mech.source}: expected 6 joints from the body to "
                          f"{EE_FRAMES[bad[0]][0]}, got {len(joints[bad[0]])} {names}")
    kin = forward_kinematics(mech, np.zeros((1, mech.n)))
    read = {s: _leg_geometry(mech, kin, s, joints[s]) for s in SIDES}
    (lr, hr, fr, wr), (ll, hl, fl, wl) = read["right"], read["left"]
    names = [f"l{i + 1}" for i in range(6)]
    for nm, a, b in [*zip(names, lr, ll, strict=True), ("foot extension", fr, fl),
                     ("blade radius", wr, wl)]:
        if abs(a - b) > 1e-9:
            raise ConfigError(f"{mech.source}: the left leg differs from the hwang2023 "
                              f"closed-form leg (the mirror image of the right): {nm} = "
                              f"{b:.6g} m on the left, {a:.6g} m on the right")
    if np.abs(hr - hl).max() > 1e-9:
        raise ConfigError(f"{mech.source}: the left leg differs from the hwang2023 closed-form "
                          f"leg: its hip is at {_vec(_S3 @ hl)} m, expected {_vec(_S3 @ hr)} "
                          "(the mirror image of the right hip)")
    lims = {s: (tuple(float(v) for v in mech.lower[joints[s]]),
                tuple(float(v) for v in mech.upper[joints[s]])) for s in SIDES}
    try:
        geo = BipedGeometry(tuple(lr), fr, wr, tuple(float(v) for v in hr),  # type: ignore
                            lims["right"][0], lims["right"][1])
    except ValueError as exc:
        raise ConfigError(f"{mech.source}: not a hwang2023 leg: {exc}") from None
    est = HWANG2023_ESTIMATED
    if _same(geo, est):
        geo = est
    legs = {s: geo if (s == "right" or np.allclose(lims[s], lims["right"], rtol=0, atol=1e-12))
            else replace(geo, q_min=lims[s][0], q_max=lims[s][1]) for s in SIDES}
    model = BipedModel(geo, legs, joints)
    check_mechanism(mech, geo, joints)
    return model


def _same(a: BipedGeometry, b: BipedGeometry) -> bool:
    va = [*a.lengths, a.foot_extension, a.wheel_radius, *a.hip_offset, *a.q_min, *a.q_max]
    vb = [*b.lengths, b.foot_extension, b.wheel_radius, *b.hip_offset, *b.q_min, *b.q_max]
    return bool(np.allclose(va, vb, rtol=0.0, atol=1e-12))


def check_mechanism(mech: Mechanism, geometry: BipedGeometry,
                    joints: Mapping[str, list[int]] | None = None) -> dict[str, list[int]]:
    """Joint indices of each leg; ConfigError unless the file's legs equal the closed-form ones
    (E and the sole point at random joint angles, to ``MODEL_TOL``)."""
    joints = dict(joints) if joints is not None else {
        s: leg_joints(mech, EE_FRAMES[s][0]) for s in SIDES}
    bad = [s for s in SIDES if len(joints[s]) != 6]
    if bad:
        raise ConfigError(f"{mech.source}: expected 6 joints from the body to "
                          f"{EE_FRAMES[bad[0]][0]}, got {len(joints[bad[0]])}")
    rng = np.random.default_rng(6)
    qs = rng.uniform(-1.0, 1.0, (3, 6))
    q = np.zeros((3, mech.n))
    for s in SIDES:
        q[:, joints[s]] = qs
    kin = forward_kinematics(mech, q)
    for s in SIDES:
        idx = [mech.frame_index(f) for f in EE_FRAMES[s]]
        T = kin.frames(mech, idx)
        for k, kind in enumerate(("blade", "foot")):
            ref = leg_fk(geometry, s, qs, np.eye(4), kind)[:, :3, 3]
            err = float(np.abs(T[:, k, :3, 3] - ref).max())
            if err > MODEL_TOL:
                raise ConfigError(
                    f"{mech.source}: the {s} leg to frame {EE_FRAMES[s][k]!r} differs from the "
                    f"hwang2023 closed-form leg by {err:.3g} m at random joint angles (expected "
                    "the legs of Eq. 1 with the geometry read from the file)")
    return joints


# --------------------------------------------------------------------------- inputs


@dataclass(frozen=True)
class LegInput:
    """What one step knows about one leg, SI (see ``mechkin.config.biped_spec``).

    ``position`` E [m] (world), or ``below_hip`` (x, y) [m] offset from the point of the plane
    below the hip, or neither (below the hip; a roll of a sequence starts from the previous
    step's state). ``beta_z``, ``beta``, ``theta6`` [rad]; ``branch`` the wanted knee branch;
    ``plane`` this leg's own plane (None: the step's); ``beta_end`` the tilt a roll ends at
    (instead of ``theta6``).
    """

    position: np.ndarray | None = None
    below_hip: np.ndarray | None = None
    beta_z: float = 0.0
    beta: float | None = None
    theta6: float | None = None
    branch: str | None = None
    plane: InclinedPlane | None = None
    beta_end: float | None = None


@dataclass(frozen=True)
class BipedStep:
    """One step of a sequence, SI: the class (``walk``, ``skate``, ``roll``), the plane, the
    body pose ``T_0_G`` (4, 4), the legs, its duration [s] and the number of roll frames."""

    mode: str
    plane: InclinedPlane
    T_0_G: np.ndarray
    legs: Mapping[str, LegInput]
    label: str
    duration: float = 1.0
    frames: int = 1
    time_law: str = "linear"

    def leg_plane(self, side: str) -> InclinedPlane:
        """The plane under ``side``'s contact: its own, else the step's."""
        p = self.legs[side].plane
        return self.plane if p is None else p


@dataclass
class StepResult:
    """A solved step: every solution and the chosen one per side, and the leg tasks (for a
    roll: the start state; ``beta_end[side]`` the tilt it rolls to, when given)."""

    alternatives: dict[str, tuple[LegSolution, ...]]
    legs: dict[str, LegSolution]
    tasks: dict[str, LegTask]
    branches: dict[str, str | None]
    beta_end: dict[str, float] = field(default_factory=dict)

    @property
    def status(self) -> str:
        return next((self.legs[s].status for s in SIDES if not self.legs[s].ok), STATUS_OK)


@dataclass
class BipedFrame:
    """One frame of the animation (a step, or one roll of an animated roll step)."""

    t: float
    legs: dict[str, LegSolution]
    step: int
    kind: str
    T_0_G: np.ndarray | None = None  # the body pose of this frame (None: the step's)


# --------------------------------------------------------------------------- solving


def _failed(status: str, method: str, branch: str) -> LegSolution:
    return LegSolution(np.full(6, np.nan), status, math.inf, math.inf, branch, method=method)


def pick(alts: tuple[LegSolution, ...], branch: str | None,
         prev: np.ndarray | None) -> LegSolution:
    """The solution of ``branch`` (any if None) nearest ``prev``; a failed record if none."""
    ok = [a for a in alts if a.ok and (branch is None or a.branch == branch)]
    if not ok:
        if branch is not None and any(a.ok for a in alts):
            at_limit = [a for a in alts if a.q_outside is not None and a.branch == branch]
            if at_limit:
                return at_limit[0]
            return _failed(STATUS_UNREACHABLE, alts[0].method, branch)
        return alts[0]
    if prev is None:
        return ok[0]
    return min(ok, key=lambda r: float(np.linalg.norm(r.q - prev)))


def start_state(geometry: BipedGeometry, plane: InclinedPlane, side: Side, q: np.ndarray,
                TG: np.ndarray) -> tuple[np.ndarray, float]:
    """E_a and beta_Ya of the blade of the previous step's q (for a roll that follows it)."""
    T = leg_fk(geometry, side, q[None], TG, "blade")[0]
    _, beta, _ = contact_angles_from_matrix(psi_from_ee_rotation(T[:3, :3], side),
                                            plane.rotation(side), side, "blade")
    return T[:3, 3], float(beta)


def _geometries(geometry: BipedGeometry | BipedModel) -> Mapping[str, BipedGeometry]:
    if isinstance(geometry, BipedModel):
        return geometry.legs
    return {s: geometry for s in SIDES}


def time_law(name: str, f: float) -> float:
    """Progress h(f) in [0, 1] at the fraction f of a step: ``linear`` (h = f) or ``smooth``
    (quintic 10 f^3 - 15 f^4 + 6 f^5: zero speed and acceleration at both ends)."""
    if name == "smooth":
        return f * f * f * (10.0 - 15.0 * f + 6.0 * f * f)
    return f


def interpolate_pose(T_a: np.ndarray, T_b: np.ndarray, h: float) -> np.ndarray:
    """Pose between T_a and T_b (4, 4): position along the straight line, rotation by slerp
    (``R_a exp(h log(R_a^T R_b))``) at the progress h in [0, 1]."""
    from scipy.spatial.transform import Rotation

    rv = Rotation.from_matrix(T_a[:3, :3].T @ T_b[:3, :3]).as_rotvec()
    out = np.eye(4)
    out[:3, :3] = T_a[:3, :3] @ Rotation.from_rotvec(h * rv).as_matrix()
    out[:3, 3] = T_a[:3, 3] + h * (T_b[:3, 3] - T_a[:3, 3])
    return out


def _relabel(alts: tuple[LegSolution, ...], method: str) -> tuple[LegSolution, ...]:
    return tuple(replace(a, method=method) for a in alts)


def solve_step(geometry: BipedGeometry | BipedModel, step: BipedStep,
               prev_q: dict[str, np.ndarray] | None,
               theta6_override: dict[str, float] | None = None,
               beta_override: dict[str, float] | None = None) -> StepResult:
    """Both legs of one step by the closed form of its class (hwang2023 §2.2-§2.4), each leg
    on its own plane with its own joint ranges.

    A roll to a given tilt ``beta_end`` (beta_Yb, 0 = upright) needs no root search: E_b
    follows from the start state by Eq. (37) and the blade pose is known, so §2.2 solves it.
    ``theta6_override`` / ``beta_override`` replace a roll's target (animation frames).
    """
    geos = _geometries(geometry)
    TG = step.T_0_G
    tasks: dict[str, LegTask] = {}
    branches: dict[str, str | None] = {}
    alts: dict[str, tuple[LegSolution, ...]] = {}
    ends: dict[str, float] = {}
    for side in SIDES:
        geo, plane = geos[side], step.leg_plane(side)
        t = step.legs[side]
        branches[side] = t.branch
        beta = t.beta
        if t.position is not None:
            p = np.asarray(t.position)
        elif t.below_hip is not None:
            p = contact_below_hip(geo, plane, TG, side, t.below_hip)
        elif step.mode == "roll" and prev_q is not None and np.all(np.isfinite(prev_q[side])):
            p, beta0 = start_state(geo, plane, side, prev_q[side], TG)
            beta = beta0 if beta is None else beta
        else:
            p = contact_below_hip(geo, plane, TG, side)
        theta6 = t.theta6
        if theta6_override is not None and side in theta6_override:
            theta6 = theta6_override[side]
        if step.mode == "walk" or step.mode == "roll":
            beta = 0.0 if beta is None else beta
        elif beta is None and theta6 is None:
            beta = 0.0
        tasks[side] = LegTask(tuple(float(v) for v in p), float(t.beta_z),  # type: ignore
                              None if beta is None else float(beta),
                              None if theta6 is None else float(theta6))
        prev = None if prev_q is None else prev_q.get(side)
        if step.mode == "roll" and t.beta_end is not None:
            b_end = float(t.beta_end if beta_override is None or side not in beta_override
                          else beta_override[side])
            ends[side] = b_end
            Delta = plane.contact_base(side, t.beta_z)
            E_b = rolled_position(p, Delta[:, 0], plane.normal, geo.wheel_radius,
                                  float(beta), b_end)  # Eq. (37)
            known = LegTask(tuple(float(v) for v in E_b), float(t.beta_z), b_end)
            _, a = solve_leg_case(plane, "skate", side, known, T_0_G=TG, geometry=geo,
                                  previous=prev, branch=t.branch)
            alts[side] = _relabel(a, "hwang2023 §2.4 Eq. (37) to beta_Y, then §2.2")
            continue
        _, alts[side] = solve_leg_case(plane, step.mode, side, tasks[side],  # type: ignore
                                       T_0_G=TG, geometry=geo, previous=prev,
                                       branch=t.branch)
    legs = {s: pick(alts[s], branches[s], None if prev_q is None else prev_q[s])
            for s in SIDES}
    return StepResult(alts, legs, tasks, branches, ends)


def _moving_frames(geometry: BipedGeometry | BipedModel, step: BipedStep, first: StepResult,
                   prev_q: dict[str, np.ndarray], prev_TG: np.ndarray, kind: str
                   ) -> list[tuple[float, dict[str, LegSolution], np.ndarray]]:
    """The frames f = 1/n .. (n-1)/n of a walk or skate step: the body and each contact frame
    move from where the previous step left them to the step's solved pose, every frame solved
    by §2.2 (the solution nearest the previous frame). Returns (f, legs, T_0_G) per frame.

    The contact frame is the step's own (``kind``): after a step of the other class it starts
    where the previous pose holds it (walk -> skate: the blade point E of the standing foot's
    pose; skate/roll -> walk: the sole point of the blade's pose), so frame 0 is the previous
    pose exactly and the foot-to-blade switch is spread over the step's frames."""
    geos = _geometries(geometry)
    T_a = {s: leg_fk(geos[s], s, prev_q[s][None], prev_TG, kind)[0] for s in SIDES}
    T_b = {s: first.legs[s].T_0_E for s in SIDES}
    out = []
    last = dict(prev_q)
    for j in range(1, step.frames):
        f = j / step.frames
        h = time_law(step.time_law, f)
        TG = interpolate_pose(prev_TG, step.T_0_G, h)
        legs = {}
        for s in SIDES:
            T = interpolate_pose(T_a[s], T_b[s], h)
            sols = solve_known_pose(geos[s], s, T, TG, kind)  # type: ignore[arg-type]
            if kind == "blade":
                sols = [blade_contact(geos[s], step.leg_plane(s), s, x) if x.ok else x
                        for x in sols]
            else:
                sols = [replace(x, p_contact=x.T_0_E[:3, 3].copy()) if x.ok else x
                        for x in sols]
            legs[s] = pick(tuple(sols), None, last[s] if np.all(np.isfinite(last[s])) else None)
            if legs[s].ok:
                last[s] = legs[s].q
        out.append((f, legs, TG))
    return out


def solve_sequence(geometry: BipedGeometry | BipedModel, steps: list[BipedStep],
                   stop: Callable[[], bool] | None = None
                   ) -> tuple[list[StepResult], list[BipedFrame]]:
    """Solve every step in order; each starts from the joint angles the last solved step left.

    A step with ``frames > 1`` after a solved step is animated. A roll: every frame rolls from
    the same start state (E_a, beta_Ya: the previous step's blade) to an intermediate ankle
    angle or tilt (Eq. 37 is path independent). A walk or skate step: the body and contact
    frames move from the previous step's (:func:`_moving_frames`). The last frame is the step
    itself. Returns one :class:`StepResult` per step and the frames of the animation (times
    in [s]). ``stop()`` after every step but the last (the caller's ``--max-time``): when True
    the steps solved so far and their frames are returned.
    """
    results: list[StepResult] = []
    frames: list[BipedFrame] = []
    prev_q: dict[str, np.ndarray] | None = None
    prev_TG: np.ndarray | None = None
    t = 0.0
    for k, step in enumerate(steps):
        t_end = t + (step.duration if k > 0 else 0.0)
        kind = "foot" if step.mode == "walk" else "blade"
        law = step.time_law
        solved_before = (prev_q is not None
                         and all(np.all(np.isfinite(prev_q[s])) for s in SIDES))
        if step.mode == "roll" and step.frames > 1 and solved_before:
            assert prev_q is not None
            first = solve_step(geometry, step, prev_q)
            t6b = {s: first.tasks[s].theta6 for s in SIDES if s not in first.beta_end}
            t6a = {s: float(prev_q[s][5]) for s in t6b}
            b_a = {s: float(first.tasks[s].beta or 0.0) for s in first.beta_end}
            sub_prev = prev_q
            for j in range(1, step.frames + 1):
                f = j / step.frames
                if j < step.frames:
                    h = time_law(law, f)
                    t6 = {s: t6a[s] + (t6b[s] - t6a[s]) * h for s in t6b}  # type: ignore
                    bo = {s: b_a[s] + (first.beta_end[s] - b_a[s]) * h for s in b_a}
                    r = solve_step(geometry, step, prev_q, t6, bo)
                    r.legs = {s: pick(r.alternatives[s], r.branches[s], sub_prev[s])
                              for s in SIDES}
                else:
                    r = first
                frames.append(BipedFrame(t + (t_end - t) * f, r.legs, k, kind))
                if all(r.legs[s].ok for s in SIDES):
                    sub_prev = {s: r.legs[s].q for s in SIDES}
            res = first
        elif step.mode in ("walk", "skate") and step.frames > 1 and solved_before:
            assert prev_q is not None and prev_TG is not None
            res = solve_step(geometry, step, prev_q)
            if all(res.legs[s].ok for s in SIDES):
                for f, legs, TG in _moving_frames(geometry, step, res, prev_q, prev_TG, kind):
                    frames.append(BipedFrame(t + (t_end - t) * f, legs, k, kind, TG))
            frames.append(BipedFrame(t_end, res.legs, k, kind))
        else:
            res = solve_step(geometry, step, prev_q)
            frames.append(BipedFrame(t_end, res.legs, k, kind))
        t = t_end
        results.append(res)
        if all(res.legs[s].ok for s in SIDES):
            prev_q = {s: res.legs[s].q for s in SIDES}
            prev_TG = step.T_0_G
        if stop is not None and k + 1 < len(steps) and stop():
            break
    return results, frames
