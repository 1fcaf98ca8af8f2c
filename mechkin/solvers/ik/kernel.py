r"""The IK objective of kim1995 §3-§4 and the per-mechanism constants that evaluate it.

The end-effector frame {E} is driven onto a precision point {P} by searching the independent
joints q_v; the dependent joints q_w follow from the loop closure phi_R(q_v, q_w) = 0 (kim1995
Eq. (4)-(6)). The objective is (kim1995 Eq. (7)-(9))

.. math:: x = ({}^P p_E^T\; {}^P e_E^T)^T,\qquad f(q_v) = \tfrac12 x^T W x

and its gradient follows from the chain rule (kim1995 Eq. (10)) with the sensitivity of the
dependent joints

.. math:: \frac{\partial q}{\partial q_v} = L_v + L_w \frac{\partial q_w}{\partial q_v},\qquad
          \frac{\partial q_w}{\partial q_v} = -\Big[\frac{\partial\phi_R}{\partial q_w}\Big]^+
          \frac{\partial\phi_R}{\partial q_v}.

This module holds :class:`IkKernel` (the constants of the objective for one mechanism and
end-effector frame: index sets, limits, the serial path to {E}; on a mechanism whose only
constraints are joint couplings, their closed form q = S q_v + c0 and the bounds they put on
q_v, :mod:`mechkin.model.couplings`), :func:`evaluate` (loop closure,
residual and reduced Jacobian of a batch), the public :func:`objective`,
:func:`reduced_jacobian`, :func:`gradient`, and :func:`pose_errors` (the verified errors of a
pose). The kinematics (forward kinematics, the residual Jacobian, the loop closure) are those of
:mod:`mechkin.model`; nothing here iterates on q_v.

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. May import :mod:`mechkin.model`,
:mod:`mechkin.spatial`; never :mod:`mechkin.solvers.ik.seeds` (which builds on the kernel:
call :func:`~mechkin.solvers.ik.seeds.seed_starts` with a kernel), ``io/``, ``cli/`` or ``tasks/``.

References
----------
kim1995_complex_chain_ik §3-§5, Eq. (4)-(10); §5.1 (loop closure).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mechkin.model.closure import solve_closure
from mechkin.model.couplings import CouplingMap, coupling_map
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
from mechkin.spatial.rotations import quat_from_matrix

TOL_PHI = 1e-12  # loop closure ||phi_R||, kim1995 §5.1 epsilon_v
MAX_ITER_CLOSURE = 30
TOL_DQ_CLOSURE = 1e-10  # ||dq_w|| of the last Newton step (kim1995 §5.1 epsilon_w)


def wrap_into(q: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Angles q moved by the fewest whole turns into [lo, hi] (needs hi - lo >= 2 pi); values
    already inside are returned unchanged."""
    two_pi = 2 * np.pi
    q = np.where(q < lo, q + two_pi * np.ceil((lo - q) / two_pi), q)
    return np.where(q > hi, q - two_pi * np.ceil((q - hi) / two_pi), q)


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
        self.n_cuts = len(mech.cuts) + len(mech.couplings)  # constraint blocks of phi
        # couplings without cut links: q = S q_v + c0 in closed form (open-chain IK, seeds)
        self.coupling: CouplingMap | None = coupling_map(mech)
        self.lower_v = mech.lower[self.iv]
        self.upper_v = mech.upper[self.iv]
        # a revolute joint whose range spans a full turn is continuous: wrap, do not clamp
        self.cont_v = (mech.s[self.iv] == 0) & (self.upper_v - self.lower_v >= 2 * np.pi - 1e-9)
        if self.coupling is not None:  # the coupled joints' limits bound their masters
            self.lower_v, self.upper_v, self.cont_v = self.coupling.bounds()
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

    @property
    def open_path(self) -> bool:
        """Whether IK searches q_v on the serial path to {E} alone: no cut links, and joint
        couplings (if any) in closed form (:attr:`coupling`)."""
        return self.n_cuts == 0 or self.coupling is not None

    @property
    def coupled_chain(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The serial path to {E} in reduced coordinates (coupled open chains, :attr:`coupling`):
        ``rc`` (r,) the positions in q_v of the independent joints that drive the path, and per
        path joint i ``jcol`` (its driver's index in rc), ``jmul``, ``joff``:
        ``q_i = jmul[i] q_v[rc[jcol[i]]] + joff[i]``."""
        hit = self.__dict__.get("_coupled_chain")
        if hit is None:
            cm = self.coupling
            assert cm is not None
            jj = self.chain.joints
            colv = cm.col[jj]
            rc = np.unique(colv)
            hit = self.__dict__["_coupled_chain"] = (
                rc, np.searchsorted(rc, colv).astype(np.int64),
                np.ascontiguousarray(cm.mult[jj]), np.ascontiguousarray(cm.off[jj]))
        return hit

    def pose_check(self, q: np.ndarray) -> np.ndarray:
        """Pose of {E} (m, 4, 4) at joints q (m, n) by forward kinematics, for verification:
        the serial path's product for open chains (tested equal to the general tree
        kinematics; coupled joints' values taken from q), the general tree kinematics for
        closed ones."""
        if self.open_path:
            return self.chain.pose(q[:, self.chain.joints])
        return self.end_effector(self.kinematics(q))

    def project(self, q_v: np.ndarray) -> np.ndarray:
        """Project independent joints (..., n_v) onto the limits.

        A revolute joint whose limits span a full turn or more (``cont_v``) is never clamped:
        a value within its limits is kept as it is, one outside is moved by the fewest whole
        turns that bring it inside (so an iterate never jumps by 2 pi for no reason)."""
        q = np.clip(q_v, self.bound_lo, self.bound_hi)
        if self.cont_v.any():
            q = np.where(self.cont_v, wrap_into(q, self.lower_v, self.upper_v), q)
        return q

    def nearest_turn(self, q_v: np.ndarray, ref: np.ndarray) -> np.ndarray:
        """The same independent joints (..., n_v) with each ``cont_v`` joint moved by whole
        turns to the representative within its limits nearest ``ref`` (the guess): the
        answer to a target that the guess already reaches is the guess itself."""
        if not self.cont_v.any():
            return q_v
        two_pi = 2 * np.pi
        t = q_v + two_pi * np.round((ref - q_v) / two_pi)
        t = wrap_into(t, self.lower_v, self.upper_v)
        return np.where(self.cont_v, t, q_v)

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


def kernel_for(mech: Mechanism, frame: int | None = None) -> IkKernel:
    """The one :class:`IkKernel` of ``mech`` and ``frame`` in this process (built on first use).

    The kernel, and with it the seed codebook (:mod:`mechkin.solvers.ik.seeds`, built lazily on
    the first seedless solve or restart), is kept in the mechanism object's own ``__dict__``
    (a Mechanism is immutable): it lives as long as the mechanism, and every solve of that
    mechanism without ``kernel=`` reuses it instead of rebuilding the codebook (FK of 8192
    configurations and a KD-tree, 0.1-0.6 s)."""
    cache = mech.__dict__.setdefault("_ik_kernels", {})
    key = mech.end_effector if frame is None else int(frame)
    kern = cache.get(key)
    if kern is None:
        kern = cache[key] = IkKernel(mech, frame)
    return kern


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
    if kern.coupling is not None:  # couplings alone: q = S q_v + c0, J_r = (dx/dq) S
        q = kern.coupling.full(q_v)
        kin = kern.kinematics(q)
        closed = np.ones(m, dtype=bool)
        zero = np.zeros(m)
        iters = np.zeros(m, dtype=int)
        if not jac:
            return _Eval(q, kern.residual(kin, T_P, rotation), None, closed, zero, iters)
        x, Jq = kern.residual_jacobian(kin, T_P, rotation)
        S = np.broadcast_to(-kern.coupling.S[kern.iw], (m, kern.iw.size, kern.iv.size))
        return _Eval(q, x, Jq @ kern.coupling.S, closed, zero, iters, S)
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
                        max_iter=max_iter, keep_kinematics=True)
    q = res.q
    closed = res.ok & np.all(np.isfinite(q), axis=1)
    # the closure's last Newton iterate is at q already: its poses and Jacobian, not an FK
    # again (the same numbers; measured: 18 % of a numpy closed-chain lm evaluation)
    kin = (kern.kinematics(q) if res.T_links is None
           else Kinematics(q=q, T_links=res.T_links, mech=mech))
    if not jac:
        return _Eval(q, kern.residual(kin, T_P, rotation), None, closed, res.residual,
                     res.iterations)
    x, Jq = kern.residual_jacobian(kin, T_P, rotation)
    Phi = closure_jacobian(mech, kin)[1] if res.jacobian is None else res.jacobian
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
    kern = kernel or kernel_for(mech, frame)
    ev = evaluate(kern, np.atleast_2d(q_v), np.atleast_2d(q_w0).reshape(1, -1),
                  np.asarray(T_P, dtype=float)[None], jac=False)
    x = ev.x[0]
    return 0.5 * float(x @ (np.asarray(weights) * x)), x, ev.q[0]


def reduced_jacobian(mech: Mechanism, q_v: np.ndarray, q_w0: np.ndarray, T_P: np.ndarray, *,
                     frame: int | None = None, kernel: IkKernel | None = None,
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x (6,), dx/dq_v (6, n_v) (kim1995 Eq. (10)) and q (n,) after the loop closure."""
    kern = kernel or kernel_for(mech, frame)
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



def pose_errors(T_E: np.ndarray, T_P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position error ||p_E - p_P|| [m] and orientation error angle(R_P^T R_E) [rad]; (m,)."""
    dp = np.linalg.norm(T_E[..., :3, 3] - T_P[..., :3, 3], axis=-1)
    e = quat_from_matrix(np.swapaxes(T_P[..., :3, :3], -1, -2) @ T_E[..., :3, :3])
    ang = 2.0 * np.arctan2(np.linalg.norm(e[..., 1:], axis=-1), np.abs(e[..., 0]))
    return dp, ang

