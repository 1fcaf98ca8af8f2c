r"""Batched forward kinematics, Jacobians and the loop-closure residual (kim1995 §2, Eq. (4)).

Twists and geometric Jacobians are ordered (omega, v) (Lynch & Park), expressed in the base
frame, with v the velocity of the frame's origin. Residuals are ordered like kim1995 Eq. (8):
position first, then the vector part of the Euler parameters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.spatial.rotations import quat_from_matrix


@dataclass(frozen=True)
class Kinematics:
    """Poses of a batch of configurations.

    T_links (m, nl, 4, 4): base -> link frames. W (m, n, 4, 4): base -> joint axis frames
    (z = joint axis, origin on the axis), evaluated after the joint's motion.
    """

    q: np.ndarray
    T_links: np.ndarray
    W: np.ndarray

    def frames(self, mech: Mechanism, idx: np.ndarray | list[int] | None = None) -> np.ndarray:
        """Poses of frames ``idx`` (all if None) in the base frame: (m, k, 4, 4)."""
        fi = np.arange(len(mech.frame_names)) if idx is None else np.asarray(idx)
        return self.T_links[:, mech.frame_link[fi]] @ mech.frame_offset[fi]


def forward_kinematics(mech: Mechanism, qs: np.ndarray) -> Kinematics:
    """Tree forward kinematics of every link for many configurations in one call.

    Parameters
    ----------
    qs : array, shape (m, n)
        Joint values [rad | m].

    Notes
    -----
    Joints of one depth of the tree are composed together (one matmul per depth), so a
    36-joint Stewart platform costs 7 batched products, a 6R arm 6.
    """
    qs = np.asarray(qs, dtype=np.float64)
    if qs.ndim != 2 or qs.shape[1] != mech.n:
        raise ValueError(f"qs: expected shape (m, {mech.n}), got {qs.shape}")
    m = qs.shape[0]
    T = np.empty((m, mech.n_links, 4, 4))
    T[:, 0] = np.eye(4)
    W = np.empty((m, mech.n, 4, 4))
    rev = mech.s == 0
    c = np.where(rev, np.cos(qs), 1.0)
    s = np.where(rev, np.sin(qs), 0.0)
    d = np.where(rev, 0.0, qs)
    A = mech.A
    # A @ Z(q): rotate the first two columns, shift the origin along the third (kim1995 Eq. (2))
    AZ = np.empty((m, mech.n, 4, 4))
    AZ[..., 0] = A[None, :, :, 0] * c[..., None] + A[None, :, :, 1] * s[..., None]
    AZ[..., 1] = A[None, :, :, 1] * c[..., None] - A[None, :, :, 0] * s[..., None]
    AZ[..., 2] = A[None, :, :, 2]
    AZ[..., 3] = A[None, :, :, 3] + A[None, :, :, 2] * d[..., None]
    for lvl in mech.levels:
        Wl = T[:, mech.joint_parent_link[lvl]] @ AZ[:, lvl]
        W[:, lvl] = Wl
        T[:, mech.joint_child_link[lvl]] = Wl @ mech.B[lvl]
    return Kinematics(q=qs, T_links=T, W=W)


def frame_poses(mech: Mechanism, qs: np.ndarray, idx: list[int] | np.ndarray | None = None):
    """Poses (m, k, 4, 4) of frames ``idx`` (all when None) for configurations qs (m, n)."""
    return forward_kinematics(mech, qs).frames(mech, idx)


def _joint_twists(mech: Mechanism, kin: Kinematics) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    z = kin.W[..., :3, 2]  # (m, n, 3)
    o = kin.W[..., :3, 3]
    rev = (mech.s == 0)[None, :, None]
    w = np.where(rev, z, 0.0)
    return z, o, w


def frame_jacobian(mech: Mechanism, kin: Kinematics, f: int) -> np.ndarray:
    """Geometric Jacobian (m, 6, n) of frame ``f``: rows (omega, v) in the base frame."""
    T_f = kin.frames(mech, [f])[:, 0]
    p = T_f[:, :3, 3]
    z, o, w = _joint_twists(mech, kin)
    mask = mech.link_ancestors[mech.frame_link[f]][None, :, None]
    v = np.where((mech.s == 0)[None, :, None], np.cross(z, p[:, None, :] - o), z)
    J = np.concatenate([w * mask, v * mask], axis=-1)  # (m, n, 6)
    return np.swapaxes(J, 1, 2)


def relative_residual(T_a: np.ndarray, T_b: np.ndarray) -> np.ndarray:
    """Residual of frame b relative to frame a (kim1995 Eq. (7)-(8)): (..., 6).

    ``x = (R_a^T (p_b - p_a), e_ab)`` with ``e_ab`` the vector part of the Euler parameters of
    ``R_a^T R_b`` (e0 >= 0).
    """
    R_a = T_a[..., :3, :3]
    dp = T_b[..., :3, 3] - T_a[..., :3, 3]
    p = np.einsum("...ji,...j->...i", R_a, dp)
    e = quat_from_matrix(np.swapaxes(R_a, -1, -2) @ T_b[..., :3, :3])
    return np.concatenate([p, e[..., 1:]], axis=-1)


def relative_jacobian(
    mech: Mechanism, kin: Kinematics, fa: int | None, fb: int, T_a_fixed: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    r"""Residual x (m, 6) of frame fb relative to fa and its Jacobian dx/dq (m, 6, n).

    ``fa = None`` means a fixed frame ``T_a_fixed`` (4, 4) or (m, 4, 4) in the base frame (a
    precision point, kim1995 Eq. (7)).

    .. math:: \dot p = R_a^T (v_b - v_a - \omega_a \times (p_b - p_a)),\quad
              \dot e = \tfrac12 (e_0 I - [e]_\times) R_a^T (\omega_b - \omega_a)
    """
    m = kin.q.shape[0]
    T_b = kin.frames(mech, [fb])[:, 0]
    if fa is None:
        T_a = np.broadcast_to(np.asarray(T_a_fixed, dtype=np.float64), (m, 4, 4))
    else:
        T_a = kin.frames(mech, [fa])[:, 0]
    R_a = T_a[:, :3, :3]
    p_a, p_b = T_a[:, :3, 3], T_b[:, :3, 3]
    z, o, w = _joint_twists(mech, kin)
    rev = (mech.s == 0)[None, :, None]
    mask_b = mech.link_ancestors[mech.frame_link[fb]][None, :, None]
    v_b = np.where(rev, np.cross(z, p_b[:, None, :] - o), z) * mask_b  # (m, n, 3)
    w_b = w * mask_b
    if fa is None:
        v_rel, w_rel = v_b, w_b
    else:
        mask_a = mech.link_ancestors[mech.frame_link[fa]][None, :, None]
        v_a = np.where(rev, np.cross(z, p_a[:, None, :] - o), z) * mask_a
        w_a = w * mask_a
        v_rel = v_b - v_a - np.cross(w_a, (p_b - p_a)[:, None, :])
        w_rel = w_b - w_a
    e = quat_from_matrix(np.swapaxes(R_a, -1, -2) @ T_b[:, :3, :3])  # (m, 4)
    e0, ev = e[:, 0], e[:, 1:]
    x = np.concatenate([np.einsum("mji,mj->mi", R_a, p_b - p_a), ev], axis=-1)
    Jp = np.einsum("mji,mkj->mik", R_a, v_rel)  # R_a^T v_rel -> (m, 3, n)
    Jw = np.einsum("mji,mkj->mik", R_a, w_rel)
    E = 0.5 * (e0[:, None, None] * np.eye(3) - _skew(ev))  # (m, 3, 3)
    Je = E @ Jw
    return x, np.concatenate([Jp, Je], axis=1)


def _skew(v: np.ndarray) -> np.ndarray:
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def closure_residual(mech: Mechanism, kin: Kinematics) -> np.ndarray:
    """phi_R (m, n_eq): the loop-closure residual of every cut, masked (kim1995 Eq. (4))."""
    m = kin.q.shape[0]
    if not mech.cuts:
        return np.zeros((m, 0))
    Ta = kin.frames(mech, [c.a for c in mech.cuts])
    Tb = kin.frames(mech, [c.b for c in mech.cuts])
    x = relative_residual(Ta, Tb)  # (m, nc, 6)
    mask = np.stack([c.mask for c in mech.cuts])
    return x[:, mask]


def closure_jacobian(mech: Mechanism, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
    """phi_R (m, n_eq) and d(phi_R)/dq (m, n_eq, n), analytic (kim1995 Eq. (4))."""
    m = kin.q.shape[0]
    if not mech.cuts:
        return np.zeros((m, 0)), np.zeros((m, 0, mech.n))
    xs, Js = [], []
    for c in mech.cuts:
        x, J = relative_jacobian(mech, kin, c.a, c.b)
        xs.append(x[:, c.mask])
        Js.append(J[:, c.mask])
    return np.concatenate(xs, axis=1), np.concatenate(Js, axis=1)
