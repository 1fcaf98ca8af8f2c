r"""Closed-form kinematics of the walking and skating biped of hwang2023 (6R legs, feet, blades).

Leg (hwang2023 Eq. 1): body ``A_0G = [Rz(theta_z) | b_0G]``, hip
``A_G0' = [diag(1,-1,-1) | b_G0']`` (z down), then six joints Rz-Ry-Rx-Rx-Rx-Ry, each
``A_(i-1)'i' = Rot(axis_i, theta_i) Trans(0,0,l_i)``.
The end effector 6' is the blade point E (``l6``) or the sole point (``l6 + foot_extension``).

Orientation targets (Eq. 3): the right end effector is ``R_0_6' = Psi_1 diag(1,-1,-1)``; the left
leg is the mirror image of the right (x -> -x), with joint angles of the same meaning (JRx + lifts
forward, JRy + lifts outward, JRz + turns outward) and end-effector frame ``R_0_6' = Psi_2`` (x
outward, y forward, z down; with gam_Y = 180 deg the left plane's Z_2 already points down).
Every left-leg problem is solved as the right-leg problem of the mirrored world: positions
``p -> S p`` with ``S = diag(-1, 1, 1)``, body ``T_0_G -> S T_0_G S``, end effector
``T -> S T D`` with ``D = diag(1, -1, 1)``, contact base ``Delta -> S Delta D F``.

Solvers (right leg, hip coordinates, the paper's P_k are the components of the target there):

* :func:`solve_known_pose` - §2.2, Eqs. (5)-(20): position and orientation known; two branches in
  the joint ranges (knee back ``theta4 <= 0`` first).
* :func:`solve_known_position` - §2.3, Eqs. (21)-(35): blade position E known, ``theta6`` given,
  blade tilt ``beta_Y`` unknown; cases theta6 = 0 (Eqs. 22-27), theta6 != 0 with P3 = 0
  (Eqs. 28-31), theta6 != 0 with P3 != 0 (Eqs. 32-35).
* :func:`solve_rolling` - §2.4, Eqs. (36)-(43): the blade rolls without slipping from a known
  state (E_a, beta_Ya) to the unknown tilt beta_Yb that gives the wanted ``theta6``; one
  numerical root search in theta2 (P3 = 0, Eq. 40) or theta1 (P3 != 0, Eqs. 40, 43).

Rolling (Eq. 36; the wheel profile is an arc of radius r_w about the blade's long axis):
``C = C0 - r_w beta_Y u_X'``, ``E = E0 - r_w (beta_Y - sin beta_Y) u_X' + r_w (1 - cos beta_Y) n``
with ``n`` the plane normal pointing away from the plane (``u_Z1'`` on the right). Eqs. (36c, d)
print ``- (1 - cos beta_Y) u_Z'``, which would put E below the plane on the right leg; Eq. (36f)
and this module use the sign above (PAPER_NOTES, hwang2023).

Units: SI (m, rad). Results are :class:`LegSolution` records with a status string (``"ok"``,
``"not converged"``, ``"singular"``, ``"unreachable"``, the values of
``mechkin.solvers.result.Status``) and the forward-kinematics errors of the solution.

References
----------
hwang2023_hybrid_walking_skating_ik: C.-S. Hwang, H. Lee, B.-Y. Kang, "Analysis of inverse
kinematics for legged walking and skated driving with hybrid mobile robot", JKSPE 40(11), 2023,
Eqs. (1)-(43), Tables 1-6.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq

from mechkin.solvers.result import Status
from mechkin.spatial.euler_conventions import (
    Side,
    blade_matrix,
    contact_angles_from_matrix,
    contact_base_matrix,
    foot_matrix,
    plane_matrix,
)
from mechkin.spatial.rotations import angle_from_matrix, rot_x, rot_y, rot_z
from mechkin.spatial.transforms import T_from

__all__ = [
    "HWANG2023_ESTIMATED",
    "Q_MAX",
    "Q_MIN",
    "STATUS_AT_LIMIT",
    "STATUS_NOT_CONVERGED",
    "STATUS_OK",
    "STATUS_SINGULAR",
    "STATUS_UNREACHABLE",
    "BipedGeometry",
    "BipedSolution",
    "ContactKind",
    "InclinedPlane",
    "LegSolution",
    "LegTask",
    "biped_polylines",
    "blade_contact",
    "body_transform",
    "contact_below_hip",
    "ee_rotation_from_psi",
    "hip_transform",
    "leg_fk",
    "leg_frames",
    "psi_from_ee_rotation",
    "rolled_position",
    "solve_biped_case",
    "solve_known_pose",
    "solve_known_pose_batch",
    "solve_known_position",
    "solve_leg_case",
    "solve_rolling",
]

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


# --------------------------------------------------------------------------- biped cases


@dataclass(frozen=True)
class LegTask:
    """What is known for one leg in :func:`solve_biped_case` (plain parameters, SI).

    position : (3,) E [m] in world ("walk", "skate"), or E_a of the start state ("roll").
    beta_z : beta_Z [rad] (Table 1).
    beta : beta_X of a foot ("walk"), beta_Y of a blade ("skate", None when theta6 is given
        instead: §2.3), or beta_Ya of the start state ("roll").
    theta6 : ankle angle [rad] for "skate" with unknown beta_Y (§2.3) and "roll" (§2.4).
    """

    position: tuple[float, float, float]
    beta_z: float = 0.0
    beta: float | None = 0.0
    theta6: float | None = None


@dataclass(frozen=True)
class BipedSolution:
    """Both legs of one hwang2023 case: ``legs[side]`` is the chosen :class:`LegSolution`,
    ``alternatives[side]`` every solution found; ``status`` is ``"ok"`` when both legs are."""

    mode: str
    plane: InclinedPlane
    T_0_G: np.ndarray
    legs: Mapping[str, LegSolution]
    alternatives: Mapping[str, tuple[LegSolution, ...]]
    kind: ContactKind

    @property
    def status(self) -> str:
        for r in self.legs.values():
            if not r.ok:
                return r.status
        return STATUS_OK


def contact_below_hip(geometry: BipedGeometry, plane: InclinedPlane, T_0_G: ArrayLike,
                      side: Side, offset: ArrayLike = (0.0, 0.0)) -> np.ndarray:
    """Point (3,) [m] of the plane straight below (world -z) the hip of ``side`` plus ``offset``
    (x, y) [m] in world axes: the contact placement of Fig. 7 (a), (b), (g)."""
    T_0_H = np.asarray(T_0_G, float) @ hip_transform(geometry, side)
    h = T_0_H[:3, 3] + np.array([*np.asarray(offset, float), 0.0])
    n = plane.normal
    o = np.asarray(plane.origin, float)
    if abs(n[2]) < 1e-12:
        raise ValueError("expected a plane that is not vertical")
    z = o[2] - (n[0] * (h[0] - o[0]) + n[1] * (h[1] - o[1])) / n[2]
    return np.array([h[0], h[1], z])


def solve_biped_case(plane: InclinedPlane, mode: Literal["walk", "skate", "roll"], *,
                     T_0_G: ArrayLike, right: LegTask, left: LegTask,
                     geometry: BipedGeometry = HWANG2023_ESTIMATED,
                     previous: Mapping[str, ArrayLike] | None = None) -> BipedSolution:
    """Solve both legs of one hwang2023 example (Fig. 7) from plain parameters.

    ``"walk"``: feet, E and (beta_Z, beta_X) known -> §2.2. ``"skate"``: blades, E and beta_Z
    known, and beta_Y known (§2.2) or ``theta6`` given with beta_Y unknown (§2.3). ``"roll"``: the
    blade rolls from the start state (E_a, beta_Ya) of each task to the given ``theta6`` with the
    body fixed (§2.4). Of several solutions the one nearest ``previous[side]`` (6,) is chosen,
    else the first (knee back).

    Returns
    -------
    BipedSolution
        Per leg: q, beta, FK errors, T_0_E, and the contact point (the rim point for blades).
    """
    TG = np.asarray(T_0_G, dtype=np.float64)
    kind: ContactKind = "foot" if mode == "walk" else "blade"
    legs: dict[str, LegSolution] = {}
    alts: dict[str, tuple[LegSolution, ...]] = {}
    pairs: tuple[tuple[Side, LegTask], ...] = (("right", right), ("left", left))
    for side, task in pairs:
        prev = None if previous is None else previous.get(side)
        legs[side], alts[side] = solve_leg_case(plane, mode, side, task, T_0_G=TG,
                                                geometry=geometry, previous=prev)
    return BipedSolution(mode, plane, TG, legs, alts, kind)


def _solve_leg(plane: InclinedPlane, mode: str, side: Side, task: LegTask, TG: np.ndarray,
               geometry: BipedGeometry) -> list[LegSolution]:
    kind: ContactKind = "foot" if mode == "walk" else "blade"
    p = np.asarray(task.position, dtype=np.float64)
    Delta = plane.contact_base(side, task.beta_z)
    if mode == "roll" or (mode == "skate" and task.beta is None):
        if task.theta6 is None:
            raise ValueError(f"{side}: expected theta6 for mode {mode!r}")
        if mode == "roll":
            sols = solve_rolling(geometry, side, p, task.beta or 0.0, Delta,
                                 plane.normal, task.theta6, TG)
        else:
            sols = solve_known_position(geometry, side, p, Delta,
                                        task.theta6, TG)
    else:
        Psi = plane.contact_rotation(side, kind, task.beta_z, task.beta or 0.0)
        T = T_from(ee_rotation_from_psi(Psi, side), p)
        sols = solve_known_pose(geometry, side, T, TG, kind)
        sols = [replace(s, beta=float(task.beta or 0.0)) if s.ok else s for s in sols]
    if kind == "blade":
        sols = [blade_contact(geometry, plane, side, s) if s.ok else s for s in sols]
    return sols


def solve_leg_case(plane: InclinedPlane, mode: Literal["walk", "skate", "roll"], side: Side,
                   task: LegTask, *, T_0_G: ArrayLike,
                   geometry: BipedGeometry = HWANG2023_ESTIMATED,
                   previous: ArrayLike | None = None, branch: str | None = None
                   ) -> tuple[LegSolution, tuple[LegSolution, ...]]:
    """One leg of :func:`solve_biped_case` on its own plane: (chosen, every solution found).

    When no solution (of ``branch``, if given) lies within the joint ranges but one exists
    outside them, a record with status ``"at a limit"`` (:attr:`Status.AT_LIMIT`) whose
    ``q_outside`` holds that solution (the nearest to ``previous``, else the first) is added
    (or replaces the failed record), so the caller can say which joint is out of range.
    """
    TG = np.asarray(T_0_G, dtype=np.float64)
    if mode not in ("walk", "skate", "roll"):
        raise ValueError(f"expected mode 'walk', 'skate' or 'roll', got {mode!r}")
    side = _side(side)
    sols = _solve_leg(plane, mode, side, task, TG, geometry)

    def wanted(r: LegSolution) -> bool:
        return r.ok and (branch is None or r.branch == branch)

    limited = not (np.all(np.isneginf(geometry.q_min)) and np.all(np.isposinf(geometry.q_max)))
    if limited and not any(wanted(r) for r in sols):
        free = replace(geometry, q_min=(-math.inf,) * 6, q_max=(math.inf,) * 6)
        outside = [r for r in _solve_leg(plane, mode, side, task, TG, free) if wanted(r)]
        if outside:
            best = outside[0]
            if previous is not None and len(outside) > 1:
                pv = np.asarray(previous, dtype=np.float64)
                best = min(outside, key=lambda r: float(np.linalg.norm(_wrap(r.q - pv))))
            rec = LegSolution(np.full(6, np.nan), STATUS_AT_LIMIT, math.inf, math.inf,
                              best.branch, method=best.method, q_outside=best.q.copy())
            sols = [rec] if not any(r.ok for r in sols) else [*sols, rec]
    best = sols[0]
    if previous is not None and len(sols) > 1 and sols[0].ok:
        pv = np.asarray(previous, dtype=np.float64)
        best = min((r for r in sols if r.ok),
                   key=lambda r: float(np.linalg.norm(_wrap(r.q - pv))))
    return best, tuple(sols)


def blade_contact(geometry: BipedGeometry, plane: InclinedPlane, side: Side,
                  sol: LegSolution) -> LegSolution:
    """Fill the blade tilt (if unknown) and the wheel-rim contact point C = E + r_w (Z'' - n)
    of a blade solution on ``plane`` (Eq. 36)."""
    R = sol.T_0_E[:3, :3]
    up = -R[:, 2]  # blade axis Z'' pointing away from the plane (Fig. 5)
    n = plane.normal
    pc = sol.T_0_E[:3, 3] + geometry.wheel_radius * (up - n)
    beta = sol.beta
    if not math.isfinite(beta):
        Psi = psi_from_ee_rotation(R, side)
        beta = float(contact_angles_from_matrix(Psi, plane.rotation(side), side, "blade")[1])
    return replace(sol, p_contact=pc, beta=beta)


# --------------------------------------------------------------------------- drawing


def biped_polylines(geometry: BipedGeometry, T_0_G: ArrayLike, q_right: ArrayLike,
                    q_left: ArrayLike, *, kind: ContactKind = "blade",
                    plane: InclinedPlane | None = None, plane_half_size: float = 0.35,
                    sole_length: float = 0.20, sole_width: float = 0.08
                    ) -> dict[str, np.ndarray]:
    """Polylines (k, 3) [m] for drawing the biped on its plane (like hwang2023 Figs. 7, 8).

    Keys: ``body`` (hip to hip through G), ``leg_right``/``leg_left`` (G, hip, joints 1'..6'),
    ``foot_right``/``foot_left`` (closed sole outline in the sole plane, for feet) or
    ``blade_right``/``blade_left`` (blade line along its long axis and the wheel-profile arc
    across it, for blades), and ``plane`` (closed square around the plane origin, if given).
    """
    TG = np.asarray(T_0_G, dtype=np.float64)
    out: dict[str, np.ndarray] = {}
    frames = {}
    sides: tuple[tuple[Side, ArrayLike], ...] = (("right", q_right), ("left", q_left))
    for side, q in sides:
        F = leg_frames(geometry, side, np.asarray(q, float)[None], TG, kind)[0]
        frames[side] = F
        out[f"leg_{side}"] = F[:, :3, 3]
    out["body"] = np.stack([frames["right"][1, :3, 3], TG[:3, 3], frames["left"][1, :3, 3]])
    for side in ("right", "left"):
        E = frames[side][-1]
        p, R = E[:3, 3], E[:3, :3]
        fwd = R[:, 1] * (-1.0 if side == "right" else 1.0)  # toe direction (world)
        lat = np.cross(fwd, -R[:, 2])
        if kind == "foot":
            h, wd = 0.5 * sole_length, 0.5 * sole_width
            pts = [p + a * h * fwd + b * wd * lat for a, b in ((1, 1), (1, -1), (-1, -1),
                                                                  (-1, 1), (1, 1))]
            out[f"foot_{side}"] = np.array(pts)
        else:
            h = 0.5 * sole_length
            line = np.array([p - h * fwd, p + h * fwd])
            r = geometry.wheel_radius
            ang = np.linspace(-0.5 * math.pi, 0.5 * math.pi, 13)
            centre = p - r * R[:, 2]
            arc = centre + r * (np.cos(ang)[:, None] * R[:, 2] + np.sin(ang)[:, None] * lat)
            out[f"blade_{side}"] = np.concatenate([line, arc[::-1]], axis=0)
    if plane is not None:
        L = plane.rotation("right")
        o = np.asarray(plane.origin, float)
        c = np.array([(1, 1), (1, -1), (-1, -1), (-1, 1), (1, 1)], float) * plane_half_size
        out["plane"] = o + c[:, :1] * L[:, 0] + c[:, 1:] * L[:, 1]
    return out
