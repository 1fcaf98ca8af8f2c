"""Path inverse kinematics (park Eq. (7), (9)-(11)) for any arm: 6-D PUMA 560 line with the
orientation held, the redundant planar 3R, park's 2R against the closed form, failures."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics, frame_jacobian
from mechkin.solvers.track.path import PlanarTwoLinkLinePath
from mechkin.solvers.track.path_ik import COMPONENTS, HandLineIK, PathIKError, left_jacobian_inverse
from mechkin.spatial.rotations import rot_axis, rotation_log

ROOT = Path(__file__).resolve().parents[2]
DEG = np.pi / 180.0
R = np.linspace(0.0, 1.0, 41)


def _hand(mech, q):
    return forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]


@cache
def puma() -> tuple[object, HandLineIK]:
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    q0 = np.array([0, 30, -120, 0, -40, 0]) * DEG
    p0 = _hand(mech, q0[None])[0, :3, 3]
    ik = HandLineIK(mech, mech.end_effector, p0, p0 + [0.0, 0.4, 0.0], q0, 1e-12,
                    mask=COMPONENTS)
    return mech, ik


@cache
def planar3r() -> tuple[object, HandLineIK]:
    mech = load_mechanism(ROOT / "mechanisms" / "planar3r.yaml")
    p0 = _hand(mech, mech.home[None])[0, :3, 3]
    ik = HandLineIK(mech, mech.end_effector, p0, p0 + [-0.4, 0.0, 0.0], mech.home, 1e-12)
    return mech, ik


def test_puma_line_holds_the_orientation_to_1e6() -> None:
    """The 6-D task: FK of q(r) on the line, orientation equal to the start orientation."""
    mech, ik = puma()
    assert ik.rank == 6 and ik.redundancy == 0 and ik.orientation_held
    q = ik.q(R)
    T = _hand(mech, q)
    assert np.max(np.linalg.norm(T[:, :3, 3] - ik.hand(R), axis=1)) <= 1e-9
    ang = np.linalg.norm(rotation_log(T[:, :3, :3] @ ik.R0.T), axis=1)
    assert np.max(ang) <= 1e-9
    err = ik.pose_errors(q, R)
    assert err["max_orientation_error_rad"] <= 1e-6 and err["max_position_error_m"] <= 1e-6
    # the position-only task (the old behaviour) lets the tool turn along the same line
    free = HandLineIK(mech, mech.end_effector, ik.p0, ik.p1, ik.q_ref, 1e-12)
    assert free.redundancy == 3
    assert free.pose_errors(free.q(R), R)["max_rotation_from_start_rad"] > 0.3


@pytest.mark.parametrize("arm", ["puma", "planar3r"])
def test_derivatives_are_those_of_q_of_r(arm: str) -> None:
    """f' and f'' (implicit function theorem on G = 0) against central differences of q(r);
    the hand velocity J f' is the line's direction with no rotation (Eq. (10))."""
    mech, ik = puma() if arm == "puma" else planar3r()
    r = np.linspace(0.05, 0.95, 7)
    h = 1e-4
    fd1 = (ik.q(r + h) - ik.q(r - h)) / (2 * h)
    d1 = ik.dq(r)
    assert_allclose(d1, fd1, atol=1e-6 * max(1.0, np.max(np.abs(d1))))
    fd2 = (ik.q(r + h) - 2 * ik.q(r) + ik.q(r - h)) / h**2
    d2 = ik.ddq(r)
    assert_allclose(d2, fd2, atol=1e-4 * max(1.0, np.max(np.abs(d2))))
    J = frame_jacobian(mech, forward_kinematics(mech, ik.q(r)), mech.end_effector)
    twist = np.einsum("mij,mj->mi", J, d1)
    assert_allclose(twist[:, 3:], np.broadcast_to(ik.dp, (len(r), 3)), atol=1e-9)
    if ik.orientation_held:
        assert_allclose(twist[:, :3], 0.0, atol=1e-9)


def test_planar_3r_redundancy_by_the_null_space_posture_term() -> None:
    """3 joints, 2 task components: the posture closest to the start solution on the
    self-motion manifold, N (q_s - q) = 0, and no crash (was LinAlgError: Singular matrix)."""
    mech, ik = planar3r()
    assert ik.rank == 2 and ik.redundancy == 1 and not ik.orientation_held
    q = ik.q(R)
    assert_allclose(_hand(mech, q)[:, :3, 3], ik.hand(R), atol=1e-12)
    N = ik._null(q)
    assert np.max(np.abs(np.einsum("mij,mj->mi", N, ik.q_ref - q))) <= 1e-9
    # a small self-motion (in the null space) moves the posture away from the start: the
    # chosen q is locally the closest (KKT point of min |q - q_s|^2 on the manifold)
    k = 20
    z = np.linalg.svd(ik._task_jacobian(q[k:k + 1])[0])[2][-1]
    for eps in (1e-3, -1e-3):
        qq = q[k] + eps * z
        for _ in range(20):  # back onto the manifold (hand at the same point)
            e = ik.target(R[k:k + 1])[0] - ik._task(qq[None])[1][0, ik.rows]
            qq = qq + np.linalg.pinv(ik._task_jacobian(qq[None])[0]) @ e
        assert np.linalg.norm(qq - ik.q_ref) > np.linalg.norm(q[k] - ik.q_ref)


def test_park_2r_matches_the_closed_form() -> None:
    """Position-only task of park's planar 2R (the default for fewer than 6 joints) is the
    analytic path of park Table 1."""
    mech = load_mechanism(ROOT / "mechanisms" / "park_scara2.yaml")
    ik = HandLineIK(mech, mech.end_effector, np.array([-0.8, 1.732, 0.0]),
                    np.array([-0.3, 1.732, 0.0]), mech.home, 1e-12)
    ref = PlanarTwoLinkLinePath([-0.8, 1.732], [-0.3, 1.732])
    assert ik.rank == 2 and ik.redundancy == 0
    assert_allclose(ik.q(R), ref.q(R), atol=1e-12)
    assert_allclose(ik.dq(R), ref.dq(R), atol=1e-10)
    assert_allclose(ik.ddq(R), ref.ddq(R), atol=1e-7)


def test_line_out_of_reach_names_r_and_the_point() -> None:
    mech = load_mechanism(ROOT / "mechanisms" / "planar3r.yaml")
    p0 = _hand(mech, mech.home[None])[0, :3, 3]
    with pytest.raises(PathIKError) as ei:
        HandLineIK(mech, mech.end_effector, p0, p0 + [1.5, 0.0, 0.0], mech.home, 1e-12)
    assert ei.value.key == "path" and 0.0 < ei.value.r < 1.0
    msg = str(ei.value)
    assert f"r = {ei.value.r:.3g}" in msg and "point [" in msg
    # the reach is 1.4 m: the failure is where the line crosses it
    assert np.linalg.norm(ei.value.point) == pytest.approx(1.4, abs=0.02)


def test_left_jacobian_inverse_differentiates_the_rotation_log() -> None:
    """d phi/dt = J_l(phi)^{-1} omega for phi = log(R R0^T), by a finite difference."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        phi = rng.normal(size=3)
        phi *= rng.uniform(0.1, 2.5) / np.linalg.norm(phi)
        w = rng.normal(size=3)
        ang = np.linalg.norm(phi)
        Q = rot_axis(phi / ang, ang)
        h = 1e-6
        Qp = rot_axis(w / np.linalg.norm(w), h * np.linalg.norm(w)) @ Q
        Qm = rot_axis(w / np.linalg.norm(w), -h * np.linalg.norm(w)) @ Q
        fd = (rotation_log(Qp[None])[0] - rotation_log(Qm[None])[0]) / (2 * h)
        assert_allclose(left_jacobian_inverse(phi[None])[0] @ w, fd, atol=1e-7)
