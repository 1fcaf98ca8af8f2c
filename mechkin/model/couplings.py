r"""Joint couplings as constraint rows of phi (DESIGN.md: "couplings (mimic joints) and cut
links are both constraint rows of phi").

A coupling ``q_j = m q_i + c`` (URDF ``<mimic>``, MJCF ``<equality><joint polycoef="c m">``)
adds the row

.. math:: \phi_c(q) = q_j - m\,q_i - c, \qquad
          \frac{\partial\phi_c}{\partial q} = e_j^T - m\,e_i^T, \qquad
          \frac{d}{dt}\Big(\frac{\partial\phi_c}{\partial q}\Big)\dot q = 0

after the cut rows of kim1995 Eq. (4). The coupled joint is dependent, so the Newton-Raphson of
the loop closure (:mod:`mechkin.model.closure`) solves it with the loops; rates and
accelerations follow from the same rows (:mod:`mechkin.model.differential`).

Without cut links the rows are linear and solve in closed form (:class:`CouplingMap`):

.. math:: q_j = M_j\,q_{v,b(j)} + C_j,\qquad q = S\,q_v + c_0,\qquad
          \frac{\partial x}{\partial q_v} = \frac{\partial x}{\partial q}\,S

with ``b(j)`` the independent joint at the root of j's coupling chain (itself for an
independent joint: M = 1, C = 0) and S (n, n_v) constant. IK then searches q_v with the reduced
Jacobian ``J S`` (the column of a coupled joint added into its master's, times M): the
open-chain lm, numpy and compiled (:mod:`mechkin.solvers.ik.coupled_jit`), and the seed codebook
use it, and forward kinematics of a batch (:func:`mechkin.model.continuation.fk_rows`) needs no
continuation. Limits of a coupled joint j are bounds on its master: ``lower_j <= M_j q_b + C_j
<= upper_j`` maps to an interval of q_b, intersected with the master's own limits
(:meth:`CouplingMap.bounds`); a revolute coupled joint whose limits span a full turn bounds
nothing (as the passive-limit checks of closed chains treat it), and a master that any joint
follows is never wrapped by whole turns (a turn of the master is not a turn of a joint with
m != +-1).

Imports: numpy, model.mechanism.
"""

from __future__ import annotations

import numpy as np

from mechkin.model.mechanism import Mechanism


def _arrays(mech: Mechanism) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    cache = mech.__dict__.get("_coupling_arrays")
    if cache is None:
        c = mech.couplings
        cache = (np.array([x.joint for x in c], dtype=int),
                 np.array([x.master for x in c], dtype=int),
                 np.array([x.multiplier for x in c], dtype=np.float64),
                 np.array([x.offset for x in c], dtype=np.float64))
        object.__setattr__(mech, "_coupling_arrays", cache)
    return cache


def coupling_residual(mech: Mechanism, q: np.ndarray) -> np.ndarray:
    """phi_c (m, k) = q_j - m q_i - c of every coupling, for joint values q (m, n)."""
    j, i, mult, off = _arrays(mech)
    return q[:, j] - mult * q[:, i] - off


def coupling_jacobian(mech: Mechanism) -> np.ndarray:
    """d(phi_c)/dq (k, n): constant (the rows are linear)."""
    cache = mech.__dict__.get("_coupling_jacobian")
    if cache is None:
        j, i, mult, _ = _arrays(mech)
        cache = np.zeros((len(j), mech.n))
        rows = np.arange(len(j))
        cache[rows, j] += 1.0
        np.add.at(cache, (rows, i), -mult)
        object.__setattr__(mech, "_coupling_jacobian", cache)
    return cache


def append_coupling_rows(mech: Mechanism, q: np.ndarray, phi: np.ndarray,
                         J: np.ndarray | None = None):
    """phi (m, n_cut_eq) -> (m, n_eq) with the coupling rows after the cut rows; and J
    (m, n_cut_eq, n) -> (m, n_eq, n) when given."""
    phi = np.concatenate([phi, coupling_residual(mech, q)], axis=1)
    if J is None:
        return phi
    Jc = np.broadcast_to(coupling_jacobian(mech), (q.shape[0],) + coupling_jacobian(mech).shape)
    return phi, np.concatenate([J, Jc], axis=1)


def coupling_position_rows(mech: Mechanism) -> np.ndarray:
    """(k,) bool: the coupling rows in length units (the coupled joint is prismatic)."""
    j = _arrays(mech)[0]
    return mech.s[j] == 1


class CouplingMap:
    """q = S q_v + c0 of a mechanism whose only constraints are joint couplings.

    Attributes
    ----------
    col : (n,) int
        Position in q_v of each joint's root master (its own position for an independent joint).
    mult, off : (n,) float
        M_j and C_j: ``q_j = mult[j] q_v[col[j]] + off[j]``.
    S : (n, n_v)
        dq/dq_v (constant).
    order : tuple of (joint, master, multiplier, offset)
        The couplings in an order where every master is set before the joints that follow it
        (:meth:`full` evaluates ``q_j = m q_master + c`` in that order, so a coupled joint equals
        its own row ``m q_master + c`` to the last bit).
    """

    def __init__(self, mech: Mechanism, col: np.ndarray, mult: np.ndarray, off: np.ndarray,
                 order: tuple) -> None:
        self.mech = mech
        self.iv = np.asarray(mech.independent, dtype=int)
        self.iw = np.asarray(mech.dependent, dtype=int)
        self.col, self.mult, self.off, self.order = col, mult, off, order
        S = np.zeros((mech.n, self.iv.size))
        S[np.arange(mech.n), col] = mult
        self.S = S

    def full(self, q_v: np.ndarray) -> np.ndarray:
        """All joints q (m, n) from the independent ones q_v (m, n_v)."""
        q_v = np.asarray(q_v, dtype=np.float64)
        q = np.empty(q_v.shape[:-1] + (self.mech.n,))
        q[..., self.iv] = q_v
        for j, i, m, c in self.order:
            q[..., j] = m * q[..., i] + c
        return q

    def bounds(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(lower, upper, continuous) of q_v (n_v,): each joint's own limits intersected with
        the images of its coupled joints' limits; continuous (wrapped by whole turns) only where
        no coupled joint follows the joint. The intervals may be empty (lower > upper):
        :func:`coupling_map` then declines the mechanism."""
        mech = self.mech
        lo = mech.lower[self.iv].astype(np.float64)
        hi = mech.upper[self.iv].astype(np.float64)
        bounded = np.zeros(self.iv.size, dtype=bool)
        for j in self.iw:
            m, c, b = self.mult[j], self.off[j], self.col[j]
            lj, hj = mech.lower[j], mech.upper[j]
            if m == 0.0:
                continue
            bounded[b] = True  # a whole turn of b is not one of j (m != +-1): never wrapped
            if mech.s[j] == 0 and hj - lj >= 2 * np.pi - 1e-9:
                continue
            a, z = (lj - c) / m, (hj - c) / m
            lo[b] = max(lo[b], min(a, z))
            hi[b] = min(hi[b], max(a, z))
        cont = ((mech.s[self.iv] == 0) & (mech.upper[self.iv] - mech.lower[self.iv]
                                          >= 2 * np.pi - 1e-9) & ~bounded)
        return lo, hi, cont


def coupling_map(mech: Mechanism) -> CouplingMap | None:
    """The :class:`CouplingMap` of ``mech`` (cached on it), or None when the mechanism has cut
    links, no couplings, a dependent joint that is not coupled, a cycle of couplings, or limits
    whose intersection is empty (those keep the loop-closure route)."""
    if "_coupling_map" in mech.__dict__:
        return mech.__dict__["_coupling_map"]
    out = _build(mech)
    object.__setattr__(mech, "_coupling_map", out)
    return out


def _build(mech: Mechanism) -> CouplingMap | None:
    if mech.cuts or not mech.couplings:
        return None
    by_joint = {c.joint: c for c in mech.couplings}
    if set(int(j) for j in mech.dependent) != set(by_joint):
        return None
    pos = {int(j): k for k, j in enumerate(mech.independent)}
    n = mech.n
    col = np.full(n, -1, dtype=int)
    mult = np.zeros(n)
    off = np.zeros(n)
    for j, k in pos.items():
        col[j], mult[j] = k, 1.0
    order: list[tuple[int, int, float, float]] = []
    for j0 in by_joint:
        stack = []
        j = j0
        while col[j] < 0:  # walk up to a set joint, then set the chain on the way back
            if j in stack or j not in by_joint:
                return None  # a cycle of couplings (or a master that is neither)
            stack.append(j)
            j = by_joint[j].master
        for j in reversed(stack):
            c = by_joint[j]
            col[j] = col[c.master]
            mult[j] = c.multiplier * mult[c.master]
            off[j] = c.multiplier * off[c.master] + c.offset
            order.append((j, c.master, c.multiplier, c.offset))
    cmap = CouplingMap(mech, col, mult, off, tuple(order))
    lo, hi, _ = cmap.bounds()
    if np.any(lo > hi):
        return None
    return cmap
