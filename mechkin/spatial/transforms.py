"""Homogeneous transforms (4, 4) and batches (..., 4, 4)."""

from __future__ import annotations

import numpy as np

from mechkin.spatial.rotations import matrix_from_rpy


def T_from(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Transform from rotation (..., 3, 3) and position (..., 3) -> (..., 4, 4)."""
    R = np.asarray(R, dtype=np.float64)
    p = np.asarray(p, dtype=np.float64)
    shape = np.broadcast_shapes(R.shape[:-2], p.shape[:-1])
    T = np.zeros(shape + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p
    T[..., 3, 3] = 1.0
    return T


def invert(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms (..., 4, 4), using R^T."""
    T = np.asarray(T, dtype=np.float64)
    Ti = np.zeros_like(T)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    Ti[..., :3, :3] = Rt
    Ti[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    Ti[..., 3, 3] = 1.0
    return Ti


def translation(p: np.ndarray) -> np.ndarray:
    """Pure translation (..., 3) -> (..., 4, 4)."""
    p = np.asarray(p, dtype=np.float64)
    return T_from(np.broadcast_to(np.eye(3), p.shape[:-1] + (3, 3)), p)


def transform_from_xyz_rpy(xyz: np.ndarray, rpy: np.ndarray) -> np.ndarray:
    """URDF-style origin: translation xyz then fixed-axis roll-pitch-yaw; -> (4, 4)."""
    return T_from(matrix_from_rpy(rpy), xyz)
