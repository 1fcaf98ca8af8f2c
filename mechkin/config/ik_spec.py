"""``ik:`` section of scenario files: precision points, weights, method and tolerances.

Registered with :func:`mechkin.config.scenario.register_task_section` on import. Values are in
the scenario's ``units`` (positions in the length unit, Euler angles and the orientation
tolerance in the angle unit); :func:`target_matrices` converts targets to SI.
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import Discriminator, Field, Tag, model_validator

from mechkin.config.scenario import BasePoseSpec, register_task_section
from mechkin.config.schema import Name, NonNegNum, Num, PosNum, Spec, Units
from mechkin.config.units import angle_factor, length_factor

Row4 = Annotated[list[Num], Field(min_length=4, max_length=4)]
Weights = Annotated[list[NonNegNum], Field(min_length=6, max_length=6)]
ORTHO_TOL = 2e-3


class EulerSpec(Spec):
    """Euler angles as scipy's ``Rotation.from_euler``: ``convention`` upper case is intrinsic
    (body axes, ``ZYX``), lower case extrinsic (fixed axes, ``xyz``); signed axes as in
    ``X-Y+Z`` allowed; ``angles`` one per axis."""

    convention: Annotated[str, Field(min_length=1, max_length=16)]
    angles: Annotated[list[Num], Field(min_length=1, max_length=6)]

    @model_validator(mode="after")
    def _check(self) -> EulerSpec:
        from mechkin.spatial.euler_conventions import parse_sequence

        axes = parse_sequence(self.convention)  # ValueError -> reported with the key path
        if len(axes) != len(self.angles):
            raise ValueError(f"convention {self.convention!r} has {len(axes)} axes, got "
                             f"{len(self.angles)} angles")
        return self


class TargetSpec(Spec):
    """One precision point {P}: a 4x4 ``matrix``, or ``xyz`` with ``rpy`` (URDF roll, pitch,
    yaw: Rz(y) Ry(p) Rx(r), as in the mechanism and track files), ``euler`` or ``quaternion``
    (w, x, y, z); optional ``weights`` (6: position x, y, z, then orientation) and ``name``."""

    name: str | None = None
    frame: Name | None = None  # the frame that meets this pose (default: the end effector)
    matrix: Annotated[list[Row4], Field(min_length=4, max_length=4)] | None = None
    xyz: Annotated[list[Num], Field(min_length=3, max_length=3)] | None = None
    rpy: Annotated[list[Num], Field(min_length=3, max_length=3)] | None = None
    euler: EulerSpec | None = None
    quaternion: Annotated[list[Num], Field(min_length=4, max_length=4)] | None = None
    weights: Weights | None = None

    @model_validator(mode="after")
    def _check(self) -> TargetSpec:
        if self.matrix is not None:
            if any(v is not None for v in (self.xyz, self.rpy, self.euler, self.quaternion)):
                raise ValueError("give either matrix, or xyz with rpy, euler or quaternion, "
                                 "not both")
            M = np.asarray(self.matrix, dtype=float)
            if np.abs(M[:3, :3]).max() > 1.0 + ORTHO_TOL:
                raise ValueError("matrix: expected a rotation in the upper-left 3x3 (entries "
                                 f"within [-1, 1]), got {np.abs(M[:3, :3]).max():.3g}")
            if not np.allclose(M[3], [0, 0, 0, 1], atol=1e-9):
                raise ValueError(f"matrix: expected last row [0, 0, 0, 1], got {M[3].tolist()}")
            R = M[:3, :3]
            err = float(np.abs(R.T @ R - np.eye(3)).max())
            if err > ORTHO_TOL or np.linalg.det(R) <= 0:
                raise ValueError(f"matrix: expected a rotation in the upper-left 3x3 "
                                 f"(R^T R = I within {ORTHO_TOL}, det > 0), got deviation "
                                 f"{err:.3g}")
            return self
        if self.xyz is None:
            raise ValueError("give a matrix, or xyz with rpy, euler or quaternion")
        if sum(v is not None for v in (self.rpy, self.euler, self.quaternion)) != 1:
            raise ValueError("with xyz give exactly one of rpy, euler or quaternion")
        if self.quaternion is not None:
            q = np.abs(np.asarray(self.quaternion, dtype=float))
            if q.max() < 1e-9 or q.max() > 1e9:
                raise ValueError("quaternion: expected a non-zero (w, x, y, z) of moderate size "
                                 "(it is normalised)")
        if self.weights is not None and not any(self.weights):
            raise ValueError("weights: all six are zero, so every pose would count as reached; "
                             "give at least one positive weight")
        return self


#: a floating base's pose in a target set: a known pose (``xyz`` + URDF ``rpy``) or ``free``
#: (a word goes to the word, a mapping to the pose: one message, not one per branch; the tags
#: hold "[" so that messages leave them out of the key path, as pydantic's own union tags)
BasePoseTarget = Annotated[
    Annotated[BasePoseSpec, Tag("pose[xyz,rpy]")] | Annotated[Literal["free"], Tag("word[free]")],
    Discriminator(lambda v: "word[free]" if isinstance(v, str) else "pose[xyz,rpy]")]


class TargetSetSpec(Spec):
    """Several frames' targets solved together (``frame`` on each; a biped's two feet, a
    humanoid's feet and hands): one least-squares problem with the loop closure and couplings
    (:mod:`mechkin.solvers.ik.multi_frame`). ``base_pose`` (a floating base only): ``free``
    (the base pose is an unknown) or a known pose ``{xyz, rpy}`` the base is held at; default
    the section's ``base_pose``."""

    name: str | None = None
    targets: Annotated[list[TargetSpec], Field(min_length=1)]
    base_pose: BasePoseTarget | None = None

    @model_validator(mode="after")
    def _check(self) -> TargetSetSpec:
        missing = [i for i, t in enumerate(self.targets) if t.frame is None]
        if missing:
            raise ValueError(f"targets[{missing[0]}]: a target set names the frame of every "
                             "target (frame: left_foot)")
        return self


class RandomTargetsSpec(Spec):
    """Reachable poses generated by forward kinematics of seeded random independent joint
    values, uniform within the joint limits."""

    count: Annotated[int, Field(strict=True, ge=1, le=1_000_000)]
    seed: Annotated[int, Field(strict=True, ge=0)] = 0


class IkToleranceSpec(Spec):
    """Stopping and acceptance tolerances.

    ``grad``: ||df/dq_v|| below which the search stops (kim1995 §5.2 Step 6); ``max_iter``;
    ``position`` [length unit] and ``orientation`` [angle unit]: verified errors below which a
    target counts as reached; ``closure``: ||phi_R|| of the loop closure (kim1995 §5.1).
    """

    grad: PosNum = 1e-10
    max_iter: Annotated[int, Field(strict=True, ge=1, le=100_000)] | None = None
    position: PosNum | None = None
    orientation: PosNum | None = None
    closure: PosNum = 1e-12
    line: PosNum = 1e-9


class IkSpec(Spec):
    """``ik:`` section.

    ``targets`` (a list of precision points, solved in order) and/or ``random_targets``;
    ``weights`` the default diagonal of W (kim1995 Eq. (9)); ``initial_guess`` independent (and
    optionally dependent) joints by name; ``method``: ``auto`` (default: ``analytic`` where the
    mechanism's joint axes decompose into subproblems and all six weights are positive, else
    ``lm``), ``analytic`` (every branch by subproblem decomposition, the one nearest the guess;
    refuses a mechanism that does not decompose, naming the axes), ``lm``, ``cg-golden``
    (kim1995 §5.2) or ``closed-form``; ``variant`` (cg-golden only): ``robust`` (default) or
    ``printed`` (kim1995 §5.2 exactly as printed: no restarts, Arora's golden section without a
    step cap, no passive-limit projection; ``cg_restart`` does not apply); ``warm_start`` each
    point from the previous solution (kim1995 §5.2);
    ``restarts`` re-solves of a target the (warm) start does not reach, from the nearest poses
    of a seeded codebook, then seeded random joints (default 50: >= 99.5 % of random reachable
    PUMA 560 / Panda poses verified; 0 turns them off); ``batch`` solve all targets at once
    (lm, independent starts; auto / analytic: one compiled call); ``solutions``: ``one``
    (default) the solution of ``method``, or ``all``: also every distinct verified solution of each
    target (the analytic branches where the mechanism decomposes and the method is auto or analytic:
    complete, ``complete: true``, except IK-Geo's 1-D search (``analytic`` on 6R arms whose h5 meets
    h6 without a closed form): ``complete: false``; the closed form where the mechanism has one;
    else multi-start lm from ``solution_starts`` seeded starts, ``complete: false``; merged with
    revolute joints modulo 2 pi; verified to 0.1 mm and 1 mrad). ``fixed``: independent joints held
    at the given values (a 7R arm's redundant joint; auto / analytic), the rest solved analytically.
    ``base_pose`` (a floating base, with target sets or framed targets): ``free`` (default: the six
    base joints are unknowns) or a known pose ``{xyz, rpy}`` (file units, URDF rpy) the base is held
    at while the rest is solved; a set's own ``base_pose`` overrides it.
    """

    targets: list[TargetSpec] = Field(default_factory=list)
    target_sets: list[TargetSetSpec] = Field(default_factory=list)
    random_targets: RandomTargetsSpec | None = None
    weights: Weights = Field(default_factory=lambda: [1.0] * 6)
    initial_guess: dict[Name, Num] | None = None
    method: Literal["auto", "analytic", "lm", "cg-golden", "closed-form"] = "auto"
    tolerances: IkToleranceSpec = Field(default_factory=IkToleranceSpec)
    restarts: Annotated[int, Field(strict=True, ge=0, le=1000)] = 50
    seed: Annotated[int, Field(strict=True, ge=0)] = 0
    warm_start: bool = True
    batch: bool = False
    cg_restart: Annotated[int, Field(strict=True, ge=0)] | None = None
    variant: Literal["robust", "printed"] = "robust"
    solutions: Literal["one", "all"] = "one"
    solution_starts: Annotated[int, Field(strict=True, ge=1, le=100_000)] = 256
    fixed: dict[Name, Num] | None = None
    base_pose: BasePoseTarget = "free"

    @model_validator(mode="after")
    def _check(self) -> IkSpec:
        if not self.targets and self.random_targets is None and not self.target_sets:
            raise ValueError("give targets (a list of precision points), target_sets or "
                             "random_targets")
        framed = [t.frame is not None for t in self.targets]
        if any(framed) and (not all(framed) or self.target_sets or self.random_targets):
            raise ValueError("targets that name their frame form one target set: name the "
                             "frame of every target (or use target_sets), without "
                             "random_targets")
        if ("base_pose" in self.model_fields_set and not any(framed)
                and not self.target_sets):
            raise ValueError("base_pose: holds a floating base in target sets; name the frame "
                             "of every target (frame: left_foot) or use target_sets")
        if self.target_sets and (self.targets or self.random_targets):
            raise ValueError("target_sets: give either target_sets or targets / "
                             "random_targets")
        if "variant" in self.model_fields_set and self.method != "cg-golden":
            raise ValueError(f"variant: applies to method cg-golden only (method is "
                             f"{self.method})")
        if self.variant == "printed" and self.cg_restart is not None:
            raise ValueError("cg_restart: the printed variant never restarts (kim1995 §5.2); "
                             "use variant robust")
        if self.fixed and (self.target_sets or any(framed)):
            raise ValueError("fixed: holds joints for the end effector's targets; target sets "
                             "and framed targets would ignore it (hold a floating base with "
                             "base_pose)")
        if self.fixed and self.method not in ("auto", "analytic"):
            raise ValueError(f"fixed: holds joints for method auto or analytic (method is "
                             f"{self.method})")
        if self.batch and self.method not in ("lm", "auto", "analytic"):
            raise ValueError("batch: only methods auto, analytic and lm solve targets in a "
                             "batch")
        uses_default = self.random_targets is not None or any(
            t.weights is None for t in self.targets)
        if uses_default and not any(self.weights):
            raise ValueError("weights: all six are zero, so every pose would count as reached; "
                             "give at least one positive weight")
        return self


def target_matrix(t: TargetSpec, units: Units) -> np.ndarray:
    """T_0_P (4, 4) in SI; the rotation of a matrix is projected onto SO(3) (polar)."""
    from mechkin.spatial.euler_conventions import euler_matrix
    from mechkin.spatial.rotations import matrix_from_quat, matrix_from_rpy

    L = length_factor(units.length)
    T = np.eye(4)
    if t.matrix is not None:
        M = np.asarray(t.matrix, dtype=float)
        U, _, Vt = np.linalg.svd(M[:3, :3])
        T[:3, :3] = U @ Vt
        T[:3, 3] = M[:3, 3] * L
        return T
    assert t.xyz is not None
    T[:3, 3] = np.asarray(t.xyz, dtype=float) * L
    if t.rpy is not None:  # URDF: Rz(yaw) Ry(pitch) Rx(roll), the extrinsic xyz
        T[:3, :3] = matrix_from_rpy(np.asarray(t.rpy, dtype=float) * angle_factor(units.angle))
    elif t.euler is not None:
        T[:3, :3] = euler_matrix(t.euler.convention,
                                 np.asarray(t.euler.angles) * angle_factor(units.angle))
    else:
        assert t.quaternion is not None
        T[:3, :3] = matrix_from_quat(np.asarray(t.quaternion, dtype=float))
    return T


register_task_section("ik", IkSpec)
