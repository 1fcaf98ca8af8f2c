r"""Euler-angle conventions of hwang2023 Table 1: inclined planes, feet and blades.

A *sequence* is a list of rotation axes of the moving (intrinsic) frame, each with a sign; the
matrix is the product from left to right,

.. math:: R = \mathrm{Rot}(s_1 a_1, t_1)\, \mathrm{Rot}(s_2 a_2, t_2) \cdots,

and ``Rot(-a, t) = Rot(a, -t)``. Two spellings are accepted:

* spaced, signs in front: ``"X Y X Y -Z +X"`` (no sign means +);
* the paper's compact name, signs written after the letter (the paper's superscripts):
  ``"XYXYZ-X+"`` is X Y X Y Z\ :sup:`-` X\ :sup:`+`.

The case of the letters follows scipy's ``Rotation.from_euler``: **upper case is intrinsic**
(axes of the moving frame, the product above), **lower case is extrinsic** (axes of the fixed
frame: ``"xyz"`` with angles (a, b, c) is ``Rz(c) Ry(b) Rx(a)``, the intrinsic ``"ZYX"`` with the
angles reversed); one sequence does not mix the two. For 1 to 3 axes every string scipy accepts
gives scipy's matrix (tests/spatial/test_euler_scipy.py); mechkin also takes longer sequences
and signs.

hwang2023 Table 1 (lam = lambda, gam = gamma, bet = beta; side ``"right"`` is leg 1, ``"left"``
leg 2):

=============  ============  ===============================================
matrix         name          rotations
=============  ============  ===============================================
plane Lam_i    XYXY          Rx(lam_X) Ry(lam_Y) Rx(gam_X) Ry(gam_Y)
foot Psi_1     XYXYZ-X+      Lam_1 Rot(-Z, bet_Z) Rot(+X, bet_X)
foot Psi_2     XYXYZ-X-      Lam_2 Rot(-Z, bet_Z) Rot(-X, bet_X)
blade Psi_1    XYXYZ-Y-      Lam_1 Rot(-Z, bet_Z) Rot(-Y, bet_Y)
blade Psi_2    XYXYZ-Y+      Lam_2 Rot(-Z, bet_Z) Rot(+Y, bet_Y)
=============  ============  ===============================================

with gam_Y = 0 on the right and 180 deg on the left, so that X_i points outward on both sides
(on the left, Z_2 then points into the plane). The signs make the angles symmetric: bet_Z > 0
turns the toe outward, bet_X > 0 lifts the toe, bet_Y > 0 lifts the outer edge of the blade
(its top leans inward). ``Delta_i = Lam_i Rot(-Z, bet_Z)`` is the frame 0_i' (Eq. 21).

References
----------
hwang2023_hybrid_walking_skating_ik, Table 1, Table 5, Eqs. (3), (21).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from mechkin.spatial.rotations import rot_x, rot_y, rot_z

__all__ = [
    "BLADE_SEQUENCE",
    "FOOT_SEQUENCE",
    "PLANE_GAMMA_Y",
    "PLANE_SEQUENCE",
    "Side",
    "blade_matrix",
    "contact_angles_from_matrix",
    "contact_base_matrix",
    "euler_angles_from_matrix",
    "euler_matrix",
    "foot_matrix",
    "is_extrinsic",
    "parse_sequence",
    "plane_angles_from_matrix",
    "plane_matrix",
]

Side = Literal["right", "left"]

PLANE_SEQUENCE = "XYXY"
"""hwang2023 Table 1: the planes Lam_1, Lam_2."""
PLANE_GAMMA_Y: dict[str, float] = {"right": 0.0, "left": math.pi}
"""hwang2023 Table 1: gam_Y of the right (leg 1) and left (leg 2) plane [rad]."""
FOOT_SEQUENCE: dict[str, str] = {"right": "XYXYZ-X+", "left": "XYXYZ-X-"}
"""hwang2023 Table 1: the feet Psi_1, Psi_2."""
BLADE_SEQUENCE: dict[str, str] = {"right": "XYXYZ-Y-", "left": "XYXYZ-Y+"}
"""hwang2023 Table 1: the blades Psi_1, Psi_2."""

_AXIS = {"X": 0, "Y": 1, "Z": 2}
_ROT = (rot_x, rot_y, rot_z)


def parse_sequence(sequence: str) -> tuple[tuple[int, int], ...]:
    """Axes and signs of a sequence: ``"X Y -Z +X"`` or the paper's ``"XYXYZ-X+"``.

    Returns
    -------
    tuple of (axis, sign)
        ``axis`` in {0, 1, 2} for X, Y, Z and ``sign`` in {+1, -1}.

    Raises
    ------
    ValueError
        On anything but the letters X, Y, Z (either case, not mixed) and signs in the stated
        places.
    """
    is_extrinsic(sequence)  # mixed case is an error
    text = sequence.strip().upper()
    out: list[tuple[int, int]] = []
    if not text:
        raise ValueError(f"expected a sequence of axes such as 'X Y -Z', got {sequence!r}")
    if any(c.isspace() for c in text):
        for tok in text.split():
            sign = -1 if tok[0] == "-" else 1
            name = tok[1:] if tok[0] in "+-" else tok
            if name not in _AXIS:
                raise ValueError(f"expected an axis token like '-Z' or 'X', got {tok!r}")
            out.append((_AXIS[name], sign))
        return tuple(out)
    i = 0
    while i < len(text):
        c = text[i]
        if c not in _AXIS:
            raise ValueError(f"expected X, Y or Z at position {i} of {sequence!r}, got {c!r}")
        sign = 1
        if i + 1 < len(text) and text[i + 1] in "+-":
            sign = -1 if text[i + 1] == "-" else 1
            i += 1
        out.append((_AXIS[c], sign))
        i += 1
    return tuple(out)


def is_extrinsic(sequence: str) -> bool:
    """True for a lower-case (extrinsic, fixed-axes) sequence, False for upper case (intrinsic),
    as scipy's ``Rotation.from_euler``; ValueError if the letters mix the two cases."""
    letters = [c for c in sequence if c.isalpha()]
    lower = [c.islower() for c in letters]
    if letters and any(lower) and not all(lower):
        raise ValueError(f"expected axes all upper case (intrinsic, e.g. 'XYZ') or all lower "
                         f"case (extrinsic, e.g. 'xyz'), got {sequence!r}")
    return bool(letters) and all(lower)


def euler_matrix(sequence: str, angles: ArrayLike) -> np.ndarray:
    r"""Rotation matrix of Euler angles with signed axes (intrinsic for upper case, extrinsic
    for lower case, as scipy).

    .. math:: R = \prod_k \mathrm{Rot}(s_k a_k, t_k) \quad\text{(intrinsic)}, \qquad
              R = \prod_{k = n}^{1} \mathrm{Rot}(s_k a_k, t_k) \quad\text{(extrinsic)}

    Parameters
    ----------
    sequence : str
        See :func:`parse_sequence`, e.g. ``"XYXYZ-X+"`` (hwang2023 Table 1).
    angles : array, shape (..., k)
        One angle per axis [rad].

    Returns
    -------
    array, shape (..., 3, 3)
    """
    axes = parse_sequence(sequence)
    t = np.asarray(angles, dtype=np.float64)
    if t.shape[-1:] != (len(axes),):
        raise ValueError(
            f"expected angles of shape (..., {len(axes)}) for {sequence!r}, got {t.shape}")
    R = np.broadcast_to(np.eye(3), t.shape[:-1] + (3, 3))
    order = range(len(axes) - 1, -1, -1) if is_extrinsic(sequence) else range(len(axes))
    for k in order:
        a, s = axes[k]
        R = R @ _ROT[a](s * t[..., k])
    return np.array(R)


def euler_angles_from_matrix(sequence: str, R: ArrayLike) -> np.ndarray:
    r"""Angles of a three-axis sequence (Tait-Bryan ``i j k`` or proper ``i j i``) from R.

    The middle angle lies in [-pi/2, pi/2] for Tait-Bryan and [0, pi] for proper sequences
    (before its sign is applied); at the gimbal lock the first angle is set to 0.

    Parameters
    ----------
    sequence : str
        Three signed axes, consecutive axes distinct (e.g. ``"-Z +X +Y"``, ``"XYX"``).
    R : array, shape (..., 3, 3)

    Returns
    -------
    array, shape (..., 3)
        Angles [rad] with ``euler_matrix(sequence, angles) == R`` (for a lower-case,
        extrinsic sequence: those of the reversed intrinsic sequence, reversed).
    """
    if is_extrinsic(sequence):
        rev = " ".join(("-" if s < 0 else "+") + "XYZ"[a]
                       for a, s in reversed(parse_sequence(sequence)))
        return euler_angles_from_matrix(rev, R)[..., ::-1]
    axes = parse_sequence(sequence)
    if len(axes) != 3 or axes[0][0] == axes[1][0] or axes[1][0] == axes[2][0]:
        raise ValueError(f"expected three axes with consecutive axes distinct, got {sequence!r}")
    R = np.asarray(R, dtype=np.float64)
    i, j = axes[0][0], axes[1][0]
    k = 3 - i - j
    e = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    if axes[2][0] != i:  # Tait-Bryan i j k
        b = np.arcsin(np.clip(e * R[..., i, k], -1.0, 1.0))
        a = np.arctan2(-e * R[..., j, k], R[..., k, k])
        lock = np.hypot(R[..., j, k], R[..., k, k]) < 1e-12
    else:  # proper i j i
        b = np.arccos(np.clip(R[..., i, i], -1.0, 1.0))
        a = np.arctan2(R[..., j, i], -e * R[..., k, i])
        lock = np.hypot(R[..., j, i], R[..., k, i]) < 1e-12
    a = np.where(lock, 0.0, a)
    # the third angle from what is left, so that it is exact at the gimbal lock too
    m3 = axes[2][0]
    M = np.swapaxes(_ROT[i](a) @ _ROT[j](b), -1, -2) @ R
    u, v = (m3 + 1) % 3, (m3 + 2) % 3
    c = np.arctan2(M[..., v, u], M[..., u, u])
    ang = np.stack([a, b, c], axis=-1)
    signs = np.array([s for _, s in axes], dtype=np.float64)
    return ang * signs


def plane_matrix(lam_x: ArrayLike, lam_y: ArrayLike, gam_x: ArrayLike, side: Side) -> np.ndarray:
    """Plane Lam_i = Rx(lam_X) Ry(lam_Y) Rx(gam_X) Ry(gam_Y), gam_Y from the side (Table 1).

    Angles (...) [rad] -> (..., 3, 3).
    """
    t = np.stack(np.broadcast_arrays(*map(np.asarray, (lam_x, lam_y, gam_x))), axis=-1)
    g = np.full(t.shape[:-1] + (1,), PLANE_GAMMA_Y[_side(side)])
    return euler_matrix(PLANE_SEQUENCE, np.concatenate([t, g], axis=-1))


def contact_base_matrix(lam_x: ArrayLike, lam_y: ArrayLike, gam_x: ArrayLike, beta_z: ArrayLike,
                        side: Side) -> np.ndarray:
    """Delta_i = Lam_i Rot(-Z, bet_Z), the frame 0_i' of Table 1 (hwang2023 Eq. 21)."""
    return plane_matrix(lam_x, lam_y, gam_x, side) @ rot_z(-np.asarray(beta_z, dtype=np.float64))


def foot_matrix(lam_x: ArrayLike, lam_y: ArrayLike, gam_x: ArrayLike, beta_z: ArrayLike,
                beta_x: ArrayLike, side: Side) -> np.ndarray:
    """Foot Psi_i: XYXYZ-X+ (right) or XYXYZ-X- (left), hwang2023 Table 1; -> (..., 3, 3)."""
    s = 1.0 if _side(side) == "right" else -1.0
    return contact_base_matrix(lam_x, lam_y, gam_x, beta_z, side) @ rot_x(
        s * np.asarray(beta_x, dtype=np.float64))


def blade_matrix(lam_x: ArrayLike, lam_y: ArrayLike, gam_x: ArrayLike, beta_z: ArrayLike,
                 beta_y: ArrayLike, side: Side) -> np.ndarray:
    """Blade Psi_i: XYXYZ-Y- (right) or XYXYZ-Y+ (left), hwang2023 Table 1; -> (..., 3, 3)."""
    s = -1.0 if _side(side) == "right" else 1.0
    return contact_base_matrix(lam_x, lam_y, gam_x, beta_z, side) @ rot_y(
        s * np.asarray(beta_y, dtype=np.float64))


def plane_angles_from_matrix(Lam: ArrayLike, side: Side) -> np.ndarray:
    """(lam_X, lam_Y, gam_X) of a plane matrix Lam_i (the inverse of :func:`plane_matrix`).

    Of the two XYX solutions the one with ``|lam_X| + |gam_X|`` smallest is returned (the
    paper's planes are tilted by less than 90 deg). ``Lam`` (..., 3, 3) -> (..., 3) [rad].
    """
    Lam = np.asarray(Lam, dtype=np.float64)
    g = rot_y(-PLANE_GAMMA_Y[_side(side)])
    a = euler_angles_from_matrix("XYX", Lam @ g)
    alt = np.stack([_wrap(a[..., 0] + np.pi), -a[..., 1], _wrap(a[..., 2] + np.pi)], axis=-1)
    use_alt = (np.abs(alt[..., 0]) + np.abs(alt[..., 2])) < (np.abs(a[..., 0]) + np.abs(a[..., 2]))
    return np.where(use_alt[..., None], alt, a)


def contact_angles_from_matrix(Psi: ArrayLike, Lam: ArrayLike, side: Side,
                               kind: Literal["foot", "blade"]) -> np.ndarray:
    """(bet_Z, bet, off) of a foot or blade on a known plane (the inverse of Table 1).

    ``bet`` is bet_X for a foot and bet_Y for a blade. ``off`` [rad] is the rotation that the
    convention cannot express (about Y for a foot: the sole leaves the plane; about X for a
    blade: the blade pitches out of the plane); it is 0 when Psi belongs to the family.

    Parameters
    ----------
    Psi : array, shape (..., 3, 3)
        Foot or blade matrix (Table 1), world coordinates.
    Lam : array, shape (3, 3) or (..., 3, 3)
        The plane Lam_i of the same side.
    """
    side = _side(side)
    rel = np.swapaxes(np.asarray(Lam, dtype=np.float64), -1, -2) @ np.asarray(Psi, float)
    if kind == "foot":
        seq = "-Z +X +Y" if side == "right" else "-Z -X +Y"
    elif kind == "blade":
        seq = "-Z -Y +X" if side == "right" else "-Z +Y +X"
    else:
        raise ValueError(f"expected kind 'foot' or 'blade', got {kind!r}")
    return euler_angles_from_matrix(seq, rel)


def _side(side: str) -> Side:
    if side not in ("right", "left"):
        raise ValueError(f"expected side 'right' or 'left', got {side!r}")
    return side  # type: ignore[return-value]


def _wrap(t: np.ndarray) -> np.ndarray:
    return (t + np.pi) % (2.0 * np.pi) - np.pi
