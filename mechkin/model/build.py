"""Mechanism spec (SI) -> immutable Mechanism, with every topology problem reported by file line."""

from __future__ import annotations

from collections import deque

import numpy as np

from mechkin.config.load import YamlDoc, short, short_list
from mechkin.config.schema import FLOATING_JOINTS, MechanismSpec
from mechkin.errors import ConfigError
from mechkin.model.mechanism import (
    AXIS_NAMES,
    Coupling,
    Cut,
    JointGroup,
    Mechanism,
    joint_rate_limits,
)
from mechkin.model.visuals import link_visuals_of
from mechkin.spatial.dh import dh_modified, dh_standard
from mechkin.spatial.rotations import rot_z
from mechkin.spatial.transforms import T_from, transform_from_xyz_rpy

#: how an importer's ``notes`` say why it chose the end effector (mechkin.config.tree_import)
EE_NOTE = "end effector: "


COMPOUND_AXES = {"universal": ([1, 0, 0], [0, 1, 0]),
                 "spherical": ([1, 0, 0], [0, 1, 0], [0, 0, 1])}


#: Largest length [m] and angle [rad] accepted in a mechanism file (beyond, the kinematics
#: overflows or loses every digit); smallest axis component that still gives a direction.
MAX_LENGTH = 1e6
MAX_ANGLE = 1e6
MAX_MASS = 1e9
MIN_AXIS = 1e-9
#: |sin| of the angle below which two successive axes of a compound joint count as parallel.
PARALLEL_TOL = 1e-6


def axis_problem(axis) -> str | None:
    """Why ``axis`` is not a direction (None if it is one): non-finite or (near) zero."""
    a = np.asarray(axis, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        return f"expected 3 finite numbers, got {short(list(axis))}"
    if np.max(np.abs(a)) < MIN_AXIS:
        return (f"axis {short(a.tolist())} has (near) zero length; expected a direction such "
                "as [0, 0, 1]")
    return None


def unit(axis) -> np.ndarray:
    """``axis`` / ||axis||, scaled by its largest component first (no overflow or underflow)."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.max(np.abs(a))
    return a / np.sqrt(a @ a)


def _check_geometry(spec: MechanismSpec, P: _Problems) -> None:
    """Joints, axes, lengths, angles and inertias that would make the model degenerate or its
    arithmetic overflow: at least one joint; every axis a direction; successive axes of a
    universal or spherical joint not parallel; lengths within MAX_LENGTH m, angles within
    MAX_ANGLE rad, masses within MAX_MASS kg (SI spec)."""
    if not spec.joints and spec.base != "floating":
        P.add(("joints",), "a mechanism needs at least one joint (a single free body: set "
              "base: floating, in a robot file's sidecar ROBOT.mechkin.yaml)")

    def bound(kp: tuple, values, limit: float, what: str) -> None:
        vals = values if isinstance(values, list) else [values]
        flat = [v for x in vals for v in (x if isinstance(x, list) else [x])]
        if any(abs(v) > limit for v in flat):
            P.add(kp, f"{what} beyond {limit:g} (SI) is outside the supported range")

    for i, link in enumerate(spec.links):
        for k, fr in enumerate(link.frames):
            bound(("links", i, "frames", k, "xyz"), fr.xyz, MAX_LENGTH, "a length")
            bound(("links", i, "frames", k, "rpy"), fr.rpy, MAX_ANGLE, "an angle")
        if link.inertial is not None:
            kp = ("links", i, "inertial")
            bound(kp + ("mass",), link.inertial.mass, MAX_MASS, "a mass")
            bound(kp + ("com",), link.inertial.com, MAX_LENGTH, "a length")
            bound(kp + ("inertia",), link.inertial.inertia, MAX_MASS * MAX_LENGTH,
                  "an inertia")
    for i, j in enumerate(spec.joints):
        kp = ("joints", i)
        q_what, q_max = (("a length", MAX_LENGTH) if j.type == "prismatic"
                         else ("an angle", MAX_ANGLE))
        for key in ("offset", "home", "limits"):
            v = getattr(j, key)
            if v is not None:
                bound(kp + (key,), v, q_max, q_what)
        if j.dh is not None:
            bound(kp + ("dh",), [j.dh.a, j.dh.d], MAX_LENGTH, "a length")
            bound(kp + ("dh",), [j.dh.alpha, j.dh.theta], MAX_ANGLE, "an angle")
        if j.origin is not None:
            bound(kp + ("origin", "xyz"), j.origin.xyz, MAX_LENGTH, "a length")
            bound(kp + ("origin", "rpy"), j.origin.rpy, MAX_ANGLE, "an angle")
        if j.axis is not None:
            msg = axis_problem(j.axis)
            if msg:
                P.add(kp + ("axis",), msg)
        if j.axes is not None:
            bad = False
            for k, ax in enumerate(j.axes):
                msg = axis_problem(ax)
                if msg:
                    P.add(kp + ("axes", k), msg)
                    bad = True
            if not bad:
                for k in range(1, len(j.axes)):
                    c = np.cross(unit(j.axes[k - 1]), unit(j.axes[k]))
                    if np.sqrt(c @ c) < PARALLEL_TOL:
                        P.add(kp + ("axes", k), f"axis {k + 1} is parallel to axis {k}: the "
                              f"{j.type} joint would lose a degree of freedom")
    if spec.gravity is not None:
        bound(("gravity",), spec.gravity, MAX_LENGTH, "an acceleration")
    P.raise_if_any()


def align_z(axis: np.ndarray) -> np.ndarray:
    """A rotation (3, 3) whose z column is the unit vector along ``axis`` (a direction: see
    :func:`axis_problem`)."""
    a = unit(axis)
    helper = np.array([1.0, 0, 0]) if abs(a[0]) < 0.9 else np.array([0, 1.0, 0])
    x = np.cross(helper, a)
    x /= np.linalg.norm(x)
    y = np.cross(a, x)
    R = np.column_stack([x, y, a])
    if np.allclose(a, [0, 0, 1]):
        R = np.eye(3)
    return R


def _tz(d: float) -> np.ndarray:
    T = np.eye(4)
    T[2, 3] = d
    return T


def _rz(t: float) -> np.ndarray:
    return T_from(rot_z(t), np.zeros(3))


def _dh_AB(conv: str, prismatic: bool, a: float, alpha: float, d: float, theta: float):
    """Split a D-H transform into A @ Z(q) @ B (q adds to theta, or to d if prismatic)."""
    if conv == "standard":  # Rz(theta) Tz(d) Tx(a) Rx(alpha)
        if prismatic:
            return _rz(theta) @ _tz(d), dh_standard(0.0, 0.0, a, alpha)
        return _rz(theta), dh_standard(0.0, d, a, alpha)
    # modified: Rx(alpha) Tx(a) Rz(theta) Tz(d)
    pre = dh_modified(0.0, 0.0, a, alpha)
    if prismatic:
        return pre @ _rz(theta) @ _tz(d), np.eye(4)
    return pre @ _rz(theta), _tz(d)


class _Problems:
    def __init__(self, doc: YamlDoc | None, name: str) -> None:
        self.doc = doc
        self.name = name
        self.lines: list[str] = []

    def add(self, key_path: tuple, msg: str) -> None:
        if self.doc is not None:
            self.lines.append(f"{self.doc.where(key_path)}: {msg}")
        else:
            from mechkin.config.load import format_key_path

            self.lines.append(f"{self.name}: {format_key_path(key_path)}: {msg}")

    def raise_if_any(self) -> None:
        if self.lines:
            raise ConfigError(self.lines)


def _as_list(v, n: int) -> list:
    if isinstance(v, list):
        return list(v)
    return [v] * n


def build_mechanism(spec: MechanismSpec, doc: YamlDoc | None = None) -> Mechanism:
    """Build the Mechanism from an SI spec (see ``config.units.mechanism_to_si``).

    Raises ConfigError with one ``file:line: key.path: message`` line per topology problem:
    duplicate or missing links and frames, a link with two parent joints (a loop without a cut),
    links not connected to the base, cut frames on the same branch, unknown independent joints,
    or a number of independent joints different from the degrees of freedom.
    """
    P = _Problems(doc, spec.name)
    _check_geometry(spec, P)
    # ---- links and frames ---------------------------------------------------------------------
    link_names: list[str] = []
    frame_names: list[str] = []
    frame_link: list[int] = []
    frame_offset: list[np.ndarray] = []
    seen: dict[str, tuple] = {}
    for i, link in enumerate(spec.links):
        if link.name in seen:
            P.add(("links", i, "name"), f"duplicate link {short(link.name)}")
            continue
        seen[link.name] = ("links", i, "name")
        link_names.append(link.name)
    floating = spec.base == "floating" and "floating" not in link_names
    base_name = spec.base or spec.links[0].name
    if floating:  # a 6-DOF virtual chain from a world link to the first link (DESIGN.md)
        body = spec.links[0].name
        base_name = next(w for w in ("world", "world_0", "world_1") if w not in link_names)
        link_names.insert(0, base_name)
    elif spec.base_pose is not None:
        P.add(("base_pose",), "base_pose is the home pose of a floating base; it needs "
              "base: floating")
    if base_name not in link_names:
        P.add(("base",), f"unknown link {short(base_name)} (links: {short_list(link_names)})")
        P.raise_if_any()
    # the base is link 0
    link_names.remove(base_name)
    link_names.insert(0, base_name)
    # virtual links of compound joints are appended below
    joints: list[tuple[str, int, str, str, np.ndarray, np.ndarray, float, float, float, tuple]] = []
    groups: list[JointGroup] = []
    jnames: dict[str, tuple] = {}
    virtual: list[str] = []

    def add_joint(name, kind, parent, child, A, B, lo, hi, home, kp):
        if name in jnames:
            P.add(kp + ("name",), f"duplicate joint name {short(name)}")
        jnames[name] = kp
        joints.append((name, kind, parent, child, A, B, lo, hi, home, kp))
        return len(joints) - 1

    if floating:
        bp = spec.base_pose
        xyz = bp.xyz if bp is not None else [0.0, 0.0, 0.0]
        rpy = bp.rpy if bp is not None else [0.0, 0.0, 0.0]
        idxs = []
        parent = base_name
        for k, (jn, prism, ax, h) in enumerate(zip(FLOATING_JOINTS, (1, 1, 1, 0, 0, 0),
                                                   ((1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, 1),
                                                    (0, 1, 0), (1, 0, 0)),
                                                   (*xyz, rpy[2], rpy[1], rpy[0]), strict=True)):
            Ra = T_from(align_z(list(ax)), np.zeros(3))
            child = body if k == 5 else f"_{jn}_link"
            if k < 5:
                virtual.append(child)
            idxs.append(add_joint(jn, prism, parent, child, Ra, Ra.T.copy(), -np.inf, np.inf,
                                  float(h), ("base",)))
            parent = child
        groups.append(JointGroup("base", "floating", tuple(idxs)))
    for i, j in enumerate(spec.joints):
        kp = ("joints", i)
        ncomp = {"universal": 2, "spherical": 3}.get(j.type, 1)
        lims = j.limits
        pairs = (lims if (lims and isinstance(lims[0], list)) else [lims]) if lims else [None]
        pairs = pairs * (ncomp if len(pairs) == 1 and ncomp > 1 else 1)
        offs = _as_list(j.offset, ncomp)
        homes = _as_list(j.home, ncomp)
        T_origin = (
            transform_from_xyz_rpy(j.origin.xyz, j.origin.rpy)
            if j.origin is not None
            else np.eye(4)
        )
        if ncomp == 1:
            prism = j.type == "prismatic"
            if j.dh is not None:
                A, B = _dh_AB(
                    spec.dh_convention, prism, j.dh.a, j.dh.alpha, j.dh.d, j.dh.theta
                )
                A = A @ (_tz(offs[0]) if prism else _rz(offs[0]))
            else:
                Ra = T_from(align_z(j.axis if j.axis is not None else [0, 0, 1]), np.zeros(3))
                A = T_origin @ Ra @ (_tz(offs[0]) if prism else _rz(offs[0]))
                B = Ra.T.copy()
            lo, hi = pairs[0] if pairs[0] else (-np.inf, np.inf)
            idx = add_joint(j.name, int(prism), j.parent, j.child, A, B, lo, hi, homes[0], kp)
            groups.append(JointGroup(j.name, j.type, (idx,)))
        else:
            axes = j.axes or [list(a) for a in COMPOUND_AXES[j.type]]
            idxs = []
            parent = j.parent
            for k in range(ncomp):
                Ra = T_from(align_z(axes[k]), np.zeros(3))
                A = (T_origin if k == 0 else np.eye(4)) @ Ra @ _rz(offs[k])
                B = Ra.T.copy()
                child = j.child if k == ncomp - 1 else f"{j.name}_link{k + 1}"
                if k < ncomp - 1:
                    virtual.append(child)
                lo, hi = pairs[k] if pairs[k] else (-np.inf, np.inf)
                idxs.append(
                    add_joint(f"{j.name}_{k + 1}", 0, parent, child, A, B, lo, hi, homes[k], kp)
                )
                parent = child
            groups.append(JointGroup(j.name, j.type, tuple(idxs)))
    for v in virtual:
        if v in link_names:
            P.add(("links",), f"link name {short(v)} is reserved for a compound joint's inner link")
        link_names.append(v)
    P.raise_if_any()
    nl = len(link_names)
    link_idx = {n: k for k, n in enumerate(link_names)}
    # frames: link body frames first, then named frames
    frame_names = list(link_names)
    frame_link = list(range(nl))
    frame_offset = [np.eye(4)] * nl
    for i, link in enumerate(spec.links):
        for k, fr in enumerate(link.frames):
            kp = ("links", i, "frames", k, "name")
            if fr.name in frame_names:
                P.add(kp, f"duplicate frame name {short(fr.name)} (already a link or frame)")
                continue
            frame_names.append(fr.name)
            frame_link.append(link_idx[link.name])
            frame_offset.append(transform_from_xyz_rpy(fr.xyz, fr.rpy))
    frame_idx = {n: k for k, n in enumerate(frame_names)}
    # ---- joints: parents, children, tree ------------------------------------------------------
    n = len(joints)
    parent_link = np.zeros(n, dtype=int)
    parent_frame = np.zeros(n, dtype=int)
    child_link = np.zeros(n, dtype=int)
    A = np.zeros((n, 4, 4))
    B = np.zeros((n, 4, 4))
    link_parent_joint = -np.ones(nl, dtype=int)
    for k, (_name, _kind, parent, child, Aj, Bj, _lo, _hi, _home, kp) in enumerate(joints):
        ok = True
        if parent not in frame_idx:
            P.add(kp + ("parent",), f"unknown link or frame {short(parent)} "
                  f"(links: {short_list(link_names)})")
            ok = False
        if child not in link_idx:
            msg = f"unknown link {short(child)}"
            if child in frame_idx:
                msg = f"{short(child)} is a frame; a joint's child must be a link"
            P.add(kp + ("child",), msg + f" (links: {short_list(link_names)})")
            ok = False
        if not ok:
            continue
        c = link_idx[child]
        if c == 0:
            P.add(kp + ("child",), f"the base link {short(child)} cannot be a joint's child")
            continue
        if link_parent_joint[c] >= 0:
            other = joints[link_parent_joint[c]][0]
            P.add(kp + ("child",), f"link {short(child)} is already the child of joint "
                  f"{short(other)}: a closed loop needs a cut (end this branch in a link of its "
                  "own and add a cut whose two frames must coincide)")
            continue
        link_parent_joint[c] = k
        pf = frame_idx[parent]
        parent_frame[k] = pf
        parent_link[k] = frame_link[pf]
        child_link[k] = c
        # a joint placed on a named frame: fold the frame's offset into A
        A[k] = frame_offset[pf] @ Aj
        B[k] = Bj
    P.raise_if_any()
    # depth from the base (BFS); links never reached are not connected (or lie on a cycle)
    children: dict[int, list[int]] = {k: [] for k in range(nl)}
    for k in range(n):
        children[parent_link[k]].append(k)
    depth = -np.ones(nl, dtype=int)
    depth[0] = 0
    ancestors = np.zeros((nl, n), dtype=bool)
    jdepth = np.zeros(n, dtype=int)
    queue = deque([0])
    while queue:
        lk = queue.popleft()
        for k in children[lk]:
            c = child_link[k]
            if depth[c] >= 0:
                continue
            depth[c] = depth[lk] + 1
            jdepth[k] = depth[lk]
            ancestors[c] = ancestors[lk]
            ancestors[c, k] = True
            queue.append(c)
    for lk in range(nl):
        if depth[lk] < 0:
            kp = ("links",)
            for i, link in enumerate(spec.links):
                if link.name == link_names[lk]:
                    kp = ("links", i, "name")
            P.add(kp, f"link {short(link_names[lk])} is not connected to the base "
                  f"{short(base_name)} (no chain of joints leads to it, or it lies on a cycle of "
                  "joints)")
    P.raise_if_any()
    levels = tuple(np.flatnonzero(jdepth == dd) for dd in range(int(jdepth.max(initial=-1)) + 1))
    # ---- cuts ----------------------------------------------------------------------------------
    cuts: list[Cut] = []
    cut_names: set[str] = set()
    for i, c in enumerate(spec.cuts):
        kp = ("cuts", i)
        if c.name in cut_names:
            P.add(kp + ("name",), f"duplicate cut name {short(c.name)}")
        cut_names.add(c.name)
        fa, fb = c.frames
        bad = False
        for k, f in enumerate((fa, fb)):
            if f not in frame_idx:
                P.add(kp + ("frames", k), f"unknown frame {short(f)}")
                bad = True
        if bad:
            continue
        la, lb = frame_link[frame_idx[fa]], frame_link[frame_idx[fb]]
        if la == lb:
            # both frames on one rigid link: no joint lies between them, so the "cut" closes no
            # loop (a cut onto an ancestor link, e.g. back to the ground, is a valid loop)
            P.add(kp + ("frames",), f"frames {short(fa)} and {short(fb)} lie on the same branch: "
                  f"both are fixed on link {short(link_names[la])}, so no joint lies between them "
                  "and the cut closes no loop")
            continue
        mask = np.ones(6, dtype=bool)
        if c.mask is not None:
            if len(set(c.mask)) != len(c.mask) or not c.mask:
                P.add(kp + ("mask",), "expected distinct axis names from x, y, z, rx, ry, rz")
                continue
            mask = np.array([a in c.mask for a in AXIS_NAMES])
        cuts.append(Cut(c.name, frame_idx[fa], frame_idx[fb], mask))
    couplings = _couplings(spec, P, [jt[0] for jt in joints], groups)
    # ---- end effector --------------------------------------------------------------------------
    ee = None
    if spec.end_effector is not None:
        if spec.end_effector not in frame_idx:
            P.add(("end_effector",), f"unknown frame {short(spec.end_effector)} "
                  f"(frames: {short_list(frame_names)})")
        else:
            ee = frame_idx[spec.end_effector]
    P.raise_if_any()
    # ---- limits, home, inertia ----------------------------------------------------------------
    lower = np.array([jt[6] for jt in joints], dtype=float)
    upper = np.array([jt[7] for jt in joints], dtype=float)
    home = np.array([jt[8] for jt in joints], dtype=float)
    for k, jt in enumerate(joints):
        if not lower[k] <= home[k] <= upper[k]:
            P.add(jt[9] + ("home",), f"home {home[k]:.6g} is outside the limits "
                  f"[{lower[k]:.6g}, {upper[k]:.6g}] (SI units)")
    mass = np.zeros(nl)
    com = np.zeros((nl, 3))
    inertia = np.zeros((nl, 3, 3))
    for link in spec.links:
        if link.inertial is not None:
            li = link_idx[link.name]
            mass[li] = link.inertial.mass
            com[li] = link.inertial.com
            ixx, iyy, izz, ixy, ixz, iyz = link.inertial.inertia
            inertia[li] = [[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]
    gravity = np.array(spec.gravity if spec.gravity is not None else [0.0, 0.0, -9.81])
    names = [jt[0] for jt in joints]
    s = np.array([jt[1] for jt in joints], dtype=int)
    vel_lim, tau_lim = joint_rate_limits(spec.joints, groups, len(names))
    mech = Mechanism(
        name=spec.name,
        source=doc.path if doc is not None else None,
        link_names=tuple(link_names),
        frame_names=tuple(frame_names),
        frame_link=np.array(frame_link, dtype=int),
        frame_offset=np.array(frame_offset),
        joint_names=tuple(names),
        s=s,
        A=A,
        B=B,
        joint_parent_link=parent_link,
        joint_child_link=child_link,
        joint_parent_frame=parent_frame,
        link_parent_joint=link_parent_joint,
        levels=levels,
        link_ancestors=ancestors,
        cuts=tuple(cuts),
        independent=np.arange(n),
        dependent=np.zeros(0, dtype=int),
        lower=lower,
        upper=upper,
        home=home,
        end_effector=ee,
        groups=tuple(groups),
        mass=mass,
        com=com,
        inertia=inertia,
        gravity=gravity,
        virtual_links=frozenset(link_idx.get(v, -1) for v in virtual) if virtual else frozenset(),
        description=spec.description or "",
        visuals=link_visuals_of(spec, doc.path if doc is not None else None),
        couplings=couplings,
        floating=floating, velocity_limit=vel_lim, torque_limit=tau_lim,
        end_effector_note=(spec.notes[len(EE_NOTE):] if spec.notes and ee is not None
                           and spec.notes.startswith(EE_NOTE) else ""),
    )
    P.raise_if_any()
    mech = _with_partition(mech, spec, P, names, groups)
    if spec.drawing is not None:  # plates of the stick drawings, names checked here
        from mechkin.model.drawing import resolve_plates

        mech = resolve_plates(mech, spec.drawing, P)
    return mech


def _with_partition(mech, spec, P: _Problems, names, groups) -> Mechanism:
    """Set independent/dependent joints (kim1995 Eq. (3)) and check them against the rank."""
    from dataclasses import replace

    from mechkin.model.kinematics import closure_jacobian, forward_kinematics

    n = mech.n
    rng = np.random.default_rng(12345)
    q0 = np.where(np.isfinite(mech.home), mech.home, 0.0)
    qs = np.stack([q0, q0 + 0.05 * rng.standard_normal(n)])
    try:
        with np.errstate(over="raise", invalid="raise", divide="raise"):
            _, J = closure_jacobian(mech, forward_kinematics(mech, qs))
    except FloatingPointError as exc:
        P.add(("joints",), f"the kinematics at home is not finite ({exc}): degenerate geometry")
        P.raise_if_any()
    if not np.all(np.isfinite(J)):
        P.add(("joints",), "the constraint Jacobian at home is not finite: degenerate geometry")
        P.raise_if_any()
    rank = (int(max(np.linalg.matrix_rank(J[0], tol=1e-9), np.linalg.matrix_rank(J[1], tol=1e-9)))
            if J.shape[1] else 0)
    dof = n - rank
    if dof < 1:
        P.add(("cuts",) if mech.cuts else ("joints",), f"the mechanism has no degree of "
              f"freedom ({n} joint coordinates, rank {rank} of the constraint Jacobian at home): "
              "nothing can move")
        P.raise_if_any()
    group_of = {g.name: g for g in groups}
    coupled = {c.joint for c in mech.couplings}
    if spec.independent is None:
        if mech.cuts:
            P.add(("independent",), f"a closed chain needs its independent joints listed "
                  f"({dof} degrees of freedom)")
            P.raise_if_any()
        if not coupled:
            return mech
        # an open chain with couplings: every joint but the coupled ones
        ind = np.array([k for k in range(n) if k not in coupled], dtype=int)
        return replace(mech, independent=ind, dependent=np.array(sorted(coupled), dtype=int))
    idx: list[int] = []
    for k, name in enumerate(spec.independent):
        if name in names:
            idx.append(names.index(name))
        elif name in group_of:
            idx.extend(group_of[name].joints)
        else:
            P.add(("independent", k), f"unknown joint {short(name)} (joints: {short_list(names)})")
    for i in sorted(set(idx) & coupled):
        P.add(("independent",), f"joint {short(names[i])} is coupled (couplings:): a coupled "
              "joint follows its master and cannot be independent")
    P.raise_if_any()
    if len(set(idx)) != len(idx):
        P.add(("independent",), "a joint is listed twice")
        P.raise_if_any()
    if len(idx) != dof:
        P.add(("independent",), f"expected {dof} independent joints (the degrees of freedom: "
              f"{n} joint coordinates minus rank {rank} of the constraint Jacobian at home), "
              f"got {len(idx)}")
        P.raise_if_any()
    ind = np.array(idx, dtype=int)
    dep = np.array([k for k in range(n) if k not in set(idx)], dtype=int)
    if len(dep):
        ok = any(np.linalg.matrix_rank(J[t][:, dep], tol=1e-9) == len(dep) for t in range(2))
        if not ok:
            P.add(("independent",), "these independent joints do not determine the others: "
                  "the constraint Jacobian of the dependent joints is rank deficient at home")
            P.raise_if_any()
    return replace(mech, independent=ind, dependent=dep)


def _couplings(spec: MechanismSpec, P: _Problems, names: list[str],
               groups: list[JointGroup]) -> tuple[Coupling, ...]:
    """Joint couplings ``joint = multiplier * master + offset`` (SI spec) -> Coupling rows
    (:mod:`mechkin.model.couplings`); unknown, self- and doubly-coupled joints are reported."""
    out: list[Coupling] = []
    seen: dict[str, int] = {}
    compound = {g.name for g in groups if len(g.joints) > 1}
    for i, c in enumerate(spec.couplings):
        kp = ("couplings", i)
        bad = False
        for key in ("joint", "master"):
            v = getattr(c, key)
            if v not in names:
                hint = (f"; name a component of the {v} joint ({v}_1, {v}_2, ...)"
                        if v in compound else "")
                P.add(kp + (key,), f"unknown joint {short(v)} (joints: {short_list(names)}){hint}")
                bad = True
        if bad:
            continue
        if c.joint == c.master:
            P.add(kp + ("master",), f"joint {short(c.joint)} cannot follow itself")
            continue
        if c.joint in seen:
            P.add(kp + ("joint",), f"joint {short(c.joint)} is already coupled "
                  f"(couplings[{seen[c.joint]}])")
            continue
        seen[c.joint] = i
        out.append(Coupling(names.index(c.joint), names.index(c.master), float(c.multiplier),
                            float(c.offset)))
    return tuple(out)
