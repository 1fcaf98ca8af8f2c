"""Inverse dynamics of a serial :class:`~mechkin.model.Mechanism` from its inertial parameters.

The mechanism already stores every joint as ``T_parent_child(q_i) = A_i @ Z(q_i) @ B_i`` with
``Z`` a rotation about (``s_i = 0``) or a translation along (``s_i = 1``) the local z axis
(kim1995 Eq. (2)), and the inertial parameters of every link in its link frame. That is exactly
the description :class:`~mechkin.solvers.dynamics.open_chain.SerialChainDynamics` takes, so
building the
recursive Newton-Euler model (park Eq. (8): ``U = M(q) qdd + h(q, qd)``) is a matter of walking
the chain from the base and picking, per joint, its ``A``, ``B``, ``s`` and the inertials of its
child link.

A closed chain (cut links), a mechanism with joint couplings (mimic joints) or a branching tree
gets :class:`~mechkin.solvers.dynamics.closed_chain.ClosedChainDynamics` instead: Newton-Euler on
the spanning tree, projected on the independent joints by the virtual-work principle (kim1995
Eq. (3)-(4)); a coupling ``q_j = m q_i + c`` is a constraint row like a cut's, so the master's
torque carries ``m`` times the coupled joint's. :func:`chain_order` itself (and park's 2-link
closed form built on it) still accepts only a serial chain of independent joints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechkin.errors import ModelError
from mechkin.model import Mechanism
from mechkin.solvers.dynamics.closed_chain import ClosedChainDynamics
from mechkin.solvers.dynamics.open_chain import (
    InverseDynamics,
    PlanarTwoLinkDynamics,
    SerialChainDynamics,
)

__all__ = [
    "MechanismDynamics",
    "chain_order",
    "dynamics_from_mechanism",
    "planar_two_link_from_mechanism",
]


def chain_order(mech: Mechanism) -> np.ndarray:
    """Joint indices ``(n,)`` from the base to the tip of a serial mechanism.

    Raises
    ------
    ModelError
        If the mechanism has cut links (closed chain), branches, or links not reached from the
        base by one path of joints.
    """
    if mech.cuts:
        raise ModelError(
            f"{mech.name}: dynamics: closed chains are not supported (cuts: "
            f"{', '.join(c.name for c in mech.cuts)}); a serial chain is needed"
        )
    if mech.is_closed:  # joint couplings (mimic joints) are constraints too
        raise ModelError(
            f"{mech.name}: dynamics: a serial chain of independent joints is needed here, "
            f"and {', '.join(mech.joint_names[c.joint] for c in mech.couplings)} "
            "is coupled (a mimic joint); use dynamics: rnea, which projects the coupled "
            "joints' torques on their masters by virtual work"
        )
    parent = np.asarray(mech.joint_parent_link)
    child = np.asarray(mech.joint_child_link)
    order: list[int] = []
    link = 0  # the base link
    for _ in range(mech.n):
        nxt = np.flatnonzero(parent == link)
        if len(nxt) != 1:
            break
        order.append(int(nxt[0]))
        link = int(child[nxt[0]])
    if len(order) != mech.n:
        branch = next((int(li) for li in range(mech.n_links)
                       if int(np.sum(parent == li)) > 1), None)
        where = (f" (link {mech.link_names[branch]!r} carries "
                 f"{int(np.sum(parent == branch))} joints)" if branch is not None else "")
        raise ModelError(
            f"{mech.name}: dynamics: expected a serial chain of {mech.n} joints from the base, "
            f"found a chain of {len(order)}{where}"
        )
    return np.asarray(order, dtype=np.int64)


@dataclass(frozen=True)
class MechanismDynamics:
    """A :class:`SerialChainDynamics` whose joints are in the mechanism's joint order.

    The chain is ordered from the base; ``order[k]`` is the mechanism joint of chain position k.
    ``q, qd, qdd`` and the torques use the mechanism's order (``mech.joint_names``).
    """

    chain: SerialChainDynamics
    order: np.ndarray

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self.chain.n_joints

    def _to_chain(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(x, dtype=np.float64)[:, self.order]

    def _from_chain(self, x: np.ndarray) -> np.ndarray:
        out = np.empty_like(x)
        out[..., self.order] = x
        return out

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """``tau (m, n) = M(q) qdd + h(q, qd)`` (park Eq. (8)), mechanism joint order."""
        return self._from_chain(self.chain.inverse_dynamics(
            self._to_chain(q), self._to_chain(qd), self._to_chain(qdd)))

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """``M(q) (m, n, n)`` in the mechanism's joint order."""
        Mc = self.chain.mass_matrix(self._to_chain(q))
        inv = np.argsort(self.order)
        return Mc[:, inv][:, :, inv]

    def bias(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """``h(q, qd) (m, n)``: Coriolis, centrifugal and gravity terms."""
        return self._from_chain(self.chain.bias(self._to_chain(q), self._to_chain(qd)))


def _is_serial(mech: Mechanism) -> bool:
    parent = np.asarray(mech.joint_parent_link)
    return not mech.is_closed and all(int(np.sum(parent == li)) <= 1
                                      for li in range(mech.n_links))


def dynamics_from_mechanism(mech: Mechanism) -> InverseDynamics:
    """Recursive Newton-Euler inverse dynamics of a mechanism (park Eq. (8)).

    Per joint its constant transforms ``A``, ``B`` and kind ``s`` (kim1995 Eq. (2)); per joint the
    mass, centre of mass and inertia about the centre of mass of its child link, in that link's
    frame (the frame after ``B``); the mechanism's gravity in the base frame.

    Returns
    -------
    SerialChainDynamics
        When the joints are listed from the base to the tip (the usual case), else a
        :class:`MechanismDynamics` that permutes to and from the chain order.
    ClosedChainDynamics
        For a closed chain or a branching tree (all-joint interface: ``tau_v`` in the
        independent columns, 0 in the passive ones; :mod:`mechkin.solvers.dynamics.closed_chain`).

    Raises
    ------
    ModelError
        For a mechanism without any mass, or joints not reached from the base.
    """
    if not _is_serial(mech):
        return ClosedChainDynamics(mech)
    order = chain_order(mech)
    links = np.asarray(mech.joint_child_link)[order]
    masses = np.asarray(mech.mass)[links]
    if not np.any(masses > 0):
        raise ModelError(
            f"{mech.name}: dynamics: no link of the chain has a mass; add 'inertial:' to the "
            "links of the mechanism file"
        )
    chain = SerialChainDynamics(
        A=np.asarray(mech.A)[order],
        B=np.asarray(mech.B)[order],
        kinds=np.asarray(mech.s)[order],
        masses=masses,
        coms=np.asarray(mech.com)[links],
        inertias=np.asarray(mech.inertia)[links],
        gravity=np.asarray(mech.gravity),
    )
    if np.array_equal(order, np.arange(mech.n)):
        return chain
    return MechanismDynamics(chain=chain, order=order)


def planar_two_link_from_mechanism(mech: Mechanism, tol: float = 1e-9) -> PlanarTwoLinkDynamics:
    """park's closed-form 2-link model (Table 1) with parameters read from a planar 2R mechanism.

    ``l1`` is the distance between the two (parallel, vertical) joint axes, ``lc1``/``lc2`` the
    distances of the centres of mass from their proximal axes, ``I1``/``I2`` the central inertias
    about the axis direction. The closed form assumes both joint axes along the base z axis and
    each centre of mass on its link's line (link 1: towards axis 2; link 2: along link 1's line
    at ``q2 = 0``); anything else raises, so the model is never silently wrong.

    Raises
    ------
    ModelError
        If the mechanism is not such a planar 2R arm.
    """
    order = chain_order(mech)
    if mech.n != 2 or np.any(np.asarray(mech.s) != 0):
        raise ModelError(f"{mech.name}: closed_form_2link needs 2 revolute joints, got "
                         f"{mech.n} joints of kinds {np.asarray(mech.s).tolist()}")
    A = np.asarray(mech.A)[order]
    B = np.asarray(mech.B)[order]
    links = np.asarray(mech.joint_child_link)[order]
    T1 = A[0] @ B[0]  # link 1 frame at q = 0
    ax2 = T1 @ A[1]  # joint 2 frame at q = 0
    T2 = ax2 @ B[1]  # link 2 frame at q = 0
    z = np.array([0.0, 0.0, 1.0])
    for name, T in (("joint 1", A[0]), ("joint 2", ax2)):
        if np.linalg.norm(T[:3, 2] - z) > tol:
            raise ModelError(f"{mech.name}: closed_form_2link: {name} axis is not the base z axis")
    o1, o2 = A[0][:3, 3], ax2[:3, 3]
    c1 = T1[:3, :3] @ mech.com[links[0]] + T1[:3, 3]
    c2 = T2[:3, :3] @ mech.com[links[1]] + T2[:3, 3]
    d12, d1c, d2c = (o2 - o1)[:2], (c1 - o1)[:2], (c2 - o2)[:2]
    l1 = float(np.linalg.norm(d12))

    def along(u: np.ndarray, v: np.ndarray) -> bool:
        return abs(u[0] * v[1] - u[1] * v[0]) <= tol * max(1.0, l1) and float(u @ v) >= -tol

    if l1 <= tol or not along(d12, d1c) or not along(d12, d2c):
        raise ModelError(f"{mech.name}: closed_form_2link: the centres of mass must lie on the "
                         "link lines (use dynamics: rnea)")
    izz = []
    for T, li in ((T1, links[0]), (T2, links[1])):
        R = T[:3, :3]
        izz.append(float((R @ mech.inertia[li] @ R.T)[2, 2]))
    return PlanarTwoLinkDynamics(
        l1=l1, l2=l1, m1=float(mech.mass[links[0]]), m2=float(mech.mass[links[1]]),
        lc1=float(np.linalg.norm(d1c)), lc2=float(np.linalg.norm(d2c)), I1=izz[0], I2=izz[1],
    )
