r"""Closed-form kinematics of the walking and skating biped of hwang2023 (6R legs, feet, blades).

Leg (hwang2023 Eq. 1): body ``A_0G = [Rz(theta_z) | b_0G]``, hip
``A_G0' = [diag(1,-1,-1) | b_G0']`` (z down), then six joints Rz-Ry-Rx-Rx-Rx-Ry, each
``A_(i-1)'i' = Rot(axis_i, theta_i) Trans(0,0,l_i)``.
The end effector 6' is the blade point E (``l6``) or the sole point (``l6 + foot_extension``).

Orientation targets (Eq. 3): the right end effector is ``R_0_6' = Psi_1 diag(1,-1,-1)``; the left
leg is the mirror image of the right (x -> -x), with joint angles of the same meaning (JRx + lifts
forward, JRy + lifts outward, JRz + turns outward) and end-effector frame ``R_0_6' = Psi_2`` (x
outward, y forward, z down; with gam_Y = 180 deg the left plane's Z_2 already points down).
Every left-leg problem is solved as the right-leg problem of the mirrored world: positions
``p -> S p`` with ``S = diag(-1, 1, 1)``, body ``T_0_G -> S T_0_G S``, end effector
``T -> S T D`` with ``D = diag(1, -1, 1)``, contact base ``Delta -> S Delta D F``.

Solvers (right leg, hip coordinates, the paper's P_k are the components of the target there),
one module per IK class (the model they share: :mod:`~mechkin.solvers.biped.leg_model`; this
module keeps the biped cases and the drawing and re-exports every public name):

* :func:`solve_known_pose` - §2.2, Eqs. (5)-(20): position and orientation known; two branches in
  the joint ranges (knee back ``theta4 <= 0`` first).
* :func:`solve_known_position` - §2.3, Eqs. (21)-(35): blade position E known, ``theta6`` given,
  blade tilt ``beta_Y`` unknown; cases theta6 = 0 (Eqs. 22-27), theta6 != 0 with P3 = 0
  (Eqs. 28-31), theta6 != 0 with P3 != 0 (Eqs. 32-35).
* :func:`solve_rolling` - §2.4, Eqs. (36)-(43): the blade rolls without slipping from a known
  state (E_a, beta_Ya) to the unknown tilt beta_Yb that gives the wanted ``theta6``; one
  numerical root search in theta2 (P3 = 0, Eq. 40) or theta1 (P3 != 0, Eqs. 40, 43).

Rolling (Eq. 36; the wheel profile is an arc of radius r_w about the blade's long axis):
``C = C0 - r_w beta_Y u_X'``, ``E = E0 - r_w (beta_Y - sin beta_Y) u_X' + r_w (1 - cos beta_Y) n``
with ``n`` the plane normal pointing away from the plane (``u_Z1'`` on the right). Eqs. (36c, d)
print ``- (1 - cos beta_Y) u_Z'``, which would put E below the plane on the right leg; Eq. (36f)
and this module use the sign above (PAPER_NOTES, hwang2023).

Units: SI (m, rad). Results are :class:`LegSolution` records with a status string (``"ok"``,
``"not converged"``, ``"singular"``, ``"unreachable"``, the values of
``mechkin.solvers.result.Status``) and the forward-kinematics errors of the solution.

References
----------
hwang2023_hybrid_walking_skating_ik: C.-S. Hwang, H. Lee, B.-Y. Kang, "Analysis of inverse
kinematics for legged walking and skated driving with hybrid mobile robot", JKSPE 40(11), 2023,
Eqs. (1)-(43), Tables 1-6.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from mechkin.solvers.biped.leg_known_pose import solve_known_pose, solve_known_pose_batch
from mechkin.solvers.biped.leg_known_position import solve_known_position
from mechkin.solvers.biped.leg_model import (
    HWANG2023_ESTIMATED,
    Q_MAX,
    Q_MIN,
    STATUS_AT_LIMIT,
    STATUS_NOT_CONVERGED,
    STATUS_OK,
    STATUS_SINGULAR,
    STATUS_UNREACHABLE,
    BipedGeometry,
    ContactKind,
    InclinedPlane,
    LegSolution,
    _side,
    _wrap,
    body_transform,
    ee_rotation_from_psi,
    hip_transform,
    leg_fk,
    leg_frames,
    psi_from_ee_rotation,
)
from mechkin.solvers.biped.leg_rolling import rolled_position, solve_rolling
from mechkin.spatial.euler_conventions import (
    Side,
    contact_angles_from_matrix,
)
from mechkin.spatial.transforms import T_from

__all__ = [
    "HWANG2023_ESTIMATED",
    "Q_MAX",
    "Q_MIN",
    "STATUS_AT_LIMIT",
    "STATUS_NOT_CONVERGED",
    "STATUS_OK",
    "STATUS_SINGULAR",
    "STATUS_UNREACHABLE",
    "BipedGeometry",
    "BipedSolution",
    "ContactKind",
    "InclinedPlane",
    "LegSolution",
    "LegTask",
    "biped_polylines",
    "blade_contact",
    "body_transform",
    "contact_below_hip",
    "ee_rotation_from_psi",
    "hip_transform",
    "leg_fk",
    "leg_frames",
    "psi_from_ee_rotation",
    "rolled_position",
    "solve_biped_case",
    "solve_known_pose",
    "solve_known_pose_batch",
    "solve_known_position",
    "solve_leg_case",
    "solve_rolling",
]

# --------------------------------------------------------------------------- biped cases


@dataclass(frozen=True)
class LegTask:
    """What is known for one leg in :func:`solve_biped_case` (plain parameters, SI).

    position : (3,) E [m] in world ("walk", "skate"), or E_a of the start state ("roll").
    beta_z : beta_Z [rad] (Table 1).
    beta : beta_X of a foot ("walk"), beta_Y of a blade ("skate", None when theta6 is given
        instead: §2.3), or beta_Ya of the start state ("roll").
    theta6 : ankle angle [rad] for "skate" with unknown beta_Y (§2.3) and "roll" (§2.4).
    """

    position: tuple[float, float, float]
    beta_z: float = 0.0
    beta: float | None = 0.0
    theta6: float | None = None


@dataclass(frozen=True)
class BipedSolution:
    """Both legs of one hwang2023 case: ``legs[side]`` is the chosen :class:`LegSolution`,
    ``alternatives[side]`` every solution found; ``status`` is ``"ok"`` when both legs are."""

    mode: str
    plane: InclinedPlane
    T_0_G: np.ndarray
    legs: Mapping[str, LegSolution]
    alternatives: Mapping[str, tuple[LegSolution, ...]]
    kind: ContactKind

    @property
    def status(self) -> str:
        for r in self.legs.values():
            if not r.ok:
                return r.status
        return STATUS_OK


def contact_below_hip(geometry: BipedGeometry, plane: InclinedPlane, T_0_G: ArrayLike,
                      side: Side, offset: ArrayLike = (0.0, 0.0)) -> np.ndarray:
    """Point (3,) [m] of the plane straight below (world -z) the hip of ``side`` plus ``offset``
    (x, y) [m] in world axes: the contact placement of Fig. 7 (a), (b), (g)."""
    T_0_H = np.asarray(T_0_G, float) @ hip_transform(geometry, side)
    h = T_0_H[:3, 3] + np.array([*np.asarray(offset, float), 0.0])
    n = plane.normal
    o = np.asarray(plane.origin, float)
    if abs(n[2]) < 1e-12:
        raise ValueError("expected a plane that is not vertical")
    z = o[2] - (n[0] * (h[0] - o[0]) + n[1] * (h[1] - o[1])) / n[2]
    return np.array([h[0], h[1], z])


def solve_biped_case(plane: InclinedPlane, mode: Literal["walk", "skate", "roll"], *,
                     T_0_G: ArrayLike, right: LegTask, left: LegTask,
                     geometry: BipedGeometry = HWANG2023_ESTIMATED,
                     previous: Mapping[str, ArrayLike] | None = None) -> BipedSolution:
    """Solve both legs of one hwang2023 example (Fig. 7) from plain parameters.

    ``"walk"``: feet, E and (beta_Z, beta_X) known -> §2.2. ``"skate"``: blades, E and beta_Z
    known, and beta_Y known (§2.2) or ``theta6`` given with beta_Y unknown (§2.3). ``"roll"``: the
    blade rolls from the start state (E_a, beta_Ya) of each task to the given ``theta6`` with the
    body fixed (§2.4). Of several solutions the one nearest ``previous[side]`` (6,) is chosen,
    else the first (knee back).

    Returns
    -------
    BipedSolution
        Per leg: q, beta, FK errors, T_0_E, and the contact point (the rim point for blades).
    """
    TG = np.asarray(T_0_G, dtype=np.float64)
    kind: ContactKind = "foot" if mode == "walk" else "blade"
    legs: dict[str, LegSolution] = {}
    alts: dict[str, tuple[LegSolution, ...]] = {}
    pairs: tuple[tuple[Side, LegTask], ...] = (("right", right), ("left", left))
    for side, task in pairs:
        prev = None if previous is None else previous.get(side)
        legs[side], alts[side] = solve_leg_case(plane, mode, side, task, T_0_G=TG,
                                                geometry=geometry, previous=prev)
    return BipedSolution(mode, plane, TG, legs, alts, kind)


def _solve_leg(plane: InclinedPlane, mode: str, side: Side, task: LegTask, TG: np.ndarray,
               geometry: BipedGeometry) -> list[LegSolution]:
    kind: ContactKind = "foot" if mode == "walk" else "blade"
    p = np.asarray(task.position, dtype=np.float64)
    Delta = plane.contact_base(side, task.beta_z)
    if mode == "roll" or (mode == "skate" and task.beta is None):
        if task.theta6 is None:
            raise ValueError(f"{side}: expected theta6 for mode {mode!r}")
        if mode == "roll":
            sols = solve_rolling(geometry, side, p, task.beta or 0.0, Delta,
                                 plane.normal, task.theta6, TG)
        else:
            sols = solve_known_position(geometry, side, p, Delta,
                                        task.theta6, TG)
    else:
        Psi = plane.contact_rotation(side, kind, task.beta_z, task.beta or 0.0)
        T = T_from(ee_rotation_from_psi(Psi, side), p)
        sols = solve_known_pose(geometry, side, T, TG, kind)
        sols = [replace(s, beta=float(task.beta or 0.0)) if s.ok else s for s in sols]
    if kind == "blade":
        sols = [blade_contact(geometry, plane, side, s) if s.ok else s for s in sols]
    return sols


def solve_leg_case(plane: InclinedPlane, mode: Literal["walk", "skate", "roll"], side: Side,
                   task: LegTask, *, T_0_G: ArrayLike,
                   geometry: BipedGeometry = HWANG2023_ESTIMATED,
                   previous: ArrayLike | None = None, branch: str | None = None
                   ) -> tuple[LegSolution, tuple[LegSolution, ...]]:
    """One leg of :func:`solve_biped_case` on its own plane: (chosen, every solution found).

    When no solution (of ``branch``, if given) lies within the joint ranges but one exists
    outside them, a record with status ``"at a limit"`` (:attr:`Status.AT_LIMIT`) whose
    ``q_outside`` holds that solution (the nearest to ``previous``, else the first) is added
    (or replaces the failed record), so the caller can say which joint is out of range.
    """
    TG = np.asarray(T_0_G, dtype=np.float64)
    if mode not in ("walk", "skate", "roll"):
        raise ValueError(f"expected mode 'walk', 'skate' or 'roll', got {mode!r}")
    side = _side(side)
    sols = _solve_leg(plane, mode, side, task, TG, geometry)

    def wanted(r: LegSolution) -> bool:
        return r.ok and (branch is None or r.branch == branch)

    limited = not (np.all(np.isneginf(geometry.q_min)) and np.all(np.isposinf(geometry.q_max)))
    if limited and not any(wanted(r) for r in sols):
        free = replace(geometry, q_min=(-math.inf,) * 6, q_max=(math.inf,) * 6)
        outside = [r for r in _solve_leg(plane, mode, side, task, TG, free) if wanted(r)]
        if outside:
            best = outside[0]
            if previous is not None and len(outside) > 1:
                pv = np.asarray(previous, dtype=np.float64)
                best = min(outside, key=lambda r: float(np.linalg.norm(_wrap(r.q - pv))))
            rec = LegSolution(np.full(6, np.nan), STATUS_AT_LIMIT, math.inf, math.inf,
                              best.branch, method=best.method, q_outside=best.q.copy())
            sols = [rec] if not any(r.ok for r in sols) else [*sols, rec]
    best = sols[0]
    if previous is not None and len(sols) > 1 and sols[0].ok:
        pv = np.asarray(previous, dtype=np.float64)
        best = min((r for r in sols if r.ok),
                   key=lambda r: float(np.linalg.norm(_wrap(r.q - pv))))
    return best, tuple(sols)


def blade_contact(geometry: BipedGeometry, plane: InclinedPlane, side: Side,
                  sol: LegSolution) -> LegSolution:
    """Fill the blade tilt (if unknown) and the wheel-rim contact point C = E + r_w (Z'' - n)
    of a blade solution on ``plane`` (Eq. 36)."""
    R = sol.T_0_E[:3, :3]
    up = -R[:, 2]  # blade axis Z'' pointing away from the plane (Fig. 5)
    n = plane.normal
    pc = sol.T_0_E[:3, 3] + geometry.wheel_radius * (up - n)
    beta = sol.beta
    if not math.isfinite(beta):
        Psi = psi_from_ee_rotation(R, side)
        beta = float(contact_angles_from_matrix(Psi, plane.rotation(side), side, "blade")[1])
    return replace(sol, p_contact=pc, beta=beta)


# --------------------------------------------------------------------------- drawing


def biped_polylines(geometry: BipedGeometry, T_0_G: ArrayLike, q_right: ArrayLike,
                    q_left: ArrayLike, *, kind: ContactKind = "blade",
                    plane: InclinedPlane | None = None, plane_half_size: float = 0.35,
                    sole_length: float = 0.20, sole_width: float = 0.08
                    ) -> dict[str, np.ndarray]:
    """Polylines (k, 3) [m] for drawing the biped on its plane (like hwang2023 Figs. 7, 8).

    Keys: ``body`` (hip to hip through G), ``leg_right``/``leg_left`` (G, hip, joints 1'..6'),
    ``foot_right``/``foot_left`` (closed sole outline in the sole plane, for feet) or
    ``blade_right``/``blade_left`` (blade line along its long axis and the wheel-profile arc
    across it, for blades), and ``plane`` (closed square around the plane origin, if given).
    """
    TG = np.asarray(T_0_G, dtype=np.float64)
    out: dict[str, np.ndarray] = {}
    frames = {}
    sides: tuple[tuple[Side, ArrayLike], ...] = (("right", q_right), ("left", q_left))
    for side, q in sides:
        F = leg_frames(geometry, side, np.asarray(q, float)[None], TG, kind)[0]
        frames[side] = F
        out[f"leg_{side}"] = F[:, :3, 3]
    out["body"] = np.stack([frames["right"][1, :3, 3], TG[:3, 3], frames["left"][1, :3, 3]])
    for side in ("right", "left"):
        E = frames[side][-1]
        p, R = E[:3, 3], E[:3, :3]
        fwd = R[:, 1] * (-1.0 if side == "right" else 1.0)  # toe direction (world)
        lat = np.cross(fwd, -R[:, 2])
        if kind == "foot":
            h, wd = 0.5 * sole_length, 0.5 * sole_width
            pts = [p + a * h * fwd + b * wd * lat for a, b in ((1, 1), (1, -1), (-1, -1),
                                                                  (-1, 1), (1, 1))]
            out[f"foot_{side}"] = np.array(pts)
        else:
            h = 0.5 * sole_length
            line = np.array([p - h * fwd, p + h * fwd])
            r = geometry.wheel_radius
            ang = np.linspace(-0.5 * math.pi, 0.5 * math.pi, 13)
            centre = p - r * R[:, 2]
            arc = centre + r * (np.cos(ang)[:, None] * R[:, 2] + np.sin(ang)[:, None] * lat)
            out[f"blade_{side}"] = np.concatenate([line, arc[::-1]], axis=0)
    if plane is not None:
        L = plane.rotation("right")
        o = np.asarray(plane.origin, float)
        c = np.array([(1, 1), (1, -1), (-1, -1), (-1, 1), (1, 1)], float) * plane_half_size
        out["plane"] = o + c[:, :1] * L[:, 0] + c[:, 1:] * L[:, 1]
    return out
