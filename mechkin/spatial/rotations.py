"""Rotation matrices, Euler parameters (unit quaternions, scalar first) and Euler angles.

Every function accepts a leading batch shape ``(...)`` where stated; angles in rad.
"""

from __future__ import annotations

import math

import numpy as np


def rot_x(t: float | np.ndarray) -> np.ndarray:
    """Rotation about x by ``t``; ``t`` shape (...) -> (..., 3, 3)."""
    t = np.asarray(t, dtype=np.float64)
    c, s = np.cos(t), np.sin(t)
    o, z = np.ones_like(t), np.zeros_like(t)
    return np.stack([o, z, z, z, c, -s, z, s, c], axis=-1).reshape(t.shape + (3, 3))


def rot_y(t: float | np.ndarray) -> np.ndarray:
    """Rotation about y by ``t``; ``t`` shape (...) -> (..., 3, 3)."""
    t = np.asarray(t, dtype=np.float64)
    c, s = np.cos(t), np.sin(t)
    o, z = np.ones_like(t), np.zeros_like(t)
    return np.stack([c, z, s, z, o, z, -s, z, c], axis=-1).reshape(t.shape + (3, 3))


def rot_z(t: float | np.ndarray) -> np.ndarray:
    """Rotation about z by ``t``; ``t`` shape (...) -> (..., 3, 3)."""
    t = np.asarray(t, dtype=np.float64)
    c, s = np.cos(t), np.sin(t)
    o, z = np.ones_like(t), np.zeros_like(t)
    return np.stack([c, -s, z, s, c, z, z, z, o], axis=-1).reshape(t.shape + (3, 3))


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix ``[v]x``; ``v`` (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, dtype=np.float64)
    z = np.zeros_like(v[..., 0])
    return np.stack(
        [z, -v[..., 2], v[..., 1], v[..., 2], z, -v[..., 0], -v[..., 1], v[..., 0], z], axis=-1
    ).reshape(v.shape[:-1] + (3, 3))


def rot_axis(axis: np.ndarray, t: float | np.ndarray) -> np.ndarray:
    """Rotation by ``t`` about the unit vector ``axis`` (3,) (Rodrigues);
    ``t`` (...) -> (..., 3, 3)."""
    k = np.asarray(axis, dtype=np.float64)
    k = k / np.linalg.norm(k)
    t = np.asarray(t, dtype=np.float64)
    K = skew(k)
    s = np.sin(t)[..., None, None]
    c = np.cos(t)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def matrix_from_rpy(rpy: np.ndarray) -> np.ndarray:
    """URDF roll-pitch-yaw (fixed axes x, y, z): ``R = Rz(y) Ry(p) Rx(r)``;
    (..., 3) -> (..., 3, 3)."""
    rpy = np.asarray(rpy, dtype=np.float64)
    return rot_z(rpy[..., 2]) @ rot_y(rpy[..., 1]) @ rot_x(rpy[..., 0])


def rpy_from_matrix(R: np.ndarray) -> np.ndarray:
    """Inverse of :func:`matrix_from_rpy`; (..., 3, 3) -> (..., 3) with pitch in [-pi/2, pi/2]."""
    R = np.asarray(R, dtype=np.float64)
    pitch = np.arcsin(np.clip(-R[..., 2, 0], -1.0, 1.0))
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    return np.stack([roll, pitch, yaw], axis=-1)


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Euler parameters (e0, e1, e2, e3) of rotation matrices, e0 >= 0; (..., 3, 3) -> (..., 4).

    Shepperd's method: the largest of the four squared parameters picks the branch, so the
    result is accurate for every rotation (vectorized, no Python loop over the batch).
    """
    R = np.asarray(R, dtype=np.float64)
    shape = R.shape[:-2]
    R = R.reshape(-1, 3, 3)
    tr = R[:, 0, 0] + R[:, 1, 1] + R[:, 2, 2]
    if np.all(tr > -0.5):
        # every rotation below 120 deg: the e0 branch is accurate (e0 > 0.5), no dispatch needed
        s0 = np.sqrt(1.0 + tr) * 2.0
        q = np.empty((R.shape[0], 4))
        q[:, 0] = 0.25 * s0
        q[:, 1] = (R[:, 2, 1] - R[:, 1, 2]) / s0
        q[:, 2] = (R[:, 0, 2] - R[:, 2, 0]) / s0
        q[:, 3] = (R[:, 1, 0] - R[:, 0, 1]) / s0
        q /= np.linalg.norm(q, axis=-1, keepdims=True)
        return q.reshape(shape + (4,))
    d = np.stack([tr, R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]], axis=-1)
    k = np.argmax(d, axis=-1)
    q = np.empty((R.shape[0], 4))
    # branch 0: e0 largest
    s0 = np.sqrt(np.maximum(1.0 + tr, 0.0)) * 2.0
    s1 = np.sqrt(np.maximum(1.0 + R[:, 0, 0] - R[:, 1, 1] - R[:, 2, 2], 0.0)) * 2.0
    s2 = np.sqrt(np.maximum(1.0 + R[:, 1, 1] - R[:, 0, 0] - R[:, 2, 2], 0.0)) * 2.0
    s3 = np.sqrt(np.maximum(1.0 + R[:, 2, 2] - R[:, 0, 0] - R[:, 1, 1], 0.0)) * 2.0
    with np.errstate(divide="ignore", invalid="ignore"):
        cand = np.stack(
            [
                np.stack(
                    [0.25 * s0, (R[:, 2, 1] - R[:, 1, 2]) / s0, (R[:, 0, 2] - R[:, 2, 0]) / s0,
                     (R[:, 1, 0] - R[:, 0, 1]) / s0], axis=-1),
                np.stack(
                    [(R[:, 2, 1] - R[:, 1, 2]) / s1, 0.25 * s1, (R[:, 0, 1] + R[:, 1, 0]) / s1,
                     (R[:, 0, 2] + R[:, 2, 0]) / s1], axis=-1),
                np.stack(
                    [(R[:, 0, 2] - R[:, 2, 0]) / s2, (R[:, 0, 1] + R[:, 1, 0]) / s2, 0.25 * s2,
                     (R[:, 1, 2] + R[:, 2, 1]) / s2], axis=-1),
                np.stack(
                    [(R[:, 1, 0] - R[:, 0, 1]) / s3, (R[:, 0, 2] + R[:, 2, 0]) / s3,
                     (R[:, 1, 2] + R[:, 2, 1]) / s3, 0.25 * s3], axis=-1),
            ],
            axis=1,
        )
    q = cand[np.arange(R.shape[0]), k]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q = np.where(q[:, :1] < 0.0, -q, q)
    return q.reshape(shape + (4,))


def matrix_from_quat(e: np.ndarray) -> np.ndarray:
    """Rotation matrices from Euler parameters (e0, e1, e2, e3); (..., 4) -> (..., 3, 3)."""
    e = np.asarray(e, dtype=np.float64)
    e = e / np.linalg.norm(e, axis=-1, keepdims=True)
    e0, e1, e2, e3 = e[..., 0], e[..., 1], e[..., 2], e[..., 3]
    return np.stack(
        [
            1 - 2 * (e2 * e2 + e3 * e3), 2 * (e1 * e2 - e0 * e3), 2 * (e1 * e3 + e0 * e2),
            2 * (e1 * e2 + e0 * e3), 1 - 2 * (e1 * e1 + e3 * e3), 2 * (e2 * e3 - e0 * e1),
            2 * (e1 * e3 - e0 * e2), 2 * (e2 * e3 + e0 * e1), 1 - 2 * (e1 * e1 + e2 * e2),
        ],
        axis=-1,
    ).reshape(e.shape[:-1] + (3, 3))


def euler_vector_from_matrix(R: np.ndarray) -> np.ndarray:
    """Vector part (e1, e2, e3) of the Euler parameters with e0 >= 0; (..., 3, 3) -> (..., 3).

    kim1995 Eq. (8): the orientation error of {E} relative to a precision point.
    """
    return quat_from_matrix(R)[..., 1:]


def angle_from_matrix(R: np.ndarray) -> np.ndarray:
    """Rotation angle in [0, pi] of rotation matrices; (..., 3, 3) -> (...)."""
    e = quat_from_matrix(R)
    return 2.0 * np.arctan2(np.linalg.norm(e[..., 1:], axis=-1), e[..., 0])


_VEE_A = np.array([7, 2, 3])  # R21, R02, R10 of a flattened (3, 3)
_VEE_B = np.array([5, 6, 1])  # R12, R20, R01
_DIAG = np.array([0, 4, 8])


def rotation_log(R: np.ndarray) -> np.ndarray:
    r"""Rotation vector (angle times unit axis, angle in [0, pi]) of rotations (m, 3, 3): (m, 3).

    With ``w = vee(R - R^T) / 2 = sin(angle) axis`` and ``cos(angle) = (tr R - 1) / 2`` the angle
    is ``atan2(|w|, cos)``. Beyond about 170 degrees ``w`` loses the axis; there the axis is the
    dominant column of the symmetric part ``(R + R^T)/2 - cos I = (1 - cos) a a^T``, signed by
    ``w``. Accurate to rounding for every rotation, including half turns.
    """
    m = R.shape[0]
    Rf = R.reshape(m, 9)
    w = (Rf[:, _VEE_A] - Rf[:, _VEE_B]) * 0.5
    cs = (Rf[:, _DIAG].sum(axis=1) - 1.0) * 0.5
    sn = np.sqrt((w * w).sum(axis=1))
    ang = np.arctan2(sn, cs)
    scale = ang / np.maximum(sn, 1e-300)  # angle / sin(angle); w = 0 gives 0
    near_pi = cs < -0.985
    if near_pi.any():
        i = np.flatnonzero(near_pi)
        B = 0.5 * (R[i] + np.swapaxes(R[i], 1, 2)) - cs[i, None, None] * np.eye(3)
        col = np.argmax(np.einsum("mii->mi", B), axis=1)
        a = B[np.arange(i.size), :, col]
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        w = w.copy()
        w[i] = np.where(np.einsum("mi,mi->m", a, w[i])[:, None] < 0.0, -a, a)
        scale[i] = ang[i]
    return w * scale[:, None]


def rpy_of(R: np.ndarray) -> list[float]:
    """URDF roll-pitch-yaw of a rotation (``R = Rz(y) Ry(p) Rx(r)``), accurate at the poles.

    The pitch is ``atan2(-R20, hypot(R00, R10))`` (``asin`` loses half the digits near +-pi/2),
    the yaw ``atan2(R10, R00)``, and the roll is read from ``Ry(p)^T Rz(y)^T R`` so that an
    inaccurate yaw near gimbal lock is absorbed by the roll: ``matrix_from_rpy`` of the result
    reproduces R to rounding error everywhere.
    """
    R = np.asarray(R, dtype=np.float64)
    c = math.hypot(R[0, 0], R[1, 0])
    pitch = math.atan2(-R[2, 0], c)
    yaw = math.atan2(R[1, 0], R[0, 0]) if c > 0 else 0.0
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    M = Ry.T @ Rz.T @ R
    return [math.atan2(M[2, 1], M[1, 1]), pitch, yaw]
