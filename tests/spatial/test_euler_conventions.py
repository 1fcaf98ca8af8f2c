"""hwang2023 Table 1 Euler conventions: composer, extraction, the signs of feet and blades."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mechkin.spatial.euler_conventions import (
    BLADE_SEQUENCE,
    FOOT_SEQUENCE,
    blade_matrix,
    contact_angles_from_matrix,
    contact_base_matrix,
    euler_angles_from_matrix,
    euler_matrix,
    foot_matrix,
    parse_sequence,
    plane_angles_from_matrix,
    plane_matrix,
)
from mechkin.spatial.rotations import rot_x, rot_y, rot_z

ATOL = 1e-12
D15 = np.deg2rad(15.0)


def test_parse_both_spellings() -> None:
    assert parse_sequence("XYXYZ-X+") == parse_sequence("X Y X Y -Z +X")
    assert parse_sequence("XYXYZ-Y-") == ((0, 1), (1, 1), (0, 1), (1, 1), (2, -1), (1, -1))
    assert parse_sequence("xyx") == ((0, 1), (1, 1), (0, 1))


@pytest.mark.parametrize("bad", ["", "XQ", "X -W", "+X"])
def test_parse_rejects(bad: str) -> None:
    with pytest.raises(ValueError, match="expected"):
        parse_sequence(bad)


def test_euler_matrix_shape_error() -> None:
    with pytest.raises(ValueError, match=r"expected angles of shape \(\.\.\., 4\)"):
        euler_matrix("XYXY", [0.1, 0.2])


def test_table1_sequences_are_the_written_products() -> None:
    rng = np.random.default_rng(0)
    lx, ly, gx, bz, b = rng.uniform(-1, 1, 5)
    base_r = rot_x(lx) @ rot_y(ly) @ rot_x(gx) @ rot_y(0.0) @ rot_z(-bz)
    base_l = rot_x(lx) @ rot_y(ly) @ rot_x(gx) @ rot_y(np.pi) @ rot_z(-bz)
    assert_allclose(foot_matrix(lx, ly, gx, bz, b, "right"), base_r @ rot_x(b), atol=ATOL)
    assert_allclose(foot_matrix(lx, ly, gx, bz, b, "left"), base_l @ rot_x(-b), atol=ATOL)
    assert_allclose(blade_matrix(lx, ly, gx, bz, b, "right"), base_r @ rot_y(-b), atol=ATOL)
    assert_allclose(blade_matrix(lx, ly, gx, bz, b, "left"), base_l @ rot_y(b), atol=ATOL)
    for side, g in (("right", 0.0), ("left", np.pi)):
        ang = [lx, ly, gx, g, bz, b]
        assert_allclose(euler_matrix(FOOT_SEQUENCE[side], ang),
                        foot_matrix(lx, ly, gx, bz, b, side), atol=ATOL)
        assert_allclose(euler_matrix(BLADE_SEQUENCE[side], ang),
                        blade_matrix(lx, ly, gx, bz, b, side), atol=ATOL)
        assert_allclose(contact_base_matrix(lx, ly, gx, bz, side),
                        euler_matrix("XYXYZ-", ang[:5]), atol=ATOL)


def test_batched_composer() -> None:
    rng = np.random.default_rng(1)
    t = rng.uniform(-np.pi, np.pi, (7, 3, 6))
    R = euler_matrix("XYXYZ-Y-", t)
    assert R.shape == (7, 3, 3, 3)
    assert_allclose(R[4, 2], euler_matrix("XYXYZ-Y-", t[4, 2]), atol=ATOL)


@pytest.mark.parametrize("seq", ["XYZ", "ZYX", "-Z +X +Y", "-Z -Y +X", "XYX", "ZXZ", "-Y +X -Y"])
def test_extraction_round_trip(seq: str) -> None:
    rng = np.random.default_rng(2)
    t = rng.uniform(-np.pi, np.pi, (500, 3))
    R = euler_matrix(seq, t)
    assert_allclose(euler_matrix(seq, euler_angles_from_matrix(seq, R)), R, atol=1e-12)
    # gimbal lock: middle angle at +-90 deg (Tait-Bryan) or 0 (proper)
    axes = parse_sequence(seq)
    t[:, 1] = 0.0 if axes[0][0] == axes[2][0] else np.pi / 2 * axes[1][1]
    R = euler_matrix(seq, t)
    assert_allclose(euler_matrix(seq, euler_angles_from_matrix(seq, R)), R, atol=1e-12)


def test_planes_x_points_outward_z_away_on_the_right() -> None:
    R = plane_matrix(0.0, 0.0, 0.0, "right")
    L = plane_matrix(0.0, 0.0, 0.0, "left")
    assert_allclose(R, np.eye(3), atol=ATOL)
    assert_allclose(L, np.diag([-1.0, 1.0, -1.0]), atol=ATOL)  # gamma_Y = 180 deg


def test_table5_planes() -> None:
    # Table 5 (a): lam_X = 0, lam_Y = 15 deg: right low, left high (normal leans to +x)
    n_a = plane_matrix(0.0, D15, 0.0, "right")[:, 2]
    assert_allclose(n_a, [np.sin(D15), 0.0, np.cos(D15)], atol=ATOL)
    # Table 5 (b): lam_X = lam_Y = 15 deg: also front high, rear low (normal leans back, -y)
    n_b = plane_matrix(D15, D15, 0.0, "right")[:, 2]
    assert n_b[0] > 0.2 and n_b[1] < -0.2
    # both sides describe the same plane
    assert_allclose(plane_matrix(D15, D15, 0.0, "left")[:, 2], -n_b, atol=ATOL)


@pytest.mark.parametrize("side", ["right", "left"])
def test_angle_signs_are_symmetric(side: str) -> None:
    out = 1.0 if side == "right" else -1.0  # world x of "outward"
    a = 0.3
    # beta_Z > 0 turns the toe (plane Y, forward) outward
    toe = contact_base_matrix(0.0, 0.0, 0.0, a, side)[:, 1]
    assert toe[0] * out > 0.0 and toe[1] > 0.0
    # beta_X > 0 lifts the toe
    assert foot_matrix(0.0, 0.0, 0.0, 0.0, a, side)[2, 1] > 0.0
    # beta_Y > 0 lifts the outer edge (the X axis of the blade points outward and rises)
    B = blade_matrix(0.0, 0.0, 0.0, 0.0, a, side)
    assert B[2, 0] > 0.0 and B[0, 0] * out > 0.0


@pytest.mark.parametrize("side", ["right", "left"])
@pytest.mark.parametrize("kind", ["foot", "blade"])
def test_contact_angles_round_trip(side: str, kind: str) -> None:
    rng = np.random.default_rng(3)
    lx, ly, gx = rng.uniform(-0.5, 0.5, 3)
    bz = rng.uniform(-np.pi, np.pi, 50)
    b = rng.uniform(-1.5, 1.5, 50)
    f = foot_matrix if kind == "foot" else blade_matrix
    Psi = f(lx, ly, gx, bz, b, side)
    Lam = plane_matrix(lx, ly, gx, side)
    got = contact_angles_from_matrix(Psi, Lam, side, kind)
    assert_allclose(got[:, 0], bz, atol=1e-12)
    assert_allclose(got[:, 1], b, atol=1e-12)
    assert_allclose(got[:, 2], 0.0, atol=1e-12)
    # a rotation outside the family shows up in ``off``
    tilt = rot_y(0.01) if kind == "foot" else rot_x(0.01)
    off = contact_angles_from_matrix(Psi[0] @ tilt, Lam, side, kind)[2]
    assert abs(abs(off) - 0.01) < 1e-12


@pytest.mark.parametrize("side", ["right", "left"])
def test_plane_angles_round_trip(side: str) -> None:
    rng = np.random.default_rng(4)
    ang = rng.uniform(-1.2, 1.2, (100, 3))
    Lam = plane_matrix(ang[:, 0], ang[:, 1], ang[:, 2], side)
    got = plane_angles_from_matrix(Lam, side)
    assert_allclose(plane_matrix(got[:, 0], got[:, 1], got[:, 2], side), Lam, atol=1e-12)
    assert_allclose(plane_angles_from_matrix(plane_matrix(D15, D15, 0.0, side), side),
                    [D15, D15, 0.0], atol=1e-12)
