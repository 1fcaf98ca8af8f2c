"""The spherical RRPS mechanism of lee: geometry, orientation (Eq. 4) and inverse position (Eq. 9).

:class:`LeeGeometry` (lee §2.1, Eqs. 2-3, 22-23), the records of the forward position
(:class:`ForwardPositionResult`, :class:`NewtonResult`), the orientation
``[R] = Rx(alpha) Ry(beta) Rz(gamma)`` (Eq. 4) and the leg lengths of a pose
(:func:`inverse_position`, Eq. 9). The conventions are described in
:mod:`mechkin.solvers.closed_form.lee_spherical`. Split out of ``lee_spherical.py`` (issue 23:
modules that fit in a head).

Design
------
Part of the closed-form room :mod:`mechkin.solvers.closed_form`; numpy and
:mod:`mechkin.errors` only.

References
----------
lee_spherical_3dof_parallel Eqs. (2)-(4), (9), (22)-(23).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mechkin.errors import ModelError

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
