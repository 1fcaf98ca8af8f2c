"""Leg IK class 1 of hwang2023 (§2.2, Eqs. (5)-(20)): position and orientation known.

:func:`solve_known_pose` and :func:`solve_known_pose_batch` (right leg in hip coordinates; the
left leg as the mirrored right leg, :mod:`mechkin.solvers.biped.leg`): two branches within the
joint ranges, knee back (``theta4 <= 0``) first. Split out of ``leg.py`` (issue 23: one module
per IK class).

Design
------
Part of the biped room :mod:`mechkin.solvers.biped`; may import
:mod:`mechkin.solvers.biped.leg_model`, :mod:`mechkin.spatial` and scipy; no other solver
room, never ``io/``, ``cli/`` or ``tasks/``.

References
----------
hwang2023_hybrid_walking_skating_ik §2.2, Eqs. (5)-(20).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mechkin.solvers.biped.leg_model import (
    _D4,
    _S4,
    STATUS_SINGULAR,
    STATUS_UNREACHABLE,
    TOL_POSE,
    BipedGeometry,
    ContactKind,
    LegSolution,
    _failed,
    _fk_errors,
    _half_atan,
    _in_range,
    _lower,
    _record,
    _side,
    _to_hip,
)
from mechkin.spatial.euler_conventions import (
    Side,
)

# --------------------------------------------------------------------------- §2.2


def _known_pose_right(geometry: BipedGeometry, M: np.ndarray, p: np.ndarray,
                      l6: float) -> tuple[np.ndarray, np.ndarray]:
    """§2.2 on hip-frame targets: q (m, 2, 6), status codes (m, 2) (0 ok, 1 singular, 2 reach)."""
    y6 = M[..., :, 1]
    P1, P2, P3 = y6[..., 0], y6[..., 1], -y6[..., 2]
    w = p - l6 * M[..., :, 2]  # wrist: E minus l6 along z_6'
    P4, P5, P6 = w[..., 0], w[..., 1], -w[..., 2]
    num = P1 * P6 - P3 * P4
    den = P2 * P6 - P3 * P5
    scale = np.linalg.norm(w, axis=-1)
    singular = np.hypot(num, den) < 1e-12 * np.maximum(scale, 1e-12)
    t1 = _half_atan(-num, den)  # Eq. (9)
    c1, s1 = np.cos(t1), np.sin(t1)
    t2 = _half_atan(-(P4 * c1 + P5 * s1), P6)  # Eq. (10)
    c2, s2 = np.cos(t2), np.sin(t2)
    x0, x2 = M[..., :, 0], M[..., :, 2]
    c6 = (x0[..., 0] * c1 + x0[..., 1] * s1) * c2 - x0[..., 2] * s2  # Eq. (11a), P7..P9
    s6 = (x2[..., 0] * c1 + x2[..., 1] * s1) * c2 - x2[..., 2] * s2  # Eq. (11b), P10..P12
    t6 = np.arctan2(s6, c6)  # Eq. (12)
    q, reach = _lower(geometry, t1, t2, t6, y6, w)
    code = np.where(singular[..., None], 1, np.where(reach, 0, 2))
    return q, code


def solve_known_pose_batch(geometry: BipedGeometry, side: Side, T_0_E: ArrayLike,
                           T_0_G: ArrayLike, kind: ContactKind = "blade"
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """§2.2 for many targets at once (hwang2023 Eqs. 5-20), both knee branches.

    Parameters
    ----------
    T_0_E : array, shape (m, 4, 4)
        End-effector targets T = T_0_6' (Eq. 2) in world coordinates.
    T_0_G : array, shape (4, 4) or (m, 4, 4)
        Body poses.

    Returns
    -------
    q : array, shape (m, 2, 6)
        Branch 0 knee back (theta4 <= 0), branch 1 knee forward [rad].
    valid : array, shape (m, 2)
        Regular, reachable, within the joint ranges and verified by forward kinematics.
    position_error, orientation_error : array, shape (m, 2)
        Forward-kinematics errors [m], [rad] (inf where the branch does not exist).
    """
    side = _side(side)
    T = np.asarray(T_0_E, dtype=np.float64)
    m = T.shape[0]
    TG = np.broadcast_to(np.asarray(T_0_G, dtype=np.float64), (m, 4, 4))
    Tr, TGr = (T, TG) if side == "right" else (_S4 @ T @ _D4, _S4 @ TG @ _S4)
    M, p = _to_hip(geometry, TGr, Tr[:, :3, :3], Tr[:, :3, 3])
    q, code = _known_pose_right(geometry, M, p, geometry.l6(kind))
    pe, oe = _fk_errors(geometry, side, q, TG, T, kind)
    ok = (code == 0) & _in_range(geometry, q) & (pe < TOL_POSE) & (oe < TOL_POSE)
    ok[:, 1] &= ~(np.abs(q[:, 1, 3]) < 1e-12)  # straight knee: both branches coincide
    pe = np.where(code == 0, pe, np.inf)
    oe = np.where(code == 0, oe, np.inf)
    return q, ok, pe, oe


def solve_known_pose(geometry: BipedGeometry, side: Side, T_0_E: ArrayLike, T_0_G: ArrayLike,
                     kind: ContactKind = "blade") -> list[LegSolution]:
    """§2.2: every solution within the joint ranges, knee back first (hwang2023 Eqs. 5-20).

    Parameters
    ----------
    T_0_E : array, shape (4, 4)
        Target end-effector pose (Eq. 2); build its rotation with
        ``ee_rotation_from_psi(plane.contact_rotation(...), side)`` (Eq. 3, Table 1).
    T_0_G : array, shape (4, 4)
        Body pose (Eq. 1a).

    Returns
    -------
    list of LegSolution
        Valid solutions (knee back first); if none, one record whose status says why.
    """
    T = np.asarray(T_0_E, dtype=np.float64)[None]
    q, ok, pe, oe = solve_known_pose_batch(geometry, side, T, T_0_G, kind)
    names = ("knee back", "knee forward")
    out = [
        _record(geometry, side, q[0, b], np.asarray(T_0_G, float), kind, pe[0, b], oe[0, b],
                names[b], "hwang2023 §2.2", None)
        for b in range(2) if ok[0, b]
    ]
    if out:
        return out
    Tr = T if side == "right" else _S4 @ T @ _D4
    TG = np.asarray(T_0_G, float)[None]
    TGr = TG if side == "right" else _S4 @ TG @ _S4
    M, p = _to_hip(geometry, TGr, Tr[:, :3, :3], Tr[:, :3, 3])
    _, code = _known_pose_right(geometry, M, p, geometry.l6(kind))
    status = STATUS_SINGULAR if code[0, 0] == 1 else STATUS_UNREACHABLE
    return [_failed(status, "hwang2023 §2.2")]
