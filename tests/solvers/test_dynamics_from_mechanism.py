"""Serial-chain dynamics built from a mechanism file's inertial parameters (park Eq. (8))."""

from pathlib import Path

import numpy as np
import pytest

from mechkin.errors import ModelError
from mechkin.model import load_mechanism
from mechkin.solvers.dynamics.from_mechanism import (
    chain_order,
    dynamics_from_mechanism,
    planar_two_link_from_mechanism,
)
from mechkin.solvers.dynamics.open_chain import PlanarTwoLinkDynamics, SerialChainDynamics

ROOT = Path(__file__).resolve().parents[2]
RNG = np.random.default_rng(7)


def test_park_scara2_equals_closed_form() -> None:
    """park Table 1 (PAPER_NOTES): RNEA from the file equals the closed form to 1e-12."""
    mech = load_mechanism(ROOT / "mechanisms" / "park_scara2.yaml")
    dyn = dynamics_from_mechanism(mech)
    assert isinstance(dyn, SerialChainDynamics)
    ref = PlanarTwoLinkDynamics()
    q = RNG.uniform(-np.pi, np.pi, (50, 2))
    qd = RNG.normal(size=(50, 2))
    qdd = RNG.normal(size=(50, 2))
    np.testing.assert_allclose(dyn.inverse_dynamics(q, qd, qdd),
                               ref.inverse_dynamics(q, qd, qdd), rtol=0, atol=1e-12)
    np.testing.assert_allclose(dyn.mass_matrix(q), ref.mass_matrix(q), rtol=0, atol=1e-12)
    # the closed form read from the same file is park's model
    cf = planar_two_link_from_mechanism(mech)
    np.testing.assert_allclose(cf.inverse_dynamics(q, qd, qdd),
                               ref.inverse_dynamics(q, qd, qdd), rtol=0, atol=1e-12)


def test_puma560_mass_matrix_symmetric_positive_definite() -> None:
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    dyn = dynamics_from_mechanism(mech)
    assert dyn.n_joints == 6
    q = RNG.uniform(mech.lower, mech.upper, (40, 6))
    M = dyn.mass_matrix(q)
    np.testing.assert_allclose(M, np.swapaxes(M, 1, 2), rtol=0, atol=1e-12)
    assert np.linalg.eigvalsh(M).min() > 0.0
    # gravity acts: holding the arm at rest needs torque on the shoulder
    tau = dyn.inverse_dynamics(q, np.zeros_like(q), np.zeros_like(q))
    assert np.max(np.abs(tau[:, 1])) > 1.0


def test_puma560_power_balance() -> None:
    """qd . tau = dE/dt along a smooth motion (central differences)."""
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    dyn = dynamics_from_mechanism(mech)
    t = np.linspace(0.0, 1.0, 2001)
    w = np.arange(1, 7)[None, :]
    q = 0.5 * np.sin(w * t[:, None])
    qd = 0.5 * w * np.cos(w * t[:, None])
    qdd = -0.5 * w**2 * np.sin(w * t[:, None])
    power = np.einsum("mi,mi->m", qd, dyn.inverse_dynamics(q, qd, qdd))
    E = dyn.energy(q, qd)
    dE = (E[2:] - E[:-2]) / (t[2] - t[0])
    np.testing.assert_allclose(power[1:-1], dE, rtol=0, atol=1e-3 * np.max(np.abs(power)))


def test_joint_order_is_followed_from_the_base(tmp_path) -> None:
    """Joints listed tip first give the same torques, in the file's joint order."""
    text = (ROOT / "mechanisms" / "park_scara2.yaml").read_text()
    lines = text.splitlines()
    i1 = next(i for i, s in enumerate(lines) if s.strip().startswith("- {name: q1"))
    lines[i1], lines[i1 + 1] = lines[i1 + 1], lines[i1]
    p = tmp_path / "swapped.yaml"
    p.write_text("\n".join(lines) + "\n")
    mech = load_mechanism(p)
    assert mech.joint_names == ("q2", "q1")
    assert chain_order(mech).tolist() == [1, 0]
    dyn = dynamics_from_mechanism(mech)
    q = RNG.normal(size=(5, 2))
    qd = RNG.normal(size=(5, 2))
    qdd = RNG.normal(size=(5, 2))
    ref = PlanarTwoLinkDynamics().inverse_dynamics(q[:, ::-1], qd[:, ::-1], qdd[:, ::-1])
    np.testing.assert_allclose(dyn.inverse_dynamics(q, qd, qdd), ref[:, ::-1], atol=1e-12)


def test_closed_chain_gets_the_projected_tree_dynamics() -> None:
    """A closed chain is no longer refused: tree RNEA projected on the independent joints
    (tests/solvers/test_closed_dynamics.py checks it); the serial chain order still refuses it,
    and a massless closed chain is refused with a located reason."""
    from mechkin.solvers.dynamics.closed_chain import ClosedChainDynamics

    dd = load_mechanism(ROOT / "mechanisms" / "kim1995_direct_drive.yaml")
    assert isinstance(dynamics_from_mechanism(dd), ClosedChainDynamics)
    mech = load_mechanism(ROOT / "tests" / "data" / "fourbar.yaml")
    with pytest.raises(ModelError, match="closed chain"):
        chain_order(mech)
    with pytest.raises(ModelError, match="no link has a mass"):
        dynamics_from_mechanism(mech)


def test_closed_form_needs_a_planar_2r_arm() -> None:
    with pytest.raises(ModelError, match="2 revolute joints"):
        planar_two_link_from_mechanism(load_mechanism(ROOT / "mechanisms" / "puma560.yaml"))
