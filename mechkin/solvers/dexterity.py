r"""Dexterity of a frame Jacobian: singular values, isotropy, condition number, manipulability.

For a batch of Jacobians ``J`` (m, 6, n_v) of a frame with respect to the independent joints
(rows omega, v; SI; closed chains: the reduced ``J_v + J_w dq_w/dq_v``, kim1995 Eq. (10)):

- isotropy ``sigma_min / sigma_max`` (the inverse condition number; 0 at singular poses), of
  the full Jacobian and of its position rows,
- condition number ``sigma_max / sigma_min``, capped at :data:`COND_CAP` (never inf),
- Yoshikawa's manipulability ``w = sqrt(det(J J^T)) = prod sigma_i``.

References
----------
kim1995_complex_chain_ik Eq. (10); Yoshikawa (1985), Manipulability of robotic mechanisms,
IJRR 4(2).
"""

from __future__ import annotations

import numpy as np

__all__ = ["COND_CAP", "dexterity", "singular_values"]

COND_CAP = 1e16
"""Condition numbers above this (numerically singular Jacobians) are reported as this value."""


def singular_values(J: np.ndarray) -> np.ndarray:
    """Singular values (m, k), descending, of a batch of matrices (m, r, c); NaN entries are
    taken as 0."""
    J = np.where(np.isfinite(J), J, 0.0)
    return np.linalg.svd(J, compute_uv=False)


def _ratio(s: np.ndarray) -> np.ndarray:
    """sigma_min / sigma_max per row of descending singular values; 0 where sigma_max = 0."""
    return np.where(s[:, 0] > 0, s[:, -1] / np.maximum(s[:, 0], 1e-300), 0.0)


def dexterity(J: np.ndarray) -> dict[str, np.ndarray]:
    """Isotropy, position-row isotropy, condition number (capped) and Yoshikawa manipulability
    of a batch of Jacobians ``J`` (m, 6, n_v), rows (omega, v); finite everywhere.

    Returns
    -------
    dict
        ``isotropy``, ``isotropy_position``, ``condition_number``, ``manipulability``, each
        (m,).
    """
    J = np.where(np.isfinite(J), J, 0.0)
    s = singular_values(J)
    sp = singular_values(J[:, 3:6, :])
    iso = _ratio(s)
    iso_p = _ratio(sp)
    cond = np.where(iso > 1.0 / COND_CAP, 1.0 / np.maximum(iso, 1e-300), COND_CAP)
    return {"isotropy": iso, "isotropy_position": iso_p, "condition_number": cond,
            "manipulability": np.prod(s, axis=1)}
