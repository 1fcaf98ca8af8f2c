"""The biped leg model of hwang2023: geometry, plane, forward kinematics, records, shared helpers.

Everything the three IK classes (:mod:`~mechkin.solvers.biped.leg_known_pose` §2.2,
:mod:`~mechkin.solvers.biped.leg_known_position` §2.3, :mod:`~mechkin.solvers.biped.leg_rolling`
§2.4) share: the geometry (:class:`BipedGeometry`, Tables 1-2) and the inclined plane
(:class:`InclinedPlane`), the leg chain of Eq. (1) (:func:`leg_frames`, :func:`leg_fk`), the
end-effector orientation of Eq. (3), the :class:`LegSolution` record, the right-leg helpers
(hip coordinates, the lower joints) and the acceptance of a candidate by forward kinematics. The
conventions (mirrored left leg, rolling) are described in :mod:`mechkin.solvers.biped.leg`.
Split out of ``leg.py`` (issue 23: modules that fit in a head).

Design
------
Part of the biped room :mod:`mechkin.solvers.biped`; may import :mod:`mechkin.spatial` and
:mod:`mechkin.solvers.result`; no other solver room, never ``io/``, ``cli/`` or ``tasks/``.

References
----------
hwang2023_hybrid_walking_skating_ik Eqs. (1)-(3), Tables 1-2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from mechkin.solvers.result import Status
from mechkin.spatial.euler_conventions import (
    Side,
    blade_matrix,
    contact_base_matrix,
    foot_matrix,
    plane_matrix,
)
from mechkin.spatial.rotations import angle_from_matrix, rot_x, rot_y, rot_z
from mechkin.spatial.transforms import T_from

ContactKind = Literal["foot", "blade"]

STATUS_OK = Status.OK.value
STATUS_NOT_CONVERGED = Status.NOT_CONVERGED.value
STATUS_SINGULAR = Status.SINGULAR.value
STATUS_UNREACHABLE = Status.UNREACHABLE.value
STATUS_AT_LIMIT = Status.AT_LIMIT.value

Q_MAX = np.deg2rad([90.0, 90.0, 90.0, 150.0, 90.0, 90.0])
"""hwang2023 §2.2: joint ranges theta1..6 are +-Q_MAX [rad]."""
Q_MIN = -Q_MAX
BETA_MAX = 0.5 * math.pi
"""hwang2023 Eq. (41): the blade tilt stays within +-90 deg."""

TOL_ANGLE = 1e-9
"""[rad] slack on the joint ranges and the case tests theta6 = 0, P3 = 0 (§2.3, §2.4)."""
TOL_POSE = 1e-9
"""[m], [rad] forward-kinematics error above which a candidate is rejected."""

_F = np.diag([1.0, -1.0, -1.0])  # hip frame of Eq. (1b); also Psi_1 -> R_0_6' (Eq. 3)
_S3 = np.diag([-1.0, 1.0, 1.0])  # world mirror x -> -x
_D3 = np.diag([1.0, -1.0, 1.0])  # end-effector axis flip that keeps mirrored frames right-handed
_S4 = np.diag([-1.0, 1.0, 1.0, 1.0])
_D4 = np.diag([1.0, -1.0, 1.0, 1.0])


# --------------------------------------------------------------------------- geometry


@dataclass(frozen=True)
class BipedGeometry:
    """Leg geometry of the hwang2023 biped (both legs; the left one mirrored in x).

    Parameters
    ----------
    lengths : tuple of 6 float
        l1..l6 [m] of Eq. (1); l6 reaches the blade point E.
    foot_extension : float
        [m] the sole point lies this far beyond E along z_6' (walking end effector).
    wheel_radius : float
        r_w [m] of the blade's wheel profile (Fig. 5, Eq. 36).
    hip_offset : tuple of 3 float
        b_G0' [m] of the right hip in the body frame (Eq. 1b); the left hip is ``(-x, y, z)``.
    q_min, q_max : tuple of 6 float
        Joint ranges [rad] (§2.2).
    estimated : tuple of str
        Names of the fields that are estimates rather than values printed in the paper.
    """

    lengths: tuple[float, float, float, float, float, float]
    foot_extension: float
    wheel_radius: float
    hip_offset: tuple[float, float, float]
    q_min: tuple[float, ...] = tuple(float(v) for v in Q_MIN)
    q_max: tuple[float, ...] = tuple(float(v) for v in Q_MAX)
    estimated: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if len(self.lengths) != 6 or not all(math.isfinite(v) for v in self.lengths):
            raise ValueError(f"expected 6 finite link lengths, got {self.lengths}")
        if self.lengths[2] <= 0.0 or self.lengths[3] <= 0.0:
            raise ValueError(f"expected l3 > 0 and l4 > 0, got {self.lengths[2:4]}")
        if len(self.hip_offset) != 3:
            raise ValueError(f"expected a hip offset of 3 numbers, got {self.hip_offset}")
        if any(lo >= hi for lo, hi in zip(self.q_min, self.q_max, strict=True)):
            raise ValueError(f"expected q_min < q_max, got {self.q_min}, {self.q_max}")

    def l6(self, kind: ContactKind) -> float:
        """Length from joint 6 to the end effector of ``kind`` [m]."""
        if kind == "blade":
            return self.lengths[5]
        if kind == "foot":
            return self.lengths[5] + self.foot_extension
        raise ValueError(f"expected kind 'foot' or 'blade', got {kind!r}")

    def hip(self, side: Side) -> np.ndarray:
        """b_G0' of ``side`` (3,) [m]."""
        b = np.array(self.hip_offset, dtype=np.float64)
        return b if _side(side) == "right" else _S3 @ b


HWANG2023_ESTIMATED = BipedGeometry(
    lengths=(0.050, 0.115, 0.175, 0.165, 0.060, 0.1485),
    foot_extension=0.0015,
    wheel_radius=0.0155,
    hip_offset=(0.110, 0.0, 0.0),
    estimated=("lengths", "foot_extension", "wheel_radius"),
)
"""ESTIMATED geometry of the hwang2023 biped: the paper's link lengths are lost.

From PAPER_NOTES (least squares on Table 6 alone): l3 = 175.0 +- 0.1 mm, l4 = 165.0 +- 0.05 mm,
l6 = 148.5 +- 0.3 mm, r_w = 15.5 +- 0.1 mm, l2 + l5 = 175 +- 1 mm, hips +-110 mm along body x
(printed: legs 220 mm apart). Chosen here: l2 = 115, l5 = 60 mm (the split is weakly determined,
+-15 mm; this one puts the contacts of Fig. 7(g) straight below the hips, as in (a) and (b));
l1 = 50 mm is free (only "body height - l1" is determined); foot_extension = 1.5 mm (+-0.1) puts
the feet of Fig. 7(a) straight below the hips on plane (a) with the body of Fig. 7(b).
"""


@dataclass(frozen=True)
class InclinedPlane:
    """Inclined plane of hwang2023 Table 5: origin (3,) [m] and XYXY angles [rad]."""

    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    lam_x: float = 0.0
    lam_y: float = 0.0
    gam_x: float = 0.0

    def rotation(self, side: Side) -> np.ndarray:
        """Lam_i (3, 3) of Table 1 (gam_Y = 0 right, 180 deg left)."""
        return plane_matrix(self.lam_x, self.lam_y, self.gam_x, side)

    @property
    def normal(self) -> np.ndarray:
        """Unit normal (3,) pointing away from the plane (Z_1 of the right plane)."""
        return self.rotation("right")[:, 2]

    def contact_base(self, side: Side, beta_z: float) -> np.ndarray:
        """Delta_i = Lam_i Rot(-Z, beta_Z) (3, 3), Eq. (21)."""
        return contact_base_matrix(self.lam_x, self.lam_y, self.gam_x, beta_z, side)

    def contact_rotation(self, side: Side, kind: ContactKind, beta_z: float,
                         beta: float) -> np.ndarray:
        """Psi_i (3, 3) of a foot (beta = beta_X) or blade (beta = beta_Y), Table 1."""
        f = foot_matrix if kind == "foot" else blade_matrix
        return f(self.lam_x, self.lam_y, self.gam_x, beta_z, beta, side)

    def mirrored(self) -> InclinedPlane:
        """The plane reflected in x -> -x (lam_Y changes sign)."""
        o = self.origin
        return InclinedPlane((-o[0], o[1], o[2]), self.lam_x, -self.lam_y, self.gam_x)


def body_transform(b_0G: ArrayLike, theta_z: float = 0.0) -> np.ndarray:
    """A_0G = [Rz(theta_z) | b_0G] (4, 4), hwang2023 Eq. (1a)."""
    return T_from(rot_z(theta_z), np.asarray(b_0G, dtype=np.float64))


def hip_transform(geometry: BipedGeometry, side: Side) -> np.ndarray:
    """A_G0' (4, 4): ``[diag(1,-1,-1) | b_G0']`` right (Eq. 1b), ``[Ry(180 deg) | S b]`` left."""
    R = _F if _side(side) == "right" else np.diag([-1.0, 1.0, -1.0])
    return T_from(R, geometry.hip(side))


def psi_from_ee_rotation(R: ArrayLike, side: Side) -> np.ndarray:
    """Psi_i of the contact from the end-effector rotation R_0_6' (..., 3, 3), Eq. (3)."""
    R = np.asarray(R, dtype=np.float64)
    return R @ _F if _side(side) == "right" else R.copy()


def ee_rotation_from_psi(Psi: ArrayLike, side: Side) -> np.ndarray:
    """R_0_6' from Psi_i (..., 3, 3), Eq. (3) (the inverse of :func:`psi_from_ee_rotation`)."""
    return psi_from_ee_rotation(Psi, side)


# --------------------------------------------------------------------------- forward kinematics


def _chain_right(geometry: BipedGeometry, q: np.ndarray, l6: float) -> np.ndarray:
    """Frames 0' (identity), 1'..6' of the right chain in hip coordinates; -> (m, 7, 4, 4)."""
    m = q.shape[0]
    ls = list(geometry.lengths[:5]) + [l6]
    rots = (rot_z, rot_y, rot_x, rot_x, rot_x, rot_y)
    out = np.empty((m, 7, 4, 4))
    T = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
    out[:, 0] = T
    for i in range(6):
        A = T_from(rots[i](q[:, i]), np.zeros(3))
        A[:, :3, 3] = A[:, :3, 2] * ls[i]  # Rot(axis, theta) Trans(0, 0, l_i), Eq. (1c)-(1h)
        T = T @ A
        out[:, i + 1] = T
    return out


def leg_frames(geometry: BipedGeometry, side: Side, q: ArrayLike, T_0_G: ArrayLike,
               kind: ContactKind = "blade") -> np.ndarray:
    """World frames G, 0', 1', ..., 6' of one leg, hwang2023 Eq. (1).

    Parameters
    ----------
    q : array, shape (m, 6)
        Joint angles theta1..6 [rad].
    T_0_G : array, shape (4, 4) or (m, 4, 4)
        Body pose (Eq. 1a; any rigid pose is accepted).

    Returns
    -------
    array, shape (m, 8, 4, 4)
        ``[G, 0', 1', ..., 6']``; 6' is the end effector of ``kind``.
    """
    side = _side(side)
    q = np.asarray(q, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 6:
        raise ValueError(f"expected q of shape (m, 6), got {q.shape}")
    T_0_G = np.broadcast_to(np.asarray(T_0_G, dtype=np.float64), (q.shape[0], 4, 4))
    T_0_Gr = T_0_G if side == "right" else _S4 @ T_0_G @ _S4
    T_0_H = T_0_Gr @ hip_transform(geometry, "right")
    chain = T_0_H[:, None] @ _chain_right(geometry, q, geometry.l6(kind))
    if side == "left":
        chain = _S4 @ chain @ _D4  # mirror image of the right leg with the same q
    return np.concatenate([T_0_G[:, None], chain], axis=1)


def leg_fk(geometry: BipedGeometry, side: Side, q: ArrayLike, T_0_G: ArrayLike,
           kind: ContactKind = "blade") -> np.ndarray:
    """End-effector pose T_0_6' (m, 4, 4) for q (m, 6), hwang2023 Eqs. (1), (4)."""
    return leg_frames(geometry, side, q, T_0_G, kind)[:, -1]


# --------------------------------------------------------------------------- records


@dataclass(frozen=True)
class LegSolution:
    """One inverse-kinematics solution of one leg (a record, never a bare flag).

    q (6,) [rad]; ``beta`` the blade tilt beta_Y or foot angle beta_X [rad] where the solver
    found or used it (NaN if unknown); ``T_0_E`` (4, 4) the end-effector pose by forward
    kinematics; ``p_contact`` (3,) the contact point (E for feet, the wheel-rim point for
    blades); ``position_error`` [m] and ``orientation_error`` [rad] compare the forward
    kinematics of q with the target; ``branch`` names the choice (e.g. ``"knee back"``);
    ``q_outside`` (6,) a solution outside the joint ranges (status ``"at a limit"``).
    """

    q: np.ndarray
    status: str
    position_error: float
    orientation_error: float
    branch: str = ""
    beta: float = math.nan
    T_0_E: np.ndarray = field(default_factory=lambda: np.full((4, 4), np.nan))
    p_contact: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    method: str = ""
    q_outside: np.ndarray | None = None

    @property
    def ok(self) -> bool:
        """True when ``status == "ok"``."""
        return self.status == STATUS_OK


def _failed(status: str, method: str, branch: str = "") -> LegSolution:
    return LegSolution(np.full(6, np.nan), status, math.inf, math.inf, branch, method=method)


# --------------------------------------------------------------------------- right-leg core


def _to_hip(geometry: BipedGeometry, T_0_G: np.ndarray, R: np.ndarray,
            p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (m,3,3) and position (m,3) in the right hip frame, relative to joint 2."""
    T_0_H = T_0_G @ hip_transform(geometry, "right")
    RH = T_0_H[..., :3, :3]
    M = np.swapaxes(RH, -1, -2) @ R
    ph = np.einsum("...ji,...j->...i", RH, p - T_0_H[..., :3, 3])
    ph = ph - np.array([0.0, 0.0, geometry.lengths[0]])
    return M, ph


def _wrap(t: np.ndarray | float) -> np.ndarray:
    return (np.asarray(t) + np.pi) % (2.0 * np.pi) - np.pi


def _half_atan(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """arctan(num / den) in [-pi/2, pi/2] that survives den = 0 (the paper's arctan)."""
    t = np.arctan2(num, den)
    return np.where(t > 0.5 * np.pi, t - np.pi, np.where(t < -0.5 * np.pi, t + np.pi, t))


def _x2(t1: np.ndarray, t2: np.ndarray) -> np.ndarray:
    """Axis x of frame 2' in hip coordinates: first row of (Rz(t1) Ry(t2))^T."""
    c1, s1, c2, s2 = np.cos(t1), np.sin(t1), np.cos(t2), np.sin(t2)
    return np.stack([c1 * c2, s1 * c2, -s2], axis=-1)


def _lower(geometry: BipedGeometry, t1: np.ndarray, t2: np.ndarray, t6: np.ndarray,
           y6: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """theta3, theta4, theta5 for both knee signs, hwang2023 Eqs. (13)-(20).

    ``y6`` (m, 3) = (P1, P2, -P3); ``w`` (m, 3) = (P4, P5, -P6) the wrist (joint 6) relative
    to joint 2. Returns q (m, 2, 6) (branch 0: theta4 <= 0, knee back) and reach (m, 2) bool.
    """
    _, l2, l3, l4, l5, _ = geometry.lengths
    P1, P2, P3 = y6[..., 0], y6[..., 1], -y6[..., 2]
    P4, P5, P6 = w[..., 0], w[..., 1], -w[..., 2]
    c1, s1, c2, s2 = np.cos(t1), np.sin(t1), np.cos(t2), np.sin(t2)
    cS = P2 * c1 - P1 * s1  # Eq. (14a)
    sS = -P3 * c2 + (P1 * c1 + P2 * s1) * s2  # Eq. (14b)
    tS = np.arctan2(sS, cS)  # Eq. (15): theta3 + theta4 + theta5
    Q3 = -P6 * c2 + (P4 * c1 + P5 * s1) * s2 - l2 - l5 * np.cos(tS)
    Q6 = -P5 * c1 + P4 * s1 - l5 * np.sin(tS)
    c4 = (Q3**2 + Q6**2 - l3**2 - l4**2) / (2.0 * l3 * l4)  # Eq. (16)
    reach = np.abs(c4) <= 1.0 + 1e-12
    c4 = np.clip(c4, -1.0, 1.0)
    out = np.empty(c4.shape + (2, 6))
    for b, sign in enumerate((-1.0, 1.0)):
        s4 = sign * np.sqrt(1.0 - c4**2)
        t4 = np.arctan2(s4, c4)  # Eq. (17)
        Q1 = l3 + l4 * c4
        Q2 = -l4 * s4
        den = Q1**2 + Q2**2
        with np.errstate(divide="ignore", invalid="ignore"):
            c3 = (Q1 * Q3 - Q2 * Q6) / den  # Eq. (19)
            s3 = (Q1 * Q6 + Q2 * Q3) / den
        t3 = np.arctan2(s3, c3)
        t5 = _wrap(tS - t3 - t4)  # Eq. (20)
        out[..., b, :] = np.stack([t1, t2, t3, t4, t5, t6], axis=-1)
    return out, np.stack([reach, reach], axis=-1)


def _in_range(geometry: BipedGeometry, q: np.ndarray) -> np.ndarray:
    lo = np.array(geometry.q_min) - TOL_ANGLE
    hi = np.array(geometry.q_max) + TOL_ANGLE
    return np.all((q >= lo) & (q <= hi), axis=-1)


# --------------------------------------------------------------------------- shared helpers


def _fk_errors(geometry: BipedGeometry, side: Side, q: np.ndarray, T_0_G: np.ndarray,
               T: np.ndarray, kind: ContactKind) -> tuple[np.ndarray, np.ndarray]:
    """FK errors of q (m, k, 6) against targets T (m, 4, 4); NaN q gives inf."""
    m, k = q.shape[:2]
    qq = np.nan_to_num(q.reshape(m * k, 6))
    TG = np.repeat(np.broadcast_to(T_0_G, (m, 4, 4)), k, axis=0)
    Tf = leg_fk(geometry, side, qq, TG, kind).reshape(m, k, 4, 4)
    pe = np.linalg.norm(Tf[..., :3, 3] - T[:, None, :3, 3], axis=-1)
    oe = angle_from_matrix(np.swapaxes(T[:, None, :3, :3], -1, -2) @ Tf[..., :3, :3])
    bad = ~np.all(np.isfinite(q), axis=-1)
    return np.where(bad, np.inf, pe), np.where(bad, np.inf, oe)


def _accept(geometry: BipedGeometry, side: Side, q: np.ndarray, reach: np.ndarray,
            T_0_G: np.ndarray, kind: ContactKind, p_right: np.ndarray, R_right: np.ndarray,
            beta: float, method: str) -> list[LegSolution]:
    """Records for the branches (2, 6) of one (theta1, theta2) pair that pass all checks."""
    T_r = T_from(R_right, p_right)
    T = T_r if side == "right" else _S4 @ T_r @ _D4
    pe, oe = _fk_errors(geometry, side, q[None], T_0_G, T[None], kind)
    out = []
    names = ("knee back", "knee forward")
    for br in range(2):
        if br == 1 and abs(q[1, 3]) < 1e-12:
            continue
        if reach[br] and _in_range(geometry, q[br]) and pe[0, br] < TOL_POSE \
                and oe[0, br] < TOL_POSE:
            out.append(_record(geometry, side, q[br], T_0_G, kind, pe[0, br], oe[0, br],
                               names[br], method, beta))
    return out


def _record(geometry: BipedGeometry, side: Side, q: np.ndarray, T_0_G: np.ndarray,
            kind: ContactKind, pe: float, oe: float, branch: str, method: str,
            beta: float | None) -> LegSolution:
    T = leg_fk(geometry, side, q[None], T_0_G, kind)[0]
    pc = T[:3, 3].copy()  # E; solve_biped_case replaces it by the wheel-rim point for blades
    return LegSolution(np.array(q, dtype=np.float64), STATUS_OK, float(pe), float(oe), branch,
                       math.nan if beta is None else float(beta), T, pc, method)


def _unique(pairs: list[tuple[float, float]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for p in pairs:
        if all(abs(_wrap(p[0] - o[0])) > 1e-10 or abs(_wrap(p[1] - o[1])) > 1e-10 for o in out):
            out.append(p)
    return out


def _side(side: str) -> Side:
    if side not in ("right", "left"):
        raise ValueError(f"expected side 'right' or 'left', got {side!r}")
    return side  # type: ignore[return-value]
