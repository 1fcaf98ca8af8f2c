"""Leg IK class 2 of hwang2023 (§2.3, Eqs. (21)-(35)): blade position known, tilt unknown.

:func:`solve_known_position`: blade position E known, ``theta6`` given, blade tilt ``beta_Y``
unknown; cases theta6 = 0 (Eqs. 22-27), theta6 != 0 with P3 = 0 (Eqs. 28-31), theta6 != 0
with P3 != 0 (Eqs. 32-35). Split out of ``leg.py`` (issue 23: one module per IK class).

Design
------
Part of the biped room :mod:`mechkin.solvers.biped`; may import
:mod:`mechkin.solvers.biped.leg_model`, :mod:`mechkin.spatial` and scipy; no other solver
room, never ``io/``, ``cli/`` or ``tasks/``.

References
----------
hwang2023_hybrid_walking_skating_ik §2.3, Eqs. (21)-(35).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from mechkin.solvers.biped.leg_model import (
    _D3,
    _F,
    _S3,
    _S4,
    BETA_MAX,
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
    _unique,
    _wrap,
    _x2,
    hip_transform,
)
from mechkin.spatial.euler_conventions import (
    Side,
)
from mechkin.spatial.rotations import rot_y

# --------------------------------------------------------------------------- §2.3


def _beta_from_x2(x2: np.ndarray, a: np.ndarray, b: np.ndarray, t6: float) -> np.ndarray:
    """beta_Y from Eqs. (26)-(27): V1 c + V2 s = cos theta6, V3 c + V4 s = sin theta6."""
    V1 = x2 @ a
    V2 = x2 @ b
    V3, V4 = -V2, V1
    det = V1 * V4 - V2 * V3
    c6, s6 = math.cos(t6), math.sin(t6)
    with np.errstate(divide="ignore", invalid="ignore"):
        cb = (c6 * V4 - s6 * V2) / det  # Eq. (27a)
        sb = (s6 * V1 - c6 * V3) / det
    return np.arctan2(sb, cb)  # Eq. (27b)


def _blade_hip(geometry: BipedGeometry, side: Side, Delta: np.ndarray, T_0_G: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Right-leg hip-frame columns for R(beta) = Delta Ry(-beta) diag(1,-1,-1) (Eq. 21).

    Returns y6 (3,) and a, b (3,) with ``M[:, 0] = a cos(beta) + b sin(beta)`` and
    ``M[:, 2] = a sin(beta) - b cos(beta)``, plus the mirrored body pose.
    """
    Dr = Delta if side == "right" else _S3 @ Delta @ _D3 @ _F
    TGr = T_0_G if side == "right" else _S4 @ T_0_G @ _S4
    RH = (TGr @ hip_transform(geometry, "right"))[:3, :3]
    a = RH.T @ Dr[:, 0]
    b = RH.T @ Dr[:, 2]
    y6 = -(RH.T @ Dr[:, 1])
    return y6, a, b, Dr, TGr


def _blade_rotation(Dr: np.ndarray, beta: float) -> np.ndarray:
    return Dr @ rot_y(-beta) @ _F  # right-leg R_0_6' of Eq. (21)


def _theta12_known_position(y6: np.ndarray, e: np.ndarray, k: float, t6: float
                            ) -> tuple[list[tuple[float, float]], str]:
    """(theta1, theta2) candidates of §2.3 and the case name (Table 3)."""
    P1, P2, P3 = y6[0], y6[1], -y6[2]
    P4, P5, P6 = e[0], e[1], -e[2]
    P7 = k  # l6 sin(theta6), Eq. (28)
    if abs(t6) <= TOL_ANGLE:  # Table 3(a), Eqs. (22)-(25)
        t1 = float(_half_atan(-(P1 * P6 - P3 * P4), P2 * P6 - P3 * P5))  # Eq. (24)
        t2 = float(_half_atan(-(P4 * math.cos(t1) + P5 * math.sin(t1)), P6))  # Eq. (25)
        return [(t1, t2)], "theta6 = 0"
    if abs(P3) <= TOL_ANGLE:  # Table 3(b), Eqs. (29)-(31)
        t1 = float(_half_atan(-P1, P2))  # Eq. (29)
        U1 = P4 * math.cos(t1) + P5 * math.sin(t1)
        U2, U3 = P6, P7
        rho = math.hypot(U1, U2)
        if rho == 0.0 or abs(U3) > rho:
            return [], "theta6 != 0, P3 = 0"
        phi = math.atan2(U2, U1)
        d = math.acos(U3 / rho)  # Eq. (31): U1 c2 + U2 s2 = U3
        return [(t1, float(_wrap(phi + d))), (t1, float(_wrap(phi - d)))], "theta6 != 0, P3 = 0"
    # Table 3(c), Eqs. (32)-(35)
    A = P2 * P6 - P3 * P5
    B = P1 * P6 - P3 * P4
    D = P1 * P5 - P2 * P4
    U5 = A * A + B * B + D * D
    U6 = -2.0 * P7 * (P2 * A + P1 * B)
    U7 = P7 * P7 * (P1 * P1 + P2 * P2) - D * D
    roots = np.roots([U5, U6, U7]) if U5 > 0 else np.array([])  # Eq. (33)
    cands: list[tuple[float, float]] = []
    for r in roots:
        if abs(r.imag) > 1e-9 * max(1.0, abs(r.real)) or abs(r.real) > 1.0 + 1e-12:
            continue
        t2 = math.asin(max(-1.0, min(1.0, r.real)))  # Eq. (34)
        U8, U9, U10 = P1 * math.cos(t2), P2 * math.cos(t2), -P3 * math.sin(t2)  # Eq. (35)
        rho = math.hypot(U8, U9)
        if rho == 0.0 or abs(U10) > rho * (1.0 + 1e-12):
            continue
        phi = math.atan2(U9, U8)
        d = math.acos(max(-1.0, min(1.0, U10 / rho)))
        for t1 in (phi + d, phi - d):
            t1 = float(_wrap(t1))
            c1, s1 = math.cos(t1), math.sin(t1)
            res28 = (P4 * c1 + P5 * s1) * math.cos(t2) + P6 * math.sin(t2) - P7  # Eq. (28)
            if abs(res28) <= 1e-9 * max(1.0, math.hypot(P4, P5, P6)):
                cands.append((t1, t2))
    return _unique(cands), "theta6 != 0, P3 != 0"


def solve_known_position(geometry: BipedGeometry, side: Side, p_0_E: ArrayLike,
                         Delta: ArrayLike, theta6: float, T_0_G: ArrayLike) -> list[LegSolution]:
    """§2.3: blade point E known, ankle angle theta6 given, blade tilt beta_Y unknown.

    The blade rotation is ``Psi_i = Delta_i Rot(-+Y, beta_Y)`` (Eq. 21, Table 1) with
    ``Delta_i = Lam_i Rot(-Z, beta_Z)`` known (:meth:`InclinedPlane.contact_base`).

    Parameters
    ----------
    p_0_E : array, shape (3,)
        Blade point E [m] in world coordinates.
    Delta : array, shape (3, 3)
        Delta_i of the same side.
    theta6 : float
        Given ankle angle [rad]; the case (Table 3 (a), (b), (c)) follows from theta6 and P3.
    T_0_G : array, shape (4, 4)

    Returns
    -------
    list of LegSolution
        Every solution with theta1..6 in range and |beta_Y| <= 90 deg, knee back first within
        each (theta1, theta2) pair; ``beta`` holds beta_Y; ``method`` names the case.
    """
    side = _side(side)
    TG = np.asarray(T_0_G, dtype=np.float64)
    y6, a, b, Dr, TGr = _blade_hip(geometry, side, np.asarray(Delta, float), TG)
    pr = np.asarray(p_0_E, float) if side == "right" else _S3 @ np.asarray(p_0_E, float)
    _, e = _to_hip(geometry, TGr, np.eye(3), pr)
    l6 = geometry.l6("blade")
    pairs, case = _theta12_known_position(y6, e, l6 * math.sin(theta6), theta6)
    method = f"hwang2023 §2.3 ({case})"
    out: list[LegSolution] = []
    for t1, t2 in pairs:
        x2 = _x2(np.array(t1), np.array(t2))
        beta = float(_beta_from_x2(x2, a, b, theta6))
        if not abs(beta) <= BETA_MAX + TOL_ANGLE:
            continue
        Rr = _blade_rotation(Dr, beta)
        Mh, ph = _to_hip(geometry, TGr, Rr, pr)
        w = ph - l6 * Mh[:, 2]
        q, reach = _lower(geometry, np.array([t1]), np.array([t2]), np.array([theta6]),
                          Mh[None, :, 1], w[None])
        out.extend(_accept(geometry, side, q[0], reach[0], TG, "blade", pr, Rr, beta, method))
    return out or [_failed(STATUS_UNREACHABLE, method)]
