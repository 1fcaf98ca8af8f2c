"""Options, results and verification of the IK solvers.

:class:`IkOptions` (what a solve is asked), :class:`IkResult` and :class:`IkBatchResult`
(what it returns), :data:`IkStatus`, and the verification of a returned configuration: the
position and orientation errors of {E} recomputed by forward kinematics at the returned joints
(only the components with non-zero weight count towards "reached"), and the status that
follows from them.

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. May import
:mod:`mechkin.solvers.ik.kernel`, :mod:`mechkin.solvers.result`, :mod:`mechkin.model` and
:mod:`mechkin.spatial`; never ``io/``, ``cli/`` or ``tasks/``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from mechkin.solvers.ik.kernel import TOL_PHI, IkKernel, pose_errors
from mechkin.solvers.result import Status
from mechkin.spatial.rotations import rotation_log

Method = Literal["lm", "cg-golden"]

TOL_POS_M = 1e-6  # a target counts as reached below these verified errors
TOL_ORI_RAD = 1e-6
GRAD_TOL = 1e-10

IkStatus = Status  # the statuses of mechkin.solvers.result (ok, not converged, ...)


@dataclass(frozen=True)
class IkOptions:
    """Options of :func:`solve_ik`.

    Attributes
    ----------
    method : {"lm", "cg-golden"}
    grad_tol : float
        Stop when ``||df/dq_v|| < grad_tol`` (kim1995 §5.2 Step 6, epsilon).
    max_iter : int or None
        Iterations of the method (default 100 for lm, 2000 for cg-golden).
    tol_pos, tol_ori : float
        Verified errors [m], [rad] below which a target counts as reached (status ok). Only the
        components with non-zero weight count.
    restarts : int
        Extra solves from seeded random independent joints within the limits when a solve
        does not reach the target; the best one is kept.
    seed : int
        Seed of the restarts.
    tol_phi : float
        Loop-closure tolerance ||phi_R|| (kim1995 §5.1 Step 3).
    line_tol : float
        Golden-section interval length at which the line search stops (cg-golden).
    cg_restart : int or None
        Reset the conjugate direction to -grad every ``cg_restart`` iterations (None: every
        n_v iterations; 0: never, as printed in kim1995 §5.2). A direction that is not a
        descent direction is always reset. Robust variant only.
    lm_grad_tol : float
        lm stops a row when ``||J_r^T W x|| < lm_grad_tol`` (0: off, the default, so default
        solves are unchanged; the task sets it from an explicit ``tolerances.grad``).
    cg_variant : {"robust", "printed"}
        cg-golden only. ``printed``: kim1995 §5.2 as printed (Fletcher-Reeves without
        restarts, Arora's three-phase golden section without a step cap, midpoint of the final
        interval, no passive-limit projection, Step 6 as the only convergence test);
        ``robust`` (default): see :func:`mechkin.solvers.ik.cg_golden.cg_golden`.
    """

    method: Method = "lm"
    grad_tol: float = GRAD_TOL
    max_iter: int | None = None
    tol_pos: float = TOL_POS_M
    tol_ori: float = TOL_ORI_RAD
    restarts: int = 0
    seed: int = 0
    tol_phi: float = TOL_PHI
    line_tol: float = 1e-7
    cg_restart: int | None = None
    cg_variant: Literal["robust", "printed"] = "robust"
    lm_grad_tol: float = 0.0


@dataclass(frozen=True)
class IkResult:
    """Record of one solve (one precision point).

    Attributes
    ----------
    q_v : (n_v,) independent joints [rad | m]; q_w : (n_w,) dependent joints; q : (n,) all.
    status : IkStatus
    position_error : float
        ``||p_E - p_P||`` [m], by forward kinematics at ``q``.
    orientation_error : float
        Rotation angle of ``R_P^T R_E`` [rad], by forward kinematics at ``q``.
    f : float
        Objective (kim1995 Eq. (9)) at exit; ``grad_norm`` its gradient norm (Eq. (10)).
    iterations, evaluations : int
        Iterations of the method and evaluations of f (each one loop closure for closed chains).
    time_s : float
    f_history : (iterations + 1,) f per iteration.
    at_limit : tuple of joint names whose value sits on a limit.
    restarts_used : int
    """

    q_v: np.ndarray
    q_w: np.ndarray
    q: np.ndarray
    status: IkStatus
    position_error: float
    orientation_error: float
    f: float
    grad_norm: float
    iterations: int
    evaluations: int
    time_s: float
    f_history: np.ndarray
    at_limit: tuple[str, ...] = ()
    restarts_used: int = 0
    method: str = "lm"

    @property
    def ok(self) -> bool:
        return self.status is IkStatus.OK


@dataclass(frozen=True)
class IkBatchResult:
    """Records of :func:`solve_ik_batch`, one row per target (shapes (m, ...))."""

    q_v: np.ndarray
    q_w: np.ndarray
    q: np.ndarray
    status: np.ndarray  # (m,) object array of IkStatus
    position_error: np.ndarray
    orientation_error: np.ndarray
    f: np.ndarray
    iterations: np.ndarray
    time_s: float

    @property
    def ok(self) -> np.ndarray:
        return np.array([s is IkStatus.OK for s in self.status], dtype=bool)


# ---- verification -------------------------------------------------------------------------------


def weighted_errors(T_E: np.ndarray, T_P: np.ndarray, w: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Errors of the components that carry weight (zero weight: not determined, not counted)."""
    return pose_and_weighted_errors(T_E, T_P, w)[2:]


def pose_and_weighted_errors(T_E: np.ndarray, T_P: np.ndarray, w: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Position and orientation errors of poses T_E (m, 4, 4) to T_P (m, 4, 4): all components,
    then the weighted components only (w (m, 6)): four (m,) arrays [m, rad, m, rad]."""
    m = T_E.shape[0]
    RPt = np.swapaxes(T_P[:, :3, :3], 1, 2)
    M = RPt @ T_E[:, :3, :]  # R_P^T [R_E | p_E]
    xp = M[:, :, 3] - (RPt @ T_P[:, :3, 3:])[:, :, 0]
    rv = rotation_log(np.ascontiguousarray(M[:, :, :3]).reshape(m, 3, 3))
    pe = np.sqrt((xp * xp).sum(axis=1))
    oe = np.sqrt((rv * rv).sum(axis=1))
    xpw = np.where(w[:, :3] > 0, xp, 0.0)
    rvw = np.where(w[:, 3:] > 0, rv, 0.0)
    return pe, oe, np.sqrt((xpw * xpw).sum(axis=1)), np.sqrt((rvw * rvw).sum(axis=1))


def verify(kern: IkKernel, q: np.ndarray, T_P: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pose of {E} (m, 4, 4) by forward kinematics at q (m, n) and its errors to T_P."""
    T_E = kern.end_effector(kern.kinematics(q))
    pe, oe = pose_errors(T_E, T_P)
    return T_E, pe, oe



def status_of(kern: IkKernel, q: np.ndarray, T_P: np.ndarray, w: np.ndarray, closed: bool,
            converged: bool, opts: IkOptions, grad_norm: float = 0.0
            ) -> tuple[IkStatus, float, float, tuple[str, ...]]:
    """The status of one answer q (n,): :func:`statuses_of` of one row."""
    st, pe, oe, at = statuses_of(kern, q[None], T_P[None], w[None], np.array([closed]),
                                 np.array([converged]), opts, np.array([grad_norm]))
    return st[0], float(pe[0]), float(oe[0]), at[0]


def statuses_of(kern: IkKernel, q: np.ndarray, T_P: np.ndarray, w: np.ndarray,
                closed: np.ndarray, converged: np.ndarray, opts: IkOptions,
                grad_norm: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
    """Statuses of answers q (m, n) to targets T_P (m, 4, 4), the same rule for a lone target,
    a sequence and a batch (issue 24): ``singular`` when the loops do not close; ``ok`` when
    the weighted errors verified by FK are within the tolerances and every passive joint is
    within its limits; else ``at a limit`` when a passive joint is outside its limits, when the
    search is stationary with a joint on a limit (an independent one on its bound, a passive
    one on its limit) or ran out of iterations with a passive joint on its limit; else
    ``unreachable`` (stationary) or ``not converged`` (``singular`` with a gradient over 1e6).
    Returns (m,) statuses, the verified position and orientation errors, and per row the
    joints on a limit."""
    mech = kern.mech
    T_E = kern.pose_check(q)
    pe, oe, wpe, woe = pose_and_weighted_errors(T_E, T_P, w)
    tol_j = 1e-9
    with np.errstate(invalid="ignore"):
        on = (q <= mech.lower + tol_j) | (q >= mech.upper - tol_j)
    out = passive_outside(mech, q)
    iv, iw = kern.iv, mech.dependent
    with np.errstate(invalid="ignore"):
        on_v = ((q[:, iv] <= kern.bound_lo + tol_j) | (q[:, iv] >= kern.bound_hi - tol_j)).any(1)
        on_w = ((q[:, iw] <= mech.lower[iw] + tol_j)
                | (q[:, iw] >= mech.upper[iw] - tol_j)).any(axis=1)
    status = np.empty(q.shape[0], dtype=object)
    at = []
    for k in range(q.shape[0]):
        a = tuple(mech.joint_names[j] for j in np.flatnonzero(on[k]))
        if not closed[k] or not np.all(np.isfinite(q[k])):
            st = IkStatus.SINGULAR
        elif out[k]:  # the loops close outside a passive joint's limits: not an answer
            st = IkStatus.AT_LIMIT
            a = tuple(dict.fromkeys(a + out[k]))
        elif wpe[k] <= opts.tol_pos and woe[k] <= opts.tol_ori:
            st = IkStatus.OK
        elif converged[k]:  # stationary above tolerance: a limit blocks the descent, or not
            st = IkStatus.AT_LIMIT if on_v[k] or on_w[k] else IkStatus.UNREACHABLE
        elif on_w[k]:  # out of iterations crawling along a passive limit
            st = IkStatus.AT_LIMIT
        elif not np.isfinite(grad_norm[k]) or grad_norm[k] > 1e6:
            st = IkStatus.SINGULAR
        else:
            st = IkStatus.NOT_CONVERGED
        status[k] = st
        at.append(a)
    return status, pe, oe, at


def passive_outside(mech, q: np.ndarray, tol: float = 1e-9) -> list[tuple[str, ...]]:
    """Per row of q (m, n): the dependent (passive) joints outside their limits (revolute ones
    after moving by whole turns into them where possible, :func:`mechkin.model.continuation.
    within_limits`)."""
    from mechkin.model.continuation import within_limits

    q = np.atleast_2d(q)
    if mech.dependent.size == 0:
        return [()] * q.shape[0]
    qm, _ = within_limits(mech, q, tol=tol)
    x = qm[:, mech.dependent]
    with np.errstate(invalid="ignore"):
        bad = (x < mech.lower[mech.dependent] - tol) | (x > mech.upper[mech.dependent] + tol)
    names = [mech.joint_names[j] for j in mech.dependent]
    return [tuple(names[j] for j in np.flatnonzero(b)) for b in bad]


def finite(a: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    return np.where(np.isfinite(a), a, fallback)



def better(a: dict, b: dict) -> bool:
    """Whether result fields a beat b: a better status, then a lower f."""
    rank = {IkStatus.OK: 0, IkStatus.AT_LIMIT: 1, IkStatus.UNREACHABLE: 2,
            IkStatus.NOT_CONVERGED: 2, IkStatus.SINGULAR: 3}
    if rank[a["status"]] != rank[b["status"]]:
        return rank[a["status"]] < rank[b["status"]]
    return a["f"] < b["f"]

