"""The serial path to a frame (mechkin.model.serial) against the general tree kinematics."""

from __future__ import annotations

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics, frame_jacobian
from mechkin.model.serial import SMALL_BATCH, SerialChain
from mechkin.spatial.transforms import invert

# open arms, a closed chain's end effector path and the Stewart platform (prismatic joints)
NAMES = ["puma560", "panda", "park_scara2", "kim1995_direct_drive", "kim1995_stewart",
         "kim1995_end_effector_robot"]


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("m", [3, SMALL_BATCH + 5])
def test_pose_and_jacobian_equal_the_tree_kinematics(root, name, m):
    mech = load_mechanism(root / "mechanisms" / f"{name}.yaml")
    ch = SerialChain(mech, mech.end_effector)
    assert np.all(mech.link_ancestors[mech.frame_link[mech.end_effector]][ch.joints])
    rng = np.random.default_rng(4)
    q = mech.home + rng.normal(0.0, 0.3, size=(m, mech.n))
    kin = forward_kinematics(mech, q)
    T = kin.frames(mech, [mech.end_effector])[:, 0]
    Jg = frame_jacobian(mech, kin, mech.end_effector)  # rows (omega, v)
    T2, J2 = ch.pose_jacobian(q[:, ch.joints])  # rows (v, omega)
    np.testing.assert_allclose(T2, T, atol=1e-12)
    np.testing.assert_allclose(J2[:, :3], Jg[:, 3:][:, :, ch.joints], atol=1e-12)
    np.testing.assert_allclose(J2[:, 3:], Jg[:, :3][:, :, ch.joints], atol=1e-12)
    np.testing.assert_allclose(ch.pose(q[:, ch.joints]), T, atol=1e-12)
    # expressed in other frames {P}: pose T_P^-1 T and rotated Jacobian
    TP = forward_kinematics(mech, q[::-1]).frames(mech, [mech.end_effector])[:, 0]
    T3, J3 = ch.pose_jacobian(q[:, ch.joints], ch.first_frame(TP))
    np.testing.assert_allclose(T3, invert(TP) @ T, atol=1e-12)
    RPt = np.swapaxes(TP[:, :3, :3], 1, 2)[:, None]
    np.testing.assert_allclose(J3.reshape(m, 2, 3, -1), RPt @ J2.reshape(m, 2, 3, -1),
                               atol=1e-12)


def test_jacobian_vs_finite_differences_with_prismatic_joints(root):
    mech = load_mechanism(root / "mechanisms" / "kim1995_stewart.yaml")
    ch = SerialChain(mech, mech.end_effector)
    assert not ch.all_rev
    q = mech.home[ch.joints] + np.random.default_rng(5).normal(0.0, 0.2, ch.k)
    T, J = ch.pose_jacobian(q[None])
    h = 1e-6
    for j in range(ch.k):
        e = np.zeros(ch.k)
        e[j] = h
        Tp, Tm = ch.pose((q + e)[None])[0], ch.pose((q - e)[None])[0]
        v = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        dR = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ T[0, :3, :3].T  # [omega]_x
        np.testing.assert_allclose(J[0, :3, j], v, atol=1e-8)
        np.testing.assert_allclose(J[0, 3:, j], [dR[2, 1], dR[0, 2], dR[1, 0]], atol=1e-8)


def test_a_frame_no_joint_moves_is_refused(root):
    mech = load_mechanism(root / "mechanisms" / "puma560.yaml")
    base = [i for i in range(len(mech.frame_names)) if mech.frame_link[i] == 0]
    if not base:
        pytest.skip("no frame on the ground link")
    with pytest.raises(ValueError, match="no joint moves"):
        SerialChain(mech, base[0])
