r"""Dexterity of a frame Jacobian: singular values, isotropy, condition number, manipulability.

For a batch of Jacobians ``J`` (m, 6, n_v) of a frame with respect to the independent joints
(rows omega, v; SI; closed chains: the reduced ``J_v + J_w dq_w/dq_v``, kim1995 Eq. (10)):

- isotropy ``sigma_min / sigma_max`` (the inverse condition number; 0 at singular poses), of
  the full Jacobian and of its position rows,
- condition number ``sigma_max / sigma_min``, capped at :data:`COND_CAP` (never inf),
- Yoshikawa's manipulability ``w = sqrt(det(J J^T)) = prod sigma_i``.

The rows of ``J`` mix rad/s and m/s (and prismatic columns mix 1/m and 1), so ``isotropy`` of
the raw SI Jacobian changes when the mechanism is measured in another length unit (scale a
robot by s and its J_v rows scale by s). The **dimensionally honest** index is
:func:`normalized_isotropy`: sigma_min/sigma_max of ``J_L = diag(I, I/L) J diag(1 | L)`` with a
characteristic length ``L`` (given, or :func:`characteristic_length`: the length that best
conditions the sampled workspace, Angeles 2007 §5.8 and Gosselin & Angeles 1991's global
conditioning index). It is invariant under a change of length unit because L scales with it.

lee's sigma_KI (:mod:`mechkin.solvers.closed_form.lee_spherical`, lee Eq. (21)) needs no L:
its Jacobian maps leg rates to *Euler-angle rates* of a purely rotational mechanism, so all
rows share one unit; it depends instead on the Euler parametrisation (it is not the isotropy
of the angular-velocity Jacobian, and it is not frame invariant).

References
----------
kim1995_complex_chain_ik Eq. (10); Yoshikawa (1985), Manipulability of robotic mechanisms,
IJRR 4(2); Gosselin & Angeles (1991), A global performance index for the kinematic
optimization of robotic manipulators, J. Mech. Des. 113(3); Angeles (2007), Fundamentals of
Robotic Mechanical Systems, 3rd ed., §5.8 (characteristic length); lee_spherical_3dof_parallel
Eq. (21).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "COND_CAP",
    "characteristic_length",
    "dexterity",
    "normalized_isotropy",
    "normalized_jacobian",
    "singular_values",
]

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


# --------------------------------------------------------------------------- characteristic length


def normalized_jacobian(J: np.ndarray, length: float, prismatic: np.ndarray | None = None
                        ) -> np.ndarray:
    r"""The dimensionless Jacobian ``J_L = diag(I_3, I_3 / L) J diag(1 | L)`` (rows omega, v).

    The translational rows are divided by the characteristic length ``L`` [m] and the columns
    of prismatic joints multiplied by it, so every entry is in rad/rad (or m/m): the singular
    values then no longer depend on the length unit (Angeles 2007, §5.8; Khan & Angeles 2006).
    """
    Jn = np.array(J, dtype=np.float64)
    Jn[:, 3:6, :] /= length
    if prismatic is not None and np.any(prismatic):
        Jn[:, :, np.asarray(prismatic, dtype=bool)] *= length
    return Jn


def normalized_isotropy(J: np.ndarray, length: float, prismatic: np.ndarray | None = None
                        ) -> np.ndarray:
    """sigma_min / sigma_max of :func:`normalized_jacobian` (m,); 0 at singular poses."""
    return _ratio(singular_values(normalized_jacobian(J, length, prismatic)))


def length_bounds(mech) -> tuple[float, float]:
    """The range a characteristic length of ``mech`` may take [m]: (size / 1000, size), with
    size the largest distance between two joint axis points at home
    (:func:`mechkin.model.singularity.characteristic_length`; a SCARA's reach)."""
    from mechkin.model.singularity import characteristic_length as size_of

    size = size_of(mech)
    return 1e-3 * size, size


def characteristic_length(J: np.ndarray, prismatic: np.ndarray | None = None, *,
                          max_samples: int = 2000,
                          bounds: tuple[float, float] | None = None) -> float:
    r"""The characteristic length that best conditions the sampled workspace.

    ``L* = argmax_L mean_k 1/kappa(J_L,k)``: the length that maximises Gosselin & Angeles's
    global conditioning index (the mean inverse condition number of the normalized Jacobian
    over the samples), i.e. minimises the condition number over the sampled workspace
    (Angeles 2007, §5.8 defines L as the length that makes the Jacobian best conditioned).
    Found by a scan of log L over six decades around ``||J_v||_F / ||J_omega||_F`` and a
    bounded Brent refinement (:func:`scipy.optimize.minimize_scalar`).

    Parameters
    ----------
    J : array, shape (m, 6, n_v)
        Jacobians at the samples (rows omega, v; SI).
    prismatic : array of bool, shape (n_v,), optional
        Columns of prismatic joints.
    max_samples : int
        At most this many samples (evenly strided) enter the search.
    bounds : (float, float), optional
        The search stays within [lo, hi] [m] (:func:`length_bounds`: the mechanism's own size),
        so an index that keeps improving as L grows (a direction only prismatic or only
        rotational columns span) cannot drive L to overflow.

    Returns
    -------
    float
        L* [m]; 1.0 when J has no rotational or no translational part (the index does not
        depend on L then).
    """
    from scipy.optimize import minimize_scalar

    J = np.where(np.isfinite(J), J, 0.0)
    if J.shape[0] > max_samples:
        J = J[:: -(-J.shape[0] // max_samples)]
    nw, nv = np.linalg.norm(J[:, 0:3, :]), np.linalg.norm(J[:, 3:6, :])
    if J.shape[0] == 0 or nw == 0.0 or nv == 0.0:
        return 1.0
    pr = None if prismatic is None else np.asarray(prismatic, dtype=bool)
    if pr is not None and pr.any():
        # prismatic columns: omega ~ 1/m, v ~ 1; revolute: omega ~ 1, v ~ m
        rv = ~pr
        cands = []
        for cols in (rv, pr):
            num = np.linalg.norm(J[:, 3:6][:, :, cols])
            den = np.linalg.norm(J[:, 0:3][:, :, cols])
            if num > 0 and den > 0:  # a prismatic joint turns nothing: no ratio from it
                cands.append(num / den)
        L0 = float(np.exp(np.mean(np.log(cands)))) if cands else nv / nw
    else:
        L0 = nv / nw

    def cost(log_l: float) -> float:
        return -float(np.mean(normalized_isotropy(J, float(np.exp(log_l)), pr)))

    grid = np.log(L0) + np.linspace(-3.0, 3.0, 61) * np.log(10.0)
    if bounds is not None:
        lo_b, hi_b = np.log(float(bounds[0])), np.log(float(bounds[1]))
        grid = np.unique(np.clip(grid, lo_b, hi_b))
        if grid.size < 8:
            grid = np.linspace(lo_b, hi_b, 61)
    vals = np.array([cost(x) for x in grid])
    k = int(np.argmin(vals))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    if hi > lo:
        res = minimize_scalar(cost, bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-6})
        best = float(res.x) if res.fun <= vals[k] else float(grid[k])
    else:
        best = float(grid[k])
    return float(np.exp(best))
