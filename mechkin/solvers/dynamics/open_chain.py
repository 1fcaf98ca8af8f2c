"""Inverse dynamics: park's closed-form planar 2-link arm and recursive Newton-Euler for chains.

Both models answer the same minimal interface, :class:`InverseDynamics`, which is all the path
and DP solvers need (park Eq. (8)):

.. math:: U = M(q) \\ddot q + h(q, \\dot q)

Batches put the sample axis first: ``q, qd, qdd (m, n)`` -> ``tau (m, n)``.

:class:`SerialChainDynamics` is written against plain arrays, not against ``mechkin.model``:
each joint i moves about (revolute) or along (prismatic) the local z axis of the frame reached
after a fixed transform ``A[i]``, followed by a second fixed transform ``B[i]``::

    T_parent_child(q_i) = A[i] @ motion(q_i) @ B[i],   motion = Rz(q_i) | Tz(q_i)

The child frame (after ``B[i]``) carries link i's inertial parameters: mass, centre of mass and
inertia tensor about the centre of mass, both in the child frame. A standard D-H link is
``A = I``, ``B = Tz(d) Tx(a) Rx(alpha)``; a modified one is ``A = Tx(a) Rx(alpha)``, ``B = I``
(with ``d`` folded into ``B`` for revolute joints).

The recursion uses 6-D spatial vectors ordered ``(omega, v)`` (Featherstone 2008, ch. 5), batched
over samples with a Python loop over the n joints only.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from mechkin.spatial.rotations import skew

REVOLUTE = 0
PRISMATIC = 1


@runtime_checkable
class InverseDynamics(Protocol):
    """What the path and DP solvers need from a dynamics model (park Eq. (8))."""

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        ...

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Joint torques/forces ``tau (m, n)`` for ``q, qd, qdd (m, n)``."""
        ...


def _as_batch(x: np.ndarray, n: int, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != n:
        raise ValueError(f"{name}: expected shape (m, {n}), got {a.shape}")
    return a


@dataclass(frozen=True)
class PlanarTwoLinkDynamics:
    r"""Closed-form dynamics of a planar 2R arm moving in a horizontal plane (no gravity).

    For link lengths ``l1``, ``l2``, masses ``m1``, ``m2``, centre-of-mass distances ``lc1``,
    ``lc2`` from the proximal joint and central inertias ``I1``, ``I2`` about the plane normal:

    .. math::

        M(q) = \begin{bmatrix} I_1 + I_2 + m_1 l_{c1}^2 + m_2 (l_1^2 + l_{c2}^2 + 2 l_1 l_{c2} c_2)
               & I_2 + m_2 (l_{c2}^2 + l_1 l_{c2} c_2) \\ \cdot & I_2 + m_2 l_{c2}^2 \end{bmatrix},
        \quad
        h(q, \dot q) = m_2 l_1 l_{c2} s_2
               \begin{bmatrix} -(2 \dot q_1 \dot q_2 + \dot q_2^2) \\ \dot q_1^2 \end{bmatrix}

    The defaults are park's simulation model (Table 1 as corrected in PAPER_NOTES): uniform rods
    ``l = 1 m``, ``m = 1 kg``, which give ``M = [[5/3 + c2, 1/3 + c2/2], [1/3 + c2/2, 1/3]]`` and
    ``h = [-s2 (qd1 qd2 + qd2^2 / 2), s2 qd1^2 / 2]`` (the OCR printed the sines as cosines).

    References
    ----------
    park_conveyor_tracking_dp, Eq. (8) and Table 1.
    """

    l1: float = 1.0
    l2: float = 1.0
    m1: float = 1.0
    m2: float = 1.0
    lc1: float = 0.5
    lc2: float = 0.5
    I1: float = 1.0 / 12.0
    I2: float = 1.0 / 12.0

    @property
    def n_joints(self) -> int:
        """Two joints."""
        return 2

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Inertia matrix ``M (m, 2, 2)`` for ``q (m, 2)`` (park Eq. (8), Table 1)."""
        q = _as_batch(q, 2, "q")
        c2 = np.cos(q[:, 1])
        k = self.m2 * self.l1 * self.lc2
        m22 = self.I2 + self.m2 * self.lc2**2
        m11 = self.I1 + self.m1 * self.lc1**2 + m22 + self.m2 * self.l1**2 + 2.0 * k * c2
        m12 = m22 + k * c2
        M = np.empty((q.shape[0], 2, 2))
        M[:, 0, 0] = m11
        M[:, 0, 1] = m12
        M[:, 1, 0] = m12
        M[:, 1, 1] = m22
        return M

    def bias(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Coriolis and centrifugal torques ``h (m, 2)`` (park Eq. (8), Table 1 with sines)."""
        q = _as_batch(q, 2, "q")
        qd = _as_batch(qd, 2, "qd")
        k = self.m2 * self.l1 * self.lc2 * np.sin(q[:, 1])
        h = np.empty_like(qd)
        h[:, 0] = -k * (2.0 * qd[:, 0] * qd[:, 1] + qd[:, 1] ** 2)
        h[:, 1] = k * qd[:, 0] ** 2
        return h

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """``U = M(q) qdd + h(q, qd)`` (park Eq. (8)); all arrays (m, 2)."""
        qdd = _as_batch(qdd, 2, "qdd")
        return np.einsum("mij,mj->mi", self.mass_matrix(q), qdd) + self.bias(q, qd)


def _motion_transform(T: np.ndarray) -> np.ndarray:
    """Spatial motion transform ``X (..., 6, 6)`` taking parent to child coordinates.

    ``T (..., 4, 4)`` is ``T_parent_child``; vectors are ordered ``(omega, v)``:
    ``X = [[R^T, 0], [-R^T [p]x, R^T]]`` (Featherstone 2008, Eq. 2.24).
    """
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    X = np.zeros(T.shape[:-2] + (6, 6))
    X[..., :3, :3] = Rt
    X[..., 3:, 3:] = Rt
    X[..., 3:, :3] = -Rt @ skew(T[..., :3, 3])
    return X


def _cross_motion(v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Spatial cross product ``v x u`` of motion vectors, ``(m, 6)`` each."""
    w, vl = v[:, :3], v[:, 3:]
    return np.concatenate(
        [np.cross(w, u[:, :3]), np.cross(vl, u[:, :3]) + np.cross(w, u[:, 3:])], axis=1
    )


def _cross_force(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Spatial cross product ``v x* f`` of a motion and a force vector, ``(m, 6)`` each."""
    w, vl = v[:, :3], v[:, 3:]
    return np.concatenate(
        [np.cross(w, f[:, :3]) + np.cross(vl, f[:, 3:]), np.cross(w, f[:, 3:])], axis=1
    )


def _joint_motion(kinds: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``motion(q) (m, 4, 4)``: Rz(q) for revolute, Tz(q) for prismatic joints."""
    m = q.shape[0]
    T = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
    if kinds == REVOLUTE:
        c, s = np.cos(q), np.sin(q)
        T[:, 0, 0] = c
        T[:, 0, 1] = -s
        T[:, 1, 0] = s
        T[:, 1, 1] = c
    else:
        T[:, 2, 3] = q
    return T


@dataclass(frozen=True)
class SerialChainDynamics:
    r"""Recursive Newton-Euler inverse dynamics of a serial chain of 1-DOF joints.

    Parameters
    ----------
    A : array, shape (n, 4, 4)
        Fixed transform from the parent link frame to joint i's frame, before its motion.
    B : array, shape (n, 4, 4)
        Fixed transform from the moved joint frame to link i's frame (the child frame).
    kinds : array of int, shape (n,)
        0 = revolute (motion ``Rz(q_i)``), 1 = prismatic (motion ``Tz(q_i)``).
    masses : array, shape (n,)
        Link masses [kg].
    coms : array, shape (n, 3)
        Centres of mass in the child frames [m].
    inertias : array, shape (n, 3, 3)
        Inertia tensors about the centres of mass, in the child frames [kg m^2].
    gravity : array, shape (3,)
        Gravitational acceleration in the base frame [m/s^2], e.g. ``(0, 0, -9.81)``.

    Notes
    -----
    ``T_parent_child = A[i] @ motion(q_i) @ B[i]``. The link spatial inertia about the child
    frame origin is ``[[I_c + m [c]x [c]x^T, m [c]x], [m [c]x^T, m 1]]`` (Featherstone 2008,
    Eq. 2.63); gravity enters as a base acceleration ``-g`` (Featherstone 2008, §5.3), so
    :meth:`bias` holds Coriolis, centrifugal and gravity terms: park's ``h(q, qd)`` of Eq. (8).
    """

    A: np.ndarray
    B: np.ndarray
    kinds: np.ndarray
    masses: np.ndarray
    coms: np.ndarray
    inertias: np.ndarray
    gravity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    _I6: np.ndarray = field(init=False, repr=False, compare=False)  # (n, 6, 6) spatial inertias
    _S: np.ndarray = field(init=False, repr=False, compare=False)  # (n, 6) joint axes, child frame

    def __post_init__(self) -> None:
        A = np.asarray(self.A, dtype=np.float64)
        n = A.shape[0] if A.ndim == 3 else -1
        checks = {
            "A": (A, (n, 4, 4)),
            "B": (np.asarray(self.B, dtype=np.float64), (n, 4, 4)),
            "kinds": (np.asarray(self.kinds, dtype=np.int64), (n,)),
            "masses": (np.asarray(self.masses, dtype=np.float64), (n,)),
            "coms": (np.asarray(self.coms, dtype=np.float64), (n, 3)),
            "inertias": (np.asarray(self.inertias, dtype=np.float64), (n, 3, 3)),
            "gravity": (np.asarray(self.gravity, dtype=np.float64), (3,)),
        }
        for name, (arr, shape) in checks.items():
            if n < 1 or arr.shape != shape:
                raise ValueError(f"{name}: expected shape {shape}, got {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name}: expected finite values")
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        if not np.all(np.isin(self.kinds, (REVOLUTE, PRISMATIC))):
            raise ValueError(f"kinds: expected 0 (revolute) or 1 (prismatic), got {self.kinds}")
        if np.any(self.masses < 0):
            raise ValueError(f"masses: expected >= 0, got {self.masses}")
        c = skew(self.coms)
        m = self.masses[:, None, None]
        I6 = np.zeros((n, 6, 6))
        I6[:, :3, :3] = self.inertias + m * c @ np.swapaxes(c, -1, -2)
        I6[:, :3, 3:] = m * c
        I6[:, 3:, :3] = m * np.swapaxes(c, -1, -2)
        I6[:, 3:, 3:] = m * np.eye(3)
        I6.setflags(write=False)
        object.__setattr__(self, "_I6", I6)
        e = np.zeros((n, 6))
        e[self.kinds == REVOLUTE, 2] = 1.0
        e[self.kinds == PRISMATIC, 5] = 1.0
        S = np.einsum("nij,nj->ni", _motion_transform(self.B), e)  # joint axis in child frame
        S.setflags(write=False)
        object.__setattr__(self, "_S", S)

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return int(self.kinds.shape[0])

    def link_transforms(self, q: np.ndarray) -> np.ndarray:
        """``T_parent_child (m, n, 4, 4)`` of every link for ``q (m, n)``."""
        q = _as_batch(q, self.n_joints, "q")
        return np.stack(
            [
                self.A[i] @ _joint_motion(self.kinds[i], q[:, i]) @ self.B[i]
                for i in range(self.n_joints)
            ],
            axis=1,
        )

    def link_poses(self, q: np.ndarray) -> np.ndarray:
        """``T_base_link (m, n, 4, 4)`` of every link frame for ``q (m, n)``."""
        Tl = self.link_transforms(q)
        out = np.empty_like(Tl)
        T = np.broadcast_to(np.eye(4), (Tl.shape[0], 4, 4))
        for i in range(self.n_joints):
            T = T @ Tl[:, i]
            out[:, i] = T
        return out

    def _rnea(
        self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, gravity: np.ndarray
    ) -> np.ndarray:
        n, m = self.n_joints, q.shape[0]
        X = _motion_transform(self.link_transforms(q))  # (m, n, 6, 6) parent -> child
        v = np.zeros((m, 6))
        a = np.zeros((m, 6))
        a[:, 3:] = -gravity  # Featherstone §5.3: accelerate the base against gravity
        f = np.empty((n, m, 6))
        for i in range(n):
            S = self._S[i]
            vJ = S[None, :] * qd[:, i : i + 1]
            v = np.einsum("mij,mj->mi", X[:, i], v) + vJ
            a = (
                np.einsum("mij,mj->mi", X[:, i], a)
                + S[None, :] * qdd[:, i : i + 1]
                + _cross_motion(v, vJ)
            )
            Iv = v @ self._I6[i].T
            f[i] = a @ self._I6[i].T + _cross_force(v, Iv)
        tau = np.empty((m, n))
        for i in range(n - 1, -1, -1):
            tau[:, i] = f[i] @ self._S[i]
            if i > 0:
                f[i - 1] += np.einsum("mji,mj->mi", X[:, i], f[i])
        return tau

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """``tau = M(q) qdd + h(q, qd)`` by recursive Newton-Euler (park Eq. (8)).

        Parameters
        ----------
        q, qd, qdd : array, shape (m, n)
            Joint positions [rad | m], velocities and accelerations.

        Returns
        -------
        array, shape (m, n)
            Joint torques [N m] or forces [N].
        """
        n = self.n_joints
        return self._rnea(
            _as_batch(q, n, "q"), _as_batch(qd, n, "qd"), _as_batch(qdd, n, "qdd"), self.gravity
        )

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """``M(q) (m, n, n)``: column k is the RNEA torque for ``qdd = e_k``, no qd, no gravity."""
        q = _as_batch(q, self.n_joints, "q")
        m, n = q.shape
        qs = np.repeat(q, n, axis=0)
        E = np.tile(np.eye(n), (m, 1))
        cols = self._rnea(qs, np.zeros_like(qs), E, np.zeros(3)).reshape(m, n, n)
        return np.swapaxes(cols, 1, 2)

    def bias(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """``h(q, qd) (m, n)``: Coriolis, centrifugal and gravity terms of park Eq. (8)."""
        q = _as_batch(q, self.n_joints, "q")
        return self._rnea(q, _as_batch(qd, self.n_joints, "qd"), np.zeros_like(q), self.gravity)

    def energy(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Kinetic plus potential energy ``E (m,)`` [J], potential zero at the base origin."""
        q = _as_batch(q, self.n_joints, "q")
        qd = _as_batch(qd, self.n_joints, "qd")
        M = self.mass_matrix(q)
        kinetic = 0.5 * np.einsum("mi,mij,mj->m", qd, M, qd)
        poses = self.link_poses(q)
        p_com = np.einsum("mnij,nj->mni", poses[..., :3, :3], self.coms) + poses[..., :3, 3]
        potential = -np.einsum("n,mni,i->m", self.masses, p_com, self.gravity)
        return kinetic + potential
