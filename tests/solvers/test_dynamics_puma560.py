"""PUMA 560 inverse dynamics (RNEA from mechanisms/puma560.yaml) against the values Peter
Corke's Robotics Toolbox prints for its Puma560 model (same D-H and inertial parameters).

Sources, typed in as published:

* petercorke/robotics-toolbox-python, ``tests/test_SerialLink.py`` (commit 0821e722),
  ``test_gravload``, ``test_inertia``, ``test_itorque``, ``test_coriolis`` with
  ``rp.models.DH.Puma560()`` at the nominal pose ``qn = (0, pi/4, pi, 0, pi/4, 0)``, 4 decimals.
* RTSX (the Scilab port of the toolbox), online help of ``gravload``
  (http://scilab.ninja/rtsx/online-help/gravload/): ``gravload(p560, q_n) = 0 31.63988
  6.035138 0 0.0282528 0``.

The toolbox model includes the motors' armature inertia ``Jm G^2`` on the diagonal of the
inertia matrix (``roboticstoolbox/models/DH/Puma560.py``: ``Jm = 200e-6`` for joints 1-3,
``33e-6`` for 4-6; gear ratios ``G = -62.6111, 107.815, -53.7063, 76.0364, 71.923, 76.686``);
mechkin's mechanism has link inertias only, so the armature term is subtracted from the
published inertia matrix and inertial torques. Gravity and Coriolis torques do not involve it.
The base offset d1 (0 here, 0.672 m in the toolbox) moves every link along the first joint
axis and so changes none of these torques.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mechkin.model import load_mechanism
from mechkin.solvers.dynamics.from_mechanism import dynamics_from_mechanism

ROOT = Path(__file__).resolve().parents[2]
QN = np.array([0.0, np.pi / 4, np.pi, 0.0, np.pi / 4, 0.0])
ZERO = np.zeros(6)
#: Armature inertia Jm G^2 [kg m^2] of the toolbox's Puma560 (models/DH/Puma560.py).
JM = np.array([200e-6, 200e-6, 200e-6, 33e-6, 33e-6, 33e-6])
G = np.array([-62.6111, 107.815, -53.7063, 76.0364, 71.923, 76.686])
ARMATURE = JM * G**2
#: Half a unit in the 4th decimal: the published values are rounded to 4 decimals.
ROUND4 = 0.5e-4


@pytest.fixture(scope="module")
def dyn():
    return dynamics_from_mechanism(load_mechanism(ROOT / "mechanisms" / "puma560.yaml"))


def _id(dyn, q, qd, qdd) -> np.ndarray:
    return dyn.inverse_dynamics(np.atleast_2d(q), np.atleast_2d(qd), np.atleast_2d(qdd))[0]


def test_gravity_load_at_qn(dyn) -> None:
    """rtb test_gravload: [-0.0000, 31.6399, 6.0351, 0.0000, 0.0283, 0]; RTSX 7 digits."""
    tau = _id(dyn, QN, ZERO, ZERO)
    assert_allclose(tau, [0.0, 31.6399, 6.0351, 0.0, 0.0283, 0.0], atol=ROUND4 + 1e-12)
    assert_allclose(tau, [0.0, 31.63988, 6.035138, 0.0, 0.0282528, 0.0], atol=0.5e-5)


def test_inertia_matrix_at_qn(dyn) -> None:
    """rtb test_inertia (with the armature Jm G^2 on the diagonal, removed here)."""
    published = np.array([
        [3.6594, -0.4044, 0.1006, -0.0025, 0.0000, -0.0000],
        [-0.4044, 4.4137, 0.3509, 0.0000, 0.0024, 0.0000],
        [0.1006, 0.3509, 0.9378, 0.0000, 0.0015, 0.0000],
        [-0.0025, 0.0000, 0.0000, 0.1925, 0.0000, 0.0000],
        [0.0000, 0.0024, 0.0015, 0.0000, 0.1713, 0.0000],
        [-0.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.1941]])
    g = _id(dyn, QN, ZERO, ZERO)
    M = np.column_stack([_id(dyn, QN, ZERO, e) - g for e in np.eye(6)])
    assert_allclose(M, M.T, atol=1e-12)
    assert_allclose(M + np.diag(ARMATURE), published, atol=ROUND4 + 1e-9)


def test_inertial_torque_at_qn(dyn) -> None:
    """rtb test_itorque: M(qn) qdd for qdd = (1, 2, 3, 1, 2, 3) (armature removed)."""
    qdd = np.array([1.0, 2.0, 3.0, 1.0, 2.0, 3.0])
    published = np.array([3.1500, 9.4805, 3.6189, 0.1901, 0.3519, 0.5823])
    tau = _id(dyn, QN, ZERO, qdd) - _id(dyn, QN, ZERO, ZERO)
    assert_allclose(tau + ARMATURE * qdd, published, atol=ROUND4 + 1e-9)


def test_coriolis_torque_at_qn(dyn) -> None:
    """rtb test_coriolis: C(qn, qd) qd for qd = (1, 2, 3, 1, 2, 3); the published matrix is
    rounded to 4 decimals, so its product with qd is known to sum |qd| * 0.5e-4 = 6e-4."""
    qd = np.array([1.0, 2.0, 3.0, 1.0, 2.0, 3.0])
    C = np.array([
        [-0.1735, -2.0494, -0.1178, -0.0002, -0.0045, 0.0001],
        [0.6274, 1.1572, 1.9287, -0.0015, -0.0003, -0.0000],
        [-0.3608, -0.7734, -0.0018, -0.0009, -0.0064, -0.0000],
        [0.0011, 0.0005, -0.0001, 0.0002, 0.0002, -0.0001],
        [-0.0002, 0.0028, 0.0046, -0.0002, -0.0000, -0.0000],
        [0.0001, 0.0000, 0.0000, 0.0000, 0.0000, 0]])
    tau = _id(dyn, QN, qd, ZERO) - _id(dyn, QN, ZERO, ZERO)
    assert_allclose(tau, C @ qd, atol=np.sum(np.abs(qd)) * ROUND4 + 1e-9)
