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

References
----------
lee_spherical_3dof_parallel: S. H. Lee, W. K. Kim, B. J. Yi, "Analysis on kinematic
characteristics for a spherical 3-DOF parallel mechanism with constrained Stewart platform
structure", Eqs. (2)-(4), (9), (10), (17)-(23).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from mechkin.errors import ModelError

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

DEFAULT_CHUNK = 1 << 16
"""Poses per vectorized block in :func:`evaluate_poses` (keeps temporaries in cache)."""

SIGMA_SINGULAR = 1e-9
"""sigma_KI below which :func:`forward_rates` treats a pose as singular."""

_TWO_PI_3 = 2.0 * math.pi / 3.0


@dataclass(frozen=True)
class LeeGeometry:
    """Design parameters of lee's mechanism (defaults: the paper's simulation, lee §3.2).

    Parameters
    ----------
    r : float
        Top-plate radius ``r`` (distance from the plate origin to each spherical joint), Eq. (3).
    R : float
        Base radius ``R`` (distance from the base origin to each universal joint), Eq. (2).
    base_angles : tuple of 3 float
        Offset angles ``gamma_bi`` [rad] of the universal joints about ``z_b``, Eq. (22).
    top_angles : tuple of 3 float
        Offset angles ``gamma_ti`` [rad] of the spherical joints about ``z_t``, Eq. (23).
    center : tuple of 3 float
        ``P``, the fixed centre of rotation (top-plate origin), lee §3.2: (0, 0, 1).
    l_min, l_max : float
        Leg stroke, ``l_min <= l_i <= l_max`` (lee §3.2: 0.5 and 2).

    Raises
    ------
    ModelError
        Non-positive radii, ``l_min >= l_max`` or coinciding / collinear spherical joints.
    """

    r: float = 0.75
    R: float = 1.0
    base_angles: tuple[float, float, float] = (0.0, _TWO_PI_3, 2.0 * _TWO_PI_3)
    top_angles: tuple[float, float, float] = (0.0, _TWO_PI_3, 2.0 * _TWO_PI_3)
    center: tuple[float, float, float] = (0.0, 0.0, 1.0)
    l_min: float = 0.5
    l_max: float = 2.0
    _cache: dict[str, np.ndarray] = field(
        default_factory=dict, init=False, repr=False, compare=False, hash=False
    )

    def __post_init__(self) -> None:
        problems = []
        if not (math.isfinite(self.r) and self.r > 0):
            problems.append(f"r: expected a positive number, got {self.r!r}")
        if not (math.isfinite(self.R) and self.R > 0):
            problems.append(f"R: expected a positive number, got {self.R!r}")
        if not (0 <= self.l_min < self.l_max):
            problems.append(f"stroke: expected 0 <= l_min < l_max, got {self.l_min}, {self.l_max}")
        for name in ("base_angles", "top_angles", "center"):
            if len(getattr(self, name)) != 3:
                problems.append(f"{name}: expected 3 numbers, got {getattr(self, name)!r}")
        if not problems:
            t = np.asarray(self.top_angles, dtype=np.float64)
            chord = np.abs(np.sin(0.5 * (t[:, None] - t[None, :])))
            if np.min(chord[np.triu_indices(3, 1)]) < 1e-9:
                problems.append(f"top_angles: expected 3 distinct angles, got {self.top_angles}")
        if problems:
            raise ModelError("lee geometry: " + "; ".join(problems))
        g_b = np.asarray(self.base_angles, dtype=np.float64)
        g_t = np.asarray(self.top_angles, dtype=np.float64)
        base = self.R * np.stack([np.cos(g_b), np.sin(g_b), np.zeros(3)], axis=-1)
        top = self.r * np.stack([np.cos(g_t), np.sin(g_t), np.zeros(3)], axis=-1)
        self._cache["base"] = base
        self._cache["top"] = top
        self._cache["b"] = np.asarray(self.center, dtype=np.float64)[None, :] - base

    @property
    def base_points(self) -> np.ndarray:
        """``R_i`` as rows, shape (3, 3), Eq. (2)."""
        return self._cache["base"].copy()

    @property
    def top_points(self) -> np.ndarray:
        """``r_i^(t)`` in the top-plate frame as rows, shape (3, 3), Eq. (3)."""
        return self._cache["top"].copy()

    @property
    def leg_offsets(self) -> np.ndarray:
        """``b_i = P - R_i`` as rows, shape (3, 3)."""
        return self._cache["b"].copy()


@dataclass(frozen=True)
class ForwardPositionResult:
    """Every real assembly mode for one set of leg lengths.

    Attributes
    ----------
    mu : ndarray, shape (k, 3)
        Euler angles (alpha, beta, gamma) [rad] of each mode, beta in [-pi/2, pi/2], sorted by
        rotation angle from the home pose.
    R : ndarray, shape (k, 3, 3)
        Plate orientation ``[R]`` of each mode (exact; ``mu`` is ambiguous at beta = +-pi/2).
    residual : ndarray, shape (k,)
        ``max_i |l_i(mu) - l_i|`` after polishing [length].
    n_candidates : int
        Real roots of the univariate polynomial that were polished (>= k).
    degenerate : bool
        True when the univariate polynomial vanished identically (a continuum of solutions or a
        degenerate formulation); ``mu`` then holds only what polishing found.
    """

    mu: np.ndarray
    R: np.ndarray
    residual: np.ndarray
    n_candidates: int
    degenerate: bool = False

    @property
    def n_modes(self) -> int:
        """Number of distinct real assembly modes."""
        return int(self.mu.shape[0])


@dataclass(frozen=True)
class NewtonResult:
    """Outcome of :func:`forward_position_newton`.

    ``status`` is one of the ``mechkin.solvers.result.Status`` values ``"ok"``,
    ``"not converged"``, ``"singular"``.
    """

    mu: np.ndarray
    status: str
    iterations: int
    residual: float


# --------------------------------------------------------------------------- orientation (Eq. 4)


def matrix_from_euler_xyz(mu: np.ndarray) -> np.ndarray:
    """``[R] = Rx(alpha) Ry(beta) Rz(gamma)``, lee Eq. (4); ``mu`` (..., 3) -> (..., 3, 3)."""
    mu = np.asarray(mu, dtype=np.float64)
    ca, sa = np.cos(mu[..., 0]), np.sin(mu[..., 0])
    cb, sb = np.cos(mu[..., 1]), np.sin(mu[..., 1])
    cg, sg = np.cos(mu[..., 2]), np.sin(mu[..., 2])
    # fmt: off
    return np.stack(
        [
            cb * cg, -cb * sg, sb,
            sa * sb * cg + ca * sg, -sa * sb * sg + ca * cg, -sa * cb,
            -ca * sb * cg + sa * sg, ca * sb * sg + sa * cg, ca * cb,
        ],
        axis=-1,
    ).reshape(mu.shape[:-1] + (3, 3))  # lee Eq. (4)
    # fmt: on


def euler_xyz_from_matrix(R: np.ndarray) -> np.ndarray:
    """Inverse of :func:`matrix_from_euler_xyz`; (..., 3, 3) -> (..., 3), beta in [-pi/2, pi/2].

    At beta = +-pi/2 only alpha + -gamma is defined; alpha is then returned as 0.
    """
    R = np.asarray(R, dtype=np.float64)
    cb = np.hypot(R[..., 1, 2], R[..., 2, 2])
    beta = np.arctan2(R[..., 0, 2], cb)
    gimbal = cb < 1e-12
    alpha = np.where(gimbal, 0.0, np.arctan2(-R[..., 1, 2], R[..., 2, 2]))
    gamma = np.where(
        gimbal, np.arctan2(R[..., 1, 0], R[..., 1, 1]), np.arctan2(-R[..., 0, 1], R[..., 0, 0])
    )
    return np.stack([alpha, beta, gamma], axis=-1)


# --------------------------------------------------------------------------- inverse position


def inverse_position(geom: LeeGeometry, mu: np.ndarray) -> np.ndarray:
    r"""Leg lengths for orientations, lee Eq. (9).

    .. math:: l_i^2 = |P|^2 + |R_i|^2 + r^2 - 2 R_i \cdot P + 2 (P - R_i) \cdot ([R] r_i)

    Parameters
    ----------
    geom : LeeGeometry
    mu : array, shape (..., 3)
        (alpha, beta, gamma) [rad].

    Returns
    -------
    ndarray, shape (..., 3)
        ``l_i`` (always real: Eq. 9 is a squared distance).
    """
    R = matrix_from_euler_xyz(mu)
    p = np.einsum("...jk,ik->...ij", R, geom._cache["top"])  # p_i = [R] r_i
    return np.linalg.norm(p + geom._cache["b"], axis=-1)  # lee Eq. (9)


def within_stroke(geom: LeeGeometry, lengths: np.ndarray) -> np.ndarray:
    """True where every leg obeys ``l_min <= l_i <= l_max``; (..., 3) -> (...) bool."""
    lengths = np.asarray(lengths, dtype=np.float64)
    return np.all((lengths >= geom.l_min) & (lengths <= geom.l_max), axis=-1)


def leg_residuals(geom: LeeGeometry, R: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """``b_i . ([R] r_i) - c_i`` (corrected Eq. 10); ``R`` (..., 3, 3), ``lengths`` (..., 3)."""
    b, top = geom._cache["b"], geom._cache["top"]
    c = 0.5 * (np.asarray(lengths) ** 2 - np.sum(b * b, axis=-1) - np.sum(top * top, axis=-1))
    p = np.einsum("...jk,ik->...ij", R, top)
    return np.einsum("...ij,ij->...i", p, b) - c


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


# --------------------------------------------------------------------------- forward position

_N_SAMPLES = 16  # >= 2 * 4 + 1 samples determine a trigonometric polynomial of degree 4 exactly
_ROOT_BAND = 1e-3  # | |z| - 1 | below which a root is polished as a real candidate
_ACCEPT = 1e-9  # max |b_i . p_i - c_i| after polishing for a real assembly mode
_SAME = 1e-7  # Frobenius distance under which two polished rotations are one mode


def _frame(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Right-handed orthonormal frame (columns) from the pair (u, v); (..., 3) -> (..., 3, 3)."""
    e1 = u / np.linalg.norm(u, axis=-1, keepdims=True)
    e3 = np.cross(u, v)
    e3 = e3 / np.linalg.norm(e3, axis=-1, keepdims=True)
    return np.stack([e1, np.cross(e3, e1), e3], axis=-1)


def _perp_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    e1 = np.cross(n, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1)


@dataclass(frozen=True)
class _Plan:
    """Leg roles of the elimination: circle of leg j is swept, leg k solved, leg m closes."""

    j: int
    k: int
    m: int
    a: float  # r_m = a r_j + b r_k
    b: float
    d_jk: float  # r_j . r_k


def _plans(geom: LeeGeometry) -> list[_Plan]:
    top = geom._cache["top"]
    plans = []
    for j in range(3):
        k, m = (j + 1) % 3, (j + 2) % 3
        M = top[[j, k], :2].T
        if abs(np.linalg.det(M)) < 1e-9 * geom.r**2:
            continue
        ab = np.linalg.solve(M, top[m, :2])
        if abs(ab[1]) < 1e-9:  # r_m parallel to r_j: leg m would not involve p_k
            continue
        plans.append(_Plan(j, k, m, float(ab[0]), float(ab[1]), float(top[j] @ top[k])))
    return plans


def _linear_rows(
    pj: np.ndarray,
    ok: np.ndarray,
    cm: np.ndarray,
    pl: _Plan,
    bm: np.ndarray,
    e1k: np.ndarray,
    e2k: np.ndarray,
) -> tuple[np.ndarray, ...]:
    """For fixed ``p_j`` legs k and m are linear in ``(x, y)``, ``p_k = o_k + x e1_k + y e2_k``.

    Row 1: ``p_j . p_k = r_j . r_k``; row 2: ``b_m . (a p_j + b p_k) = c_m``. Returns
    ``a11, a12, f1, a21, a22, f2`` of ``[[a11, a12], [a21, a22]] (x, y) = (f1, f2)``.
    """
    a11 = pj @ e1k
    a12 = pj @ e2k
    f1 = pl.d_jk - np.sum(pj * ok, axis=-1)
    a21 = np.full_like(a11, pl.b * (bm @ e1k))
    a22 = np.full_like(a11, pl.b * (bm @ e2k))
    f2 = cm - pl.a * (pj @ bm) - pl.b * (ok @ bm)
    return a11, a12, f1, a21, a22, f2


def _candidates(
    geom: LeeGeometry, lengths: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Starting rotations from the real roots of the univariate polynomial, for m problems.

    Returns ``R0 (n, 3, 3)``, ``owner (n,)`` (problem index of each start), ``n_real (m,)``
    (roots on the unit circle per problem) and ``degenerate (m,)``.
    """
    b, top = geom._cache["b"], geom._cache["top"]
    m_prob = lengths.shape[0]
    bn = np.linalg.norm(b, axis=-1)
    n = b / bn[:, None]
    c = 0.5 * (lengths**2 - bn**2 - geom.r**2)  # corrected lee Eq. (10)
    h = c / bn  # signed distance of leg i's circle plane from P
    rho2 = geom.r**2 - h**2
    reachable = np.all(rho2 >= -1e-12 * geom.r**2, axis=-1)
    rho = np.sqrt(np.clip(rho2, 0.0, None))
    plans = _plans(geom)
    score = np.stack([rho[:, p.j] * rho[:, p.k] for p in plans], axis=-1)
    choice = np.argmax(score, axis=-1)  # sweep the pair of largest circles: best conditioned
    basis = [_perp_basis(n[i]) for i in range(3)]
    theta = 2.0 * np.pi * np.arange(_N_SAMPLES) / _N_SAMPLES

    R_out, owner_out = [], []
    n_real = np.zeros(m_prob, dtype=np.int64)
    degenerate = np.zeros(m_prob, dtype=bool)
    for ip, pl in enumerate(plans):
        sel = np.flatnonzero((choice == ip) & reachable)
        if sel.size == 0:
            continue
        j, k, m = pl.j, pl.k, pl.m
        (e1j, e2j), (e1k, e2k) = basis[j], basis[k]
        oj, ok = h[sel, j, None] * n[j], h[sel, k, None] * n[k]  # circle centres (S, 3)
        rj, rk, cm = rho[sel, j], rho[sel, k], c[sel, m]

        # F(theta_j) = Nx^2 + Ny^2 - rho_k^2 D^2 (Cramer on the 2x2 rows, then x^2 + y^2 =
        # rho_k^2) is a trigonometric polynomial of degree 4: 16 samples give it exactly.
        pj = oj[:, None, :] + rj[:, None, None] * (
            np.cos(theta)[:, None] * e1j + np.sin(theta)[:, None] * e2j
        )
        a11, a12, f1, a21, a22, f2 = _linear_rows(
            pj, ok[:, None, :], cm[:, None], pl, b[m], e1k, e2k
        )
        D = a11 * a22 - a12 * a21
        Nx = f1 * a22 - a12 * f2
        Ny = a11 * f2 - f1 * a21
        F = Nx * Nx + Ny * Ny - (rk * rk)[:, None] * D * D
        X = np.fft.fft(F, axis=-1) / _N_SAMPLES
        coef = np.concatenate([X[:, 4:0:-1], X[:, :1], X[:, -1:-5:-1]], axis=-1)  # f_4 .. f_-4
        scale = np.max(np.abs(coef), axis=-1)
        degen = scale <= 1e-14 * np.maximum(np.max(np.abs(F), axis=-1), 1e-300)
        degen |= scale == 0.0
        lead_ok = np.abs(coef[:, 0]) > 1e-10 * scale
        degenerate[sel[degen]] = True

        # Roots of z^4 F = sum_k f_k z^(k+4), z = exp(i theta): companion eigenvalues.
        roots = np.full((sel.size, 8), np.nan + 0j)
        reg = lead_ok & ~degen
        if reg.any():
            C = np.zeros((int(reg.sum()), 8, 8), dtype=complex)
            C[:, 0, :] = -coef[reg, 1:] / coef[reg, :1]
            C[:, np.arange(1, 8), np.arange(7)] = 1.0
            roots[reg] = np.linalg.eigvals(C)
        for s in np.flatnonzero(~lead_ok & ~degen):
            rts = np.roots(np.where(np.abs(coef[s]) > 1e-13 * scale[s], coef[s], 0.0))
            roots[s, : rts.size] = rts
        on_circle = np.abs(np.abs(roots) - 1.0) < _ROOT_BAND
        n_real[sel] = on_circle.sum(axis=-1)
        th_roots = np.where(on_circle, np.angle(roots), np.nan)
        if degen.any():  # F == 0: every theta_j solves it; start from a ring of samples
            th_roots[degen] = np.linspace(0.0, 2 * np.pi, 9)[:-1]

        s_idx, r_idx = np.nonzero(np.isfinite(th_roots))
        if s_idx.size == 0:
            continue
        th = th_roots[s_idx, r_idx]
        pj = oj[s_idx] + rj[s_idx, None] * (np.cos(th)[:, None] * e1j + np.sin(th)[:, None] * e2j)
        a11, a12, f1, a21, a22, f2 = _linear_rows(pj, ok[s_idx], cm[s_idx], pl, b[m], e1k, e2k)
        D = a11 * a22 - a12 * a21
        rel_D = np.abs(D) / np.maximum(np.hypot(a11, a12) * np.hypot(a21, a22), 1e-300)
        regular = rel_D >= 1e-6
        safe_D = np.where(regular, D, 1.0)
        xy_cramer = np.stack([f1 * a22 - a12 * f2, a11 * f2 - f1 * a21], -1) / safe_D[:, None]
        starts = [(regular, xy_cramer)]
        # Nearly parallel rows: p_k is where one row's line meets circle k (both points).
        rk_s = rk[s_idx]
        for A1, A2, F0 in ((a11, a12, f1), (a21, a22, f2)):
            nrm = np.hypot(A1, A2)
            good = ~regular & (nrm > 1e-12)
            u = np.stack([A1, A2], -1) / np.where(good, nrm, 1.0)[:, None]
            t0 = F0 / np.where(good, nrm, 1.0)
            half = np.sqrt(np.clip(rk_s**2 - t0**2, 0.0, None))
            perp = np.stack([-u[:, 1], u[:, 0]], -1)
            for sgn in (1.0, -1.0):
                starts.append((good, t0[:, None] * u + sgn * half[:, None] * perp))
        for keep, xy in starts:
            if not keep.any():
                continue
            pk = ok[s_idx[keep]] + xy[keep, :1] * e1k + xy[keep, 1:] * e2k
            Rp = _frame(pj[keep], pk)
            Rr = _frame(top[j], top[k])
            R_out.append(Rp @ Rr.T)  # the rotation taking (r_j, r_k) to (p_j, p_k)
            owner_out.append(sel[s_idx[keep]])
    if R_out:
        return np.concatenate(R_out), np.concatenate(owner_out), n_real, degenerate
    return np.zeros((0, 3, 3)), np.zeros(0, dtype=np.int64), n_real, degenerate


def _polish(
    geom: LeeGeometry, R: np.ndarray, c: np.ndarray, *, max_iter: int = 40
) -> tuple[np.ndarray, np.ndarray]:
    """Newton on ``b_i . (exp([delta]) R r_i) = c_i`` for stacked starts; returns R, residual."""
    b, top = geom._cache["b"], geom._cache["top"]
    R = R.copy()
    eye = np.eye(3)
    active = np.ones(R.shape[0], dtype=bool)
    for _ in range(max_iter):
        if not active.any():
            break
        Ra = R[active]
        p = np.einsum("njk,ik->nij", Ra, top)
        f = np.einsum("nij,ij->ni", p, b) - c[active]
        J = np.cross(p, np.broadcast_to(b, p.shape))  # d f_i / d delta = (p_i x b_i)^T
        JT = np.swapaxes(J, -1, -2)
        H = JT @ J
        mu = 1e-15 * np.trace(H, axis1=-2, axis2=-1)[:, None, None] + 1e-300
        delta = -np.linalg.solve(H + mu * eye, (JT @ f[..., None]))[..., 0]
        ang = np.linalg.norm(delta, axis=-1)
        axis = np.where(ang[:, None] > 0, delta / np.where(ang > 0, ang, 1.0)[:, None], eye[2])
        R[active] = _rodrigues(axis, ang) @ Ra
        # Quadratic convergence: after a step of 1e-12 the error is at round-off level.
        active[np.flatnonzero(active)[(ang < 1e-12) | (ang > 10.0)]] = False
    # Re-orthonormalize and evaluate the final residual.
    U, _, Vt = np.linalg.svd(R)
    R = U @ Vt
    p = np.einsum("njk,ik->nij", R, top)
    res = np.max(np.abs(np.einsum("nij,ij->ni", p, b) - c), axis=-1)
    return R, res


def _rodrigues(axis: np.ndarray, ang: np.ndarray) -> np.ndarray:
    K = np.zeros(axis.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -axis[..., 2], axis[..., 1]
    K[..., 1, 0], K[..., 1, 2] = axis[..., 2], -axis[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -axis[..., 1], axis[..., 0]
    s, c = np.sin(ang)[..., None, None], np.cos(ang)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def forward_position_batch(geom: LeeGeometry, lengths: np.ndarray) -> list[ForwardPositionResult]:
    r"""Every real assembly mode for each of m sets of leg lengths (complete, lee §2.3 redone).

    Method. With ``p_i = [R] r_i``, the legs are ``b_i . p_i = c_i`` (corrected Eq. 10) and
    ``|p_i| = r``, so each ``p_i`` lies on a circle ``C_i``. Because the ``r_i`` are coplanar,
    ``r_m = a r_j + b r_k`` and the rotation is fixed by the pair ``(p_j, p_k)`` with
    ``p_j . p_k = r_j . r_k``. Sweep ``p_j`` round ``C_j`` by its angle ``theta``; for fixed
    ``p_j`` the two remaining conditions (``p_j . p_k = r_j . r_k`` and
    ``b_m . (a p_j + b p_k) = c_m``) are *linear* in the in-plane coordinates ``(x, y)`` of
    ``p_k``, and ``p_k`` on ``C_k`` means ``x^2 + y^2 = rho_k^2``. Eliminating ``(x, y)`` by
    Cramer's rule gives

    .. math:: F(\theta) = N_x^2 + N_y^2 - \rho_k^2 D^2 = 0,

    a trigonometric polynomial of degree 4, i.e. a degree-8 polynomial in
    ``z = exp(i theta)``: eight complex solutions, matching the Bezout bound of three quadrics
    in the Euler parameters (the forward problem has at most 8 assembly modes). Its
    coefficients are obtained exactly from 16 samples by an FFT and its roots as eigenvalues
    of the companion matrix; roots on the unit circle are the real solutions. No tangent
    half-angle substitution is used, so no solution can hide at ``theta = pi``; every real
    solution makes ``F = 0`` (also where ``D = 0``, where the rows are parallel and both
    intersection points of a row with ``C_k`` are tried). Each root is then polished by
    Newton's method on the three leg equations in rotation space and duplicates are merged.

    Why not lee Eqs. (11)-(16): they write the three legs as ``[B] ([R] r^(t)) = A`` with a
    *single* vector ``r^(t)``, but each leg carries its own ``r_i`` (the rows of Eq. 10 involve
    three different vectors ``[R] r_i``), so ``v = [B]^{-1} A`` of Eq. (13) is none of them and
    in general not even of length ``r``. And even a correct vector pair ``u -> v`` fixes only
    two of the three rotational freedoms: every ``Rot(v, phi) Rot(k, theta)`` maps ``u`` to
    ``v``, so Eqs. (14)-(16) pick one rotation out of a one-parameter family. The paper's
    formula therefore returns a wrong orientation, and at most one of the up to eight
    assembly modes. (Eq. 10/12 also carries a sign error, corrected above.)

    Parameters
    ----------
    geom : LeeGeometry
    lengths : array, shape (m, 3)
        Leg lengths ``l_i``.

    Returns
    -------
    list of ForwardPositionResult, length m
        Empty ``mu`` (shape (0, 3)) when the lengths admit no real assembly.
    """
    lengths = np.asarray(lengths, dtype=np.float64).reshape(-1, 3)
    m_prob = lengths.shape[0]
    R0, owner, n_real, degenerate = _candidates(geom, lengths)
    b, top = geom._cache["b"], geom._cache["top"]
    c = 0.5 * (lengths**2 - np.sum(b * b, -1) - geom.r**2)
    R, res_c = _polish(geom, R0, c[owner])
    scale = max(geom.R, geom.r, float(np.linalg.norm(geom.center))) ** 2
    ok = res_c < _ACCEPT * scale
    R, owner = R[ok], owner[ok]
    order = np.argsort(owner, kind="stable")
    R, owner = R[order], owner[order]
    bounds = np.searchsorted(owner, np.arange(m_prob + 1))
    out = []
    for i in range(m_prob):
        Ri = R[bounds[i] : bounds[i + 1]]
        keep: list[int] = []
        for a in range(Ri.shape[0]):
            if all(np.linalg.norm(Ri[a] - Ri[q]) > _SAME for q in keep):
                keep.append(a)
        Ri = Ri[keep]
        angle = np.arccos(np.clip(0.5 * (np.trace(Ri, axis1=-2, axis2=-1) - 1.0), -1.0, 1.0))
        Ri = Ri[np.argsort(angle, kind="stable")]
        p = np.einsum("njk,ik->nij", Ri, top)
        res = np.max(np.abs(np.linalg.norm(p + b, axis=-1) - lengths[i]), axis=-1)
        out.append(
            ForwardPositionResult(
                mu=euler_xyz_from_matrix(Ri),
                R=Ri,
                residual=res,
                n_candidates=int(n_real[i]),
                degenerate=bool(degenerate[i]),
            )
        )
    return out


def forward_position(geom: LeeGeometry, lengths: np.ndarray) -> ForwardPositionResult:
    """Every real assembly mode for one set of leg lengths ``(3,)``.

    See :func:`forward_position_batch` for the method and why lee Eqs. (11)-(16) are not used.
    """
    lengths = np.asarray(lengths, dtype=np.float64)
    if lengths.shape != (3,):
        raise ValueError(f"lengths: expected shape (3,), got {lengths.shape}")
    return forward_position_batch(geom, lengths[None, :])[0]


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
