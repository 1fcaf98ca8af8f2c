r"""Closed-form inverse kinematics of a Stewart platform: leg lengths from the pose.

.. math:: l_i = \| p + R\, b_i - a_i \|

with a_i the base attachment points (base frame) and b_i the platform attachment points in the
end-effector frame {E} (kim1995 §6.2, Table 4; for the 3-6 platform of kim1995 the b_i repeat in
pairs). :func:`stewart_attachments` extracts a_i and b_i from a mechanism whose independent
joints are prismatic legs between a base-fixed joint and a platform joint (U-P-S legs).

References
----------
kim1995_complex_chain_ik §6.2, Tables 4-6 ("analytical solution", after Masory et al. 1992).
"""

from __future__ import annotations

import numpy as np

from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import forward_kinematics
from mechkin.model.mechanism import Mechanism
from mechkin.spatial.transforms import invert


def leg_lengths(T_0_E: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Leg lengths (m, k) for platform poses T_0_E (m, 4, 4), base points a (k, 3) in {0} and
    platform points b (k, 3) in {E}."""
    T = np.asarray(T_0_E, dtype=np.float64).reshape(-1, 4, 4)
    B = np.einsum("mij,kj->mki", T[:, :3, :3], np.asarray(b, float)) + T[:, None, :3, 3]
    return np.linalg.norm(B - np.asarray(a, float)[None], axis=-1)


def stewart_attachments(mech: Mechanism) -> tuple[np.ndarray, np.ndarray]:
    """Base points a (k, 3) [base frame] and platform points b (k, 3) [{E} frame] of the legs.

    Each independent joint must be prismatic; its leg's base point is the axis origin of the
    joint before it (the universal joint at A_i), its platform point the axis origin of the
    joint after it (the spherical joint at B_i), read at the assembled home configuration.

    Raises
    ------
    ValueError
        If an independent joint is not prismatic, a leg has no joint before or after it, or the
        home configuration does not assemble.
    """
    if mech.end_effector is None:
        raise ValueError(f"{mech.name}: no end_effector frame")
    dep = mech.dependent
    res = solve_closure(mech, mech.home[mech.independent][None], mech.home[dep][None])
    if not res.ok[0]:
        raise ValueError(f"{mech.name}: the home configuration does not assemble")
    kin = forward_kinematics(mech, res.q)
    o = kin.W[0, :, :3, 3]
    T_E = kin.frames(mech, [mech.end_effector])[0, 0]
    T_E_0 = invert(T_E)
    a, b = [], []
    for j in mech.independent:
        if mech.s[j] != 1:
            raise ValueError(f"{mech.name}: joint {mech.joint_names[j]} is not a prismatic leg")
        before = np.flatnonzero(mech.joint_child_link == mech.joint_parent_link[j])
        after = np.flatnonzero(mech.joint_parent_link == mech.joint_child_link[j])
        if before.size != 1 or after.size != 1:
            raise ValueError(f"{mech.name}: leg {mech.joint_names[j]} is not a U-P-S chain")
        # the base joint's axis origin is fixed; walk to the first joint of the leg
        first = int(before[0])
        while True:
            prev = np.flatnonzero(mech.joint_child_link == mech.joint_parent_link[first])
            if prev.size == 0:
                break
            first = int(prev[0])
        a.append(o[first])
        b.append(T_E_0[:3, :3] @ o[int(after[0])] + T_E_0[:3, 3])
    return np.array(a), np.array(b)
