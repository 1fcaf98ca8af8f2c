"""``biped:`` section of ``task: ik`` scenarios: the hwang2023 biped on an inclined plane.

One case (``mode`` + ``legs``) or a switching ``sequence`` of steps (walk -> skate -> roll).
Numbers are in the scenario's ``units`` (lengths in the length unit, angles in the angle unit);
:func:`plane_si`, :func:`body_si` and :func:`leg_si` convert them to SI.

Per leg (hwang2023 Table 1, §2.2-§2.4):

* ``position`` - the end-effector point E (walk: the sole point; skate/roll: the blade point) in
  world coordinates, or ``below_hip`` - an offset (x, y) [world axes] from the point of the plane
  straight below the hip (the placement of Fig. 7). Neither: straight below the hip, or, for a
  ``roll`` step of a sequence, the state the previous step left (E_a, beta_Ya).
* ``beta_z`` - beta_Z (toe turned outward), default 0.
* ``beta`` - walk: beta_X of the foot (default 0); skate: beta_Y of the blade (default 0, unless
  ``theta6`` is given: §2.3 with beta_Y unknown); roll: beta_Ya of the start state.
* ``theta6`` - skate: the ankle angle with beta_Y unknown (§2.3); roll: the ankle angle the blade
  rolls to (§2.4); a roll needs it or ``beta_end``.
* ``beta_end`` - roll: the blade tilt beta_Y the blade rolls to (0: upright); E follows from
  Eq. (37) and the pose is solved by §2.2.
* ``plane`` - this leg's own inclined plane (same keys as the section's ``plane``); default the
  step's (or the section's) plane, so one foot can stand on a slope and the other on the level.
* ``branch`` - the expected branch (``knee back`` or ``knee forward``); the run picks it and fails
  the leg when that branch has no solution. Default: the first (knee back), or in a sequence the
  one nearest the previous step.

Registered with :func:`mechkin.config.scenario.register_task_section` on import.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, model_validator

from mechkin.config.scenario import register_task_section
from mechkin.config.schema import Num, PosNum, Spec, Units, Vec3
from mechkin.config.units import angle_factor, length_factor

Mode = Literal["walk", "skate", "roll"]
Branch = Literal["knee back", "knee forward"]
Vec2 = Annotated[list[Num], Field(min_length=2, max_length=2)]


class PlaneSpec(Spec):
    """An inclined plane of hwang2023 Table 5: XYXY angles lam_X, lam_Y, gam_X and a point."""

    lam_x: Num = 0.0
    lam_y: Num = 0.0
    gam_x: Num = 0.0
    origin: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])


class BodySpec(Spec):
    """The body pose A_0G: position of G and its orientation ``Rz(theta_z) Ry(theta_y)
    Rx(theta_x)`` (turns about the world x, then y, then z axes; hwang2023 Eq. 1a has theta_z
    only, the closed forms accept any rigid A_0G)."""

    position: Vec3
    theta_x: Num = 0.0
    theta_y: Num = 0.0
    theta_z: Num = 0.0


class LegTaskSpec(Spec):
    """What is known for one leg (see the module docstring)."""

    position: Vec3 | None = None
    below_hip: Vec2 | None = None
    beta_z: Num = 0.0
    beta: Num | None = None
    theta6: Num | None = None
    beta_end: Num | None = None
    branch: Branch | None = None
    plane: PlaneSpec | None = None

    @model_validator(mode="after")
    def _check(self) -> LegTaskSpec:
        if self.position is not None and self.below_hip is not None:
            raise ValueError("give either position or below_hip, not both")
        return self


class LegsSpec(Spec):
    right: LegTaskSpec = Field(default_factory=LegTaskSpec)
    left: LegTaskSpec = Field(default_factory=LegTaskSpec)


def _check_mode(mode: str, legs: LegsSpec) -> None:
    for side in ("right", "left"):
        t: LegTaskSpec = getattr(legs, side)
        if mode == "walk" and t.theta6 is not None:
            raise ValueError(f"legs.{side}: theta6 is for skate (beta_Y unknown) and roll, "
                             "not walk (give beta = beta_X)")
        if mode == "skate" and t.theta6 is not None and t.beta is not None:
            raise ValueError(f"legs.{side}: give either beta (beta_Y known, §2.2) or theta6 "
                             "(beta_Y unknown, §2.3), not both")
        if mode == "roll" and (t.theta6 is None) == (t.beta_end is None):
            raise ValueError(f"legs.{side}: a roll needs theta6 (the ankle angle to roll to) "
                             "or beta_end (the blade tilt beta_Y to roll to), not both")
        if mode != "roll" and t.beta_end is not None:
            raise ValueError(f"legs.{side}: beta_end is the tilt a roll ends at, not for {mode}")


class StepSpec(Spec):
    """One step of a switching sequence; ``plane`` and ``body`` default to the section's."""

    name: Annotated[str, Field(min_length=1)] | None = None
    mode: Mode
    legs: LegsSpec = Field(default_factory=LegsSpec)
    plane: PlaneSpec | None = None
    body: BodySpec | None = None
    duration: PosNum = 1.0
    frames: Annotated[int, Field(strict=True, ge=1, le=1000)] = 1
    time_law: Literal["linear", "smooth"] = "linear"

    @model_validator(mode="after")
    def _check(self) -> StepSpec:
        _check_mode(self.mode, self.legs)
        return self


class BipedSpec(Spec):
    """``biped:`` section: one case (``mode`` + ``legs``) or a ``sequence`` of steps.

    ``frames`` of a step (after a solved step) animates it in that many frames: a roll goes
    from the previous step's ankle angle (or blade tilt) to ``theta6`` (or ``beta_end``) in
    rolls without slipping (§2.4); a walk or skate step moves the body and each contact frame
    from where the previous step left them to the step's pose (positions along straight lines,
    orientations by slerp), every frame solved by §2.2. Across a switch the moving frame is
    the new step's contact frame where the old pose holds it (walk -> skate: the blade point E
    of the standing foot's pose; skate or roll -> walk: the sole of the blade's pose), so the
    foot-to-blade switch is continuous too; with ``frames: 1`` it is one jump (hwang2023 Table
    6 (a) -> (b): right theta4 -11.60 -> -5.00 deg). ``time_law``: ``linear`` or ``smooth``
    (10 s^3 - 15 s^4 + 6 s^5: zero speed and acceleration at both ends).
    ``solutions: all`` lists every closed-form solution of each leg (each checked by the
    mechanism file's forward kinematics) in the summary.
    """

    plane: PlaneSpec = Field(default_factory=PlaneSpec)
    body: BodySpec
    mode: Mode | None = None
    legs: LegsSpec | None = None
    name: Annotated[str, Field(min_length=1)] | None = None
    sequence: Annotated[list[StepSpec], Field(min_length=1, max_length=100)] | None = None
    solutions: Literal["one", "all"] = "one"

    @model_validator(mode="after")
    def _check(self) -> BipedSpec:
        if self.sequence is not None:
            if self.mode is not None or self.legs is not None or self.name is not None:
                raise ValueError("give either mode and legs (one case) or sequence, not both")
            return self
        if self.mode is None:
            raise ValueError("give mode (walk, skate or roll) with legs, or a sequence")
        _check_mode(self.mode, self.legs or LegsSpec())
        return self

    def steps(self) -> list[StepSpec]:
        """The steps to solve: the sequence, or the one case as a 1-step sequence."""
        if self.sequence is not None:
            return list(self.sequence)
        return [StepSpec(name=self.name, mode=self.mode, legs=self.legs or LegsSpec())]


# ---- SI --------------------------------------------------------------------------------------


def plane_si(p: PlaneSpec, units: Units) -> dict[str, Any]:
    """Plane angles [rad] and origin [m]."""
    a, L = angle_factor(units.angle), length_factor(units.length)
    return {"lam_x": p.lam_x * a, "lam_y": p.lam_y * a, "gam_x": p.gam_x * a,
            "origin": tuple(float(v) * L for v in p.origin)}


def body_si(b: BodySpec, units: Units) -> tuple[np.ndarray, tuple[float, float, float]]:
    """Body position [m] and (theta_x, theta_y, theta_z) [rad]."""
    a = angle_factor(units.angle)
    return (np.asarray(b.position, float) * length_factor(units.length),
            (b.theta_x * a, b.theta_y * a, b.theta_z * a))


def leg_si(t: LegTaskSpec, units: Units) -> dict[str, Any]:
    """A leg task with lengths in m and angles in rad (None kept)."""
    a, L = angle_factor(units.angle), length_factor(units.length)
    return {
        "position": None if t.position is None else np.asarray(t.position, float) * L,
        "below_hip": None if t.below_hip is None else np.asarray(t.below_hip, float) * L,
        "beta_z": t.beta_z * a,
        "beta": None if t.beta is None else t.beta * a,
        "theta6": None if t.theta6 is None else t.theta6 * a,
        "beta_end": None if t.beta_end is None else t.beta_end * a,
        "branch": t.branch,
        "plane": None if t.plane is None else plane_si(t.plane, units),
    }


register_task_section("biped", BipedSpec)
