r"""Which subproblem decomposition a mechanism admits, read from its joint axes at q = 0.

The serial path to {E} is put in product-of-exponentials form (Murray, Li & Sastry Eq. (3.3)):
joint i's axis ``h_i`` (unit) through ``p_i``, both in the base frame at q = 0, and the end
pose ``M``; for the model's joints ``T_parent_child(q_i) = A_i Z(q_i) B_i`` the joint frame
at q = 0 is ``F_0 = A_0``, ``F_{i+1} = F_i B_i A_{i+1}``, so ``h_i`` is the third column of
``F_i`` and ``p_i`` its origin (:class:`mechkin.model.serial.SerialChain`).

Recognised (IK-Geo §IV; tested on the forward chain, then on the reversed chain
``T^{-1} = M^{-1} e^{-xi_6 q_6} ... e^{-xi_1 q_1}``, whose axes are ``-R_M^T h_{7-i}`` through
``M^{-1} p_{7-i}`` and whose end pose is ``M^{-1}``):

* ``spherical wrist`` (axes 4, 5, 6 meet in a point) with h2 || h3 (``POS_PAR23``) or with
  h1, h2 meeting (``POS_INT12``): PUMA 560, ABB IRB, KUKA KR, Fanuc, Staubli...; with h1 || h2
  (``POS_PAR12``), h2, h3 meeting (``POS_INT23``) or none of these (``POS_GENERAL``, IK-Geo's
  Subproblem 5); reversed: a spherical joint at the base (EAIK's seven spherical classes);
* ``three parallel`` (h2 || h3 || h4, and h5, h6 meeting: the UR family; or h5, h6 skew,
  IK-Geo's Subproblem 6: EAIK's "three inner parallel"); reversed: h3 || h4 || h5;
* ``5R`` (5 revolute joints, h2 || h3 || h4, h1 and h5 not parallel to them;
  :mod:`mechkin.solvers.ik.analytic.arm5r`; or h4 meeting h5 with any position case of the
  spherical-wrist arms for h1..h3: :mod:`mechkin.solvers.ik.analytic.arm5w`);
* ``SCARA`` (4 joints: three revolute and one prismatic, every axis parallel;
  :mod:`mechkin.solvers.ik.analytic.scara`; ``pos_kind`` is the prismatic joint's place);
* prismatic joints among the first three, with a spherical wrist: R-R-P with h1 meeting h2
  (a Stanford arm, a U-P-S leg), P-P-P (gantry), R-P-P (cylindrical), P-R-R with h2, h3
  meeting or parallel;
* only with ``search`` (``method: analytic``): any other 6R whose h5 meets h6 (e.g. two
  intersecting pairs, h1 meeting h2 and h5 meeting h6), or reversed h1 meets h2: IK-Geo's
  1-D search (:mod:`mechkin.solvers.ik.analytic.search1d`; ``complete`` False) when it
  solves four seeded poses (Subproblem 5 degenerates on some axes, e.g. the Kinova Jaco's).

Anything else (an offset wrist such as the Kinova Jaco's, other prismatic joints,
other joint counts, a closed chain) raises :class:`NotDecomposable` naming the axes that break it.

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy, :mod:`mechkin.model`; the 1-D search
class is accepted only after its compiled search solves four seeded poses.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mechkin.errors import ModelError
from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.analytic.arm5w import WRIST5_BASE, virtual_six
from mechkin.solvers.ik.analytic.search1d import SEARCH_INT56
from mechkin.solvers.ik.analytic.solve6r import (
    KIND_ARM5,
    KIND_PAR234,
    KIND_SCARA,
    KIND_SEARCH,
    KIND_SPHERICAL,
    PAR_GENERAL,
    PAR_MEET56,
    POS_GENERAL,
    POS_INT12,
    POS_INT12_P,
    POS_INT23,
    POS_PAR12,
    POS_PAR23,
    POS_PPP,
    POS_PRR_INT,
    POS_PRR_PAR,
    POS_RPP,
)

PAR_TOL = 1e-9  # |h_i x h_j| below which two axes are parallel
MEET_TOL = 1e-9  # [m] (relative to the arm's size, at least 1 m) distance of meeting lines


class NotDecomposable(ModelError):
    """The mechanism does not decompose into the recognised subproblems (the message names
    the joints and axes that break it)."""


@dataclass(frozen=True, eq=False)
class AnalyticChain:
    """A 6R serial chain in the form its subproblem solver takes.

    Attributes
    ----------
    kind, pos_kind : int
        Solver (``KIND_SPHERICAL``, ``KIND_PAR234``) and position sub-case.
    reversed : bool
        Solved as the reversed chain (targets inverted, joint order reversed).
    H, P : (6, 3)
        Axes and points of the (possibly reversed) chain at q = 0; M (4, 4) its end pose.
    Hf, Pf, Mf : (6, 3), (6, 3), (4, 4)
        The forward chain (equal to H, P, M unless reversed): FK for verification.
    point, point2 : (3,)
        Wrist centre (spherical) or o56 (three parallel); o12 (``POS_INT12``).
    joints : (6,) int
        Model joint index of each chain joint (base first, forward order).
    order : (6,) int
        Column of q_v holding each chain joint (``q_v[order] = q_chain``).
    description : str
    packed : (131,)
        Every constant above with the limits in chain order, packed for the compiled
        :func:`mechkin.solvers.ik.analytic.finish.solve_finish`.
    identity : bool
        ``order`` is 0..5 (q_v is in chain order).
    limits : ((n_v,), (n_v,))
        Lower and upper limits of the independent joints (q_v order).
    all_joints : bool
        The independent joints are every joint of the mechanism, in order (q is q_v).
    fixed_cols, fixed_values : (k,)
        Columns of q_v held (``fixed``) and their values.
    complete : bool
        The solver's list is proved to be every solution (False for the 1-D search).
    """

    kind: int
    pos_kind: int
    reversed: bool
    H: np.ndarray
    P: np.ndarray
    M: np.ndarray
    Hf: np.ndarray
    Pf: np.ndarray
    Mf: np.ndarray
    point: np.ndarray
    point2: np.ndarray
    joints: np.ndarray
    order: np.ndarray
    description: str
    packed: np.ndarray
    identity: bool
    limits: tuple[np.ndarray, np.ndarray]
    limits_list: tuple[list[float], list[float]]
    all_joints: bool = False
    fixed_cols: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    fixed_values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    complete: bool = True


def zero_config(mech: Mechanism, frame: int, fixed: dict[int, float] | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(joints (k,), H (k, 3), P (k, 3), M (4, 4)) of the serial path to ``frame`` at q = 0;
    ``fixed`` {joint index: value} joints are held at their value and folded into the
    constant transforms (they are not among the k joints)."""
    from mechkin.model.kinematics import _ZC, _ZD, _ZK, _ZS
    from mechkin.model.serial import SerialChain

    fixed = fixed or {}
    ch = SerialChain(mech, frame)
    F = ch.A0.copy()
    H, P, J = [], [], []
    for i, j in enumerate(ch.joints):
        if int(j) in fixed:
            v = float(fixed[int(j)])
            Z = (_ZC * np.cos(v) + _ZS * np.sin(v) + _ZK if mech.s[j] == 0
                 else np.eye(4) + _ZD * v)
            F = F @ Z @ ch.C[i]
            continue
        H.append(F[:3, 2] / np.linalg.norm(F[:3, 2]))
        P.append(F[:3, 3].copy())
        J.append(int(j))
        F = F @ ch.C[i]
    return np.array(J, dtype=int), np.array(H).reshape(-1, 3), np.array(P).reshape(-1, 3), F


def _parallel(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.linalg.norm(np.cross(a, b)) < PAR_TOL)


def _meet(h1: np.ndarray, p1: np.ndarray, h2: np.ndarray, p2: np.ndarray, tol: float
          ) -> np.ndarray | None:
    """The point where two non-parallel lines meet (midpoint of the closest points), or None
    when they miss by more than tol (or are parallel)."""
    n = np.cross(h1, h2)
    nn = float(n @ n)
    if nn < PAR_TOL**2:
        return None
    d = p2 - p1
    if abs(float(d @ n)) / np.sqrt(nn) > tol:
        return None
    t1 = float(np.cross(d, h2) @ n) / nn
    t2 = float(np.cross(d, h1) @ n) / nn
    return 0.5 * ((p1 + t1 * h1) + (p2 + t2 * h2))


def _try(H: np.ndarray, P: np.ndarray, tol: float) -> tuple[int, int, np.ndarray, np.ndarray,
                                                            str] | None:
    """The decomposition of the chain (H, P), or None."""
    c45 = _meet(H[3], P[3], H[4], P[4], tol)
    if c45 is not None and _meet(H[4], P[4], H[5], P[5], tol) is not None and \
            np.linalg.norm(np.cross(H[5], c45 - P[5])) < tol and not _parallel(H[3], H[4]) \
            and not _parallel(H[4], H[5]):
        if _parallel(H[1], H[2]) and not _parallel(H[0], H[1]):
            return KIND_SPHERICAL, POS_PAR23, c45, c45, "spherical wrist, h2 || h3"
        o12 = _meet(H[0], P[0], H[1], P[1], tol)
        if o12 is not None:
            return KIND_SPHERICAL, POS_INT12, c45, o12, "spherical wrist, h1 meets h2"
        if _parallel(H[0], H[1]) and not _parallel(H[1], H[2]):
            return KIND_SPHERICAL, POS_PAR12, c45, c45, "spherical wrist, h1 || h2"
        o23 = _meet(H[1], P[1], H[2], P[2], tol)
        if o23 is not None:
            return KIND_SPHERICAL, POS_INT23, c45, o23, "spherical wrist, h2 meets h3"
        if not _parallel(H[0], H[1]) and not _parallel(H[1], H[2]):
            return (KIND_SPHERICAL, POS_GENERAL, c45, c45,
                    "spherical wrist, h1..h3 neither parallel nor meeting (Subproblem 5)")
    if _parallel(H[1], H[2]) and _parallel(H[2], H[3]) and not _parallel(H[0], H[1]) \
            and not _parallel(H[4], H[1]):
        o56 = _meet(H[4], P[4], H[5], P[5], tol)
        if o56 is not None:
            return (KIND_PAR234, PAR_MEET56, o56, o56,
                    "three parallel axes h2 || h3 || h4, h5 meets h6")
        if not _parallel(H[4], H[5]):
            return (KIND_PAR234, PAR_GENERAL, P[5].copy(), P[5].copy(),
                    "three parallel axes h2 || h3 || h4, h5 and h6 skew (Subproblem 6)")
    return None


def _search_works(H: np.ndarray, P: np.ndarray, M: np.ndarray, o: np.ndarray) -> bool:
    """Whether the 1-D search finds the generating joints of 4 seeded random poses (Subproblem
    5 has degenerate geometries, e.g. the Kinova Jaco's axes, where it finds nothing)."""
    from mechkin.solvers.ik.analytic.search1d import N_SAMPLES, search_int56

    rng = np.random.default_rng(0)
    out = np.empty((16, 6))
    for q in rng.uniform(-np.pi, np.pi, (4, 6)):
        T = np.eye(4)
        for h, p, t in zip(H, P, q, strict=True):
            K = np.array([[0, -h[2], h[1]], [h[2], 0, -h[0]], [-h[1], h[0], 0]])
            R = np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K
            E = np.eye(4)
            E[:3, :3], E[:3, 3] = R, p - R @ p
            T = T @ E
        T = T @ M
        n = search_int56(H, P, M, o, T, np.zeros(6), N_SAMPLES, out)
        d = (out[:n] - q + np.pi) % (2 * np.pi) - np.pi
        if n == 0 or np.abs(d).max(axis=1).min() > 1e-6:
            return False
    return True


def _try_search(H: np.ndarray, P: np.ndarray, M: np.ndarray, tol: float
                ) -> tuple[int, int, np.ndarray, np.ndarray, str] | None:
    """h5 meets h6 and no two of h1..h3 parallel (no closed form): IK-Geo's 1-D search over
    q4 (:mod:`mechkin.solvers.ik.analytic.search1d`), or None."""
    o56 = _meet(H[4], P[4], H[5], P[5], tol)
    if o56 is None or _parallel(H[0], H[1]) or _parallel(H[1], H[2]):
        return None  # Subproblem 5 in (q1, q2, q3) takes no two parallel axes
    if not _search_works(H, P, M, o56):
        return None
    pairs = [f"h{i + 1} meets h{i + 2}" for i in range(3)
             if _meet(H[i], P[i], H[i + 1], P[i + 1], tol) is not None]
    what = ("two intersecting pairs, " + pairs[0] + ", h5 meets h6") if pairs else \
        "h5 meets h6"
    return (KIND_SEARCH, SEARCH_INT56, o56, o56,
            what + " (1-D search over q4, IK-Geo IK_2_intersecting; not proved complete)")


def _try_prismatic(H: np.ndarray, P: np.ndarray, s3: tuple[int, int, int], tol: float
                   ) -> tuple[int, int, np.ndarray, np.ndarray, str] | None:
    """A chain with prismatic joints among the first three and a spherical wrist (axes 4-6
    revolute, meeting), by the pattern of joints 1-3 (1: prismatic), or None."""
    c45 = _meet(H[3], P[3], H[4], P[4], tol)
    if c45 is None or _meet(H[4], P[4], H[5], P[5], tol) is None or \
            np.linalg.norm(np.cross(H[5], c45 - P[5])) >= tol or _parallel(H[3], H[4]) or \
            _parallel(H[4], H[5]):
        return None
    if s3 == (0, 0, 1):
        o12 = _meet(H[0], P[0], H[1], P[1], tol)
        if o12 is not None:
            return (KIND_SPHERICAL, POS_INT12_P, c45, o12,
                    "U-P-S: h1 meets h2, prismatic, spherical")
    elif s3 == (1, 1, 1):
        if abs(float(np.linalg.det(H[:3]))) > PAR_TOL:
            return KIND_SPHERICAL, POS_PPP, c45, c45, "P-P-P (gantry), spherical wrist"
    elif s3 == (0, 1, 1):
        nn = np.cross(H[1], H[2])
        if np.linalg.norm(nn) > PAR_TOL and not _parallel(H[0], nn / np.linalg.norm(nn)):
            return KIND_SPHERICAL, POS_RPP, c45, c45, "R-P-P (cylindrical), spherical wrist"
    elif s3 == (1, 0, 0):
        o23 = _meet(H[1], P[1], H[2], P[2], tol)
        if o23 is not None:
            return KIND_SPHERICAL, POS_PRR_INT, c45, o23, "P-R-R, h2 meets h3, spherical wrist"
        if _parallel(H[1], H[2]) and abs(float(H[0] @ H[1])) > PAR_TOL:
            return KIND_SPHERICAL, POS_PRR_PAR, c45, c45, "P-R-R, h2 || h3, spherical wrist"
    return None


def _common_miss(H: np.ndarray, P: np.ndarray) -> float:
    """How far three lines (h_i, p_i) are from sharing a point [m]: the largest distance from
    the least-squares point to the lines (parallel lines: the pairwise distance)."""
    A = sum(np.eye(3) - np.outer(h, h) for h in H)
    b = sum((np.eye(3) - np.outer(h, h)) @ p for h, p in zip(H, P, strict=True))
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    return float(max(np.linalg.norm(np.cross(x - p, h)) for h, p in zip(H, P, strict=True)))


def _why(names: list[str], H: np.ndarray, P: np.ndarray) -> str:
    """One line naming what keeps the chain from decomposing."""
    j = names
    w = _common_miss(H[3:6], P[3:6])
    b = _common_miss(H[0:3], P[0:3])
    return (f"no subproblem decomposition: the axes of {j[3]}, {j[4]}, {j[5]} miss a common "
            f"point by {w:.4g} m (no spherical wrist), those of {j[0]}, {j[1]}, {j[2]} by "
            f"{b:.4g} m (none at the base), and neither {j[1]}, {j[2]}, {j[3]} nor "
            f"{j[2]}, {j[3]}, {j[4]} are three parallel axes")


def classify(mech: Mechanism, frame: int | None = None,
             fixed: dict[int, float] | None = None, check_independent: bool = True,
             search: bool = False) -> AnalyticChain:
    """The subproblem decomposition of ``mech``'s serial path to ``frame`` (default {E}),
    with the ``fixed`` {joint index: value} joints held (e.g. a 7R arm's redundant joint: the
    remaining 6R is solved; kim1995's q_v minus the fixed joints). ``search``: a 6R chain
    without a closed form whose h5 meets h6 (or h1 meets h2, reversed) is taken by the 1-D
    search (``KIND_SEARCH``, ``complete`` False).

    Raises
    ------
    NotDecomposable
        Closed chains, independent joints other than the 6 revolute joints of the path, or
        axes that fit none of the recognised structures (the message says which).
    """
    frame = mech.end_effector if frame is None else frame
    if frame is None:
        raise NotDecomposable(f"mechanism {mech.name} has no end_effector frame")
    if mech.cuts and check_independent:
        raise NotDecomposable(f"mechanism {mech.name} is a closed chain (cuts "
                              f"{', '.join(c.name for c in mech.cuts)}): no serial "
                              "decomposition")
    fixed = fixed or {}
    joints, H, P, M = zero_config(mech, frame, fixed)
    names = [mech.joint_names[i] for i in joints]
    iv = list(mech.independent) if check_independent else [int(j) for j in joints]
    if sorted(j for j in iv if j not in fixed) != sorted(int(j) for j in joints):
        raise NotDecomposable(f"the independent joints ({', '.join(mech.independent_names)}) "
                              f"are not the serial path to {mech.frame_names[frame]} "
                              f"({', '.join(names)})")
    pris = [n for n, j in zip(names, joints, strict=True) if mech.s[j] == 1]
    if len(joints) == 4:
        return _scara(mech, joints, names, H, P, M, pris)
    if len(joints) == 5 and not pris:
        return _arm5(mech, joints, names, H, P, M)
    if len(joints) != 6:
        raise NotDecomposable(f"{len(joints)} joints on the path to "
                              f"{mech.frame_names[frame]} ({', '.join(names)}); the "
                              "subproblem solvers take 6R chains, 5R arms and 4-DOF SCARA "
                              "arms")
    size = max(1.0, float(np.abs(P).max()), float(np.abs(M[:3, 3]).max()))
    tol = MEET_TOL * size
    order = np.array([iv.index(int(j)) if int(j) in iv else k for k, j in enumerate(joints)])
    Hf, Pf, Mf = (np.ascontiguousarray(a) for a in (H, P, M))
    if pris:
        s3 = tuple(int(mech.s[j]) for j in joints[:3])
        found = None if any(mech.s[j] for j in joints[3:]) else \
            _try_prismatic(H, P, s3, tol)  # type: ignore[arg-type]
        if found is None:
            raise NotDecomposable(
                f"prismatic joint(s) {', '.join(pris)}: with prismatic joints the subproblem "
                "solvers take a spherical wrist (joints 4-6 revolute, axes meeting) after "
                "R-R-P with h1 meeting h2, P-P-P, R-P-P, or P-R-R with h2, h3 meeting or "
                "parallel")
    else:
        found = _try(H, P, tol)
    rev = False
    if found is None and not pris:
        Mi = np.linalg.inv(M)
        Hr = -(M[:3, :3].T @ H[::-1].T).T
        Pr = (Mi[:3, :3] @ P[::-1].T).T + Mi[:3, 3]
        found = _try(Hr, Pr, tol)
        if found is not None:
            rev, H, P, M = True, Hr, Pr, Mi
        if found is None and search:
            found = _try_search(H, P, M, tol)
            if found is None:
                found = _try_search(Hr, Pr, Mi, tol)
                if found is not None:
                    rev, H, P, M = True, Hr, Pr, Mi
    if found is None:
        held = "".join(f" ({mech.joint_names[j]} held)" for j in fixed)
        raise NotDecomposable(_why(names, Hf, Pf) + held)
    kind, pos, pt, pt2, desc = found
    if fixed:
        desc += ", " + ", ".join(f"{mech.joint_names[j]} held at {v:.6g}"
                                 for j, v in fixed.items())
    jj = np.asarray(joints)
    packed = np.concatenate([[kind, pos, float(rev)], np.ravel(H), np.ravel(P), np.ravel(M),
                             pt, pt2, np.ravel(Hf), np.ravel(Pf), np.ravel(Mf), mech.lower[jj],
                             mech.upper[jj], (mech.s[jj] == 0).astype(float)]).astype(float)
    return AnalyticChain(kind=kind, pos_kind=pos, reversed=rev,
                         H=np.ascontiguousarray(H), P=np.ascontiguousarray(P),
                         M=np.ascontiguousarray(M), Hf=Hf, Pf=Pf, Mf=Mf,
                         point=np.asarray(pt, float),
                         point2=np.asarray(pt2, float), joints=np.asarray(joints),
                         order=order, packed=np.ascontiguousarray(packed),
                         identity=bool(np.array_equal(order, np.arange(len(iv)))),
                         all_joints=bool(np.array_equal(mech.independent, np.arange(mech.n))),
                         fixed_cols=np.array([iv.index(j) for j in fixed], dtype=int),
                         fixed_values=np.array([fixed[j] for j in fixed], dtype=float),
                         limits=(mech.lower[iv].copy(), mech.upper[iv].copy()),
                         limits_list=(mech.lower[iv].tolist(), mech.upper[iv].tolist()),
                         complete=kind != KIND_SEARCH,
                         description=desc + (" (reversed chain: at the base)" if rev else ""))


def _scara(mech: Mechanism, joints: np.ndarray, names: list[str], H: np.ndarray,
           P: np.ndarray, M: np.ndarray, pris: list[str]) -> AnalyticChain:
    """A 4-DOF SCARA: one prismatic joint, every axis parallel (else NotDecomposable)."""
    if len(pris) != 1:
        raise NotDecomposable(f"4 joints ({', '.join(names)}): a SCARA needs exactly one "
                              f"prismatic joint, got {len(pris)}")
    bad = [n for n, h in zip(names, H, strict=True) if not _parallel(h, H[0])]
    if bad:
        raise NotDecomposable(f"4 joints: the axes of {', '.join(bad)} are not parallel to "
                              f"that of {names[0]} (a SCARA has all four parallel)")
    iv = list(mech.independent)
    order = np.array([iv.index(int(j)) for j in joints])
    k = int(np.flatnonzero(mech.s[joints] == 1)[0])
    H, P, M = (np.ascontiguousarray(a) for a in (H, P, M))
    return AnalyticChain(kind=KIND_SCARA, pos_kind=k, reversed=False, H=H, P=P, M=M, Hf=H,
                         Pf=P, Mf=M, point=np.zeros(3), point2=np.zeros(3),
                         joints=np.asarray(joints), order=order,
                         description="SCARA: parallel axes, one prismatic joint",
                         packed=np.zeros(0), identity=bool(np.array_equal(order, np.arange(4))),
                         limits=(mech.lower[iv].copy(), mech.upper[iv].copy()),
                         limits_list=(mech.lower[iv].tolist(), mech.upper[iv].tolist()))


def _arm5(mech: Mechanism, joints: np.ndarray, names: list[str], H: np.ndarray,
          P: np.ndarray, M: np.ndarray) -> AnalyticChain:
    """A 5R arm with h2 || h3 || h4 and h1, h5 not parallel to them, or with h4 meeting h5 and
    a position case for the first three axes (:mod:`mechkin.solvers.ik.analytic.arm5w`), else
    NotDecomposable."""
    iv = list(mech.independent)
    order = np.array([iv.index(int(j)) for j in joints])
    H, P, M = (np.ascontiguousarray(a) for a in (H, P, M))
    pos, pt, pt2 = -1, np.zeros(3), np.zeros(3)
    desc = "5R: three parallel axes h2 || h3 || h4"
    if not (_parallel(H[1], H[2]) and _parallel(H[2], H[3])) or _parallel(H[0], H[1]) or \
            _parallel(H[4], H[1]):
        size = max(1.0, float(np.abs(P).max()), float(np.abs(M[:3, 3]).max()))
        w = _meet(H[3], P[3], H[4], P[4], MEET_TOL * size)
        found = None
        if w is not None:
            H6, P6 = virtual_six(H, P, w)
            found = _try(H6, P6, MEET_TOL * size)
        if found is None or found[0] != KIND_SPHERICAL:
            raise NotDecomposable(
                f"5 joints ({', '.join(names)}): the 5R solvers need the axes of {names[1]}, "
                f"{names[2]}, {names[3]} parallel (those of {names[0]}, {names[4]} not), or "
                f"those of {names[3]}, {names[4]} meeting with a position case for "
                f"{names[0]}..{names[2]}")
        pos, pt, pt2 = WRIST5_BASE + found[1], w, found[3]
        desc = "5R: h4 meets h5 (two-axis wrist), " + found[4].replace("spherical wrist, ", "")
    return AnalyticChain(kind=KIND_ARM5, pos_kind=pos, reversed=False, H=H, P=P, M=M, Hf=H,
                         Pf=P, Mf=M, point=np.asarray(pt, float), point2=np.asarray(pt2, float),
                         joints=np.asarray(joints), order=order, description=desc,
                         packed=np.zeros(0), identity=bool(np.array_equal(order, np.arange(5))),
                         limits=(mech.lower[iv].copy(), mech.upper[iv].copy()),
                         limits_list=(mech.lower[iv].tolist(), mech.upper[iv].tolist()))


def analytic_chain(mech: Mechanism, search: bool = False) -> AnalyticChain | None:
    """:func:`classify` of {E}'s path, cached on the Mechanism; None when it does not
    decompose (``search``: also the 1-D search classes, ``method: analytic`` only)."""
    key = "_search_chain" if search else "_analytic_chain"
    cache = mech.__dict__.get(key, ())
    if cache == ():
        try:
            cache = classify(mech, search=search)
        except NotDecomposable:
            cache = None
        object.__setattr__(mech, key, cache)
    return cache


def held_chain(mech: Mechanism, fixed: dict[str, float]) -> AnalyticChain:
    """:func:`classify` with the joints named in ``fixed`` held at their values [rad | m]
    (cached on the Mechanism per set of values). Raises NotDecomposable (also for a name that
    is not an independent joint, or a value outside its limits)."""
    idx = {}
    for name, v in fixed.items():
        if name not in mech.independent_names:
            raise NotDecomposable(f"fixed: {name!r} is not an independent joint of {mech.name} "
                                  f"({', '.join(mech.independent_names)})")
        j = mech.joint_index(name)
        if not mech.lower[j] - 1e-12 <= v <= mech.upper[j] + 1e-12:
            raise NotDecomposable(f"fixed: {name} = {v:.6g} is outside its limits "
                                  f"[{mech.lower[j]:.6g}, {mech.upper[j]:.6g}]")
        idx[j] = float(v)
    cache = mech.__dict__.setdefault("_held_chains", {})
    key = tuple(sorted(idx.items()))
    if key not in cache:
        if len(cache) > 256:
            cache.clear()
        cache[key] = classify(mech, fixed=idx)
    return cache[key]
