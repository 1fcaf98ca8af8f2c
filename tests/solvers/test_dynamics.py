"""Inverse dynamics: park's closed-form 2-link arm vs recursive Newton-Euler; a PUMA-like 6R."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mechkin.solvers.dynamics.open_chain import (
    InverseDynamics,
    PlanarTwoLinkDynamics,
    SerialChainDynamics,
)

GRAVITY = np.array([0.0, 0.0, -9.81])


def _tx(x: float) -> np.ndarray:
    T = np.eye(4)
    T[0, 3] = x
    return T


def _dh(d: float, a: float, alpha: float) -> np.ndarray:
    """Standard D-H fixed part ``Tz(d) Tx(a) Rx(alpha)``."""
    c, s = np.cos(alpha), np.sin(alpha)
    return np.array([[1.0, 0, 0, a], [0, c, -s, 0], [0, s, c, d], [0, 0, 0, 1]])


def _rod_inertia(m: float, length: float) -> np.ndarray:
    """Uniform thin rod along x, about its centre."""
    return np.diag([0.0, 1.0, 1.0]) * m * length**2 / 12.0


def park_arm_as_chain(*, frame_at_tip: bool) -> SerialChainDynamics:
    """park's arm (PAPER_NOTES: uniform rods l = 1 m, m = 1 kg) in the horizontal plane.

    Joint axes are vertical, gravity is along -z, so gravity does no work. With
    ``frame_at_tip`` the link frame sits at the distal end (B = Tx(1), com at -0.5).
    """
    eye = np.eye(4)
    if frame_at_tip:
        A = np.stack([eye, eye])
        B = np.stack([_tx(1.0), _tx(1.0)])
        coms = [[-0.5, 0, 0], [-0.5, 0, 0]]
    else:
        A = np.stack([eye, _tx(1.0)])
        B = np.stack([eye, eye])
        coms = [[0.5, 0, 0], [0.5, 0, 0]]
    inertia = _rod_inertia(1.0, 1.0)
    return SerialChainDynamics(
        A=A,
        B=B,
        kinds=np.array([0, 0]),
        masses=np.array([1.0, 1.0]),
        coms=np.array(coms),
        inertias=np.stack([inertia, inertia]),
        gravity=GRAVITY,
    )


def puma_like() -> SerialChainDynamics:
    """PUMA 560 standard D-H and inertial parameters (Corke's toolbox / mechanisms/puma560.yaml)."""
    d = [0.67183, 0.0, 0.15005, 0.4318, 0.0, 0.0]  # d1: the Python toolbox's pedestal
    a = [0.0, 0.4318, 0.0203, 0.0, 0.0, 0.0]
    alpha = np.deg2rad([90.0, 0.0, -90.0, 90.0, -90.0, 0.0])
    masses = np.array([0.0, 17.4, 4.8, 0.82, 0.34, 0.09])
    coms = np.array(
        [
            [0, 0, 0],
            [-0.3638, 0.006, 0.2275],
            [-0.0203, -0.0141, 0.070],
            [0, 0.019, 0],
            [0, 0, 0],
            [0, 0, 0.032],
        ]
    )
    diag = [
        [0, 0.35, 0],
        [0.13, 0.524, 0.539],
        [0.066, 0.086, 0.0125],
        [1.8e-3, 1.3e-3, 1.8e-3],
        [0.3e-3, 0.4e-3, 0.3e-3],
        [0.15e-3, 0.15e-3, 0.04e-3],
    ]
    return SerialChainDynamics(
        A=np.broadcast_to(np.eye(4), (6, 4, 4)).copy(),
        B=np.stack([_dh(d[i], a[i], alpha[i]) for i in range(6)]),
        kinds=np.zeros(6, dtype=int),
        masses=masses,
        coms=coms,
        inertias=np.stack([np.diag(x) for x in diag]),
        gravity=GRAVITY,
    )


def rp_arm() -> SerialChainDynamics:
    """A vertical-plane RP arm: revolute shoulder about y, prismatic slide along the link."""
    rx = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])  # z -> -y
    ry = np.array([[0.0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]])  # z -> x
    A = np.stack([rx, ry])
    B = np.stack([np.eye(4), np.eye(4)])
    return SerialChainDynamics(
        A=A,
        B=B,
        kinds=np.array([0, 1]),
        masses=np.array([2.0, 1.5]),
        coms=np.array([[0.3, 0.05, 0.0], [0.0, 0.02, -0.2]]),
        inertias=np.stack([np.diag([0.01, 0.05, 0.05]), np.diag([0.02, 0.02, 0.005])]),
        gravity=GRAVITY,
    )


@pytest.mark.parametrize("frame_at_tip", [False, True])
def test_park_closed_form_matches_rnea(frame_at_tip: bool) -> None:
    rng = np.random.default_rng(4)
    q, qd, qdd = rng.uniform(-3, 3, size=(3, 64, 2))
    closed = PlanarTwoLinkDynamics()
    chain = park_arm_as_chain(frame_at_tip=frame_at_tip)
    assert_allclose(
        chain.inverse_dynamics(q, qd, qdd), closed.inverse_dynamics(q, qd, qdd), atol=1e-12
    )
    assert_allclose(chain.mass_matrix(q), closed.mass_matrix(q), atol=1e-12)
    assert_allclose(chain.bias(q, qd), closed.bias(q, qd), atol=1e-12)


def test_park_closed_form_printed_entries() -> None:
    """PAPER_NOTES (park Table 1, sines restored): M and h of uniform rods l = 1, m = 1."""
    q = np.array([[0.3, 0.7]])
    qd = np.array([[0.4, -1.1]])
    c2, s2 = np.cos(0.7), np.sin(0.7)
    M = PlanarTwoLinkDynamics().mass_matrix(q)[0]
    assert_allclose(M, [[5 / 3 + c2, 1 / 3 + c2 / 2], [1 / 3 + c2 / 2, 1 / 3]], atol=1e-15)
    h = PlanarTwoLinkDynamics().bias(q, qd)[0]
    assert_allclose(h, [-s2 * (0.4 * -1.1 + 1.1**2 / 2), s2 * 0.4**2 / 2], atol=1e-15)


@pytest.mark.parametrize("make", [puma_like, rp_arm])
def test_mass_matrix_symmetric_positive_definite(make) -> None:
    chain = make()
    rng = np.random.default_rng(7)
    q = rng.uniform(-np.pi, np.pi, size=(50, chain.n_joints))
    M = chain.mass_matrix(q)
    assert_allclose(M, np.swapaxes(M, 1, 2), atol=1e-12)
    assert np.linalg.eigvalsh(M).min() > 0.0


@pytest.mark.parametrize("make", [puma_like, rp_arm])
def test_inverse_dynamics_splits_into_mass_matrix_and_bias(make) -> None:
    chain = make()
    rng = np.random.default_rng(8)
    q, qd, qdd = rng.normal(size=(3, 20, chain.n_joints))
    tau = chain.inverse_dynamics(q, qd, qdd)
    expected = np.einsum("mij,mj->mi", chain.mass_matrix(q), qdd) + chain.bias(q, qd)
    assert_allclose(tau, expected, atol=1e-10)


@pytest.mark.parametrize("make", [puma_like, rp_arm])
def test_power_balance_along_a_motion(make) -> None:
    """qd . tau = dE/dt, E kinetic plus potential (gravity on), by a central difference in t."""
    chain = make()
    n = chain.n_joints
    rng = np.random.default_rng(9)
    q0, amp = rng.uniform(-1, 1, size=(2, n))
    w = rng.uniform(0.5, 2.0, size=n)
    t = np.linspace(0.0, 2.0, 41)
    h = 1e-5

    def motion(tt: np.ndarray) -> tuple[np.ndarray, ...]:
        arg = np.outer(tt, w)
        return q0 + amp * np.sin(arg), amp * w * np.cos(arg), -amp * w**2 * np.sin(arg)

    q, qd, qdd = motion(t)
    power = np.einsum("mi,mi->m", qd, chain.inverse_dynamics(q, qd, qdd))
    qp, qdp, _ = motion(t + h)
    qm, qdm, _ = motion(t - h)
    dE = (chain.energy(qp, qdp) - chain.energy(qm, qdm)) / (2 * h)
    scale = np.max(np.abs(power))
    assert scale > 1.0  # the motion does real work against gravity and inertia
    assert_allclose(power, dE, atol=1e-6 * scale)


def test_prismatic_joint_lifting_a_mass() -> None:
    """One vertical slide: tau = m (qdd + g)."""
    chain = SerialChainDynamics(
        A=np.eye(4)[None],
        B=np.eye(4)[None],
        kinds=np.array([1]),
        masses=np.array([3.0]),
        coms=np.array([[0.1, 0.2, 0.3]]),
        inertias=np.eye(3)[None] * 0.01,
        gravity=GRAVITY,
    )
    tau = chain.inverse_dynamics(np.array([[0.5]]), np.array([[2.0]]), np.array([[1.5]]))
    assert_allclose(tau, [[3.0 * (1.5 + 9.81)]], atol=1e-12)


def test_models_satisfy_the_protocol() -> None:
    assert isinstance(PlanarTwoLinkDynamics(), InverseDynamics)
    assert isinstance(puma_like(), InverseDynamics)


def test_bad_shapes_are_rejected() -> None:
    chain = park_arm_as_chain(frame_at_tip=False)
    with pytest.raises(ValueError, match="expected shape"):
        chain.inverse_dynamics(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="coms"):
        SerialChainDynamics(
            A=np.stack([np.eye(4)] * 2),
            B=np.stack([np.eye(4)] * 2),
            kinds=np.array([0, 0]),
            masses=np.ones(2),
            coms=np.zeros((2, 2)),
            inertias=np.stack([np.eye(3)] * 2),
        )
    with pytest.raises(ValueError, match="kinds"):
        SerialChainDynamics(
            A=np.stack([np.eye(4)] * 2),
            B=np.stack([np.eye(4)] * 2),
            kinds=np.array([0, 2]),
            masses=np.ones(2),
            coms=np.zeros((2, 3)),
            inertias=np.stack([np.eye(3)] * 2),
        )
