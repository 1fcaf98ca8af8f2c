"""Leg IK class 3 of hwang2023 (§2.4, Eqs. (36)-(43)): the blade rolls without slipping.

:func:`rolled_position` (Eq. 36) and :func:`solve_rolling`: from a known state (E_a, beta_Ya)
to the unknown tilt beta_Yb that gives the wanted ``theta6``; one numerical root search in
theta2 (P3 = 0, Eq. 40) or theta1 (P3 != 0, Eqs. 40, 43). The sign of Eq. (36c, d) is
discussed in :mod:`mechkin.solvers.biped.leg`. Split out of ``leg.py`` (issue 23: one module
per IK class).

Design
------
Part of the biped room :mod:`mechkin.solvers.biped`; may import
:mod:`mechkin.solvers.biped.leg_model` and :mod:`~mechkin.solvers.biped.leg_known_position`,
:mod:`mechkin.spatial` and scipy; no other solver room, never ``io/``, ``cli/`` or ``tasks/``.

References
----------
hwang2023_hybrid_walking_skating_ik §2.4, Eqs. (36)-(43).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq

from mechkin.solvers.biped.leg_known_position import _beta_from_x2, _blade_hip, _blade_rotation
from mechkin.solvers.biped.leg_model import (
    _S3,
    BETA_MAX,
    STATUS_NOT_CONVERGED,
    STATUS_UNREACHABLE,
    TOL_ANGLE,
    BipedGeometry,
    LegSolution,
    _accept,
    _failed,
    _half_atan,
    _lower,
    _side,
    _to_hip,
    _wrap,
    _x2,
)
from mechkin.spatial.euler_conventions import (
    Side,
)

# --------------------------------------------------------------------------- §2.4


def rolled_position(p_a: ArrayLike, u_x: ArrayLike, n: ArrayLike, r_w: float, beta_a: float,
                    beta_b: ArrayLike) -> np.ndarray:
    r"""Blade point E_b after rolling without slipping from beta_a to beta_b, Eqs. (36), (37).

    .. math:: E_b = E_a - r_w [(\beta_b - \sin\beta_b) - (\beta_a - \sin\beta_a)] u_{X'}
              + r_w (\cos\beta_a - \cos\beta_b)\, n

    ``u_x`` (3,) is u_X' = Delta[:, 0] and ``n`` (3,) the plane normal pointing away from the
    plane. ``beta_b`` (...) -> (..., 3) [m].
    """
    bb = np.asarray(beta_b, dtype=np.float64)[..., None]
    g = (bb - np.sin(bb)) - (beta_a - math.sin(beta_a))
    return (np.asarray(p_a, float) - r_w * g * np.asarray(u_x, float)
            + r_w * (math.cos(beta_a) - np.cos(bb)) * np.asarray(n, float))


def solve_rolling(geometry: BipedGeometry, side: Side, p_a: ArrayLike, beta_a: float,
                  Delta: ArrayLike, normal: ArrayLike, theta6: float, T_0_G: ArrayLike, *,
                  n_scan: int = 721, xtol: float = 1e-14) -> list[LegSolution]:
    """§2.4: the blade rolls from (E_a, beta_Ya) to the tilt beta_Yb that gives ``theta6``.

    Unknowns theta1..5, beta_Yb and E_b = E_a + dE(beta_Yb) (Eqs. 36f, 37). P3 = 0 (Table 4(a)):
    theta1 from Eq. (29), beta_Yb(theta2) from Eqs. (39), (41), theta2 from Eq. (40) by a root
    search. P3 != 0 (Table 4(b)): theta2(theta1) from Eq. (43), beta_Yb(theta1) from Eq. (39),
    theta1 from Eq. (40). The search scans the joint range on ``n_scan`` points, then refines
    every sign change with Brent's method; theta3..5 follow from Eqs. (13)-(20).

    Parameters
    ----------
    p_a : array, shape (3,)
        E_a [m], world.
    beta_a : float
        beta_Ya [rad] of the start state.
    Delta : array, shape (3, 3)
        Delta_i of the blade (plane and beta_Z), Eq. (21).
    normal : array, shape (3,)
        Plane normal pointing away from the plane (:attr:`InclinedPlane.normal`).
    theta6 : float
        Wanted ankle angle [rad] (0: the ankle straightens, Fig. 7 (e)-(h)).
    T_0_G : array, shape (4, 4)
        Body pose; the body does not move.

    Returns
    -------
    list of LegSolution
        All solutions in range, ordered by |beta_Yb - beta_Ya| then knee back first; ``beta``
        is beta_Yb and ``T_0_E`` places E_b.
    """
    side = _side(side)
    TG = np.asarray(T_0_G, dtype=np.float64)
    y6, a, b, Dr, TGr = _blade_hip(geometry, side, np.asarray(Delta, float), TG)
    pa = np.asarray(p_a, float)
    n = np.asarray(normal, float)
    if side == "left":
        pa, n = _S3 @ pa, _S3 @ n
    ux = Dr[:, 0]
    r_w = geometry.wheel_radius
    l6 = geometry.l6("blade")
    k = l6 * math.sin(theta6)  # P34 of Eq. (40)
    P1, P2, P3 = y6[0], y6[1], -y6[2]
    case_a = abs(P3) <= TOL_ANGLE
    method = f"hwang2023 §2.4 ({'P3 = 0' if case_a else 'P3 != 0'})"

    def angles(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if case_a:
            t1 = np.full_like(s, float(_half_atan(-P1, P2)))  # Eq. (29)
            return t1, s
        t1 = s
        return t1, _half_atan(-(P1 * np.cos(t1) + P2 * np.sin(t1)), P3)  # Eq. (43)

    def g(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t1, t2 = angles(s)
        x2 = _x2(t1, t2)
        beta = _beta_from_x2(x2, a, b, theta6)  # Eq. (39)
        pb = rolled_position(pa, ux, n, r_w, beta_a, beta)  # Eq. (37)
        _, e = _to_hip(geometry, TGr, np.eye(3), pb)
        return np.einsum("...i,...i->...", x2, e) - k, beta  # Eq. (40)

    lim = 0.5 * math.pi - 1e-9
    s = np.linspace(-lim, lim, n_scan)
    gs, bs = g(s)
    roots: list[float] = []
    for i in np.flatnonzero(np.sign(gs[:-1]) * np.sign(gs[1:]) <= 0):
        if not (np.isfinite(gs[i]) and np.isfinite(gs[i + 1])):
            continue
        if abs(_wrap(bs[i + 1] - bs[i])) > 0.5 * math.pi:  # beta wraps: a pole, not a root
            continue
        if gs[i] == 0.0:
            roots.append(float(s[i]))
            continue
        if gs[i + 1] == 0.0:
            continue
        roots.append(brentq(lambda x: float(g(np.array(x))[0]), s[i], s[i + 1], xtol=xtol,
                            rtol=4 * np.finfo(float).eps, maxiter=200))
    out: list[LegSolution] = []
    for s0 in roots:
        t1, t2 = angles(np.array(s0))
        gv, beta_arr = g(np.array(s0))
        beta = float(beta_arr)
        if not abs(beta) <= BETA_MAX + TOL_ANGLE or abs(float(gv)) > 1e-9:
            continue
        pb = rolled_position(pa, ux, n, r_w, beta_a, beta)
        Rr = _blade_rotation(Dr, beta)
        Mh, ph = _to_hip(geometry, TGr, Rr, pb)
        w = ph - l6 * Mh[:, 2]
        q, reach = _lower(geometry, np.atleast_1d(t1), np.atleast_1d(t2), np.array([theta6]),
                          Mh[None, :, 1], w[None])
        out.extend(_accept(geometry, side, q[0], reach[0], TG, "blade", pb, Rr, beta, method))
    out.sort(key=lambda r: abs(r.beta - beta_a))
    return out or [_failed(STATUS_NOT_CONVERGED if not roots else STATUS_UNREACHABLE, method)]
