r"""Legs of parallel mechanisms from the platform pose, by the same subproblem decomposition.

A parallel mechanism in mechkin is a tree closed by cut links (kim1995 §2): the platform (the
link carrying {E}) hangs on one leg, and every other leg ends in a link that a cut ties to a
frame of the platform. Given the platform pose, each leg is a serial chain with a known end
pose (the pose of the platform frame its cut names), so each leg is solved by
:func:`mechkin.solvers.ik.analytic.classify.classify` of its path and
:func:`mechkin.solvers.ik.analytic.solutions.analytic_batch` like an arm: a U-P-S leg (Stewart
platform, kim1995 §6.2) by ``POS_INT12_P`` (two meeting axes, the stroke from a quadratic,
the spherical joint by Subproblems 2 and 1). Every joint of the mechanism follows, actuated
and passive, each leg's branch nearest a reference configuration.

A planar leg of three parallel revolute axes (3-RRR: the leg that carries the platform) is
solved like a SCARA without its prismatic joint (Subproblems 3 and 1, the rotation about the
common axis), and a leg whose cut ties positions only (3-RRR legs 2, 3: two parallel revolute
axes reaching a pin) by Subproblems 3 and 1; an R-U-U leg (the Delta's) by Subproblems 3, 2
and 1 (:func:`mechkin.solvers.ik.analytic.arm5r.uu_leg_branches`); a spherical joint that
carries the platform (lee's RRPS) by Subproblems 2 and 1; a revolute followed by three
parallel revolute axes (the kim1995 direct-drive arm's crank, rod and forearm on the turning
shoulder) by Subproblem 1 (the first axis turns the common axis onto the target's) and the
planar 3R. Legs may share their first joints with a leg solved before them (the direct-drive
arm's upper arm hangs on the same turning shoulder): those joints are known by then, their
motion is taken off the leg's target and the rest of the leg is solved as above. Legs of
other structures raise NotDecomposable naming the leg.

The closed forms of :mod:`mechkin.solvers.closed_form` (Stewart leg lengths, lee's RRPS,
kim1995's direct-drive appendix) are cases of this decomposition: their inverse kinematics
goes through :func:`legs_all` (``closed_form:`` in a mechanism file names which one and
checks its geometry).

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy and the package.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.analytic.arm5r import spherical3_branches, uu_leg_branches
from mechkin.solvers.ik.analytic.classify import AnalyticChain, NotDecomposable, classify
from mechkin.solvers.ik.analytic.finish import finish_batch
from mechkin.solvers.ik.analytic.scara import _sp1, poe_fk, point2r_branches, scara_branches
from mechkin.solvers.ik.analytic.solutions import analytic_batch
from mechkin.solvers.ik.results import IkResult


@dataclass(frozen=True, eq=False)
class Leg:
    """One leg: how it is solved (``kind``: "chain" an :class:`AnalyticChain`; "planar3" three
    parallel revolute axes reaching a pose; "point2r" two parallel revolute axes putting a
    point on a point (a cut that ties positions only); "pose2r" two parallel revolute axes
    reaching a pose; "uu" an R-U-U leg, a Delta's; "spherical3" three axes
    meeting in a point, lee's central spherical joint; "rplanar3" a revolute and three
    parallel revolute axes), the model joints it solves (base first), the frame that ends it
    and the platform frame it must meet (-1: the platform link's frame); H, P, M the leg at
    q = 0, o and w its U centres; ``prefix`` the joints before it that an earlier leg solves
    (their axes Hp, Pp at q = 0)."""

    kind: str
    chain: AnalyticChain | None
    joints: np.ndarray
    end_frame: int
    platform_frame: int
    H: np.ndarray | None = None
    P: np.ndarray | None = None
    M: np.ndarray | None = None
    o: np.ndarray | None = None
    w: np.ndarray | None = None
    prefix: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    Hp: np.ndarray | None = None
    Pp: np.ndarray | None = None


def _leg(mech: Mechanism, end: int, target: int, position_only: bool,
         known: set[int]) -> Leg:
    """The solver of the leg ending at frame ``end`` (NotDecomposable naming it); ``known``
    the joints earlier legs solve (they may only start the leg)."""
    from mechkin.solvers.ik.analytic.classify import MEET_TOL, _meet, _parallel, zero_config

    joints, H, P, M = zero_config(mech, end)
    name = mech.frame_names[end]
    k0 = 0
    while k0 < len(joints) and int(joints[k0]) in known:
        k0 += 1
    if any(int(j) in known for j in joints[k0:]):
        raise NotDecomposable(f"leg to {name}: it shares joints with another leg after its "
                              "own first joint")
    pre = {"prefix": joints[:k0].copy(), "Hp": H[:k0].copy(), "Pp": P[:k0].copy()}
    joints, H, P = joints[k0:], H[k0:], P[k0:]
    if len(joints) == 0:
        raise NotDecomposable(f"leg to {name}: no joint of its own")
    rev = bool(np.all(mech.s[joints] == 0))
    par = rev and all(_parallel(h, H[0]) for h in H)
    if len(joints) == 2 and par:
        return Leg("point2r" if position_only else "pose2r", None, joints, end, target, H, P,
                   M, **pre)
    if position_only:
        raise NotDecomposable(f"leg to {name}: a position-only cut needs two parallel "
                              "revolute joints")
    tol = MEET_TOL * max(1.0, float(np.abs(P).max()))
    if len(joints) == 3 and par:
        return Leg("planar3", None, joints, end, target, H, P, M, **pre)
    if len(joints) == 3 and rev:
        c = _meet(H[0], P[0], H[1], P[1], tol)
        if c is not None and np.linalg.norm(np.cross(H[2], c - P[2])) < tol:
            return Leg("spherical3", None, joints, end, target, H, P, M, **pre)
    if len(joints) == 4 and rev and not _parallel(H[0], H[1]) and \
            all(_parallel(h, H[1]) for h in H[2:]):
        return Leg("rplanar3", None, joints, end, target, H, P, M, **pre)
    if len(joints) == 5 and rev:
        o, w = _meet(H[1], P[1], H[2], P[2], tol), _meet(H[3], P[3], H[4], P[4], tol)
        if o is not None and w is not None:
            return Leg("uu", None, joints, end, target, H, P, M, o, w, **pre)
    if k0:
        raise NotDecomposable(f"leg to {name}: after the joints another leg solves, "
                              f"{len(joints)} joints of no decomposable structure")
    try:
        chain = classify(mech, frame=end, check_independent=False)
    except NotDecomposable as exc:
        raise NotDecomposable(f"leg to {name}: {exc}") from None
    return Leg("chain", chain, chain.joints, end, target)


def platform_legs(mech: Mechanism) -> list[Leg]:
    """The legs of a parallel mechanism whose platform carries {E} (see the module
    docstring), the platform's own leg first. Raises NotDecomposable naming a leg that does
    not decompose."""
    if mech.end_effector is None or not mech.cuts:
        raise NotDecomposable(f"mechanism {mech.name}: legs need a platform ({{E}}) and cuts")
    plat = int(mech.frame_link[mech.end_effector])
    ends = [(plat, -1, False)]
    for cut in mech.cuts:
        full = bool(np.all(cut.mask))
        if not full and (cut.mask[3:].any() or not cut.mask[:2].all()):
            raise NotDecomposable(f"cut {cut.name}: a leg end needs all 6 components or the "
                                  "position (x, y or x, y, z)")
        if int(mech.frame_link[cut.b]) == plat:
            ends.append((int(cut.a), int(cut.b), not full))
        elif int(mech.frame_link[cut.a]) == plat:
            ends.append((int(cut.b), int(cut.a), not full))
        else:
            raise NotDecomposable(f"cut {cut.name} does not end on the platform "
                                  f"{mech.link_names[plat]}")
    legs: list[Leg] = []
    known: set[int] = set()
    for end, target, pos in ends:
        leg = _leg(mech, end, target, pos, known)
        known |= {int(j) for j in leg.joints}
        legs.append(leg)
    return legs


def _leg_targets(mech: Mechanism, leg: Leg, T_0_plat: np.ndarray, q: np.ndarray
                 ) -> np.ndarray:
    """The poses (r, 4, 4) the leg's own joints must reach: its end frame on the platform
    frame its cut names (T_0_plat (r, 4, 4)), less the motion of its prefix joints (their
    values in q (r, n), solved by an earlier leg)."""
    T = T_0_plat if leg.platform_frame < 0 else T_0_plat @ mech.frame_offset[leg.platform_frame]
    if leg.prefix.size:
        E = np.broadcast_to(np.eye(4), T.shape).copy()
        for i, j in enumerate(leg.prefix):
            E = E @ poe_fk(leg.Hp[i:i + 1], leg.Pp[i:i + 1], np.eye(4),
                           0 if mech.s[j] == 1 else -1, q[:, j:j + 1])
        T = np.linalg.inv(E) @ T
    return np.ascontiguousarray(T)


def _branches(leg: Leg, T: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raw branches of a leg of a structured kind (not "chain") for its targets T (r, 4, 4):
    q (r, nb, k), count (r,), FK errors err (r, nb, 2)."""
    if leg.kind == "planar3":
        return scara_branches(leg.H, leg.P, leg.M, -1, T)
    if leg.kind == "spherical3":
        return spherical3_branches(leg.H, leg.P, leg.M, T)
    if leg.kind == "uu":
        return uu_leg_branches(leg.H, leg.P, leg.M, leg.o, leg.w, T)
    if leg.kind == "point2r":
        return point2r_branches(leg.H, leg.P, leg.M[:3, 3], T[:, :3, 3])
    if leg.kind == "pose2r":
        return _pose2r_branches(leg, T)
    # rplanar3: R(h0, q0) turns the common axis d onto the target's (Subproblem 1), then the
    # planar 3R reaches the target with the first joint's motion taken off
    d = leg.H[1]
    RG = T[:, :3, :3] @ leg.M[:3, :3].T
    q0 = _sp1(leg.H[0], np.broadcast_to(d, (len(T), 3)), RG @ d)
    E0 = poe_fk(leg.H[:1], leg.P[:1], np.eye(4), -1, -q0[:, None])
    qb, cnt, err = scara_branches(leg.H[1:], leg.P[1:], leg.M, -1, E0 @ T)
    q = np.concatenate([np.broadcast_to(q0[:, None, None], qb.shape[:2] + (1,)), qb], axis=-1)
    return q, cnt, err


def _pose2r_branches(leg: Leg, T: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two parallel revolute axes reaching poses T (r, 4, 4): the sum of the two angles (the
    second one's sign flipped when its axis points the other way) is the rotation about the
    first axis d (Subproblem 1 on a vector across d), the first angle
    carries the second axis to its place (Subproblem 1 on a point of that axis, which the
    second joint does not move). One branch; its FK errors tell whether the pose is reached."""
    d = leg.H[0]
    r = len(T)
    G = T @ np.linalg.inv(leg.M)  # e^{xi_a q_a} e^{xi_b q_b}
    v = np.cross(d, [1.0, 0, 0] if abs(d[0]) < 0.9 else [0, 1.0, 0])
    v /= np.linalg.norm(v)
    theta = _sp1(d, np.broadcast_to(v, (r, 3)), G[:, :3, :3] @ v)
    y = G[:, :3, :3] @ leg.P[1] + G[:, :3, 3]  # where the second axis' point goes
    qa = _sp1(d, np.broadcast_to(leg.P[1] - leg.P[0], (r, 3)), y - leg.P[0])
    sb = 1.0 if leg.H[1] @ d > 0 else -1.0  # the second axis along d or against it
    q = np.stack([qa, sb * (theta - qa)], axis=-1)[:, None]
    Tq = poe_fk(leg.H, leg.P, leg.M, -1, q[:, 0])
    err = np.stack([np.linalg.norm(Tq[:, :3, 3] - T[:, :3, 3], axis=-1),
                    np.linalg.norm(Tq[:, :3, :3] - T[:, :3, :3], axis=(-2, -1)) / np.sqrt(2.0)],
                   axis=-1)[:, None]
    return q, np.ones(r, dtype=np.int64), err


def _leg_solutions_batch(mech: Mechanism, leg: Leg, T: np.ndarray, ref: np.ndarray,
                         tol: float = 1e-8) -> tuple[np.ndarray, np.ndarray]:
    """Every solution within the limits of the leg's targets T (r, 4, 4), nearest ref (r, k)
    first, each reaching its target within ``tol`` [m], [rad]: q (r, nb, k) and count (r,)."""
    if leg.kind == "chain":
        b = analytic_batch(mech, leg.chain, T, ref[0] if len(T) == 1 else ref, tol_pos=tol,
                           tol_ori=tol)  # one target: the shortest compiled call
        return b.q_v, b.count
    qb, cnt, err = _branches(leg, T)
    r, nb, k = qb.shape
    out = np.empty((r, nb, k))
    pe, oe, dist = (np.empty((r, nb)) for _ in range(3))
    n = np.empty(r, dtype=np.int64)
    j = leg.joints
    finish_batch(np.ascontiguousarray(qb), cnt.astype(np.int64), np.ascontiguousarray(err),
                 np.ascontiguousarray(ref, dtype=np.float64), mech.lower[j].astype(float),
                 mech.upper[j].astype(float), mech.s[j] == 0, tol, tol, 1e-3, out, pe, oe, dist,
                 n)
    return out, n


def solve_legs(mech: Mechanism, legs: list[Leg], T_0_E: np.ndarray, q_ref: np.ndarray,
               tol: float = 1e-8) -> tuple[np.ndarray, bool]:
    """Every joint (n,) of the mechanism with {E} at T_0_E (4, 4): each leg's solution
    nearest q_ref (n,) (revolute joints at the turn nearest it, within the limits; each leg's
    end within ``tol`` [m], [rad] of its target). Returns (q, ok); ok is False when a leg has
    no solution within its limits (q keeps q_ref there)."""
    e = int(mech.end_effector)
    T_0_plat = (T_0_E @ np.linalg.inv(mech.frame_offset[e]))[None]
    q = np.array(q_ref, dtype=np.float64)
    ok = True
    for leg in legs:
        T_end = _leg_targets(mech, leg, T_0_plat, q[None])
        sols, n = _leg_solutions_batch(mech, leg, T_end, q[leg.joints][None], tol)
        if n[0] == 0:
            ok = False
            continue
        q[leg.joints] = sols[0, 0]
    return q, ok


def legs_for(mech: Mechanism) -> list[Leg] | None:
    """:func:`platform_legs`, cached on the Mechanism; None when a leg does not decompose."""
    cache = mech.__dict__.get("_analytic_legs", ())
    if cache == ():
        try:
            cache = platform_legs(mech)
        except NotDecomposable:
            cache = None
        object.__setattr__(mech, "_analytic_legs", cache)
    return cache

def legs_ik(mech: Mechanism, legs: list[Leg], T_P: np.ndarray, q_v0: np.ndarray,
            q_w0: np.ndarray, tol_pos: float, tol_ori: float) -> IkResult:
    """IK of a parallel mechanism through its legs: every joint from the platform pose T_P
    (4, 4) of {E}, each leg's branch nearest the guess (q_v0, q_w0); verified by the model's
    FK (pose of {E} and the loop closure). Status ok when within tol_pos / tol_ori and the
    loops close (1e-8); unreachable when a leg has no solution within its limits."""
    import time

    from mechkin.model.kinematics import closure_residual, forward_kinematics
    from mechkin.solvers.ik.kernel import pose_errors
    from mechkin.solvers.ik.results import IkStatus

    t0 = time.perf_counter()
    ref = np.where(np.isfinite(mech.home), mech.home, 0.0)
    ref[mech.independent], ref[mech.dependent] = q_v0, q_w0
    q, found = solve_legs(mech, legs, np.asarray(T_P, dtype=np.float64), ref)
    kin = forward_kinematics(mech, q[None])
    T_E = kin.frames(mech, [mech.end_effector])[:, 0]
    pe, oe = pose_errors(T_E, np.asarray(T_P, dtype=np.float64)[None])
    phi = closure_residual(mech, kin)
    closed = float(np.linalg.norm(phi)) < 1e-8 if phi.size else True
    ok = found and closed and pe[0] <= tol_pos and oe[0] <= tol_ori
    return IkResult(q_v=q[mech.independent], q_w=q[mech.dependent], q=q,
                    status=IkStatus.OK if ok else IkStatus.UNREACHABLE,
                    position_error=float(pe[0]), orientation_error=float(oe[0]), f=0.0,
                    grad_norm=0.0, iterations=0, evaluations=1,
                    time_s=time.perf_counter() - t0, f_history=np.zeros(1),
                    method="analytic legs")


def legs_all(mech: Mechanism, legs: list[Leg], T_0_E: np.ndarray, q_ref: np.ndarray,
             tol: float = 1e-8) -> np.ndarray:
    """Every configuration (k, n) of the mechanism with {E} at T_0_E: every combination of
    the legs' solutions within their limits (once the platform pose is given a leg depends
    only on the legs before it that solve its first joints, so the list is complete). Built
    leg by leg on arrays: each partial configuration is repeated once per solution of the
    next leg (no loop over combinations); each leg's end within ``tol`` of its target.
    Unverified here: the caller verifies and orders."""
    e = int(mech.end_effector)
    T_0_plat = (np.asarray(T_0_E, dtype=np.float64) @ np.linalg.inv(mech.frame_offset[e]))[None]
    rows = np.array(q_ref, dtype=np.float64)[None]
    for leg in legs:
        T_end = _leg_targets(mech, leg, np.broadcast_to(T_0_plat, (len(rows), 4, 4)), rows)
        sols, n = _leg_solutions_batch(mech, leg, T_end, rows[:, leg.joints], tol)
        rows = np.repeat(rows, n, axis=0)
        rows[:, leg.joints] = sols[np.arange(sols.shape[1])[None] < n[:, None]]
        if not len(rows):
            return np.zeros((0, mech.n))
    return rows
