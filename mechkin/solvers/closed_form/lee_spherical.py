r"""Spherical 3-DOF RRPS parallel mechanism of lee: position, rates and isotropy in closed form.

Geometry (lee §2.1, Eqs. 2-3, 22-23): three universal joints on the base at
``R_i = R (cos g_bi, sin g_bi, 0)``, three spherical joints on the top plate at
``r_i = r (cos g_ti, sin g_ti, 0)`` in the plate frame, legs ``l_i = |P + [R] r_i - R_i|`` with
the plate origin held at the fixed centre ``P = (0, 0, 1)`` of the passive RRR chain (its three
axes are concurrent, so it acts as a spherical joint). Orientation ``mu = (alpha, beta, gamma)``
with ``[R] = Rx(alpha) Ry(beta) Rz(gamma)`` (lee Eq. 4, correct as printed).

With ``b_i = P - R_i``, ``p_i = [R] r_i`` and ``c_i = (l_i^2 - |b_i|^2 - |r_i|^2) / 2`` every leg
reads

.. math:: b_i \cdot ([R] r_i) = c_i, \qquad i = 1, 2, 3,

which is lee Eq. (10) with its sign corrected (Eq. 10/12 as printed has ``+ l_i^2`` on the wrong
side: the correct form is ``2 (P - R_i) . ([R] r_i) = l_i^2 - |P|^2 - |R_i|^2 - r^2 + 2 R_i . P``).

Units: lengths in the unit of ``R`` (the paper uses ``R = 1``), angles in rad.

Modules: the geometry, orientation and inverse position in
:mod:`~mechkin.solvers.closed_form.lee_geometry`, every assembly mode of the forward position in
:mod:`~mechkin.solvers.closed_form.lee_forward`; the rates, the isotropy index and the Newton
forward position here (every public name is re-exported from here).

References
----------
lee_spherical_3dof_parallel: S. H. Lee, W. K. Kim, B. J. Yi, "Analysis on kinematic
characteristics for a spherical 3-DOF parallel mechanism with constrained Stewart platform
structure", Eqs. (2)-(4), (9), (10), (17)-(23).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from mechkin.solvers.closed_form.lee_forward import forward_position, forward_position_batch
from mechkin.solvers.closed_form.lee_geometry import (
    _TWO_PI_3,
    DEFAULT_CHUNK,
    SIGMA_SINGULAR,
    ForwardPositionResult,
    LeeGeometry,
    NewtonResult,
    euler_xyz_from_matrix,
    inverse_position,
    leg_residuals,
    matrix_from_euler_xyz,
    within_stroke,
)

__all__ = [
    "DEFAULT_CHUNK",
    "ForwardPositionResult",
    "LeeGeometry",
    "NewtonResult",
    "PoseBatch",
    "euler_xyz_from_matrix",
    "evaluate_poses",
    "forward_position",
    "forward_position_batch",
    "forward_position_newton",
    "forward_rates",
    "inverse_position",
    "isotropy_from_jacobian",
    "isotropy_index",
    "jacobian",
    "leg_residuals",
    "matrix_from_euler_xyz",
    "sym3_eigvalsh",
    "within_stroke",
]

# --------------------------------------------------------------------------- rates (Eqs. 17-21)


def _euler_rate_columns(mu: np.ndarray) -> np.ndarray:
    """Columns of ``E`` with ``omega = E mu_dot`` for Rx Ry Rz (space frame); (..., 3, 3)."""
    ca, sa = np.cos(mu[..., 0]), np.sin(mu[..., 0])
    cb, sb = np.cos(mu[..., 1]), np.sin(mu[..., 1])
    o, z = np.ones_like(ca), np.zeros_like(ca)
    # omega = alpha_dot x + beta_dot Rx(alpha) y + gamma_dot Rx(alpha) Ry(beta) z
    return np.stack([o, z, z, z, ca, sa, sb, -sa * cb, ca * cb], axis=-1).reshape(
        mu.shape[:-1] + (3, 3)
    )  # row k = k-th column of E


def jacobian(geom: LeeGeometry, mu: np.ndarray) -> np.ndarray:
    r"""``[G] = dl/dmu``, the inverse rate relation ``l_dot = [G] mu_dot`` of lee Eqs. (17)-(18).

    Differentiating Eq. (9) with ``d([R] r_i)/dt = omega x p_i`` and ``omega = E(mu) mu_dot``:

    .. math:: g_{ik} = \frac{(p_i \times b_i) \cdot E_k}{l_i}, \qquad
              E = [x_b,\; R_x(\alpha) y_b,\; R_x(\alpha) R_y(\beta) z_b]

    Parameters
    ----------
    geom : LeeGeometry
    mu : array, shape (..., 3)
        (alpha, beta, gamma) [rad].

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Row i is ``dl_i/d(alpha, beta, gamma)``.
    """
    mu = np.asarray(mu, dtype=np.float64)
    R = matrix_from_euler_xyz(mu)
    b = geom._cache["b"]
    p = np.einsum("...jk,ik->...ij", R, geom._cache["top"])
    length = np.linalg.norm(p + b, axis=-1)
    w = np.cross(p, np.broadcast_to(b, p.shape)) / length[..., None]
    return np.einsum("...ij,...kj->...ik", w, _euler_rate_columns(mu))  # lee Eq. (18)


def forward_rates(
    geom: LeeGeometry, mu: np.ndarray, l_dot: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    r"""Forward rate relation ``mu_dot = [G]^{-1} l_dot``, lee Eqs. (19)-(20).

    Parameters
    ----------
    geom : LeeGeometry
    mu : array, shape (m, 3)
        Poses [rad].
    l_dot : array, shape (m, 3)
        Leg rates [length/s].

    Returns
    -------
    mu_dot : ndarray, shape (m, 3)
        Euler-angle rates [rad/s]; at singular poses the minimum-norm least-squares rates.
    singular : ndarray of bool, shape (m,)
        ``sigma_KI < SIGMA_SINGULAR``: ``[G]`` has no inverse there (Eq. 20 undefined).
    """
    G = jacobian(geom, np.asarray(mu, dtype=np.float64).reshape(-1, 3))
    l_dot = np.asarray(l_dot, dtype=np.float64).reshape(-1, 3)
    singular = isotropy_from_jacobian(G) < SIGMA_SINGULAR
    mu_dot = np.empty_like(l_dot)
    ok = ~singular
    if ok.any():
        mu_dot[ok] = np.linalg.solve(G[ok], l_dot[ok, :, None])[..., 0]  # lee Eq. (19)
    if singular.any():
        mu_dot[singular] = (np.linalg.pinv(G[singular], rcond=1e-12) @ l_dot[singular, :, None])[
            ..., 0
        ]
    return mu_dot, singular


def sym3_eigvalsh(A: np.ndarray) -> np.ndarray:
    """Eigenvalues of symmetric 3x3 matrices in closed form (trigonometric method), ascending.

    Smith's formula ``q + 2 p cos(phi + 2 pi k / 3)``; the few matrices within 1e-4 of a double
    eigenvalue (where ``arccos`` would lose half the digits) are redone with
    ``numpy.linalg.eigvalsh``, so the absolute accuracy is ``O(eps * ||A||)`` throughout.
    ``A`` (..., 3, 3) -> (..., 3).
    """
    A = np.asarray(A, dtype=np.float64)
    a00, a11, a22 = A[..., 0, 0], A[..., 1, 1], A[..., 2, 2]
    a01, a02, a12 = A[..., 0, 1], A[..., 0, 2], A[..., 1, 2]
    q = (a00 + a11 + a22) / 3.0
    d0, d1, d2 = a00 - q, a11 - q, a22 - q
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    p = np.sqrt((d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * p1) / 6.0)
    safe = np.where(p > 0.0, p, 1.0)
    detB = (
        d0 * (d1 * d2 - a12 * a12) - a01 * (a01 * d2 - a12 * a02) + a02 * (a01 * a12 - d1 * a02)
    ) / (safe * safe * safe)
    phi = np.arccos(np.clip(0.5 * detB, -1.0, 1.0)) / 3.0
    lam_max = q + 2.0 * p * np.cos(phi)
    lam_min = q + 2.0 * p * np.cos(phi + _TWO_PI_3)
    lam_mid = 3.0 * q - lam_max - lam_min
    lam = np.stack([lam_min, lam_mid, lam_max], axis=-1)
    # Near a double eigenvalue arccos loses half the digits: redo those few with LAPACK.
    near = np.abs(0.5 * detB) > 1.0 - 1e-4
    if np.any(near):
        lam[near] = np.linalg.eigvalsh(A[near])
    return lam


def _isotropy_closed_form(G: np.ndarray) -> np.ndarray:
    """sigma_min/sigma_max of 3x3 ``G`` (..., 3, 3) from the eigenvalues of ``G^T G``.

    The smallest eigenvalue is recomputed as ``det(G)^2 / (lam_mid lam_max)``, which keeps full
    relative accuracy near singularities; the rare matrices of rank <= 1 (``lam_mid`` not well
    separated from zero) are redone by SVD.
    """
    A = np.einsum("...ji,...jk->...ik", G, G)
    lam = sym3_eigvalsh(A)
    lam_mid, lam_max = lam[..., 1], lam[..., 2]
    det = _det3(G)
    good = lam_mid > 1e-6 * lam_max
    lam_min = det * det / np.where(good, lam_mid * lam_max, 1.0)
    ratio = np.where(good, lam_min / np.where(good, lam_max, 1.0), 0.0)
    sigma = np.sqrt(np.clip(ratio, 0.0, 1.0))
    if not np.all(good):
        sigma[~good] = isotropy_from_jacobian(G[~good], method="svd")
    return sigma


def _det3(G: np.ndarray) -> np.ndarray:
    return (
        G[..., 0, 0] * (G[..., 1, 1] * G[..., 2, 2] - G[..., 1, 2] * G[..., 2, 1])
        - G[..., 0, 1] * (G[..., 1, 0] * G[..., 2, 2] - G[..., 1, 2] * G[..., 2, 0])
        + G[..., 0, 2] * (G[..., 1, 0] * G[..., 2, 1] - G[..., 1, 1] * G[..., 2, 0])
    )


def isotropy_from_jacobian(G: np.ndarray, *, method: str = "closed_form") -> np.ndarray:
    r"""Kinematic isotropy index of stacked 3x3 Jacobians, lee Eq. (21).

    .. math:: \sigma_{KI} = \frac{\sigma_{min}([G_l^u])}{\sigma_{max}([G_l^u])}
              = \frac{\sigma_{min}([G])}{\sigma_{max}([G])}

    since ``[G_l^u] = [G]^{-1}`` (Eq. 20) has the reciprocal singular values. Computing it from
    ``[G]`` never inverts anything, so singular poses give 0, never NaN.

    Parameters
    ----------
    G : array, shape (..., 3, 3)
    method : {"closed_form", "svd"}
        ``"closed_form"`` (default, fast) or ``numpy.linalg.svd`` (reference).

    Returns
    -------
    ndarray, shape (...)
        sigma_KI in [0, 1].
    """
    G = np.asarray(G, dtype=np.float64)
    batch = G.shape[:-2]
    G = G.reshape(-1, 3, 3)
    if method == "svd":
        s = np.linalg.svd(G, compute_uv=False)
        pos = s[..., 0] > 0.0
        sigma = np.where(pos, s[..., -1] / np.where(pos, s[..., 0], 1.0), 0.0)
    elif method == "closed_form":
        sigma = _isotropy_closed_form(G)
    else:
        raise ValueError(f"method: expected 'closed_form' or 'svd', got {method!r}")
    return sigma.reshape(batch)


class PoseBatch(NamedTuple):
    """Leg lengths, sigma_KI and det([G]) of a batch of poses (see :func:`evaluate_poses`)."""

    lengths: np.ndarray
    sigma: np.ndarray
    det_G: np.ndarray


def evaluate_poses(
    geom: LeeGeometry,
    mu: np.ndarray,
    *,
    method: str = "closed_form",
    chunk: int = DEFAULT_CHUNK,
) -> PoseBatch:
    """Leg lengths (Eq. 9), sigma_KI (Eq. 21) and det([G]) of many poses, in cache-sized blocks.

    Parameters
    ----------
    geom : LeeGeometry
    mu : array, shape (m, 3)
        (alpha, beta, gamma) [rad].
    method : {"closed_form", "svd"}
        See :func:`isotropy_from_jacobian`.
    chunk : int
        Poses per block.

    Returns
    -------
    PoseBatch
        ``lengths (m, 3)``, ``sigma (m,)`` in [0, 1] and ``det_G (m,)``; the sign of ``det_G``
        changes across every (generic) singular surface, which lets sampled maps see a
        singularity that falls between two grid points.
    """
    mu = np.asarray(mu, dtype=np.float64).reshape(-1, 3)
    m = mu.shape[0]
    lengths = np.empty((m, 3))
    sigma = np.empty(m)
    det = np.empty(m)
    b, top = geom._cache["b"], geom._cache["top"]
    for s in range(0, m, chunk):
        blk = mu[s : s + chunk]
        R = matrix_from_euler_xyz(blk)
        p = np.einsum("mjk,ik->mij", R, top)  # p_i = [R] r_i
        d = p + b
        ln = np.sqrt(np.einsum("mij,mij->mi", d, d))  # lee Eq. (9)
        w = np.cross(p, np.broadcast_to(b, p.shape)) / ln[..., None]
        G = np.einsum("mij,mkj->mik", w, _euler_rate_columns(blk))  # lee Eq. (18)
        lengths[s : s + chunk] = ln
        sigma[s : s + chunk] = isotropy_from_jacobian(G, method=method)
        det[s : s + chunk] = _det3(G)
    return PoseBatch(lengths, sigma, det)


def isotropy_index(geom: LeeGeometry, mu: np.ndarray, *, method: str = "closed_form") -> np.ndarray:
    """sigma_KI (lee Eq. 21) at orientations ``mu`` (..., 3) -> (...); 0 at singular poses."""
    mu = np.asarray(mu, dtype=np.float64)
    sigma = evaluate_poses(geom, mu.reshape(-1, 3), method=method).sigma
    return sigma.reshape(mu.shape[:-1])


def forward_position_newton(
    geom: LeeGeometry,
    lengths: np.ndarray,
    mu0: np.ndarray,
    *,
    tol: float = 1e-13,
    max_iter: int = 50,
) -> NewtonResult:
    r"""One assembly mode by plain Newton-Raphson on Eq. (9) from a starting pose.

    .. math:: \mu^{k+1} = \mu^k - [G(\mu^k)]^{-1} (l(\mu^k) - l)

    The reference against which :func:`forward_position` is cross-checked (and the way to
    track a mode continuously along a trajectory).

    Parameters
    ----------
    geom : LeeGeometry
    lengths : array, shape (3,)
    mu0 : array, shape (3,)
        Start [rad].
    tol : float
        Stop when ``max |l(mu) - l| < tol``.
    max_iter : int

    Returns
    -------
    NewtonResult
        ``status`` "ok", "not converged" or "singular" (sigma_KI < 1e-12).
    """
    target = np.asarray(lengths, dtype=np.float64).reshape(3)
    mu = np.asarray(mu0, dtype=np.float64).reshape(3).copy()
    res = math.inf
    for it in range(max_iter + 1):
        err = inverse_position(geom, mu) - target
        res = float(np.max(np.abs(err)))
        if res < tol:
            return NewtonResult(mu, "ok", it, res)
        if it == max_iter:
            break
        G = jacobian(geom, mu)
        if isotropy_from_jacobian(G) < 1e-12:
            return NewtonResult(mu, "singular", it, res)
        mu = mu - np.linalg.solve(G, err)  # lee Eq. (19)-(20) as a Newton step
    return NewtonResult(mu, "not converged", max_iter, res)
