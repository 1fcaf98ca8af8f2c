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
