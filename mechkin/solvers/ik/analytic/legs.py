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
carries the platform (lee's RRPS) by Subproblems 2 and 1. Legs of other structures raise
NotDecomposable naming the leg; their closed forms stay as they are.

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy and the package.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.analytic.arm5r import spherical3_branches, uu_leg_branches
from mechkin.solvers.ik.analytic.classify import AnalyticChain, NotDecomposable, classify
from mechkin.solvers.ik.analytic.finish import finish_batch
from mechkin.solvers.ik.analytic.scara import point2r_branches, scara_branches
from mechkin.solvers.ik.analytic.solutions import analytic_batch
from mechkin.solvers.ik.results import IkResult


@dataclass(frozen=True, eq=False)
class Leg:
    """One leg: how it is solved (``kind``: "chain" an :class:`AnalyticChain`; "planar3" three
    parallel revolute axes reaching a pose; "point2r" two parallel revolute axes putting a
    point on a point, for a cut that ties positions only; "uu" an R-U-U leg, a Delta's;
    "spherical3" three axes meeting in a point, lee's central spherical joint), the
    model joints (base first), the frame that ends it and the platform frame it must meet
    (-1: the platform link's frame); H, P, M the leg at q = 0, o and w its U centres."""

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


def _leg(mech: Mechanism, end: int, target: int, position_only: bool) -> Leg:
    """The solver of the leg ending at frame ``end`` (NotDecomposable naming it)."""
    from mechkin.solvers.ik.analytic.classify import _parallel, zero_config

    joints, H, P, M = zero_config(mech, end)
    rev = bool(np.all(mech.s[joints] == 0))
    par = rev and all(_parallel(h, H[0]) for h in H)
    if position_only:
        if len(joints) == 2 and par:
            return Leg("point2r", None, joints, end, target, H, P, M)
        raise NotDecomposable(f"leg to {mech.frame_names[end]}: a position-only cut needs two "
                              "parallel revolute joints")
    if len(joints) == 3 and par:
        return Leg("planar3", None, joints, end, target, H, P, M)
    if len(joints) == 3 and rev:
        from mechkin.solvers.ik.analytic.classify import MEET_TOL, _meet

        tol = MEET_TOL * max(1.0, float(np.abs(P).max()))
        c = _meet(H[0], P[0], H[1], P[1], tol)
        if c is not None and np.linalg.norm(np.cross(H[2], c - P[2])) < tol:
            return Leg("spherical3", None, joints, end, target, H, P, M)
    if len(joints) == 5 and rev:
        from mechkin.solvers.ik.analytic.classify import MEET_TOL, _meet

        tol = MEET_TOL * max(1.0, float(np.abs(P).max()))
        o, w = _meet(H[1], P[1], H[2], P[2], tol), _meet(H[3], P[3], H[4], P[4], tol)
        if o is not None and w is not None:
            return Leg("uu", None, joints, end, target, H, P, M, o, w)
    try:
        chain = classify(mech, frame=end, check_independent=False)
    except NotDecomposable as exc:
        raise NotDecomposable(f"leg to {mech.frame_names[end]}: {exc}") from None
    return Leg("chain", chain, chain.joints, end, target)


def platform_legs(mech: Mechanism) -> list[Leg]:
    """The legs of a parallel mechanism whose platform carries {E} (see the module
    docstring). Raises NotDecomposable naming a leg that does not decompose."""
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
    return [_leg(mech, end, target, pos) for end, target, pos in ends]


def _nearest(mech: Mechanism, joints: np.ndarray, q: np.ndarray, count: np.ndarray,
             err: np.ndarray, ref: np.ndarray) -> np.ndarray | None:
    """The branch of q (1, nb, k) nearest ref (k,) within the limits (None: none)."""
    m, nb, k = q.shape
    out = np.empty((1, nb, k))
    pe, oe, dist = (np.empty((1, nb)) for _ in range(3))
    n = np.empty(1, dtype=np.int64)
    finish_batch(np.ascontiguousarray(q), count.astype(np.int64), np.ascontiguousarray(err),
                 np.ascontiguousarray(ref[None]), mech.lower[joints].astype(float),
                 mech.upper[joints].astype(float), mech.s[joints] == 0, 1e-8, 1e-8, 1e-3, out,
                 pe, oe, dist, n)
    return out[0, 0] if n[0] > 0 else None


def solve_legs(mech: Mechanism, legs: list[Leg], T_0_E: np.ndarray, q_ref: np.ndarray
               ) -> tuple[np.ndarray, bool]:
    """Every joint (n,) of the mechanism with {E} at T_0_E (4, 4): each leg's solution
    nearest q_ref (n,) (revolute joints at the turn nearest it, within the limits). Returns
    (q, ok); ok is False when a leg has no solution within its limits (q keeps q_ref there)."""
    e = int(mech.end_effector)
    T_0_plat = T_0_E @ np.linalg.inv(mech.frame_offset[e])
    q = np.array(q_ref, dtype=np.float64)
    ok = True
    for leg in legs:
        # the leg's end frame coincides with the platform frame its cut names
        T_end = T_0_plat if leg.platform_frame < 0 else \
            T_0_plat @ mech.frame_offset[leg.platform_frame]
        if leg.kind == "chain":
            b = analytic_batch(mech, leg.chain, T_end[None], q[leg.joints])
            sol = b.q_v[0, 0] if b.count[0] > 0 else None
        elif leg.kind == "planar3":
            qb, cnt, err = scara_branches(leg.H, leg.P, leg.M, -1, T_end[None])
            sol = _nearest(mech, leg.joints, qb, cnt, err, q[leg.joints])
        elif leg.kind == "spherical3":
            qb, cnt, err = spherical3_branches(leg.H, leg.P, leg.M, T_end[None])
            sol = _nearest(mech, leg.joints, qb, cnt, err, q[leg.joints])
        elif leg.kind == "uu":
            qb, cnt, err = uu_leg_branches(leg.H, leg.P, leg.M, leg.o, leg.w, T_end[None])
            sol = _nearest(mech, leg.joints, qb, cnt, err, q[leg.joints])
        else:
            qb, cnt, err = point2r_branches(leg.H, leg.P, leg.M[:3, 3], T_end[None, :3, 3])
            sol = _nearest(mech, leg.joints, qb, cnt, err, q[leg.joints])
        if sol is None:
            ok = False
            continue
        q[leg.joints] = sol
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


def _leg_solutions(mech: Mechanism, leg: Leg, T_end: np.ndarray, ref: np.ndarray
                   ) -> np.ndarray:
    """Every solution (k, n_leg) of one leg within its limits, nearest ref first."""
    if leg.kind == "chain":
        b = analytic_batch(mech, leg.chain, T_end[None], ref)
        return b.q_v[0, :b.count[0]]
    if leg.kind == "planar3":
        qb, cnt, err = scara_branches(leg.H, leg.P, leg.M, -1, T_end[None])
    elif leg.kind == "spherical3":
        qb, cnt, err = spherical3_branches(leg.H, leg.P, leg.M, T_end[None])
    elif leg.kind == "uu":
        qb, cnt, err = uu_leg_branches(leg.H, leg.P, leg.M, leg.o, leg.w, T_end[None])
    else:
        qb, cnt, err = point2r_branches(leg.H, leg.P, leg.M[:3, 3], T_end[None, :3, 3])
    m, nb, k = qb.shape
    out = np.empty((1, nb, k))
    pe, oe, dist = (np.empty((1, nb)) for _ in range(3))
    n = np.empty(1, dtype=np.int64)
    finish_batch(np.ascontiguousarray(qb), cnt.astype(np.int64), np.ascontiguousarray(err),
                 np.ascontiguousarray(ref[None]), mech.lower[leg.joints].astype(float),
                 mech.upper[leg.joints].astype(float), mech.s[leg.joints] == 0, 1e-8, 1e-8,
                 1e-3, out, pe, oe, dist, n)
    return out[0, :n[0]]


def legs_all(mech: Mechanism, legs: list[Leg], T_0_E: np.ndarray, q_ref: np.ndarray
             ) -> np.ndarray:
    """Every configuration (k, n) of the mechanism with {E} at T_0_E: every combination of
    the legs' solutions within their limits (the legs are independent once the platform pose
    is given, so the list is complete). Unverified here: the caller verifies and orders."""
    import itertools

    e = int(mech.end_effector)
    T_0_plat = T_0_E @ np.linalg.inv(mech.frame_offset[e])
    per = []
    for leg in legs:
        T_end = T_0_plat if leg.platform_frame < 0 else \
            T_0_plat @ mech.frame_offset[leg.platform_frame]
        per.append(_leg_solutions(mech, leg, T_end, q_ref[leg.joints]))
    if any(len(p) == 0 for p in per):
        return np.zeros((0, mech.n))
    rows = []
    for combo in itertools.product(*[range(len(p)) for p in per]):
        q = np.array(q_ref, dtype=np.float64)
        for leg, sols, i in zip(legs, per, combo, strict=True):
            q[leg.joints] = sols[i]
        rows.append(q)
    return np.array(rows)
