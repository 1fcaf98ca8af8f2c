"""Denavit-Hartenberg link transforms (kim1995 §2 compound-chain notation builds on these).

Standard convention (Denavit and Hartenberg 1955; Paul; Corke's ``DHRobot``):
``T_{i-1,i} = Rz(theta) Tz(d) Tx(a) Rx(alpha)``, joint i moves about / along z_{i-1}.
Modified convention (Craig; Corke's ``mdh``): ``T_{i-1,i} = Rx(alpha) Tx(a) Rz(theta) Tz(d)``
with ``a, alpha`` those of link i-1; joint i moves about / along z_i.
"""

from __future__ import annotations

import numpy as np


def _rz_tz(theta: np.ndarray, d: np.ndarray) -> np.ndarray:
    theta = np.asarray(theta, dtype=np.float64)
    d = np.asarray(d, dtype=np.float64)
    shape = np.broadcast_shapes(theta.shape, d.shape)
    c, s = np.cos(theta), np.sin(theta)
    T = np.zeros(shape + (4, 4))
    T[..., 0, 0] = c
    T[..., 0, 1] = -s
    T[..., 1, 0] = s
    T[..., 1, 1] = c
    T[..., 2, 2] = 1.0
    T[..., 2, 3] = d
    T[..., 3, 3] = 1.0
    return T


def _tx_rx(a: float, alpha: float) -> np.ndarray:
    c, s = np.cos(alpha), np.sin(alpha)
    return np.array([[1.0, 0, 0, a], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def dh_standard(theta, d, a: float, alpha: float) -> np.ndarray:
    """Standard D-H transform; ``theta``, ``d`` (...) -> (..., 4, 4)."""
    return _rz_tz(theta, d) @ _tx_rx(a, alpha)


def dh_modified(theta, d, a: float, alpha: float) -> np.ndarray:
    """Modified (Craig) D-H transform; ``theta``, ``d`` (...) -> (..., 4, 4)."""
    return _tx_rx(a, alpha) @ _rz_tz(theta, d)
