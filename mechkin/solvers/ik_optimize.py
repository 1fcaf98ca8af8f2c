r"""Inverse kinematics of complex chains by optimisation (kim1995 §3-§5).

The end-effector frame {E} is driven onto a precision point {P} by searching the independent
joints q_v; the dependent joints q_w follow from the loop closure phi_R(q_v, q_w) = 0 (kim1995
Eq. (4)-(6)). The objective is (kim1995 Eq. (7)-(9))

.. math:: x = ({}^P p_E^T\; {}^P e_E^T)^T,\qquad f(q_v) = \tfrac12 x^T W x

and its gradient follows from the chain rule (kim1995 Eq. (10)) with the sensitivity of the
dependent joints

.. math:: \frac{\partial q}{\partial q_v} = L_v + L_w \frac{\partial q_w}{\partial q_v},\qquad
          \frac{\partial q_w}{\partial q_v} = -\Big[\frac{\partial\phi_R}{\partial q_w}\Big]^+
          \frac{\partial\phi_R}{\partial q_v}.

Two methods share that objective:

* ``cg-golden``: kim1995 §5.2 as printed: Fletcher-Reeves conjugate gradient, golden-section line
  search with bracketing (Arora 1989), every function evaluation running the §5.1 loop closure
  warm-started from the current dependent joints.
* ``lm``: damped Gauss-Newton (Levenberg-Marquardt) on the reduced Jacobian
  ``J_r = dx/dq_v`` of the same residual; the default. :func:`solve_ik_batch` runs it on many
  targets at once, vectorized across targets.

Joint limits and leg strokes of the independent joints are respected by projection (clamping
q_v after every step and every line-search trial). Every result carries the position and
orientation error of {E} recomputed by forward kinematics at the returned joints.

The kinematics (forward kinematics, the residual Jacobian, the loop closure) are those of
:mod:`mechkin.model`; :class:`IkKernel` only holds the per-mechanism constants of the objective.

References
----------
kim1995_complex_chain_ik §3-§5, Eq. (4)-(10); §5.1 (loop closure) and §5.2 (inverse kinematics).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import (
    Kinematics,
    closure_jacobian,
    forward_kinematics,
    relative_jacobians,
    relative_residual,
    rotation_vector,
)
from mechkin.model.mechanism import Mechanism
from mechkin.model.serial import SerialChain
from mechkin.solvers.accel import compiled_lm_available
from mechkin.solvers.result import Status
from mechkin.spatial.rotations import quat_from_matrix, rotation_log

log = logging.getLogger(__name__)

Method = Literal["lm", "cg-golden"]

TOL_POS_M = 1e-6  # a target counts as reached below these verified errors
TOL_ORI_RAD = 1e-6
GRAD_TOL = 1e-10
MAX_ITER_LM = 100
LM_MU = 1e-9  # isotropic part of the damping: keeps steps small along unweighted directions
SEED_CODEBOOK = 8192  # configurations searched for the start of a solve without a guess
SEED_RESTARTS = 8  # restarts that start from the next-nearest codebook poses
STALL_WINDOW = 12  # lm with restarts: a row that has not halved E in this many steps restarts
MAX_ITER_CG = 2000
TOL_PHI = 1e-12  # loop closure ||phi_R||, kim1995 §5.1 epsilon_v
MAX_ITER_CLOSURE = 30
TOL_DQ_CLOSURE = 1e-10  # ||dq_w|| of the last Newton step (kim1995 §5.1 epsilon_w)
ACTIVE_BAND = 1e-3  # cg-golden: a passive joint this close to a limit (share of range) is active
PASSIVE_BAND = 1e-3  # lm: a trial may cross a passive limit by this share of its range
GOLDEN = 0.5 * (np.sqrt(5.0) - 1.0)  # 0.618...


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
        descent direction is always reset.
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


# ---- kinematics kernel -------------------------------------------------------------------------


class IkKernel:
    """Per-mechanism constants of the IK objective; the kinematics are the model's.

    Parameters
    ----------
    mech : Mechanism
    frame : int or None
        The end-effector frame {E} (default ``mech.end_effector``).
    """

    def __init__(self, mech: Mechanism, frame: int | None = None) -> None:
        self.mech = mech
        f = mech.end_effector if frame is None else frame
        if f is None:
            raise ValueError("the mechanism has no end_effector frame; give frame=")
        self.frame = int(f)
        self.fb = np.array([self.frame])
        self.n = mech.n
        self.iv = np.asarray(mech.independent, dtype=int)
        self.iw = np.asarray(mech.dependent, dtype=int)
        self.n_cuts = len(mech.cuts)
        self.lower_v = mech.lower[self.iv]
        self.upper_v = mech.upper[self.iv]
        # a revolute joint whose range spans a full turn is continuous: wrap, do not clamp
        self.cont_v = (mech.s[self.iv] == 0) & (self.upper_v - self.lower_v >= 2 * np.pi - 1e-9)
        self.bound_lo = np.where(self.cont_v, -np.inf, self.lower_v)
        self.bound_hi = np.where(self.cont_v, np.inf, self.upper_v)

    @property
    def lo_w(self) -> np.ndarray:
        return self.mech.lower[self.iw]

    @property
    def hi_w(self) -> np.ndarray:
        return self.mech.upper[self.iw]

    @property
    def range_w(self) -> np.ndarray:
        return np.minimum(self.hi_w - self.lo_w, 2 * np.pi)

    @property
    def passive_bounded(self) -> bool:
        """Whether any dependent joint has a limit narrower than a full turn."""
        return bool(self.iw.size and np.any(self.range_w < 2 * np.pi - 1e-9))

    @property
    def chain(self) -> SerialChain:
        """The serial path to {E} (open chains; built on first use)."""
        ch = self.__dict__.get("_chain")
        if ch is None:
            ch = self.__dict__["_chain"] = SerialChain(self.mech, self.frame)
        return ch

    @property
    def chain_cols(self) -> np.ndarray | None:
        """Positions of the chain's joints in q_v (None when the chain is q_v, in order)."""
        if "_chain_cols" not in self.__dict__:
            pos = {int(j): i for i, j in enumerate(self.iv)}
            cols = np.array([pos[int(j)] for j in self.chain.joints], dtype=int)
            self.__dict__["_chain_cols"] = (None if np.array_equal(cols, np.arange(self.iv.size))
                                            else cols)
        return self.__dict__["_chain_cols"]

    def pose_check(self, q: np.ndarray) -> np.ndarray:
        """Pose of {E} (m, 4, 4) at joints q (m, n) by forward kinematics, for verification:
        the serial path's product for open chains (tested equal to the general tree
        kinematics), the general tree kinematics for closed ones."""
        if self.n_cuts == 0:
            return self.chain.pose(q[:, self.chain.joints])
        return self.end_effector(self.kinematics(q))

    def project(self, q_v: np.ndarray) -> np.ndarray:
        """Project independent joints (..., n_v) onto the limits (continuous joints wrapped)."""
        q = np.clip(q_v, self.bound_lo, self.bound_hi)
        if self.cont_v.any():
            lo = self.lower_v
            q = np.where(self.cont_v, lo + np.mod(q - lo, 2 * np.pi), q)
        return q

    def seed_starts(self, T_P: np.ndarray, w: np.ndarray, ranks=(0,),
                    size: int = SEED_CODEBOOK) -> np.ndarray | None:
        """Initial independent joints (m, len(ranks), n_v) for targets T_P (m, 4, 4): the
        nearest poses of a seeded codebook of random configurations within the limits (open
        chains only; None for closed chains).

        Distance: position error [m] plus 0.5 m per unit of ``||R_P - R||_F`` (about 0.7 m per
        radian for small angles), each counted only where ``w`` weights it, so far targets
        start in the right region and LM needs few steps. ``ranks`` picks which neighbours
        (0 = the nearest; restarts take the next ones).
        """
        if self.n_cuts or self.iw.size:
            return None
        ranks = np.asarray(ranks, dtype=int)
        m = T_P.shape[0]
        wp = (w[:, :3] > 0).any(axis=1)  # (m,)
        wo = (w[:, 3:] > 0).any(axis=1)
        out = np.empty((m, ranks.size, self.iv.size))
        # features: position [m] and 0.5 m per unit of ||R_t - R||_F (= 2 sqrt(2) sin(theta/2))
        feats = np.empty((m, 12))
        feats[:, :3] = T_P[:, :3, 3]
        feats[:, 3:] = 0.5 * T_P[:, :3, :3].reshape(m, 9)
        modes = wp.astype(int) * 2 + wo.astype(int)
        for mode in (modes[0],) if m == 1 else np.unique(modes):
            rows = slice(None) if m == 1 else np.flatnonzero(modes == mode)
            cols = tuple(([0, 1, 2] if mode & 2 else []) + (list(range(3, 12)) if mode & 1
                                                            else []))
            if not cols:
                out[rows] = self._codebook(size)[0][ranks]
                continue
            qs, tree = self._codebook(size, cols)
            # approximate search (eps = 1: within twice the nearest distance) is as good a
            # start and 5x faster on large batches
            _, nearest = tree.query(feats[rows][:, cols], k=int(ranks.max()) + 1, eps=1.0,
                                    workers=-1 if m >= 256 else 1)
            out[rows] = qs[nearest.reshape(len(feats[rows]), -1)[:, ranks]]
        return out

    def _codebook(self, size: int, cols: tuple[int, ...] = tuple(range(12))):
        """Seeded random configurations within the limits and a KD-tree of their poses."""
        from scipy.spatial import cKDTree

        cache = self.__dict__.setdefault("_codebooks", {})
        hit = cache.get((size, cols))
        if hit is None:
            rng = np.random.default_rng(12345)
            lo = np.where(np.isfinite(self.lower_v), self.lower_v, -np.pi)
            hi = np.where(np.isfinite(self.upper_v), self.upper_v, np.pi)
            qs = rng.uniform(lo, hi, size=(size, self.iv.size))
            q = np.zeros((size, self.n))
            q[:, self.iv] = qs
            T = self.end_effector(self.kinematics(q))
            feats = np.concatenate([T[:, :3, 3], 0.5 * T[:, :3, :3].reshape(size, 9)], axis=1)
            hit = (qs, cKDTree(feats[:, list(cols)]))
            cache[(size, cols)] = hit
        return hit

    def kinematics(self, q: np.ndarray) -> Kinematics:
        """Forward kinematics of configurations q (m, n) (mechkin.model)."""
        return forward_kinematics(self.mech, q)

    def end_effector(self, kin: Kinematics) -> np.ndarray:
        """Pose of {E} (m, 4, 4)."""
        return kin.frames(self.mech, self.fb)[:, 0]

    def residual_jacobian(self, kin: Kinematics, T_P: np.ndarray, rotation: str = "euler"
                          ) -> tuple[np.ndarray, np.ndarray]:
        """x (m, 6) of {E} relative to {P} (kim1995 Eq. (7)-(8)) and dx/dq (m, 6, n).

        ``rotation="log"``: the orientation part is the rotation vector (for lm)."""
        x, J = relative_jacobians(self.mech, kin, None, self.fb, T_P[:, None],
                                  rotation=rotation)
        return x[:, 0], J[:, 0]

    def residual(self, kin: Kinematics, T_P: np.ndarray, rotation: str = "euler") -> np.ndarray:
        """x (m, 6) of {E} relative to {P} (kim1995 Eq. (8)); rotation vector if "log"."""
        x = relative_residual(T_P, self.end_effector(kin))
        if rotation == "log":
            e0 = np.sqrt(np.maximum(1.0 - np.sum(x[:, 3:] ** 2, axis=1), 0.0))
            x[:, 3:] = rotation_vector(np.concatenate([e0[:, None], x[:, 3:]], axis=1))
        return x


def _lstsq_steps(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A^+ b for stacks A (m, k, p) with full column rank, b (m, k, r) (kim1995 §5.1:
    [A]^+ = [A^T A]^{-1} A^T; a square A is solved directly)."""
    if A.shape[1] == A.shape[2]:
        return np.linalg.solve(A, b)
    At = np.swapaxes(A, 1, 2)
    return np.linalg.solve(At @ A, At @ b)


@dataclass
class _Eval:
    """One evaluation at q (m, n): pose residual, reduced Jacobian and closure state."""

    q: np.ndarray
    x: np.ndarray  # (m, 6)
    J: np.ndarray | None  # (m, 6, n_v) reduced Jacobian dx/dq_v
    closed: np.ndarray  # (m,) bool: loop closure converged
    phi_norm: np.ndarray  # (m,)
    closure_iters: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    S: np.ndarray | None = None  # (m, n_w, n_v): dq_w/dq_v = -S


def evaluate(kern: IkKernel, q_v: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray, *,
             jac: bool = True, tol_phi: float = TOL_PHI,
             max_iter: int = MAX_ITER_CLOSURE, rotation: str = "euler") -> _Eval:
    r"""Loop closure (kim1995 §5.1), residual x (Eq. (8)) and reduced Jacobian for a batch.

    The dependent joints are solved by Newton-Raphson from ``q_w0``
    (:func:`mechkin.model.closure.solve_closure`); then

    .. math:: J_r = \frac{\partial x}{\partial q_v} - \frac{\partial x}{\partial q_w}
              \Big[\frac{\partial\phi_R}{\partial q_w}\Big]^+\frac{\partial\phi_R}{\partial q_v}

    (kim1995 Eq. (10)).

    Parameters
    ----------
    q_v : (m, n_v); q_w0 : (m, n_w); T_P : (m, 4, 4) precision points.
    """
    mech = kern.mech
    m = q_v.shape[0]
    if kern.n_cuts == 0 or kern.iw.size == 0:
        q = np.empty((m, kern.n))
        q[:, kern.iv] = q_v
        q[:, kern.iw] = q_w0
        kin = kern.kinematics(q)
        closed = np.ones(m, dtype=bool)
        zero = np.zeros(m)
        iters = np.zeros(m, dtype=int)
        if not jac:
            return _Eval(q, kern.residual(kin, T_P, rotation), None, closed, zero, iters)
        x, Jq = kern.residual_jacobian(kin, T_P, rotation)
        return _Eval(q, x, Jq[:, :, kern.iv], closed, zero, iters)
    res = solve_closure(mech, q_v, q_w0, tol_phi=tol_phi, tol_dq=TOL_DQ_CLOSURE,
                        max_iter=max_iter)
    q = res.q
    closed = res.ok & np.all(np.isfinite(q), axis=1)
    kin = kern.kinematics(q)
    if not jac:
        return _Eval(q, kern.residual(kin, T_P, rotation), None, closed, res.residual,
                     res.iterations)
    x, Jq = kern.residual_jacobian(kin, T_P, rotation)
    _, Phi = closure_jacobian(mech, kin)
    Pw = Phi[:, :, kern.iw]
    Pv = Phi[:, :, kern.iv]
    try:
        S = _lstsq_steps(Pw, Pv)  # dq_w/dq_v = -S
    except np.linalg.LinAlgError:
        S = np.stack([np.linalg.lstsq(a, b, rcond=None)[0] for a, b in zip(Pw, Pv, strict=False)])
        closed &= False
    Jr = Jq[:, :, kern.iv] - Jq[:, :, kern.iw] @ S  # kim1995 Eq. (10)
    return _Eval(q, x, Jr, closed, res.residual, res.iterations, S)


# ---- objective and gradient (public, used by the tests) ----------------------------------------


def objective(mech: Mechanism, q_v: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
              weights: np.ndarray, *, frame: int | None = None,
              kernel: IkKernel | None = None) -> tuple[float, np.ndarray, np.ndarray]:
    r"""f(q_v) = 1/2 x^T W x (kim1995 Eq. (9)) after the loop closure (Eq. (6)).

    Returns
    -------
    f : float; x : (6,) residual (Eq. (8)); q : (n,) all joints.
    """
    kern = kernel or IkKernel(mech, frame)
    ev = evaluate(kern, np.atleast_2d(q_v), np.atleast_2d(q_w0).reshape(1, -1),
                  np.asarray(T_P, dtype=float)[None], jac=False)
    x = ev.x[0]
    return 0.5 * float(x @ (np.asarray(weights) * x)), x, ev.q[0]


def reduced_jacobian(mech: Mechanism, q_v: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray, *,
                     frame: int | None = None, kernel: IkKernel | None = None,
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x (6,), dx/dq_v (6, n_v) (kim1995 Eq. (10)) and q (n,) after the loop closure."""
    kern = kernel or IkKernel(mech, frame)
    ev = evaluate(kern, np.atleast_2d(q_v), np.atleast_2d(q_w0).reshape(1, -1),
                  np.asarray(T_P, dtype=float)[None])
    assert ev.J is not None
    return ev.x[0], ev.J[0], ev.q[0]


def gradient(mech: Mechanism, q_v: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
             weights: np.ndarray, *, frame: int | None = None,
             kernel: IkKernel | None = None) -> np.ndarray:
    r"""df/dq_v (n_v,) = (W x)^T dx/dq_v, kim1995 Eq. (10)."""
    x, J, _ = reduced_jacobian(mech, q_v, q_w0, T_P, frame=frame, kernel=kernel)
    return J.T @ (np.asarray(weights) * x)


# ---- verification -------------------------------------------------------------------------------


def pose_errors(T_E: np.ndarray, T_P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position error ||p_E - p_P|| [m] and orientation error angle(R_P^T R_E) [rad]; (m,)."""
    dp = np.linalg.norm(T_E[..., :3, 3] - T_P[..., :3, 3], axis=-1)
    e = quat_from_matrix(np.swapaxes(T_P[..., :3, :3], -1, -2) @ T_E[..., :3, :3])
    ang = 2.0 * np.arctan2(np.linalg.norm(e[..., 1:], axis=-1), np.abs(e[..., 0]))
    return dp, ang


def _weighted_errors(T_E: np.ndarray, T_P: np.ndarray, w: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Errors of the components that carry weight (zero weight: not determined, not counted)."""
    return _errors(T_E, T_P, w)[2:]


def _errors(T_E: np.ndarray, T_P: np.ndarray, w: np.ndarray
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


# ---- Levenberg-Marquardt, batched ----------------------------------------------------------------


class _OpenRows:
    """lm evaluations of an open chain on the serial path to {E} (:class:`SerialChain`), with
    the chain expressed in {P} itself (``F_0 = T_P^{-1} A_0``, see
    :meth:`SerialChain.first_frame`): the pose of {E} in {P} gives the residual (position,
    rotation vector) and the geometric Jacobian in {P} is its Jacobian. No carry."""

    def __init__(self, kern: IkKernel) -> None:
        self.chain = kern.chain
        self.nv = kern.iv.size
        self.cols = kern.chain_cols  # None: the chain is q_v itself, in order

    def prepare(self, T_P: np.ndarray) -> np.ndarray:
        """Per-target constants (m, 4, 4): F_0 in {P}."""
        return self.chain.first_frame(T_P)

    def __call__(self, qv: np.ndarray, F0: np.ndarray, carry: tuple, q_prev: np.ndarray):
        qc = qv if self.cols is None else qv[:, self.cols]
        T_E, J = self.chain.pose_jacobian(qc, F0)
        x = np.empty((qv.shape[0], 6))
        x[:, :3] = T_E[:, :3, 3]
        x[:, 3:] = rotation_log(T_E[:, :3, :3])
        if self.cols is not None:
            Jf = np.zeros((qv.shape[0], 6, self.nv))
            Jf[:, :, self.cols] = J
            J = Jf
        return x, J, None, ()


class _ClosedRows:
    """lm evaluations of a closed chain: loop closure warm-started by the first-order predictor
    ``q_w - S (q_v - q_v,prev)`` (kim1995 §5.1), Euler-parameter residual (Eq. (8)), reduced
    Jacobian (Eq. (10)). Carry: (q_w, S)."""

    def __init__(self, kern: IkKernel, tol_phi: float) -> None:
        self.kern = kern
        self.tol_phi = tol_phi

    def prepare(self, T_P: np.ndarray) -> np.ndarray:
        """Per-target constants: the precision points themselves."""
        return T_P

    def __call__(self, qv: np.ndarray, T_P: np.ndarray, carry: tuple, q_prev: np.ndarray):
        qw, S = carry
        if S is not None:
            qw = qw - np.einsum("mij,mj->mi", S, qv - q_prev)
        ev = evaluate(self.kern, qv, qw, T_P, tol_phi=self.tol_phi, rotation="euler")
        return ev.x, ev.J, ev.closed, (ev.q[:, self.kern.iw], ev.S)


def _lm_open_compiled(kern: IkKernel, q_v0: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
                      w: np.ndarray, opts: IkOptions, history: bool):
    """:func:`_lm_batch` of an open chain by the compiled kernel (:mod:`ik_serial_jit`)."""
    from mechkin.solvers import ik_serial_jit

    m = q_v0.shape[0]
    max_iter = opts.max_iter or MAX_ITER_LM
    cols = kern.chain_cols
    sel = slice(None) if cols is None else cols
    # the kernel projects the chain's joints onto their limits; the others are left as given
    qv = np.array(q_v0, dtype=np.float64) if cols is None else kern.project(q_v0)
    f_abs = 0.5 * (1e-3 * min(opts.tol_pos, opts.tol_ori)) ** 2
    stall = STALL_WINDOW if opts.restarts > 0 else 0
    qc, f, iters, done, gnorm, hist = ik_serial_jit.lm_serial(
        qv[:, sel], kern.chain.first_frame(T_P), w, kern.chain, kern.bound_lo[sel],
        kern.bound_hi[sel], kern.cont_v[sel], kern.lower_v[sel], f_abs=f_abs,
        max_iter=max_iter, stall=stall, mu=LM_MU, history=history)
    qv[:, sel] = qc
    q = np.empty((m, kern.n))
    q[:, kern.iv] = qv
    q[:, kern.iw] = q_w0
    hl = [h[: i + 1] for h, i in zip(hist, iters, strict=True)] if history else []
    return dict(q=q, qv=qv, qw=q_w0, f=f, iters=iters, nev=iters + 1, gnorm=gnorm,
                closed=np.ones(m, dtype=bool), converged=done, hist=hl)


def _passive_limited_steps(A: np.ndarray, g: np.ndarray, step: np.ndarray, qw: np.ndarray,
                           S: np.ndarray, lo_w: np.ndarray, hi_w: np.ndarray) -> np.ndarray:
    r"""lm steps (q_v <- q_v - step) that keep the dependent (passive) joints within their
    limits to first order: where the predicted ``q_w + S step`` crosses a limit, the step is
    re-solved with those joints held on it (equality constraints, KKT system)

    .. math:: \begin{pmatrix} A & C^T \\ C & 0\end{pmatrix}
              \begin{pmatrix} \delta \\ \nu\end{pmatrix} =
              \begin{pmatrix} g \\ q_{w,lim} - q_w \end{pmatrix},\qquad C = S_{active}

    adding crossed joints until none is crossed (an active-set loop, rows one by one)."""
    pred = qw + (S @ step[:, :, None])[:, :, 0]
    crossing = np.flatnonzero(((pred > hi_w) | (pred < lo_w)).any(axis=1))
    if crossing.size == 0:
        return step
    step = step.copy()
    nv = step.shape[1]
    for r in crossing:
        act = np.zeros(qw.shape[1], dtype=bool)
        st = step[r]
        for _ in range(qw.shape[1]):
            p = qw[r] + S[r] @ st
            new = ((p > hi_w) | (p < lo_w)) & ~act
            if not new.any():
                break
            act |= new
            C = S[r][act]
            tgt = np.where(p[act] > hi_w[act], hi_w[act], lo_w[act]) - qw[r][act]
            na = int(act.sum())
            K = np.zeros((nv + na, nv + na))
            K[:nv, :nv], K[:nv, nv:], K[nv:, :nv] = A[r], C.T, C
            st = np.linalg.lstsq(K, np.concatenate([g[r], tgt]), rcond=None)[0][:nv]
        step[r] = st
    return step


def _lm_batch(kern: IkKernel, q_v0: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
              w: np.ndarray, opts: IkOptions, history: bool = False,
              stop_on_first: bool = False):
    r"""Levenberg-Marquardt on the reduced Jacobian for m targets at once.

    The residual is kim1995's x (Eq. (8)); for open chains its orientation part is written as a
    rotation vector (angle times axis) instead of the vector part of the Euler parameters: both
    vanish at the same point, but the rotation vector does not flatten out for large errors, so
    far targets converge in a few steps. Closed chains keep the Euler parameters (measured on
    the kim1995 end-effector robot: with position weight 0 the rotation-vector steps drift along
    the unweighted directions onto the leg strokes and the next precision point fails).
    With E = 1/2 x^T W x and Marquardt's scaling,

    .. math:: (H + \lambda\,(\mathrm{diag}\,H + \mu I))\,\delta = -J_r^T W x,\qquad
              H = J_r^T W J_r

    q_v is projected onto its limits after each step; a step is kept when E decreases
    (lambda / 10), else lambda x 4. On closed chains the dependent (passive) joints keep their
    limits too: a step that would carry them across is re-solved with them held on the limit
    (:func:`_passive_limited_steps`), and a trial whose loop closure lands more than
    PASSIVE_BAND of a range beyond a limit is rejected. (Measured on the kim1995 end-effector
    robot: without this, lm reaches Table 8 points 2-4 with spherical joint s1 through the
    gimbal lock of its Euler angles, s1_2 = 126 deg, after a ~100-step crawl; with it, point 2
    takes 33 steps and every answer stays within the limits, as Table 9's do.)
    Rows that have converged leave the working set (vectorized across targets): the working
    arrays are compacted only when rows leave, so one target costs a fixed, small number of
    array operations per iteration. With ``stop_on_first`` (several starts for one target) the
    run ends when one row converges.
    """
    m, nv = q_v0.shape
    max_iter = opts.max_iter or MAX_ITER_LM
    lo, hi = kern.bound_lo, kern.bound_hi
    bounded = bool(np.isfinite(lo).any() or np.isfinite(hi).any())
    closed_chain = bool(kern.n_cuts) and kern.iw.size > 0
    if compiled_lm_available():
        if not closed_chain:
            return _lm_open_compiled(kern, q_v0, q_w0, T_P, w, opts, history)
        from mechkin.solvers import ik_tree_jit

        return ik_tree_jit.lm_closed_rows(
            kern, q_v0, q_w0, T_P, w, tol_phi=opts.tol_phi, tol_dq=TOL_DQ_CLOSURE,
            max_iter_closure=MAX_ITER_CLOSURE, max_iter=max_iter, mu=LM_MU, history=history,
            passive_band=PASSIVE_BAND,
            f_abs=0.5 * (1e-3 * min(opts.tol_pos, opts.tol_ori)) ** 2)
    rows = _ClosedRows(kern, opts.tol_phi) if closed_chain else _OpenRows(kern)
    passive_bounded = closed_chain and kern.passive_bounded
    qv = kern.project(q_v0)
    tgt = rows.prepare(T_P)
    x, J, closed, carry = rows(qv, tgt, (q_w0, None), qv)
    closed_ok = np.ones(m, dtype=bool) if closed is None else closed.copy()
    f = 0.5 * np.einsum("mi,mi->m", x, w * x)
    qw = carry[0] if closed_chain else q_w0
    iters = np.zeros(m, dtype=int)
    nev = np.ones(m, dtype=int)
    gnorm = np.zeros(m)
    lam = np.full(m, 1e-2)
    hist: list[list[float]] = [[float(v)] for v in f] if history else []
    eye = np.eye(nv)
    mu_eye = LM_MU * eye
    # converged: weighted errors far below the verification tolerances
    f_abs = 0.5 * (1e-3 * min(opts.tol_pos, opts.tol_ori)) ** 2
    done = ~closed_ok | (f < f_abs)
    stall_check = opts.restarts > 0 and not kern.n_cuts  # closed chains crawl by nature
    act = np.flatnonzero(~done)
    # compacted working set of the active rows
    qa, xa, Ja, fa, la, wa = qv[act], x[act], J[act], f[act], lam[act], w[act]
    tga = tgt[act]
    ca = tuple(c[act] for c in carry) if closed_chain else ()
    fref = fa.copy()
    ga_norm = np.zeros(act.size)
    its = 0
    for it in range(max_iter):
        if act.size == 0:
            break
        JW = np.swapaxes(Ja, 1, 2) * wa[:, None, :]
        g = (JW @ xa[:, :, None])[:, :, 0]
        H = JW @ Ja
        if bounded:
            # active bounds: a joint on a limit whose gradient pushes outward is frozen
            blocked = ((qa <= lo + 1e-12) & (g > 0)) | ((qa >= hi - 1e-12) & (g < 0))
            if blocked.any():
                g = np.where(blocked, 0.0, g)
                free = ~blocked
                H = H * (free[:, :, None] & free[:, None, :]) + eye * blocked[:, :, None]
        ga_norm = np.sqrt(np.einsum("mi,mi->m", g, g))
        A = H + la[:, None, None] * (H * eye + mu_eye)
        try:
            step = np.linalg.solve(A, g[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            step = np.stack([np.linalg.lstsq(a, b, rcond=None)[0]
                             for a, b in zip(A, g, strict=False)])
        if passive_bounded:
            step = _passive_limited_steps(A, g, step, ca[0], ca[1], kern.lo_w, kern.hi_w)
        qn = qa - step
        if bounded:
            qn = kern.project(qn)
        xn, Jn, cl, cn = rows(qn, tga, ca, qa)
        if passive_bounded and cl is not None:
            band = PASSIVE_BAND * kern.range_w
            cl = cl & np.all((cn[0] >= kern.lo_w - band) & (cn[0] <= kern.hi_w + band), axis=1)
        fn = 0.5 * np.einsum("mi,mi->m", xn, wa * xn)
        its += 1
        good = fn < fa if cl is None else cl & (fn < fa)
        gain = fa - fn
        if good.all():
            fin = (fn < f_abs) | (gain <= 1e-14 * np.maximum(fn, 1e-300))
            qa, xa, Ja, fa, ca = qn, xn, Jn, fn, cn
            la = np.maximum(la * 0.1, 1e-12)
        else:
            gm = good[:, None]
            qa = np.where(gm, qn, qa)
            xa = np.where(gm, xn, xa)
            Ja = np.where(good[:, None, None], Jn, Ja)
            fa = np.where(good, fn, fa)
            ca = tuple(np.where(good.reshape((-1,) + (1,) * (o.ndim - 1)), n_, o)
                       for n_, o in zip(cn, ca, strict=True))
            la = np.where(good, np.maximum(la * 0.1, 1e-12), la * 4.0)
            # finished: converged, no measurable progress, or a rejected step that is tiny
            fin = np.where(good, (fn < f_abs) | (gain <= 1e-14 * np.maximum(fn, 1e-300)),
                           (np.sqrt(np.einsum("mi,mi->m", step, step)) < 1e-13) | (la > 1e10))
        if history:
            for r_, fv in zip(act, fa, strict=True):
                hist[r_].append(float(fv))
        if stall_check and (it + 1) % STALL_WINDOW == 0:
            # a row whose E has not halved in STALL_WINDOW steps is crawling (a limit, a
            # singularity or a local minimum): let the restarts have it
            fin = fin | (fa > 0.5 * fref)
            fref = fa.copy()
        if stop_on_first and np.any(fa < f_abs):
            fin = np.ones(act.size, dtype=bool)
        if fin.any():
            # write the finished rows back and compact the working set
            r_ = act[fin]
            qv[r_], x[r_], f[r_], lam[r_], gnorm[r_] = qa[fin], xa[fin], fa[fin], la[fin], \
                ga_norm[fin]
            iters[r_] = its
            if closed_chain:
                qw[r_] = ca[0][fin]
            done[r_] = True
            keep = ~fin
            act = act[keep]
            qa, xa, Ja, fa, la, wa = qa[keep], xa[keep], Ja[keep], fa[keep], la[keep], wa[keep]
            tga, fref, ga_norm = tga[keep], fref[keep], ga_norm[keep]
            ca = tuple(c[keep] for c in ca)
    if act.size:  # out of iterations
        qv[act], x[act], f[act], gnorm[act] = qa, xa, fa, ga_norm
        iters[act] = its
        if closed_chain:
            qw[act] = ca[0]
    nev += iters
    q = np.empty((m, kern.n))
    q[:, kern.iv] = qv
    q[:, kern.iw] = qw
    return dict(q=q, qv=qv, qw=qw, f=f, iters=iters, nev=nev, gnorm=gnorm,
                closed=closed_ok, converged=done, hist=hist)


# ---- conjugate gradient + golden section (kim1995 §5.2) ----------------------------------------


def _point_evaluator(kern: IkKernel, opts: IkOptions):
    """``(q_v, q_w guess, T_P, jac) -> (closed, x, J_r | None, q, S | None)`` for one point:
    the compiled closed-chain evaluation when available, else :func:`evaluate`."""
    if compiled_lm_available():  # the tree kernel also serves open chains (no cuts)
        from mechkin.solvers.ik_tree_jit import ClosedEvaluator

        ce = ClosedEvaluator(kern, opts.tol_phi, TOL_DQ_CLOSURE, MAX_ITER_CLOSURE)
        return lambda qv, qw, T_P, jac: ce(qv, qw, T_P)

    def ev(qv, qw, T_P, jac):
        e = evaluate(kern, qv[None], qw[None], T_P[None], jac=jac, tol_phi=opts.tol_phi)
        return (bool(e.closed[0]), e.x[0], None if e.J is None else e.J[0], e.q[0],
                None if e.S is None else e.S[0])

    return ev


def _cg_golden(kern: IkKernel, q_v0: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray,
               w: np.ndarray, opts: IkOptions):
    """kim1995 §5.2 Steps 3-8 for one precision point (arrays (n_v,), (n_w,), (4, 4), (6,)).

    §5.2 has no constraints. Independent joints are projected onto their limits (as in lm);
    the dependent (passive) joints' limits, which are nonlinear constraints on q_v, are kept by
    Rosen's gradient projection (Arora 1989 §11): a line-search trial with a passive joint
    beyond its limit is infeasible (f = inf), and at a point where passive joints sit on their
    limits the search direction is projected onto the tangent of those limits,
    ``d <- (I - A^T (A A^T)^-1 A) d`` with the rows ``A = +-dq_w/dq_v`` of the active limits the
    direction would cross. The convergence test (Step 6) uses the projected gradient. Without
    it, steepest descent on the kim1995 end-effector robot drives the 3-RPS stage into the
    gimbal lock of a spherical joint (s1_2 = 90 deg, beyond its 80 deg limit) and stops.
    """
    max_iter = opts.max_iter or MAX_ITER_CG
    nv = q_v0.size
    restart = nv if opts.cg_restart is None else opts.cg_restart
    nev = 0
    lo_w, hi_w = kern.mech.lower[kern.iw], kern.mech.upper[kern.iw]
    evaluate_at = _point_evaluator(kern, opts)

    S = None  # dq_w/dq_v = -S at the current iterate

    def fval(qv: np.ndarray, qw: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, bool]:
        # kim1995 §5.2 Steps 7.1-7.3: closure warm-started from q_w^(k), then f; a trial
        # beyond passive limits is restored onto them (Rosen), up to 3 linearized steps
        nonlocal nev
        for _ in range(4):
            nev += 1
            closed_e, x, _, q_e, _ = evaluate_at(qv, qw, T_P, False)
            if not closed_e:
                return np.inf, qv, qw, False
            qwe = q_e[kern.iw]
            over = np.maximum(qwe - hi_w, 0.0) - np.maximum(lo_w - qwe, 0.0)
            if not np.any(np.abs(over) > 1e-9):
                return 0.5 * float(x @ (w * x)), qv, qwe, True
            if S is None:
                break
            J_ = np.flatnonzero(np.abs(over) > 1e-9)
            A = -S[J_]  # dq_w/dq_v of the violated joints
            qv = kern.project(qv - A.T @ np.linalg.lstsq(A @ A.T, over[J_], rcond=None)[0])
            qw = qwe
        return np.inf, qv, qw, False

    def project_dir(d: np.ndarray, qv: np.ndarray, qw: np.ndarray, S: np.ndarray | None
                    ) -> np.ndarray:
        """Rosen's projection of d onto the tangent of the limits it would cross: independent
        joints on a limit keep still, passive ones move along their limit."""
        band_v = 1e-6 * np.minimum(kern.upper_v - kern.lower_v, 2 * np.pi)
        d = np.where(((qv <= kern.bound_lo + band_v) & (d < 0))
                     | ((qv >= kern.bound_hi - band_v) & (d > 0)), 0.0, d)
        if S is None or not S.size:
            return d
        rng_w = np.minimum(hi_w - lo_w, 2 * np.pi)
        at_hi = qw >= hi_w - ACTIVE_BAND * rng_w
        at_lo = qw <= lo_w + ACTIVE_BAND * rng_w
        if not (at_hi.any() or at_lo.any()):
            return d
        G = -S  # dq_w/dq_v (n_w, n_v)
        rows = np.concatenate([G[at_hi], -G[at_lo]])  # outward normals
        act = np.zeros(len(rows), dtype=bool)
        for _ in range(len(rows) + 1):
            viol = (rows @ d > 1e-12 * np.linalg.norm(d)) & ~act
            if not viol.any():
                break
            act |= viol
            A = rows[act]
            d = d - A.T @ np.linalg.lstsq(A @ A.T, A @ d, rcond=None)[0]
        return d

    qv = kern.project(q_v0)
    closed_e, x, Jr, q_e, S = evaluate_at(qv, q_w0, T_P, True)  # Step 3
    nev += 1
    if not closed_e:
        return dict(qv=qv, qw=q_w0, f=np.inf, iters=0, nev=nev, gnorm=np.inf, closed=False,
                    converged=False, hist=[np.inf])
    qw = q_e[kern.iw]
    f = 0.5 * float(x @ (w * x))
    g = Jr.T @ (w * x)  # Step 4, kim1995 Eq. (10)
    gp = -project_dir(-g, qv, qw, S)
    d = -gp
    g_prev_n2 = float(gp @ gp)
    hist = [f]
    k = 0
    converged = False
    alpha_prev = 0.0
    for k in range(max_iter):  # noqa: B007 - k is reported
        gn = float(np.sqrt(gp @ gp))
        if gn < opts.grad_tol:  # Step 6 (projected gradient)
            converged = True
            break
        if k > 0:  # Step 5: Fletcher-Reeves
            beta = float(gp @ gp) / g_prev_n2
            d = project_dir(-gp + beta * d, qv, qw, S)
            if (restart and k % restart == 0) or float(d @ g) >= 0.0:
                d = -gp
        g_prev_n2 = float(gp @ gp)
        # Step 7: golden-section search for alpha* along d, with bracketing
        dn = float(np.linalg.norm(d))
        delta = (alpha_prev * 0.5 if alpha_prev > 0 else 0.05 / dn)
        alpha, f_new, qv_new, qw_new = _golden_line(fval, qv, qw, d, f, delta, kern.project,
                                                    opts.line_tol / dn)
        if not np.isfinite(f_new) or f_new >= f:
            # no decrease along d: steepest descent once more, then stop
            if not np.array_equal(d, -gp):
                d = -gp
                dn = float(np.linalg.norm(d))
                alpha, f_new, qv_new, qw_new = _golden_line(
                    fval, qv, qw, d, f, 0.05 / dn, kern.project, opts.line_tol / dn)
            if not np.isfinite(f_new) or f_new >= f:
                converged = True  # no descent along -grad: a numerical stationary point
                break
        alpha_prev = alpha
        qv = qv_new  # Step 8: q_v + alpha d (projected, restored onto passive limits)
        _, x, Jr, q_e, S = evaluate_at(qv, qw_new, T_P, True)
        nev += 1
        qw = q_e[kern.iw]
        f = 0.5 * float(x @ (w * x))
        g = Jr.T @ (w * x)
        gp = -project_dir(-g, qv, qw, S)
        hist.append(f)
    else:
        k = max_iter
    gn = float(np.sqrt(gp @ gp))
    converged = converged or gn < opts.grad_tol
    return dict(qv=qv, qw=qw, f=f, iters=k, nev=nev, gnorm=gn, closed=True,
                converged=converged, hist=hist)


def _golden_line(fval, qv: np.ndarray, qw: np.ndarray, d: np.ndarray, f0: float, delta: float,
                 project, tol: float, max_step: float = 0.1):
    """Golden-section search of min_alpha f(q_v + alpha d) (Arora 1989 §8.2): bracket with
    steps growing by the golden ratio, then shrink the interval until shorter than ``tol``."""
    cache: dict[float, tuple[float, np.ndarray, np.ndarray]] = {}

    def F(a: float) -> float:
        if a not in cache:
            fa, qva, qwa, ok = fval(project(qv + a * d), qw)
            cache[a] = (fa if ok else np.inf, qva, qwa)
        return cache[a][0]

    # phase 1: bracketing, alpha_q = sum_j delta (1.618)^j, up to a joint change of max_step
    amax = max_step / max(float(np.abs(d).max()), 1e-300)
    delta = min(delta, amax)
    a_prev2, a_prev, f_prev = 0.0, 0.0, f0
    a = delta
    fa = F(a)
    if fa >= f0:
        lo_a, hi_a = 0.0, a
    else:
        step = delta
        while True:
            step *= 1.0 / GOLDEN
            a_next = a + step
            fn = F(a_next)
            if fn >= fa or a_next > amax:
                lo_a, hi_a = a_prev, a_next
                break
            a_prev2, a_prev, f_prev = a_prev, a, fa
            a, fa = a_next, fn
    del a_prev2, f_prev
    # phase 2: golden-section reduction of [lo_a, hi_a]
    aL, aU = lo_a, hi_a
    a1 = aL + (1.0 - GOLDEN) * (aU - aL)
    a2 = aL + GOLDEN * (aU - aL)
    f1, f2 = F(a1), F(a2)
    while aU - aL > tol:
        if f1 < f2 or (f1 == f2 == np.inf):  # both infeasible: the feasible side is near 0
            aU, a2, f2 = a2, a1, f1
            a1 = aL + (1.0 - GOLDEN) * (aU - aL)
            f1 = F(a1)
        elif f1 > f2:
            aL, a1, f1 = a1, a2, f2
            a2 = aL + GOLDEN * (aU - aL)
            f2 = F(a2)
        else:
            aL, aU = a1, a2
            a1 = aL + (1.0 - GOLDEN) * (aU - aL)
            a2 = aL + GOLDEN * (aU - aL)
            f1, f2 = F(a1), F(a2)
    # phase 3: the best point evaluated
    best = min(cache, key=lambda t: cache[t][0])
    return best, *cache[best]


# ---- public solvers ----------------------------------------------------------------------------


def _status(kern: IkKernel, q: np.ndarray, T_P: np.ndarray, w: np.ndarray, closed: bool,
            converged: bool, opts: IkOptions, grad_norm: float = 0.0
            ) -> tuple[IkStatus, float, float, tuple[str, ...]]:
    T_E = kern.pose_check(q[None])
    pe, oe, wpe, woe = _errors(T_E, T_P[None], w[None])
    mech = kern.mech
    tol_j = 1e-9
    at = tuple(mech.joint_names[j] for j in
               np.flatnonzero((q <= mech.lower + tol_j) | (q >= mech.upper - tol_j)))
    pos, ori = float(pe[0]), float(oe[0])
    if not closed or not np.all(np.isfinite(q)):
        return IkStatus.SINGULAR, pos, ori, at
    if wpe[0] <= opts.tol_pos and woe[0] <= opts.tol_ori:
        return IkStatus.OK, pos, ori, at
    if converged:
        # stationary above tolerance: a limit blocks the descent (at a limit) or the target is
        # outside the workspace of the mechanism (unreachable)
        iv = kern.iv
        on = (q[iv] <= kern.bound_lo + tol_j) | (q[iv] >= kern.bound_hi - tol_j)
        return (IkStatus.AT_LIMIT if on.any() else IkStatus.UNREACHABLE), pos, ori, at
    if not np.isfinite(grad_norm) or grad_norm > 1e6:
        return IkStatus.SINGULAR, pos, ori, at
    return IkStatus.NOT_CONVERGED, pos, ori, at


def _finite(a: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    return np.where(np.isfinite(a), a, fallback)


def solve_ik(mech: Mechanism, T_P: np.ndarray, *, q_v0: np.ndarray | None = None,
             q_w0: np.ndarray | None = None, weights: np.ndarray | None = None,
             options: IkOptions | None = None, frame: int | None = None,
             kernel: IkKernel | None = None) -> IkResult:
    r"""Independent joints that bring {E} onto the precision point T_P (kim1995 Eq. (5)-(6)).

    .. math:: q_v^* = \arg\min f(q_v),\quad f = \tfrac12 x^T W x,\quad
              \phi_R(q_v^*, q_w^*) = 0

    Parameters
    ----------
    mech : Mechanism
    T_P : array, shape (4, 4)
        Precision point {P} in the base frame.
    q_v0 : array, shape (n_v,), optional
        Initial independent joints (default: home).
    q_w0 : array, shape (n_w,), optional
        Initial approximation of the dependent joints (default: home).
    weights : array, shape (6,), optional
        Diagonal of W: position (3), then orientation (3); zeros allowed (default ones).
    options : IkOptions, optional
    frame : int, optional
        {E} (default ``mech.end_effector``).

    Returns
    -------
    IkResult
        With errors verified by forward kinematics at the returned joints. A failed solve is
        retried ``options.restarts`` times from seeded random q_v within the limits.

    References
    ----------
    kim1995_complex_chain_ik §5.2 (cg-golden) and Eq. (7)-(10).
    """
    opts = options or IkOptions()
    kern = kernel or IkKernel(mech, frame)
    T_P = np.asarray(T_P, dtype=np.float64)
    w = np.ones(6) if weights is None else np.asarray(weights, dtype=np.float64)
    t0 = time.perf_counter()
    qv0 = mech.home[kern.iv].copy() if q_v0 is None else np.asarray(q_v0, dtype=np.float64)
    if q_v0 is None:  # no guess: the nearest pose of the seeded codebook (open chains)
        seeded = kern.seed_starts(T_P[None], w[None])
        if seeded is not None:
            qv0 = seeded[0, 0]
    qw0 = mech.home[kern.iw].copy() if q_w0 is None else np.asarray(q_w0, dtype=np.float64)
    rng: np.random.Generator | None = None
    best: dict | None = None
    tot_it = tot_ev = 0
    attempt = 0
    while attempt <= opts.restarts:
        if attempt == 0:
            starts_v, start_w = qv0[None], qw0
        else:
            rng = rng or np.random.default_rng(opts.seed)
            lo = np.where(np.isfinite(kern.lower_v), kern.lower_v, -np.pi)
            hi = np.where(np.isfinite(kern.upper_v), kern.upper_v, np.pi)
            # lm: every remaining restart at once, as rows of one batch that stops at the
            # first success; cg-golden: one at a time (kim1995 §5.2 is sequential)
            k = opts.restarts if opts.method == "lm" else 1
            if kern.n_cuts:
                # closed chains: random joints seldom assemble, so restart near the given start
                # (which does) with a seeded jitter of 2 % of each range
                starts_v = kern.project(qv0 + rng.normal(0.0, 0.02, size=(k, kern.iv.size))
                                        * np.minimum(hi - lo, 2 * np.pi))
                start_w = qw0
            else:
                starts_v = rng.uniform(lo, hi, size=(k, kern.iv.size))
                start_w = qw0 if best is None else best["q_w"]
            # the nearest codebook poses not tried yet come first (lm: all in one batch;
            # cg-golden: the next one per attempt)
            first = (1 if q_v0 is None else 0) + (attempt - 1 if opts.method != "lm" else 0)
            nr = min(k, max(SEED_RESTARTS - first, 0))
            seed = (kern.seed_starts(T_P[None], w[None], ranks=range(first, first + nr))
                    if nr else None)
            if seed is not None:
                starts_v[:nr] = seed[0]
        if opts.method == "cg-golden":
            r = _cg_golden(kern, starts_v[0], start_w, T_P, w, opts)
            hist = np.asarray(r["hist"], dtype=float)
            qv, qw = r["qv"], r["qw"]
            f, iters, nev, gn = r["f"], r["iters"], r["nev"], r["gnorm"]
            closed, conv = r["closed"], r["converged"]
            attempt += 1
        elif opts.method == "lm":
            k = starts_v.shape[0]
            r = _lm_batch(kern, starts_v, np.broadcast_to(start_w, (k, kern.iw.size)),
                          np.broadcast_to(T_P, (k, 4, 4)) if k > 1 else T_P[None],
                          np.broadcast_to(w, (k, 6)) if k > 1 else w[None], opts,
                          history=True, stop_on_first=k > 1)
            if k == 1:
                b = 0
            else:
                fr = np.where(r["closed"], r["f"], np.inf)
                b = int(np.argmin(fr)) if np.isfinite(fr).any() else 0
            hist = np.asarray(r["hist"][b], dtype=float)
            qv, qw = r["qv"][b], r["qw"][b]
            f, iters, nev, gn = (float(r["f"][b]), int(r["iters"].max()),
                                 int(r["nev"].sum()), float(r["gnorm"][b]))
            closed, conv = bool(r["closed"][b]), bool(r["converged"][b])
            attempt += k
        else:
            raise ValueError(f"method: expected 'lm' or 'cg-golden', got {opts.method!r}")
        tot_it += int(iters)
        tot_ev += int(nev)
        q = np.empty(kern.n)
        q[kern.iv], q[kern.iw] = qv, qw
        q = _finite(q, mech.home)
        st, pe, oe, at = _status(kern, q, T_P, w, closed, conv, opts, float(gn))
        f_fin = float(f) if np.isfinite(f) else 0.5 * float(np.sum(w) * 4.0)
        if not np.isfinite(hist).all():
            hist = _finite(hist, np.full_like(hist, f_fin))
        res = dict(q_v=q[kern.iv], q_w=q[kern.iw], q=q, status=st, position_error=pe,
                   orientation_error=oe, f=f_fin, grad_norm=float(gn) if np.isfinite(gn) else 0.0,
                   f_history=hist, at_limit=at, restarts_used=attempt - 1, method=opts.method)
        if best is None or _better(res, best):
            best = res
        if best["status"] is IkStatus.OK:
            break
    assert best is not None
    return IkResult(**best, iterations=tot_it, evaluations=tot_ev,
                    time_s=time.perf_counter() - t0)


def _better(a: dict, b: dict) -> bool:
    """Whether result fields a beat b: a better status, then a lower f."""
    rank = {IkStatus.OK: 0, IkStatus.AT_LIMIT: 1, IkStatus.UNREACHABLE: 2,
            IkStatus.NOT_CONVERGED: 2, IkStatus.SINGULAR: 3}
    if rank[a["status"]] != rank[b["status"]]:
        return rank[a["status"]] < rank[b["status"]]
    return a["f"] < b["f"]


def solve_ik_sequence(mech: Mechanism, targets: list[np.ndarray] | np.ndarray, *,
                      q_v0: np.ndarray | None = None, q_w0: np.ndarray | None = None,
                      weights: np.ndarray | list[np.ndarray] | None = None,
                      options: IkOptions | None = None, frame: int | None = None,
                      ) -> list[IkResult]:
    """Solve precision points in order, each warm-started from the previous solution
    (kim1995 §5.2 Step 2). ``weights`` (6,) for all or (k, 6) per point."""
    kern = IkKernel(mech, frame)
    Ts = np.asarray(targets, dtype=np.float64).reshape(-1, 4, 4)
    W = np.ones((len(Ts), 6)) if weights is None else np.broadcast_to(
        np.asarray(weights, dtype=np.float64), (len(Ts), 6))
    qv = mech.home[kern.iv].copy() if q_v0 is None else np.asarray(q_v0, dtype=np.float64)
    qw = mech.home[kern.iw].copy() if q_w0 is None else np.asarray(q_w0, dtype=np.float64)
    out = []
    for T, w in zip(Ts, W, strict=False):
        r = solve_ik(mech, T, q_v0=qv, q_w0=qw, weights=w, options=options, kernel=kern)
        out.append(r)
        if r.status is not IkStatus.SINGULAR:
            qv, qw = r.q_v, r.q_w
    return out


def solve_ik_batch(mech: Mechanism, T_P: np.ndarray, *, q_v0: np.ndarray | None = None,
                   q_w0: np.ndarray | None = None, weights: np.ndarray | None = None,
                   options: IkOptions | None = None, frame: int | None = None,
                   ) -> IkBatchResult:
    r"""Levenberg-Marquardt on many targets at once, vectorized across targets.

    Parameters
    ----------
    T_P : array, shape (m, 4, 4)
        Precision points (a trajectory, a grid), solved independently.
    q_v0 : array, shape (m, n_v) or (n_v,), optional
        Initial independent joints (default home).
    q_w0 : array, shape (m, n_w) or (n_w,), optional
    weights : array, shape (m, 6) or (6,), optional
    options : IkOptions, optional
        ``method`` is ignored (always lm); ``restarts`` re-solve the failed targets together
        from seeded random starts.

    Returns
    -------
    IkBatchResult
        Errors verified by forward kinematics at the returned joints.

    References
    ----------
    kim1995_complex_chain_ik Eq. (7)-(10); the step is Levenberg-Marquardt, not §5.2.
    """
    opts = options or IkOptions()
    kern = IkKernel(mech, frame)
    t0 = time.perf_counter()
    T_P = np.asarray(T_P, dtype=np.float64).reshape(-1, 4, 4)
    m = T_P.shape[0]
    nv, nw = kern.iv.size, kern.iw.size
    qv0 = np.broadcast_to(mech.home[kern.iv] if q_v0 is None else np.asarray(q_v0, float),
                          (m, nv)).copy()
    w_seed = np.broadcast_to(np.ones(6) if weights is None else np.asarray(weights, float),
                             (m, 6))
    if q_v0 is None:
        seeded = kern.seed_starts(T_P, w_seed)
        if seeded is not None:
            qv0 = seeded[:, 0]
    qw0 = np.broadcast_to(mech.home[kern.iw] if q_w0 is None else np.asarray(q_w0, float),
                          (m, nw)).copy()
    w = np.broadcast_to(np.ones(6) if weights is None else np.asarray(weights, float),
                        (m, 6)).copy()
    r = _lm_batch(kern, qv0, qw0, T_P, w, opts)
    q, f, iters = r["q"], r["f"], r["iters"]
    conv, closed = r["converged"], r["closed"]

    def check(qq: np.ndarray, TT: np.ndarray, ww: np.ndarray) -> np.ndarray:
        T_E = kern.pose_check(qq)
        pe, oe = _weighted_errors(T_E, TT, ww)
        return (pe <= opts.tol_pos) & (oe <= opts.tol_ori)

    ok = check(q, T_P, w) & closed
    rng = np.random.default_rng(opts.seed)
    lo = np.where(np.isfinite(kern.lower_v), kern.lower_v, -np.pi)
    hi = np.where(np.isfinite(kern.upper_v), kern.upper_v, np.pi)
    for k in range(opts.restarts):
        bad = np.flatnonzero(~ok)
        if bad.size == 0:
            break
        # the next-nearest codebook poses first, then seeded random starts
        start = (kern.seed_starts(T_P[bad], w[bad], ranks=(k + 1,))
                 if q_v0 is None and k < SEED_RESTARTS else None)
        start = (start[:, 0] if start is not None
                 else rng.uniform(lo, hi, size=(bad.size, nv)))
        r2 = _lm_batch(kern, start, qw0[bad], T_P[bad], w[bad], opts)
        iters[bad] += r2["iters"]
        better = r2["f"] < f[bad]
        sel = bad[better]
        q[sel], f[sel] = r2["q"][better], r2["f"][better]
        conv[sel], closed[sel] = r2["converged"][better], r2["closed"][better]
        ok[bad] = check(q[bad], T_P[bad], w[bad]) & closed[bad]
    T_E = kern.pose_check(q)
    pe, oe = pose_errors(T_E, T_P)
    status = np.empty(m, dtype=object)
    for i in range(m):
        status[i] = (IkStatus.OK if ok[i] else IkStatus.SINGULAR if not closed[i]
                     else IkStatus.UNREACHABLE if conv[i] else IkStatus.NOT_CONVERGED)
    return IkBatchResult(q_v=q[:, kern.iv], q_w=q[:, kern.iw], q=q, status=status,
                         position_error=pe, orientation_error=oe, f=f, iterations=iters,
                         time_s=time.perf_counter() - t0)
