"""The immutable Mechanism: a tree of 1-DOF joints closed by cut links (kim1995 §2).

Every joint i moves its child link relative to its parent frame as
``T_parent_child(q_i) = A_i @ Z(q_i) @ B_i`` where ``Z`` is a rotation about (s_i = 0, revolute)
or a translation along (s_i = 1, prismatic) the local z axis (kim1995 Eq. (2)). D-H parameters,
origins with arbitrary axes and joint offsets are folded into the constant ``A_i`` and ``B_i`` when
the mechanism is built, so forward kinematics is one code path for every description.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

AXIS_NAMES = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True)
class Cut:
    """A cut link: frames ``a`` and ``b`` (frame indices) must coincide (kim1995 Eq. (4))."""

    name: str
    a: int
    b: int
    mask: np.ndarray  # (6,) bool over (x, y, z, rx, ry, rz)


@dataclass(frozen=True)
class Coupling:
    """A linear joint coupling ``q_joint = multiplier * q_master + offset`` (URDF mimic, MJCF
    joint equality): one constraint row ``q_joint - multiplier q_master - offset`` of phi,
    after the cut rows (:mod:`mechkin.model.couplings`). ``joint``, ``master``: joint indices."""

    joint: int
    master: int
    multiplier: float
    offset: float


@dataclass(frozen=True)
class JointGroup:
    """A joint as the user wrote it (a universal expands to 2 joints, a spherical to 3)."""

    name: str
    type: str
    joints: tuple[int, ...]


@dataclass(frozen=True, eq=False)
class Mechanism:
    """Immutable description of a mechanism; per-call scratch lives in the solvers.

    Attributes (n joints, nl links, nf frames; frames 0..nl-1 are the link body frames)
    ----------
    s : (n,) int
        Joint index s_i: 0 revolute, 1 prismatic (kim1995 Eq. (2)).
    A, B : (n, 4, 4)
        Constant transforms before and after the joint motion.
    joint_parent_link, joint_child_link : (n,) int
    link_parent_joint : (nl,) int, -1 for the base.
    levels : tuple of (k,) int arrays
        Joints grouped by depth in the tree; a level's parents are all computed before it.
    link_ancestors : (nl, n) bool
        ``link_ancestors[l, j]``: joint j lies on the path from the base to link l.
    frame_link : (nf,) int; frame_offset : (nf, 4, 4) pose of each frame in its link frame.
    independent, dependent : int arrays, the partition q = L_v q_v + L_w q_w (kim1995 Eq. (3)).
    lower, upper, home : (n,) SI values.
    """

    name: str
    source: Path | None
    link_names: tuple[str, ...]
    frame_names: tuple[str, ...]
    frame_link: np.ndarray
    frame_offset: np.ndarray
    joint_names: tuple[str, ...]
    s: np.ndarray
    A: np.ndarray
    B: np.ndarray
    joint_parent_link: np.ndarray
    joint_child_link: np.ndarray
    joint_parent_frame: np.ndarray
    link_parent_joint: np.ndarray
    levels: tuple[np.ndarray, ...]
    link_ancestors: np.ndarray
    cuts: tuple[Cut, ...]
    independent: np.ndarray
    dependent: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    home: np.ndarray
    end_effector: int | None
    groups: tuple[JointGroup, ...]
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    gravity: np.ndarray
    virtual_links: frozenset[int] = field(default_factory=frozenset)
    couplings: tuple[Coupling, ...] = ()
    #: ``base: floating``: joints base_x..base_roll carry the first link from a world link 0
    floating: bool = False
    #: how an importer chose the default end effector ("site 'tcp' (named like a tool)"), or ""
    end_effector_note: str = ""
    description: str = ""
    # stick drawings (mechkin.model.drawing): declared plates (name, link, ((kind, index), ...)),
    # kind "frame" or "joint"; auto_plates: convex-hull plates on the other links
    plates: tuple = ()
    auto_plates: bool = True
    #: the file's visuals of its links (mechkin.model.visuals.LinkVisual): what viewers draw
    visuals: tuple = ()
    #: (n,) joint velocity [rad/s | m/s] and torque [N m | N] limits as the file gives them
    #: (``velocity_limit``, ``torque_limit``; > 0), inf where it gives none; None: not read
    velocity_limit: np.ndarray | None = None
    torque_limit: np.ndarray | None = None

    # ---- sizes -------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of joint coordinates N_j (kim1995 Eq. (1))."""
        return len(self.joint_names)

    @property
    def n_links(self) -> int:
        return len(self.link_names)

    @property
    def n_cuts(self) -> int:
        return len(self.cuts)

    @property
    def n_equations(self) -> int:
        """Number of constraint equations of phi: 6 per cut (fewer with masks), then one per
        joint coupling."""
        return int(sum(int(c.mask.sum()) for c in self.cuts)) + len(self.couplings)

    @property
    def is_closed(self) -> bool:
        """Whether phi has rows (cuts or joint couplings): the dependent joints are solved by
        the loop closure."""
        return bool(self.cuts) or bool(self.couplings)

    # ---- partition (kim1995 Eq. (3)) -----------------------------------------------------------
    @property
    def L_v(self) -> np.ndarray:
        """(n, n_v) selection matrix of the independent joints."""
        L = np.zeros((self.n, len(self.independent)))
        L[self.independent, np.arange(len(self.independent))] = 1.0
        return L

    @property
    def L_w(self) -> np.ndarray:
        """(n, n_w) selection matrix of the dependent joints."""
        L = np.zeros((self.n, len(self.dependent)))
        L[self.dependent, np.arange(len(self.dependent))] = 1.0
        return L

    def assemble(self, q_v: np.ndarray, q_w: np.ndarray) -> np.ndarray:
        """q = L_v q_v + L_w q_w for batches: q_v (..., n_v), q_w (..., n_w) -> (..., n)."""
        q_v = np.asarray(q_v, dtype=np.float64)
        q_w = np.asarray(q_w, dtype=np.float64)
        shape = np.broadcast_shapes(q_v.shape[:-1], q_w.shape[:-1])
        q = np.empty(shape + (self.n,))
        q[..., self.independent] = q_v
        q[..., self.dependent] = q_w
        return q

    # ---- names ---------------------------------------------------------------------------------
    def frame_index(self, name: str) -> int:
        try:
            return self.frame_names.index(name)
        except ValueError:
            raise KeyError(
                f"unknown frame {name!r} (frames: {', '.join(self.frame_names)})"
            ) from None

    def joint_index(self, name: str) -> int:
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise KeyError(
                f"unknown joint {name!r} (joints: {', '.join(self.joint_names)})"
            ) from None

    @property
    def independent_names(self) -> list[str]:
        return [self.joint_names[i] for i in self.independent]

    @property
    def dependent_names(self) -> list[str]:
        return [self.joint_names[i] for i in self.dependent]

    def joint_unit(self, i: int) -> str:
        return "m" if self.s[i] == 1 else "rad"

    def frame_parent_frame(self, f: int) -> int:
        """The frame that frame ``f`` hangs on in the /tf tree (-1 for the base)."""
        if f >= self.n_links:
            return int(self.frame_link[f])
        j = self.link_parent_joint[f]
        return -1 if j < 0 else int(self.joint_parent_frame[j])


def joint_rate_limits(joints: Sequence[Any], groups: Sequence[JointGroup], n: int
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(velocity (n,), torque (n,)): the file joints' ``velocity_limit`` and ``torque_limit``
    (SI; one value for every axis of a compound joint, or one per axis) on their coordinates,
    inf where a joint gives none (the virtual joints of a floating base)."""
    by_name = {j.name: j for j in joints}
    vel, tau = np.full(n, np.inf), np.full(n, np.inf)
    for g in groups:
        j = by_name.get(g.name)
        if j is None or j.type != g.type:
            continue
        for arr, v in ((vel, j.velocity_limit), (tau, j.torque_limit)):
            if v is not None:
                arr[list(g.joints)] = v
    return vel, tau


def end_effector_hint(mech: Mechanism, limit: int = 4) -> str:
    """What to write when ``mech`` has no end effector: the key, where it goes (the sidecar
    ``ROBOT.mechkin.yaml`` beside a URDF/MJCF file, else the mechanism file), an example and the
    candidate frames (frames on links that carry no joint, tool-like names first)."""
    import re

    carrying = set(int(x) for x in mech.joint_parent_link)
    leaves = [f for f in range(len(mech.frame_names))
              if int(mech.frame_link[f]) not in carrying
              and int(mech.frame_link[f]) not in mech.virtual_links]
    names = [mech.frame_names[f] for f in leaves] or list(mech.frame_names)

    def rank(n: str) -> int:
        low = n.lower()
        if any(w in low for w in ("tool", "tcp", "end_effector", "sole", "foot", "hand")):
            return 0
        return 1 if re.search(r"(^|_)(ee|eef|tip|flange|gripper)(_|$)", low) else 2

    names = sorted(names, key=rank)
    more = f", ... {len(names)} in all" if len(names) > limit else ""
    src = mech.source
    if src is not None and src.suffix.lower() in (".urdf", ".xml", ".mjcf"):
        where = f"in the sidecar {src.stem}.mechkin.yaml beside it"
    else:
        where = "in the mechanism file"
    return (f"fix: set end_effector {where}, e.g. 'end_effector: {names[0]}' (candidate "
            f"frames: {', '.join(names[:limit])}{more})")
