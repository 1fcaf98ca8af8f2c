r"""Differential kinematics of complex chains: joint rates, twists and accelerations (kim1995 §2).

Design
------
kim1995 writes every mechanism as a tree of 1-DOF joints closed by cut links, with the joint
vector split as ``q = L_v q_v + L_w q_w`` (Eq. (3)) and the loop closure ``phi_R(q_v, q_w) = 0``
(Eq. (4): per cut, the position of frame b in frame a and the vector part of the Euler
parameters of ``R_a^T R_b``). Differentiating Eq. (4) once and twice along a motion gives

.. math:: \Phi_w \dot q_w = -\Phi_v \dot q_v
          \quad\Rightarrow\quad \dot q_w = S \dot q_v,\quad S = -\Phi_w^+ \Phi_v

.. math:: \Phi_w \ddot q_w = -(\Phi_v \ddot q_v + \gamma(q, \dot q)),
          \quad \gamma = \dot\Phi \dot q

with ``Phi_w = d phi/d q_w``, ``Phi_v = d phi/d q_v`` (:func:`closure_jacobian`). The pseudo-inverse
is the SVD one of the nondimensionalised ``Phi_w`` (lengths divided by the characteristic
length, :mod:`mechkin.model.singularity`; the direct-drive arm's planar loop has 6 equations of
rank 3). While ``Phi_w`` has full column rank this is the exact solution; at a constraint
singularity (rank lost) it returns the minimum-norm rates in those units and the record says
so.

The quadratic term ``gamma`` is analytic, from the structure of the cut residual: with the link
twists and the velocity-product ("bias") accelerations of the tree
(:func:`link_motion`, ``qdd = 0``), for a cut between frames a and b, ``d = p_b - p_a``,

.. math:: \gamma_p = R_a^T\left(\ddot d - \alpha_a\times d - 2\,\omega_a\times\dot d
          + \omega_a\times(\omega_a\times d)\right)

(the second derivative of ``R_a^T d``), and with ``e = (e_0, e_v)`` the Euler parameters of
``R_a^T R_b``, ``omega_r = R_a^T(omega_b - omega_a)`` the relative angular velocity in frame a
and ``omega_r' = R_a^T(alpha_b - alpha_a - omega_a x (omega_b - omega_a))``,

.. math:: \dot e_0 = -\tfrac12\,\omega_r\cdot e_v,\qquad
          \dot e_v = \tfrac12(e_0\,\omega_r + \omega_r\times e_v),\qquad
          \gamma_e = \tfrac12(\dot e_0\,\omega_r + e_0\,\dot\omega_r + \dot\omega_r\times e_v
          + \omega_r\times\dot e_v)

(the second derivative of the vector part, from ``e' = 1/2 (0, omega_r) e``). Both hold for any
joint motion, on or off the closure manifold, so ``gamma`` can be checked against finite
differences of the Jacobian (tests/model/test_differential.py).

Conventions
-----------
Everything is expressed in the base frame. A twist is ``(omega, v)`` with ``v`` the velocity of
the frame's **origin** (as :func:`frame_jacobian`); a classical acceleration is
``(alpha, a)`` with ``a`` the second time derivative of the origin's position. The spatial
(Featherstone) acceleration, the derivative of the twist referred to the base origin, is
``(alpha, a - alpha x p - omega x v)``; :attr:`MotionDerivatives.spatial_accelerations`.
Batches put the sample axis first. SI units: rad, m, s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechkin.model.kinematics import (
    Kinematics,
    _cross,
    _cut_arrays,
    closure_jacobian,
    forward_kinematics,
)
from mechkin.model.mechanism import Mechanism
from mechkin.model.reduced import (
    RCOND,
    _frame_indices,
    _svd_pinv,
    reduced_jacobian,
    scatter_rows,
)
from mechkin.model.singularity import (
    SingularityReport,
    classify,
    constraint_scaling,
    resolve_length_scale,
)
from mechkin.spatial.rotations import quat_from_matrix

__all__ = ["RCOND", "reduced_jacobian", "scatter_rows"]



@dataclass(frozen=True)
class LinkMotion:
    """Spatial velocities and accelerations of every link, referred to the base origin.

    V, A : (m, nl, 6) ``(omega, v_O)`` and its time derivative ``(alpha, a_O)``, where ``v_O``
    is the velocity of the body point at the base origin (Featherstone's spatial vectors,
    base frame). :func:`frame_motion` turns them into twists and classical accelerations of
    frame origins.
    """

    V: np.ndarray
    A: np.ndarray


def joint_twists(mech: Mechanism, kin: Kinematics) -> np.ndarray:
    """Unit twists xi_j (m, n, 6) of the joints, base frame, referred to the base origin.

    Revolute: ``(z, o x z)``; prismatic: ``(0, z)`` (z the axis, o a point on it; kim1995
    Eq. (2): s_i picks the kind). ``xi_j qd_j`` is the velocity of joint j's child link
    relative to its parent.
    """
    z, o = kin.axes()
    rev = (mech.s == 0)[None, :, None]
    xi = np.empty(z.shape[:2] + (6,))
    xi[..., :3] = np.where(rev, z, 0.0)
    xi[..., 3:] = np.where(rev, _cross(o, z), z)
    return xi


def _crm(V: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Spatial motion cross product ``V x X`` over the last axis (6,): (w x a, v x a + w x b)."""
    w, v = V[..., :3], V[..., 3:]
    a, b = X[..., :3], X[..., 3:]
    out = np.empty(np.broadcast_shapes(V.shape, X.shape))
    out[..., :3] = _cross(w, a)
    out[..., 3:] = _cross(v, a) + _cross(w, b)
    return out


def _ancestors(mech: Mechanism) -> np.ndarray:
    cache = mech.__dict__.get("_ancestors_f")
    if cache is None:
        cache = mech.link_ancestors.astype(np.float64)
        object.__setattr__(mech, "_ancestors_f", cache)
    return cache


def link_motion(mech: Mechanism, kin: Kinematics, qd: np.ndarray,
                qdd: np.ndarray | None = None, *, xi: np.ndarray | None = None) -> LinkMotion:
    r"""Spatial velocities and accelerations of all links of the tree (all joints moving).

    .. math:: V_l = \sum_{j \prec l} \xi_j \dot q_j,\qquad
              A_l = \sum_{j \prec l} \left(\xi_j \ddot q_j
              + (V_{p(j)} \times \xi_j)\,\dot q_j\right)

    over the joints j on the path from the base to link l, with ``xi_j`` the joint's unit twist
    (:func:`joint_twists`) and ``V_p(j)`` the spatial velocity of its parent link: the axis is
    fixed in the parent, so ``xi_j' = V_p(j) x xi_j`` (spatial motion cross product). This is
    the time derivative of the kim1995 Eq. (2) chain ``A Z(q) B``; the sums over the tree are
    one product with ``mech.link_ancestors``. ``qdd = None`` gives the velocity-product
    accelerations (``A`` at ``qdd = 0``).

    Parameters
    ----------
    qd, qdd : (m, n) joint rates [rad/s | m/s] and accelerations [rad/s^2 | m/s^2].
    xi : (m, n, 6), optional; the joint twists if already computed.
    """
    xi = joint_twists(mech, kin) if xi is None else xi
    anc = _ancestors(mech)  # (nl, n)
    qd = np.asarray(qd, dtype=np.float64)
    V = anc @ (xi * qd[..., None])  # (m, nl, 6)
    Vp = V[:, mech.joint_parent_link]  # (m, n, 6)
    rate = _crm(Vp, xi) * qd[..., None]
    if qdd is not None:
        rate = rate + xi * np.asarray(qdd, dtype=np.float64)[..., None]
    return LinkMotion(V, anc @ rate)


def frame_motion(mech: Mechanism, kin: Kinematics, lm: LinkMotion, idx: np.ndarray):
    """Twists (m, k, 6) and classical accelerations (m, k, 6) of frames ``idx`` (origins).

    From the spatial vectors of the frame's link and the origin p:
    ``omega``, ``v_p = v_O + omega x p``, ``alpha``, ``a_p = a_O + alpha x p + omega x v_p``.
    """
    idx = np.asarray(idx, dtype=int)
    lk = mech.frame_link[idx]
    p = kin.frames(mech, idx)[:, :, :3, 3]
    V, A = lm.V[:, lk], lm.A[:, lk]
    w, al = V[..., :3], A[..., :3]
    tw = np.empty(V.shape)
    acc = np.empty(V.shape)
    tw[..., :3] = w
    tw[..., 3:] = V[..., 3:] + _cross(w, p)
    acc[..., :3] = al
    acc[..., 3:] = A[..., 3:] + _cross(al, p) + _cross(w, tw[..., 3:])
    return tw, acc


def _closure_second_derivative(mech: Mechanism, kin: Kinematics, lm: LinkMotion) -> np.ndarray:
    """d^2 phi_R / dt^2 (m, n_eq) from the frame motion of the cut frames (module docstring)."""
    m = kin.q.shape[0]
    if not mech.cuts:  # coupling rows are linear in q: no quadratic term
        return np.zeros((m, len(mech.couplings)))
    fa, fb, mask = _cut_arrays(mech)
    Ta, Tb = kin.frames(mech, fa), kin.frames(mech, fb)
    twa, acca = frame_motion(mech, kin, lm, fa)
    twb, accb = frame_motion(mech, kin, lm, fb)
    Ra = Ta[..., :3, :3]
    RaT = np.swapaxes(Ra, -1, -2)
    wa, wb, ala, alb = twa[..., :3], twb[..., :3], acca[..., :3], accb[..., :3]
    d = Tb[..., :3, 3] - Ta[..., :3, 3]
    dd = twb[..., 3:] - twa[..., 3:]
    ddd = accb[..., 3:] - acca[..., 3:]
    gp = ddd - _cross(ala, d) - 2.0 * _cross(wa, dd) + _cross(wa, _cross(wa, d))

    def to_a(x):
        return (RaT @ x[..., None])[..., 0]

    dw = wb - wa
    wr = to_a(dw)
    wrd = to_a(alb - ala - _cross(wa, dw))
    e = quat_from_matrix(RaT @ Tb[..., :3, :3])
    e0, ev = e[..., :1], e[..., 1:]
    e0d = -0.5 * np.sum(wr * ev, axis=-1, keepdims=True)
    evd = 0.5 * (e0 * wr + _cross(wr, ev))
    ge = 0.5 * (e0d * wr + e0 * wrd + _cross(wrd, ev) + _cross(wr, evd))
    x = np.concatenate([to_a(gp), ge], axis=-1)  # (m, nc, 6)
    return np.concatenate([x[:, mask], np.zeros((m, len(mech.couplings)))], axis=1)


def closure_bias(mech: Mechanism, q: np.ndarray | Kinematics, qd: np.ndarray) -> np.ndarray:
    r"""The quadratic term gamma(q, qd) = (d/dt dphi_R/dq) qd of the closure (m, n_eq).

    With it, the second derivative of kim1995 Eq. (4) along any motion is
    ``phi'' = (dphi/dq) q'' + gamma``. Analytic (module docstring); valid for any q and qd (all
    joints), whether or not q closes the loops.

    Parameters
    ----------
    q : (m, n) joint values, or their :class:`Kinematics`.
    qd : (m, n) rates of all joints.
    """
    kin = q if isinstance(q, Kinematics) else forward_kinematics(mech, np.atleast_2d(q))
    qd = np.broadcast_to(np.asarray(qd, dtype=np.float64), kin.q.shape)
    return _closure_second_derivative(mech, kin, link_motion(mech, kin, qd))


@dataclass(frozen=True)
class MotionDerivatives:
    r"""Joint rates, frame twists and accelerations of a batch of configurations.

    Attributes
    ----------
    q, qd, qdd : (m, n)
        All joints: positions, rates (kim1995 Eq. (3) differentiated: ``qd_w = S qd_v``) and
        accelerations [rad | m, /s, /s^2].
    S : (m, n_w, n_v)
        ``dq_w/dq_v = -Phi_w^+ Phi_v`` (kim1995 Eq. (4) differentiated).
    gamma : (m, n_eq)
        Quadratic term of the closure acceleration, ``Phi q'' + gamma = 0``.
    closure_rate_residual, closure_accel_residual : (m,)
        ``||Phi qd||`` and ``||Phi qdd + gamma||``: zero up to round-off unless ``Phi_w`` is
        rank deficient and the motion ``qd_v`` is not compatible (constraint singularity).
    frames : (k,) int; frame_names : tuple of str
    twists : (m, k, 6)
        ``(omega, v)`` of each frame, base frame, ``v`` = velocity of the frame's origin.
    accelerations : (m, k, 6)
        Classical ``(alpha, a)``: ``a`` = acceleration of the frame's origin, base frame.
    singularity : SingularityReport
        Condition numbers of ``Phi_w`` and of the reduced Jacobian, and the classification
        (:func:`mechkin.model.singularity.classify`).
    """

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    S: np.ndarray
    gamma: np.ndarray
    closure_rate_residual: np.ndarray
    closure_accel_residual: np.ndarray
    frames: np.ndarray
    frame_names: tuple[str, ...]
    twists: np.ndarray
    accelerations: np.ndarray
    positions: np.ndarray
    singularity: SingularityReport

    @property
    def spatial_accelerations(self) -> np.ndarray:
        """Featherstone spatial accelerations (m, k, 6) referred to the base origin.

        ``(alpha, a - alpha x p - omega x v)``: the time derivative of the twist
        ``(omega, v - omega x p)`` of the body point at the base origin.
        """
        w, v = self.twists[..., :3], self.twists[..., 3:]
        al, a = self.accelerations[..., :3], self.accelerations[..., 3:]
        p = self.positions
        return np.concatenate([al, a - _cross(al, p) - _cross(w, v)], axis=-1)

    def frame(self, name: str) -> int:
        """Column of frame ``name`` in :attr:`twists` / :attr:`accelerations`."""
        try:
            return self.frame_names.index(name)
        except ValueError:
            raise KeyError(f"frame {name!r} not in this record "
                           f"(frames: {', '.join(self.frame_names)})") from None


def _as_batch(x, m: int, width: int, what: str) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[None]
    if x.ndim != 2 or x.shape[1] != width or x.shape[0] not in (1, m):
        raise ValueError(f"{what}: expected shape ({m}, {width}), got {x.shape}")
    return np.broadcast_to(x, (m, width))


def motion_derivatives(
    mech: Mechanism,
    q: np.ndarray,
    qd_v: np.ndarray,
    qdd_v: np.ndarray | None = None,
    frames=None,
    *,
    end_effector: int | str | None = None,
    length_scale: float | None = None,
    tol_singular: float | None = None,
    tol_near: float | None = None,
) -> MotionDerivatives:
    r"""Rates and accelerations of every joint and frame from those of the independent joints.

    .. math:: \dot q_w = S\dot q_v,\qquad
              \ddot q_w = -\Phi_w^+(\Phi_v \ddot q_v + \gamma(q, \dot q))

    (kim1995 Eq. (3)-(4) differentiated once and twice; ``gamma`` analytic, see the module
    docstring), then the frame twists and accelerations from :func:`link_motion`.

    Parameters
    ----------
    mech : Mechanism
    q : (m, n)
        Assembled configurations (all joints; e.g. ``solve_trajectory(...).q``).
    qd_v, qdd_v : (m, n_v) or (n_v,)
        Rates and accelerations of the independent joints [rad | m, /s, /s^2]; ``qdd_v = None``
        means zero.
    frames : None, or a list of frame names / indices
        Frames whose twists and accelerations are returned (all frames when None).
    end_effector, length_scale, tol_singular, tol_near
        Passed to :func:`mechkin.model.singularity.classify` (the frame of the reduced
        Jacobian, default ``mech.end_effector``; the characteristic length; thresholds).

    Returns
    -------
    MotionDerivatives

    References
    ----------
    kim1995_complex_chain_ik §2, Eq. (3)-(4); §5.1 Eq. (10) (reduced Jacobian).
    """

    q = np.atleast_2d(np.asarray(q, dtype=np.float64))
    if q.ndim != 2 or q.shape[1] != mech.n:
        raise ValueError(f"q: expected shape (m, {mech.n}), got {q.shape}")
    m = q.shape[0]
    iv, iw = mech.independent, mech.dependent
    qd_v = _as_batch(qd_v, m, len(iv), "qd_v")
    qdd_v = np.zeros((m, len(iv))) if qdd_v is None else _as_batch(qdd_v, m, len(iv), "qdd_v")
    ok = np.isfinite(q).all(axis=1)
    if not ok.all():  # e.g. failed closure steps: nan rows, "undefined" class
        sub = motion_derivatives(mech, q[ok], qd_v[ok], qdd_v[ok], frames,
                                 end_effector=end_effector, length_scale=length_scale,
                                 tol_singular=tol_singular, tol_near=tol_near)
        return scatter_rows(sub, ok, q=q)
    idx = _frame_indices(mech, frames)
    kin = forward_kinematics(mech, q)
    _, Phi = closure_jacobian(mech, kin)
    Phi_w, Phi_v = Phi[:, :, iw], Phi[:, :, iv]
    # one SVD of the nondimensionalised Phi_w: the pseudo-inverse and the singular values of
    # the classification (the same solution as the plain pseudo-inverse unless rank deficient)
    L = resolve_length_scale(mech, length_scale)
    row, col = constraint_scaling(mech, L)
    Pinv, s_c = _svd_pinv(Phi_w * row[None, :, None] * col[None, None, :])
    Pinv = Pinv * col[None, :, None] * row[None, None, :]
    S = -Pinv @ Phi_v
    qd = mech.assemble(qd_v, np.einsum("mij,mj->mi", S, qd_v))
    xi = joint_twists(mech, kin)
    lm0 = link_motion(mech, kin, qd, xi=xi)  # qdd = 0: velocity-product accelerations
    gamma = _closure_second_derivative(mech, kin, lm0)
    rhs = np.einsum("mij,mj->mi", Phi_v, qdd_v) + gamma
    qdd = mech.assemble(qdd_v, -np.einsum("mij,mj->mi", Pinv, rhs))
    lm = LinkMotion(lm0.V, lm0.A + _ancestors(mech) @ (xi * qdd[..., None]))
    tw, acc = frame_motion(mech, kin, lm, idx)
    rate_res = np.linalg.norm(np.einsum("mij,mj->mi", Phi, qd), axis=1)
    acc_res = np.linalg.norm(np.einsum("mij,mj->mi", Phi, qdd) + gamma, axis=1)
    report = classify(mech, q, kin=kin, Phi=Phi, S=S, s_constraint=s_c,
                      end_effector=end_effector, length_scale=L, tol_singular=tol_singular,
                      tol_near=tol_near)
    return MotionDerivatives(
        q=q, qd=qd, qdd=qdd, S=S, gamma=gamma, closure_rate_residual=rate_res,
        closure_accel_residual=acc_res, frames=idx,
        frame_names=tuple(mech.frame_names[i] for i in idx), twists=tw, accelerations=acc,
        positions=kin.frames(mech, idx)[:, :, :3, 3], singularity=report)


def rates_from_samples(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and second time derivatives of sampled values x (m, k) at times t (m,).

    Second-order central differences on a possibly non-uniform grid (one-sided second order at
    the ends; ``numpy.gradient`` with ``edge_order=2``), for motions given only as samples
    (e.g. a table of independent joint values). Needs m >= 3 strictly increasing times. A
    piecewise-linear motion has kinks at its knots: there the accelerations are the
    differences' smoothing of a velocity jump, not an exact value.
    """
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if t.ndim != 1 or x.shape[:1] != t.shape or t.size < 3:
        raise ValueError(f"need t (m,) and x (m, k) with m >= 3, got {t.shape} and {x.shape}")
    if not np.all(np.diff(t) > 0):
        raise ValueError("times must be strictly increasing")
    xd = np.gradient(x, t, axis=0, edge_order=2)
    return xd, np.gradient(xd, t, axis=0, edge_order=2)

