r"""The serial chain from the ground to one frame: pose and geometric Jacobian in few array calls.

In a tree (no cut joints) the joints before a frame form one path from the ground. Along that
path the link poses are a running product of the joints' ``A Z(q) B`` (kim1995 Eq. (2)); this
module evaluates that product and the frame's Jacobian with a fixed, small number of numpy
calls per batch, so that iterative solvers (IK) pay little per iteration even for one
configuration. :func:`mechkin.model.kinematics.forward_kinematics` remains the general tree
kinematics; the two agree to rounding (tested).
"""

from __future__ import annotations

import numpy as np

from mechkin.model.kinematics import _ZC, _ZD, _ZK, _ZS
from mechkin.model.mechanism import Mechanism

SMALL_BATCH = 32  # below: one small product per joint; above: column mixing and one GEMM


_EPS = np.zeros((3, 3, 3))  # Levi-Civita symbol: (a x b)_i = eps_ijk a_j b_k
_EPS[0, 1, 2] = _EPS[1, 2, 0] = _EPS[2, 0, 1] = 1.0
_EPS[0, 2, 1] = _EPS[2, 1, 0] = _EPS[1, 0, 2] = -1.0


class SerialChain:
    r"""The joints before frame ``frame`` of a mechanism, as one serial chain.

    The running product is regrouped around the joint frames ``F_i = T_parent(i) A_i`` (axis
    z_i = third column, point o_i = fourth column):

    .. math:: F_0 = A_0,\qquad F_{i+1} = F_i\,Z(q_i)\,C_i,\qquad
              C_i = B_i A_{i+1},\quad C_{k-1} = B_{k-1}\,T_{offset}

    so the frame's pose is ``F_k`` and the Jacobian reads the axes straight from ``F_0..F_{k-1}``
    (no extra products). A different output frame (e.g. a precision point {P}) is a different
    ``F_0 = T_P^{-1} A_0``, see :meth:`first_frame`.

    Parameters
    ----------
    mech : Mechanism
    frame : int
        Frame index (e.g. ``mech.end_effector``).

    Attributes
    ----------
    joints : (k,) joint indices along the path, ground first.

    Raises
    ------
    ValueError
        When no joint moves the frame, or the joints before it do not form one path from the
        ground (cannot happen in a tree; a guard for hand-built mechanisms).
    """

    def __init__(self, mech: Mechanism, frame: int) -> None:
        link = int(mech.frame_link[frame])
        path = []
        while link != 0:
            j = int(mech.link_parent_joint[link])
            if j < 0:
                raise ValueError(f"frame {mech.frame_names[frame]!r} is not connected to ground")
            path.append(j)
            link = int(mech.joint_parent_link[j])
        if not path:
            raise ValueError(f"no joint moves frame {mech.frame_names[frame]!r}")
        jj = np.array(path[::-1], dtype=int)
        self.joints = jj
        self.k = k = jj.size
        A, B = mech.A[jj], mech.B[jj]
        C = np.empty((k, 4, 4))
        C[:-1] = B[:-1] @ A[1:]
        C[-1] = B[-1] @ mech.frame_offset[frame]
        self.A0 = A[0].copy()
        self.C = C
        self.rev = rev = mech.s[jj] == 0
        self.all_rev = bool(rev.all())
        r3 = rev[:, None, None]
        # Z(q) C = c Pc + s Ps + d Pd + P0, joint-major (k, 1, 4, 4) to broadcast over (k, m)
        self.Pc = np.where(r3, _ZC @ C, 0.0)[:, None]
        self.Ps = np.where(r3, _ZS @ C, 0.0)[:, None]
        self.Pd = np.where(r3, 0.0, _ZD @ C)[:, None]
        self.P0 = np.where(r3, _ZK @ C, C)[:, None]

    def first_frame(self, T_out: np.ndarray | None = None) -> np.ndarray:
        """``F_0`` (m, 4, 4) for results expressed in frames ``T_out`` (m, 4, 4) given in the
        base frame (None: the base frame itself, shape (1, 4, 4))."""
        if T_out is None:
            return self.A0[None]
        m = T_out.shape[0]
        X = np.empty((m, 3, 4))
        X[:] = self.A0[:3]
        X[:, :, 3] -= T_out[:, :3, 3]
        F0 = np.empty((m, 4, 4))
        np.matmul(np.swapaxes(T_out[:, :3, :3], 1, 2), X, out=F0[:, :3])  # T_out^-1 A_0
        F0[:, 3] = self.A0[3]
        return F0

    def pose_jacobian(self, q: np.ndarray, F0: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
        """Pose of the frame (m, 4, 4) and its geometric Jacobian (m, 6, k), rows (v, omega).

        Parameters
        ----------
        q : (m, k) values of :attr:`joints` [rad | m].
        F0 : (m, 4, 4) or (1, 4, 4), optional
            :meth:`first_frame` of the output frame (default: the base frame).

        Notes
        -----
        v is the velocity of the frame's origin, omega the angular velocity, both in the output
        frame: ``v_j = z_j x (p - o_j)``, ``omega_j = z_j`` for a revolute joint,
        ``v_j = z_j``, ``omega_j = 0`` for a prismatic one.
        """
        F = self._frames(q, F0)
        m, k = q.shape
        Fs = np.stack(F[:k], axis=1)  # (m, k, 4, 4)
        z = Fs[..., :3, 2]
        r = F[k][:, None, :3, 3] - Fs[..., :3, 3]
        J = np.empty((m, 6, k))
        if m < SMALL_BATCH:
            Jv = np.einsum("ijk,mnj,mnk->min", _EPS, z, r)
        else:
            Jv = np.empty((m, 3, k))
            Jv[:, 0] = z[..., 1] * r[..., 2] - z[..., 2] * r[..., 1]
            Jv[:, 1] = z[..., 2] * r[..., 0] - z[..., 0] * r[..., 2]
            Jv[:, 2] = z[..., 0] * r[..., 1] - z[..., 1] * r[..., 0]
        if self.all_rev:
            J[:, :3] = Jv
            J[:, 3:] = np.swapaxes(z, 1, 2)
        else:
            zt = np.swapaxes(z, 1, 2)
            J[:, :3] = np.where(self.rev, Jv, zt)
            J[:, 3:] = np.where(self.rev, zt, 0.0)
        return F[k], J

    def pose(self, q: np.ndarray, F0: np.ndarray | None = None) -> np.ndarray:
        """Pose of the frame (m, 4, 4) for joint values q (m, k) (see :meth:`pose_jacobian`)."""
        return self._frames(q, F0)[-1]

    def _frames(self, q: np.ndarray, F0: np.ndarray | None) -> list[np.ndarray]:
        """Joint frames F_0..F_{k-1} and the frame's pose F_k, each (m, 4, 4)."""
        m = q.shape[0]
        F = [np.broadcast_to(self.A0 if F0 is None else F0, (m, 4, 4))]
        qT = q.T
        if m >= SMALL_BATCH:
            # F Z(q) only mixes columns 0 and 1 (revolute) or shifts column 3 (prismatic);
            # the constant C_i is then one GEMM over the batch, (m * 4, 4) @ (4, 4)
            c, s = np.cos(qT)[..., None], np.sin(qT)[..., None]
            for i in range(self.k):
                Fi = F[-1]
                X = np.empty((m, 4, 4))
                if self.rev[i]:
                    X[:, :, 0] = Fi[:, :, 0] * c[i] + Fi[:, :, 1] * s[i]
                    X[:, :, 1] = Fi[:, :, 1] * c[i] - Fi[:, :, 0] * s[i]
                    X[:, :, 2:] = Fi[:, :, 2:]
                else:
                    X[:, :, :3] = Fi[:, :, :3]
                    X[:, :, 3] = Fi[:, :, 3] + Fi[:, :, 2] * qT[i, :, None]
                F.append((X.reshape(m * 4, 4) @ self.C[i]).reshape(m, 4, 4))
            return F
        if self.all_rev:
            L = np.cos(qT)[..., None, None] * self.Pc
            L += np.sin(qT)[..., None, None] * self.Ps
            L += self.P0
        else:
            c = np.where(self.rev[:, None], np.cos(qT), 0.0)[..., None, None]
            s = np.where(self.rev[:, None], np.sin(qT), 0.0)[..., None, None]
            d = np.where(self.rev[:, None], 0.0, qT)[..., None, None]
            L = c * self.Pc + s * self.Ps + d * self.Pd + self.P0
        for Li in L:
            F.append(F[-1] @ Li)
        return F
