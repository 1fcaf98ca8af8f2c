r"""Inverse dynamics of closed and complex chains: Newton-Euler on the spanning tree, projected.

Design
------
A mechanism is a tree of 1-DOF joints closed by cut links (kim1995 §2). Cutting the loops open
leaves the spanning tree, whose inverse dynamics is recursive Newton-Euler with branches
allowed; the loops then only restrict the motion. By the virtual-work principle the torques of
the independent (actuated) joints that produce a motion of the closed chain are the tree torques
projected on the independent joints:

.. math:: \tau_v = (L_v + L_w S)^T\,\tau_{tree}(q, \dot q, \ddot q),
          \qquad S = \frac{\partial q_w}{\partial q_v} = -\Phi_w^+\Phi_v

(kim1995 Eq. (3)-(4) differentiated; ``Phi = d phi_R / dq``). The constraint forces of the cut
links do no work on a motion that keeps the loops closed, ``Phi (L_v + L_w S) = 0``, so they
drop out; the passive joints carry no torque. The motion of the tree must close the loops:
from the independent rates and accelerations,

.. math:: \dot q_w = S \dot q_v, \qquad
          \ddot q_w = -\Phi_w^+\left(\Phi_v \ddot q_v + \gamma(q, \dot q)\right)

with the analytic quadratic term ``gamma`` of :mod:`mechkin.model.differential`.

Joint couplings (mimic joints, :mod:`mechkin.model.couplings`) are rows of ``Phi`` too: a row
``q_j - m q_i - c`` gives ``S = m`` for the coupled joint, so ``qd_j = m qd_i``,
``qdd_j = m qdd_i`` (``gamma = 0``: the row is linear) and ``tau_i = tau_tree,i + m tau_tree,j``,
the coupled joint's torque carried by its master (tests/solvers/test_dynamics_couplings.py:
Pinocchio's own mimic joints).

The tree recursion is written with Featherstone's spatial vectors in the base frame, referred to
the base origin (Featherstone 2008, ch. 5 and §9.2 for trees): the link velocities and
accelerations ``V_l``, ``A_l`` come from :func:`mechkin.model.differential.link_motion` (the
forward pass), gravity enters as a base acceleration ``-g`` (Featherstone §5.3), each link's
net force is

.. math:: f_l = I_l A_l + V_l \times^* I_l V_l

(``I_l`` the spatial inertia in base coordinates) and the backward pass sums the forces of the
links each joint carries, ``F_j = sum_{l in subtree(j)} f_l`` (one product with
``mech.link_ancestors``), so ``tau_j = xi_j . F_j`` with ``xi_j`` the joint's unit twist. On an
open serial chain this is the same recursion as
:class:`mechkin.solvers.dynamics.open_chain.SerialChainDynamics` in other coordinates (a test
checks that).

Interfaces (:class:`mechkin.solvers.dynamics.open_chain.InverseDynamics`)
-------------------------------------------------------------
- :class:`ClosedChainDynamics` takes ``q, qd, qdd (m, n)`` of **all** joints, ``q`` assembled;
  only the independent columns of ``qd`` and ``qdd`` are used (the dependent ones are derived as
  above, so the torques are those of a motion that keeps the loops closed), and it returns
  ``tau (m, n)``: ``tau_v`` in the independent columns, 0 in the passive ones. This is what the
  track DP uses (its path gives all joints, so the joint position limits of passive joints are
  DP constraints too); ``U = a r'' + b r'^2 + g`` stays exact (park Eq. (12)) because
  ``qd_w`` is linear in ``qd_v`` and ``qdd_w`` affine in ``qdd_v`` and quadratic in ``qd``.
- :meth:`ClosedChainDynamics.independent` gives an :class:`IndependentJointDynamics` of
  ``q_v, qd_v, qdd_v (m, n_v) -> tau_v (m, n_v)``, which closes the loops itself from a
  reference configuration (the assembly mode nearest it).

Imports: numpy, model, errors.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mechkin.errors import ModelError
from mechkin.model.closure import ClosureStatus, dependent_sensitivity, solve_closure
from mechkin.model.differential import (
    LinkMotion,
    _ancestors,
    _closure_second_derivative,
    joint_twists,
    link_motion,
)
from mechkin.model.kinematics import Kinematics, _cross, closure_jacobian, forward_kinematics
from mechkin.model.mechanism import Mechanism
from mechkin.model.reduced import _svd_pinv
from mechkin.model.singularity import constraint_scaling, resolve_length_scale

__all__ = ["ClosedChainDynamics", "ClosedMotion", "IndependentJointDynamics",
           "closed_chain_dynamics", "closed_motion", "sensitivity"]


@dataclass(frozen=True)
class ClosedMotion:
    """Joint motion of a closed chain from that of its independent joints.

    Attributes
    ----------
    q, qd, qdd : (m, n)
        All joints; ``qd_w = S qd_v``, ``qdd_w = -Phi_w^+ (Phi_v qdd_v + gamma)``.
    S : (m, n_w, n_v)
        ``dq_w / dq_v``.
    kin : Kinematics
        Forward kinematics of ``q``.
    lm : LinkMotion
        Spatial velocities and accelerations of every link (base frame, base origin).
    """

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    S: np.ndarray
    kin: Kinematics
    lm: LinkMotion


def _pinv(P: np.ndarray) -> np.ndarray:
    """Pseudo-inverse (m, c, r) of the nondimensionalised ``Phi_w (m, r, c)``.

    With full column rank (the regular case) ``Phi_w^+ = (Phi_w^T Phi_w)^{-1} Phi_w^T``, or
    ``Phi_w^{-1}`` when square, by LU: the same matrix as the SVD pseudo-inverse, several times
    cheaper for the Stewart platform's 30 x 30 blocks. Rows where that fails (rank lost, a
    constraint singularity) take the SVD one of :func:`mechkin.model.reduced._svd_pinv`
    (minimum-norm rates, singular values below ``RCOND * sigma_max`` dropped).
    """
    m, r, c = P.shape
    out = np.full((m, c, r), np.nan)
    if m == 0 or c == 0:
        return np.zeros((m, c, r))
    with np.errstate(all="ignore"):
        try:
            if r == c:
                out = np.linalg.inv(P)
            else:
                Pt = np.swapaxes(P, 1, 2)
                out = np.linalg.solve(Pt @ P, Pt)
        except np.linalg.LinAlgError:
            pass
        # a singular or nearly singular block passes LU with inf or garbage: keep the rows
        # whose inverse reproduces the identity on the columns
        resid = np.abs(out @ P - np.eye(c)).max(axis=(1, 2))
        bad = ~(resid < 1e-8)
    if bad.any():
        out[bad] = _svd_pinv(P[bad])[0]
    return out


class _Geometry:
    """Per-configuration quantities shared by the calls at one q (kinematics, Phi^+, S)."""

    def __init__(self, mech: Mechanism, q: np.ndarray, length_scale: float) -> None:
        self.kin = forward_kinematics(mech, q)
        self.xi = joint_twists(mech, self.kin)
        iv, iw = mech.independent, mech.dependent
        m = q.shape[0]
        if len(iw):
            _, Phi = closure_jacobian(mech, self.kin)
            row, col = constraint_scaling(mech, length_scale)
            Pinv = _pinv(Phi[:, :, iw] * row[None, :, None] * col[None, None, :])
            self.Pinv = Pinv * col[None, :, None] * row[None, None, :]
            self.Phi_v = Phi[:, :, iv]
            self.S = -self.Pinv @ self.Phi_v
        else:
            self.Pinv = np.zeros((m, 0, mech.n_equations))
            self.Phi_v = np.zeros((m, mech.n_equations, len(iv)))
            self.S = np.zeros((m, 0, len(iv)))


def _geometry(mech: Mechanism, q: np.ndarray, length_scale: float,
              cache: dict | None = None) -> _Geometry:
    if cache is None:
        return _Geometry(mech, q, length_scale)
    key = (q.shape, q.tobytes())
    g = cache.get(key)
    if g is None:
        cache.clear()  # one entry: the DP evaluates one grid of q several times in a row
        g = cache[key] = _Geometry(mech, q, length_scale)
    return g


def _as_batch(x, n: int, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        a = a[None]
    if a.ndim != 2 or a.shape[1] != n:
        raise ValueError(f"{name}: expected shape (m, {n}), got {a.shape}")
    return a


def _motion(mech: Mechanism, geo: _Geometry, qd_v: np.ndarray, qdd_v: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, LinkMotion]:
    """All joint rates and accelerations closing the loops, and the link motion."""
    qd = mech.assemble(qd_v, np.einsum("mij,mj->mi", geo.S, qd_v))
    lm0 = link_motion(mech, geo.kin, qd, xi=geo.xi)  # qdd = 0: velocity-product terms
    if len(mech.dependent):
        gamma = _closure_second_derivative(mech, geo.kin, lm0)
        rhs = np.einsum("mij,mj->mi", geo.Phi_v, qdd_v) + gamma
        qdd = mech.assemble(qdd_v, -np.einsum("mij,mj->mi", geo.Pinv, rhs))
    else:
        qdd = mech.assemble(qdd_v, np.zeros((qd.shape[0], 0)))
    lm = LinkMotion(lm0.V, lm0.A + _ancestors(mech) @ (geo.xi * qdd[..., None]))
    return qd, qdd, lm


def sensitivity(mech: Mechanism, q: np.ndarray, *, length_scale: float | None = None
                ) -> np.ndarray:
    """``S = dq_w/dq_v = -Phi_w^+ Phi_v (m, n_w, n_v)`` at assembled ``q (m, n)`` (kim1995
    Eq. (4) differentiated; the pseudo-inverse of :func:`_pinv`, nondimensionalised)."""
    q = _as_batch(q, mech.n, "q")
    return _Geometry(mech, q, resolve_length_scale(mech, length_scale)).S


def closed_motion(mech: Mechanism, q: np.ndarray, qd_v: np.ndarray,
                  qdd_v: np.ndarray | None = None, *, length_scale: float | None = None
                  ) -> ClosedMotion:
    r"""Rates and accelerations of all joints of a closed chain from the independent ones.

    .. math:: \dot q_w = S\dot q_v,\qquad
              \ddot q_w = -\Phi_w^+(\Phi_v \ddot q_v + \gamma(q, \dot q))

    (kim1995 Eq. (3)-(4) differentiated once and twice; ``Phi_w^+`` the pseudo-inverse of the
    nondimensionalised ``Phi_w`` as in :func:`mechkin.model.differential.motion_derivatives`,
    without its singularity classification).

    Parameters
    ----------
    q : (m, n) assembled configurations (all joints).
    qd_v, qdd_v : (m, n_v) independent rates and accelerations; ``qdd_v = None`` means zero.
    """
    q = _as_batch(q, mech.n, "q")
    nv = len(mech.independent)
    qd_v = np.broadcast_to(_as_batch(qd_v, nv, "qd_v"), (q.shape[0], nv))
    qdd_v = (np.zeros_like(qd_v) if qdd_v is None
             else np.broadcast_to(_as_batch(qdd_v, nv, "qdd_v"), qd_v.shape))
    geo = _Geometry(mech, q, resolve_length_scale(mech, length_scale))
    qd, qdd, lm = _motion(mech, geo, qd_v, qdd_v)
    return ClosedMotion(q=q, qd=qd, qdd=qdd, S=geo.S, kin=geo.kin, lm=lm)


def _inertia_times(mass: np.ndarray, c: np.ndarray, Ic: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Spatial inertia (about the base origin) times motion vectors ``X (m, nl, 6)``.

    For a body of mass m, centre of mass c and central inertia Ic (base frame), ``I (w, v) =
    (Ic w + c x m (v + w x c), m (v + w x c))``: the angular momentum about the origin and the
    linear momentum (Featherstone 2008, Eq. 2.63, written without the 6x6 matrix).
    """
    w, v = X[..., :3], X[..., 3:]
    lin = mass[None, :, None] * (v + _cross(w, c))
    out = np.empty(X.shape)
    out[..., :3] = (Ic @ w[..., None])[..., 0] + _cross(c, lin)
    out[..., 3:] = lin
    return out


def _cross_force(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """``V x* F`` over the last axis (6,): (w x n + v x f, w x f)."""
    w, v = V[..., :3], V[..., 3:]
    n, f = F[..., :3], F[..., 3:]
    out = np.empty(np.broadcast_shapes(V.shape, F.shape))
    out[..., :3] = _cross(w, n) + _cross(v, f)
    out[..., 3:] = _cross(w, f)
    return out


@dataclass(frozen=True, eq=False)
class ClosedChainDynamics:
    r"""Inverse dynamics of a mechanism with cut links (or a branching tree), all-joint interface.

    Parameters
    ----------
    mech : Mechanism
        Any mechanism: closed (cut links), branching or serial. The inertial parameters of its
        links (mass, centre of mass and inertia about it, link frame) are used; cut links and
        the virtual links of compound joints are usually massless.
    gravity : array (3,), optional
        Gravitational acceleration in the base frame [m/s^2]; default ``mech.gravity``.
    length_scale : float, optional
        Characteristic length of the nondimensionalised ``Phi_w`` (default: the mechanism's).

    Notes
    -----
    ``inverse_dynamics(q, qd, qdd)`` uses the independent columns of ``qd, qdd`` and returns
    ``tau (m, n)`` with ``tau_v = (L_v + L_w S)^T tau_tree`` in the independent columns and 0 in
    the dependent ones (module docstring). ``q`` must be assembled (the loops closed).
    """

    mech: Mechanism
    gravity: np.ndarray | None = None
    length_scale: float | None = None
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        g = np.asarray(self.mech.gravity if self.gravity is None else self.gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"gravity: expected a finite (3,) vector, got {g!r}")
        object.__setattr__(self, "gravity", g)
        object.__setattr__(self, "length_scale",
                           resolve_length_scale(self.mech, self.length_scale))
        mass = np.asarray(self.mech.mass, dtype=float)
        if not np.any(mass > 0):
            raise ModelError(f"{self.mech.name}: dynamics: no link has a mass; add 'inertial:' "
                             "to the links of the mechanism file")

    # ---- sizes --------------------------------------------------------------------------------

    @property
    def n_joints(self) -> int:
        """Number of joints n (all joints: the DP's path gives them all)."""
        return int(self.mech.n)

    @property
    def n_independent(self) -> int:
        """Number of independent (actuated) joints n_v."""
        return len(self.mech.independent)

    # ---- the tree -----------------------------------------------------------------------------

    def _link_inertias(self, kin: Kinematics) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Masses (nl,), centres of mass (m, nl, 3) and central inertias (m, nl, 3, 3), base."""
        mech = self.mech
        R = kin.T_links[..., :3, :3]
        c = (R @ mech.com[None, :, :, None])[..., 0] + kin.T_links[..., :3, 3]
        Ic = R @ mech.inertia[None] @ np.swapaxes(R, -1, -2)
        return np.asarray(mech.mass, dtype=float), c, Ic

    def _tree_torques(self, kin: Kinematics, xi: np.ndarray, lm: LinkMotion,
                      gravity: np.ndarray) -> np.ndarray:
        """Tree RNEA backward pass from the link motion (module docstring): ``tau_tree (m, n)``."""
        mass, c, Ic = self._link_inertias(kin)
        A = lm.A.copy()
        A[..., 3:] -= gravity  # Featherstone §5.3: the base accelerates against gravity
        f = _inertia_times(mass, c, Ic, A) + _cross_force(lm.V, _inertia_times(mass, c, Ic, lm.V))
        F = _ancestors(self.mech).T @ f  # (m, n, 6): forces carried by each joint
        return np.einsum("mjk,mjk->mj", xi, F)

    def tree_inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                              gravity: np.ndarray | None = None) -> np.ndarray:
        """Recursive Newton-Euler on the spanning tree (loops cut open): ``tau_tree (m, n)``.

        Every joint moves as given (no closure); the torque of joint j is the force that the
        links it carries need, ``xi_j . sum_{l in subtree(j)} (I_l A_l + V_l x* I_l V_l)``.
        """
        n = self.mech.n
        q, qd, qdd = (_as_batch(x, n, nm) for x, nm in ((q, "q"), (qd, "qd"), (qdd, "qdd")))
        kin = forward_kinematics(self.mech, q)
        xi = joint_twists(self.mech, kin)
        lm = link_motion(self.mech, kin, qd, qdd, xi=xi)
        g = self.gravity if gravity is None else np.asarray(gravity, dtype=float)
        return self._tree_torques(kin, xi, lm, g)

    # ---- the closed chain ---------------------------------------------------------------------

    def independent_torques(self, q: np.ndarray, qd_v: np.ndarray, qdd_v: np.ndarray
                            ) -> np.ndarray:
        r"""``tau_v (m, n_v) = (L_v + L_w S)^T tau_tree`` for assembled ``q (m, n)`` and the
        independent rates and accelerations ``qd_v, qdd_v (m, n_v)`` (module docstring)."""
        mech = self.mech
        q = _as_batch(q, mech.n, "q")
        nv = len(mech.independent)
        qd_v = _as_batch(qd_v, nv, "qd_v")
        qdd_v = _as_batch(qdd_v, nv, "qdd_v")
        geo = _geometry(mech, q, self.length_scale, self._cache)
        _, _, lm = _motion(mech, geo, qd_v, qdd_v)
        tau = self._tree_torques(geo.kin, geo.xi, lm, self.gravity)
        return tau[:, mech.independent] + np.einsum("mwv,mw->mv", geo.S, tau[:, mech.dependent])

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """``tau (m, n)``: ``tau_v`` in the independent columns, 0 in the dependent ones.

        ``q`` assembled; the dependent columns of ``qd`` and ``qdd`` are not read (they are
        derived from the independent ones so that the loops stay closed).
        """
        mech = self.mech
        n = mech.n
        qd = _as_batch(qd, n, "qd")
        qdd = _as_batch(qdd, n, "qdd")
        tau_v = self.independent_torques(q, qd[:, mech.independent], qdd[:, mech.independent])
        out = np.zeros((tau_v.shape[0], n))
        out[:, mech.independent] = tau_v
        return out

    def motion(self, q: np.ndarray, qd_v: np.ndarray, qdd_v: np.ndarray | None = None
               ) -> ClosedMotion:
        """All joint rates and accelerations closing the loops (:func:`closed_motion`)."""
        return closed_motion(self.mech, q, qd_v, qdd_v, length_scale=self.length_scale)

    # ---- energy (checks) ----------------------------------------------------------------------

    def kinetic_energy(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """``sum_l 1/2 V_l . I_l V_l`` (m,) [J] for all-joint rates ``qd (m, n)`` as given."""
        q = _as_batch(q, self.mech.n, "q")
        kin = forward_kinematics(self.mech, q)
        V = link_motion(self.mech, kin, _as_batch(qd, self.mech.n, "qd")).V
        mass, c, Ic = self._link_inertias(kin)
        return 0.5 * np.einsum("mlk,mlk->m", V, _inertia_times(mass, c, Ic, V))

    def potential_energy(self, q: np.ndarray) -> np.ndarray:
        """``-sum_l m_l g . c_l`` (m,) [J], zero at the base origin."""
        kin = forward_kinematics(self.mech, _as_batch(q, self.mech.n, "q"))
        mass, c, _ = self._link_inertias(kin)
        return -np.einsum("l,mli,i->m", mass, c, self.gravity)

    # ---- the independent-joint interface ------------------------------------------------------

    def independent(self, q_ref: np.ndarray | None = None) -> IndependentJointDynamics:
        """The ``q_v, qd_v, qdd_v -> tau_v`` interface, closing the loops from ``q_ref``
        (default ``mech.home``, closed first)."""
        return IndependentJointDynamics(self, q_ref)


class IndependentJointDynamics:
    """``InverseDynamics`` of a closed chain in its independent joints: ``(m, n_v)`` arrays.

    The dependent joints are solved by the loop closure (:func:`mechkin.model.closure.
    solve_closure`) from the reference configuration, moved to first order,
    ``q_w = q_w,ref + S_ref (q_v - q_v,ref)``: the assembly mode of the reference, as long as
    ``q_v`` stays near it. A configuration that does not close raises :class:`ModelError`.
    """

    def __init__(self, closed: ClosedChainDynamics, q_ref: np.ndarray | None = None) -> None:
        mech = closed.mech
        self.closed = closed
        q0 = np.asarray(mech.home if q_ref is None else q_ref, dtype=float).reshape(1, mech.n)
        res = solve_closure(mech, q0[:, mech.independent], q0[:, mech.dependent])
        if res.status[0] is not ClosureStatus.CONVERGED:
            raise ModelError(f"{mech.name}: dynamics: the reference configuration does not "
                             f"close its loops (residual {res.residual[0]:.3g})")
        self.q_ref = res.q[0]
        self.S_ref = dependent_sensitivity(mech, res.q)[0]

    @property
    def n_joints(self) -> int:
        """Number of independent joints n_v."""
        return self.closed.n_independent

    def configurations(self, q_v: np.ndarray) -> np.ndarray:
        """Assembled ``q (m, n)`` for ``q_v (m, n_v)`` (class docstring)."""
        mech = self.closed.mech
        q_v = _as_batch(q_v, self.n_joints, "q_v")
        guess = (self.q_ref[mech.dependent]
                 + (q_v - self.q_ref[mech.independent]) @ self.S_ref.T)
        res = solve_closure(mech, q_v, guess)
        bad = np.flatnonzero(~res.ok)
        if bad.size:
            k = int(bad[0])
            raise ModelError(f"{mech.name}: dynamics: q_v = {np.round(q_v[k], 6).tolist()} does "
                             f"not close the loops ({res.status[k].value}, residual "
                             f"{res.residual[k]:.3g})")
        return res.q

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """``tau_v (m, n_v)`` for ``q_v, qd_v, qdd_v (m, n_v)``."""
        return self.closed.independent_torques(self.configurations(q), qd, qdd)


def closed_chain_dynamics(mech: Mechanism) -> ClosedChainDynamics:
    """Tree Newton-Euler dynamics projected on the independent joints (module docstring)."""
    return ClosedChainDynamics(mech)
