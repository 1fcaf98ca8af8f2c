"""Both legs of a hwang2023-type biped over a switching sequence (walk -> skate -> roll).

DESIGN: the solving half of ``mechkin ik`` with a ``biped:`` section. :func:`check_mechanism`
finds the two 6-joint legs in the mechanism model and checks them against the closed-form
chain (:mod:`mechkin.solvers.closed_form.biped_leg`, hwang2023 Eq. 1) by forward kinematics;
:func:`solve_sequence` solves every step with the closed form of its class (§2.2 known pose,
§2.3 unknown blade tilt, §2.4 rolling without slipping) and animates roll steps frame by frame.
Inputs are plain SI values (:class:`BipedStep`, :class:`LegInput`); the scenario's units and
keys are converted by ``mechkin.tasks.biped``.

Imports: numpy, model (forward kinematics), solvers.closed_form.biped_leg, spatial.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mechkin.errors import ConfigError
from mechkin.model import Mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.closed_form.biped_leg import (
    STATUS_OK,
    STATUS_UNREACHABLE,
    BipedGeometry,
    BipedSolution,
    InclinedPlane,
    LegSolution,
    LegTask,
    contact_below_hip,
    leg_fk,
    psi_from_ee_rotation,
    solve_biped_case,
)
from mechkin.spatial.euler_conventions import Side, contact_angles_from_matrix

__all__ = [
    "EE_FRAMES",
    "MODEL_TOL",
    "SIDES",
    "BipedFrame",
    "BipedStep",
    "LegInput",
    "StepResult",
    "check_mechanism",
    "leg_joints",
    "solve_sequence",
    "solve_step",
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


def check_mechanism(mech: Mechanism, geometry: BipedGeometry) -> dict[str, list[int]]:
    """Joint indices of each leg; ConfigError unless the file's legs equal the closed-form ones
    (E and the sole point at random joint angles, to ``MODEL_TOL``)."""
    joints = {s: leg_joints(mech, EE_FRAMES[s][0]) for s in SIDES}
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
                    f"hwang2023 closed-form leg by {err:.3g} m (expected the legs of Eq. 1 "
                    "with the HWANG2023_ESTIMATED geometry)")
    return joints


# --------------------------------------------------------------------------- inputs


@dataclass(frozen=True)
class LegInput:
    """What one step knows about one leg, SI (see ``mechkin.config.biped_spec``).

    ``position`` E [m] (world), or ``below_hip`` (x, y) [m] offset from the point of the plane
    below the hip, or neither (below the hip; a roll of a sequence starts from the previous
    step's state). ``beta_z``, ``beta``, ``theta6`` [rad]; ``branch`` the wanted knee branch.
    """

    position: np.ndarray | None = None
    below_hip: np.ndarray | None = None
    beta_z: float = 0.0
    beta: float | None = None
    theta6: float | None = None
    branch: str | None = None


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


@dataclass
class StepResult:
    """A solved step: the closed-form solution, the chosen leg per side and the leg tasks."""

    solution: BipedSolution
    legs: dict[str, LegSolution]
    tasks: dict[str, LegTask]
    branches: dict[str, str | None]

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
    extra: dict[str, Any] = field(default_factory=dict)


# --------------------------------------------------------------------------- solving


def _failed(status: str, method: str, branch: str) -> LegSolution:
    return LegSolution(np.full(6, np.nan), status, math.inf, math.inf, branch, method=method)


def pick(alts: tuple[LegSolution, ...], branch: str | None,
         prev: np.ndarray | None) -> LegSolution:
    """The solution of ``branch`` (any if None) nearest ``prev``; a failed record if none."""
    ok = [a for a in alts if a.ok and (branch is None or a.branch == branch)]
    if not ok:
        if branch is not None and any(a.ok for a in alts):
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


def solve_step(geometry: BipedGeometry, step: BipedStep, prev_q: dict[str, np.ndarray] | None,
               theta6_override: dict[str, float] | None = None) -> StepResult:
    """Both legs of one step by the closed form of its class (hwang2023 §2.2-§2.4)."""
    plane, TG = step.plane, step.T_0_G
    tasks: dict[str, LegTask] = {}
    branches: dict[str, str | None] = {}
    for side in SIDES:
        t = step.legs[side]
        branches[side] = t.branch
        beta = t.beta
        if t.position is not None:
            p = np.asarray(t.position)
        elif t.below_hip is not None:
            p = contact_below_hip(geometry, plane, TG, side, t.below_hip)
        elif step.mode == "roll" and prev_q is not None and np.all(np.isfinite(prev_q[side])):
            p, beta0 = start_state(geometry, plane, side, prev_q[side], TG)
            beta = beta0 if beta is None else beta
        else:
            p = contact_below_hip(geometry, plane, TG, side)
        theta6 = t.theta6
        if theta6_override is not None:
            theta6 = theta6_override[side]
        if step.mode == "walk" or step.mode == "roll":
            beta = 0.0 if beta is None else beta
        elif beta is None and theta6 is None:
            beta = 0.0
        tasks[side] = LegTask(tuple(float(v) for v in p), float(t.beta_z),  # type: ignore
                              None if beta is None else float(beta),
                              None if theta6 is None else float(theta6))
    sol = solve_biped_case(plane, step.mode, T_0_G=TG, right=tasks["right"],  # type: ignore
                           left=tasks["left"], geometry=geometry, previous=prev_q)
    legs = {s: pick(sol.alternatives[s], branches[s], None if prev_q is None else prev_q[s])
            for s in SIDES}
    return StepResult(sol, legs, tasks, branches)


def solve_sequence(geometry: BipedGeometry, steps: list[BipedStep]
                   ) -> tuple[list[StepResult], list[BipedFrame]]:
    """Solve every step in order; each starts from the joint angles the last solved step left.

    A roll step with ``frames > 1`` after a solved step is animated: every frame rolls from
    the same start state (E_a, beta_Ya: the previous step's blade) to an intermediate ankle
    angle (Eq. 37 is path independent); the last frame is the step itself. Returns one
    :class:`StepResult` per step and the frames of the animation (times in [s]).
    """
    results: list[StepResult] = []
    frames: list[BipedFrame] = []
    prev_q: dict[str, np.ndarray] | None = None
    t = 0.0
    for k, step in enumerate(steps):
        t_end = t + (step.duration if k > 0 else 0.0)
        kind = "foot" if step.mode == "walk" else "blade"
        if (step.mode == "roll" and step.frames > 1 and prev_q is not None
                and all(np.all(np.isfinite(prev_q[s])) for s in SIDES)):
            first = solve_step(geometry, step, prev_q)
            t6b = {s: first.tasks[s].theta6 for s in SIDES}
            t6a = {s: float(prev_q[s][5]) for s in SIDES}
            sub_prev = prev_q
            for j in range(1, step.frames + 1):
                f = j / step.frames
                if j < step.frames:
                    t6 = {s: t6a[s] + (t6b[s] - t6a[s]) * f for s in SIDES}  # type: ignore
                    r = solve_step(geometry, step, prev_q, t6)
                    r.legs = {s: pick(r.solution.alternatives[s], r.branches[s], sub_prev[s])
                              for s in SIDES}
                else:
                    r = first
                frames.append(BipedFrame(t + (t_end - t) * f, r.legs, k, kind))
                if all(r.legs[s].ok for s in SIDES):
                    sub_prev = {s: r.legs[s].q for s in SIDES}
            res = first
        else:
            res = solve_step(geometry, step, prev_q)
            frames.append(BipedFrame(t_end, res.legs, k, kind))
        t = t_end
        results.append(res)
        if all(res.legs[s].ok for s in SIDES):
            prev_q = {s: res.legs[s].q for s in SIDES}
    return results, frames
