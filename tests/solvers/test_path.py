"""Straight-line hand paths (park Eq. (7)-(12)): joint maps, derivatives and torques."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mechkin.errors import SingularityError
from mechkin.solvers.dynamics.open_chain import PlanarTwoLinkDynamics
from mechkin.solvers.track.path import (
    IKLinePath,
    JointPath,
    PlanarTwoLinkLinePath,
    path_torques,
    phase_coefficients,
)

# park §5.1 / PAPER_NOTES: hand from (-0.8, 1.732) to (-0.3, 1.732), x = -0.8 + 0.5 r
P0 = np.array([-0.8, 1.732])
P1 = np.array([-0.3, 1.732])
R = np.linspace(0.0, 1.0, 21)


def fk(q: np.ndarray) -> np.ndarray:
    return np.stack(
        [
            np.cos(q[:, 0]) + np.cos(q[:, 0] + q[:, 1]),
            np.sin(q[:, 0]) + np.sin(q[:, 0] + q[:, 1]),
        ],
        axis=1,
    )


def jacobian(q: np.ndarray) -> np.ndarray:
    s1, c1 = np.sin(q[:, 0]), np.cos(q[:, 0])
    s12, c12 = np.sin(q[:, 0] + q[:, 1]), np.cos(q[:, 0] + q[:, 1])
    return np.stack([np.stack([-s1 - s12, -s12], 1), np.stack([c1 + c12, c12], 1)], 1)


@pytest.fixture
def path() -> PlanarTwoLinkLinePath:
    return PlanarTwoLinkLinePath(P0, P1)


def test_ik_lands_on_the_line_with_elbow_up(path: PlanarTwoLinkLinePath) -> None:
    q = path.q(R)
    assert_allclose(fk(q), path.hand(R), atol=1e-12)
    assert_allclose(path.hand(R)[:, 0], -0.8 + 0.5 * R, atol=1e-15)
    assert np.all(q[:, 1] > 0)  # park: q2 > 0 branch
    down = PlanarTwoLinkLinePath(P0, P1, elbow=-1).q(R)
    assert np.all(down[:, 1] < 0)
    assert_allclose(fk(down), path.hand(R), atol=1e-12)


def test_derivatives_match_finite_differences(path: PlanarTwoLinkLinePath) -> None:
    h = 1e-6
    fd1 = (path.q(R + h) - path.q(R - h)) / (2 * h)
    fd2 = (path.dq(R + h) - path.dq(R - h)) / (2 * h)
    assert_allclose(path.dq(R), fd1, atol=1e-8)
    assert_allclose(path.ddq(R), fd2, atol=1e-8)


def test_first_derivative_is_park_table1(path: PlanarTwoLinkLinePath) -> None:
    """park Table 1: df/dx1 = (0.5 / s2) [c12, -c1 - c12] (the OCR wrote x2 for s2)."""
    q = path.q(R)
    c1, c12, s2 = np.cos(q[:, 0]), np.cos(q[:, 0] + q[:, 1]), np.sin(q[:, 1])
    expected = 0.5 / s2[:, None] * np.stack([c12, -c1 - c12], axis=1)
    assert_allclose(path.dq(R), expected, atol=1e-14)


def test_velocity_limit_crossing_sets_the_steady_state_bound(path: PlanarTwoLinkLinePath) -> None:
    """PAPER_NOTES: |qd2| = 0.4 |f2'| <= 0.2 first holds at t = 1.0935 s (r = 0.2374)."""
    r = np.linspace(0.0, 1.0, 100001)
    ok = np.all(0.4 * np.abs(path.dq(r)) <= 0.2, axis=1)
    r_star = r[np.argmax(ok)]
    assert (r_star + 0.2) / 0.4 == pytest.approx(1.0935, abs=5e-5)


def test_generic_ik_path_matches_the_analytic_one(path: PlanarTwoLinkLinePath) -> None:
    generic = IKLinePath(P0, P1, ik=lambda X: _analytic_ik(X), jacobian=jacobian, n=2)
    assert isinstance(generic, JointPath)
    assert_allclose(generic.q(R), path.q(R), atol=1e-14)
    assert_allclose(generic.dq(R), path.dq(R), atol=1e-12)
    assert_allclose(generic.ddq(R), path.ddq(R), atol=1e-6)


def _analytic_ik(X: np.ndarray) -> np.ndarray:
    x, y = X[:, 0], X[:, 1]
    c2 = (x**2 + y**2 - 2.0) / 2.0
    q2 = np.arccos(c2)
    q1 = np.arctan2(y, x) - np.arctan2(np.sin(q2), 1.0 + c2)
    return np.stack([q1, q2], axis=1)


def test_torque_along_path_eq12(path: PlanarTwoLinkLinePath) -> None:
    """U = M f' r'' + M f'' r'^2 + h (park Eq. (12)) vs Eq. (8) with Eq. (10)-(11)."""
    dyn = PlanarTwoLinkDynamics()
    rng = np.random.default_rng(12)
    rd, rdd = rng.normal(size=(2, R.size))
    U = path_torques(dyn, path, R, rd, rdd)
    q, f1, f2 = path.q(R), path.dq(R), path.ddq(R)
    M = dyn.mass_matrix(q)
    expected = (
        np.einsum("mij,mj->mi", M, f1) * rdd[:, None]
        + np.einsum("mij,mj->mi", M, f2) * (rd**2)[:, None]
        + dyn.bias(q, f1 * rd[:, None])
    )
    assert_allclose(U, expected, atol=1e-12)
    pc = phase_coefficients(dyn, path, R)
    assert_allclose(pc.torque(rd, rdd), expected, atol=1e-12)
    assert_allclose(pc.g, 0.0, atol=1e-15)  # horizontal plane


def test_out_of_reach_raises() -> None:
    far = PlanarTwoLinkLinePath([1.5, 0.0], [2.5, 0.0])
    with pytest.raises(SingularityError, match="out of reach"):
        far.q(np.array([0.0, 1.0]))
