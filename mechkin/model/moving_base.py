r"""A moving base: the pose T_0(t) of the base frame {0} in a world (inertial) frame and its
rates, and frame motion composed with it (kim1995 §5.1 Step 1, ``T_0(t)``).

Design
------
The mechanism's kinematics stay in the base frame (:mod:`mechkin.model.kinematics`,
:mod:`mechkin.model.differential`); a moving base only changes how a frame's pose and motion
read in the world frame. With the base pose ``(R_0, p_0)``, its angular velocity
``omega_0``, origin velocity ``v_0``, angular acceleration ``alpha_0`` and origin acceleration
``a_0`` (all in world axes), and a frame's pose ``(R, p)``, twist ``(omega, v)`` and classical
acceleration ``(alpha, a)`` in the base frame (``v``, ``a``: its origin's), with
``r = R_0 p``:

.. math::
    T_w = T_0 T, \qquad \omega_w = \omega_0 + R_0\omega, \qquad
    v_w = v_0 + \omega_0\times r + R_0 v,

    \alpha_w = \alpha_0 + R_0\alpha + \omega_0\times R_0\omega, \qquad
    a_w = a_0 + \alpha_0\times r + \omega_0\times(\omega_0\times r)
          + 2\,\omega_0\times R_0 v + R_0 a

(the transport theorem applied once and twice). The base orientation is given as URDF
roll-pitch-yaw, ``R_0 = Rz(y) Ry(p) Rx(r)`` (fixed axes, as the mechanism file's frames); its
angular velocity is that of three revolute joints in series about ``z``, the turned ``y`` and
the twice-turned ``x``:

.. math::
    \omega_0 = \dot y\,a_1 + \dot p\,a_2 + \dot r\,a_3, \quad a_1 = e_z,\ a_2 = R_z(y) e_y,\
    a_3 = R_0 e_x,

    \alpha_0 = \ddot y\,a_1 + \ddot p\,a_2 + \ddot r\,a_3 + \dot p\,(\dot y a_1)\times a_2
    + \dot r\,(\dot y a_1 + \dot p a_2)\times a_3 .

Conventions: batches put the sample axis first; twists are ``(omega, v)``, accelerations
``(alpha, a)``; SI units.

Imports: numpy, spatial.
"""

from __future__ import annotations

import numpy as np

from mechkin.spatial.rotations import matrix_from_rpy


def base_motion(xyz: np.ndarray, rpy: np.ndarray, xyz_d: np.ndarray, rpy_d: np.ndarray,
                xyz_dd: np.ndarray, rpy_dd: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Base poses, twists and accelerations in the world frame from the coordinates and rates.

    Parameters
    ----------
    xyz, xyz_d, xyz_dd : (m, 3)
        Base origin position [m], velocity [m/s] and acceleration [m/s^2] in world axes.
    rpy, rpy_d, rpy_dd : (m, 3)
        Roll, pitch, yaw [rad] (``R_0 = Rz(y) Ry(p) Rx(r)``) and their first and second time
        derivatives.

    Returns
    -------
    T_w0 : (m, 4, 4)
        Pose of the base in the world frame, T_0(t) (kim1995 §5.1 Step 1).
    twist : (m, 6)
        ``(omega_0, v_0)`` in world axes.
    accel : (m, 6)
        ``(alpha_0, a_0)`` in world axes (classical: ``a_0`` is the origin's acceleration).
    """
    xyz, rpy = np.atleast_2d(xyz).astype(float), np.atleast_2d(rpy).astype(float)
    m = xyz.shape[0]
    R = matrix_from_rpy(rpy)
    T = np.zeros((m, 4, 4))
    T[:, :3, :3] = R
    T[:, :3, 3] = xyz
    T[:, 3, 3] = 1.0
    r_d, p_d, y_d = (rpy_d[:, k:k + 1] for k in range(3))
    r_dd, p_dd, y_dd = (rpy_dd[:, k:k + 1] for k in range(3))
    yaw = rpy[:, 2]
    a1 = np.broadcast_to([0.0, 0.0, 1.0], (m, 3))
    a2 = np.stack([-np.sin(yaw), np.cos(yaw), np.zeros(m)], axis=1)
    a3 = R[:, :, 0]
    w1 = y_d * a1
    w12 = w1 + p_d * a2
    omega = w12 + r_d * a3
    alpha = (y_dd * a1 + p_dd * a2 + r_dd * a3 + p_d * np.cross(w1, a2)
             + r_d * np.cross(w12, a3))
    return T, np.concatenate([omega, xyz_d], axis=1), np.concatenate([alpha, xyz_dd], axis=1)


def in_world(T_w0: np.ndarray, tw0: np.ndarray, acc0: np.ndarray, T: np.ndarray,
             tw: np.ndarray | None = None, acc: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    r"""Frame poses, twists and accelerations in the world frame (module docstring formulas).

    Parameters
    ----------
    T_w0, tw0, acc0 : (m, 4, 4), (m, 6), (m, 6)
        The base motion (:func:`base_motion`).
    T : (m, k, 4, 4)
        Frame poses in the base frame.
    tw, acc : (m, k, 6), optional
        Frame twists ``(omega, v)`` and classical accelerations ``(alpha, a)`` in the base frame.

    Returns
    -------
    (T_w (m, k, 4, 4), tw_w (m, k, 6) | None, acc_w (m, k, 6) | None)
    """
    T_w = T_w0[:, None] @ T
    if tw is None:
        return T_w, None, None
    R0 = T_w0[:, None, :3, :3]
    w0, v0 = tw0[:, None, :3], tw0[:, None, 3:]
    r = (R0 @ T[..., :3, 3, None])[..., 0]
    w_r = (R0 @ tw[..., :3, None])[..., 0]
    v_r = (R0 @ tw[..., 3:, None])[..., 0]
    w0b = np.broadcast_to(w0, r.shape)
    tw_w = np.concatenate([w0 + w_r, v0 + np.cross(w0b, r) + v_r], axis=-1)
    if acc is None:
        return T_w, tw_w, None
    al0, a0 = acc0[:, None, :3], acc0[:, None, 3:]
    al0b = np.broadcast_to(al0, r.shape)
    al_r = (R0 @ acc[..., :3, None])[..., 0]
    a_r = (R0 @ acc[..., 3:, None])[..., 0]
    acc_w = np.concatenate([
        al0 + al_r + np.cross(w0b, w_r),
        a0 + np.cross(al0b, r) + np.cross(w0b, np.cross(w0b, r)) + 2.0 * np.cross(w0b, v_r)
        + a_r], axis=-1)
    return T_w, tw_w, acc_w
