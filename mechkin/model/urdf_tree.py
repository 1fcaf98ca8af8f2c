"""The frame tree of a mechanism's URDF (its spanning tree), for ``/tf``.

``mechkin.io.urdf_out.mechanism_to_urdf`` writes each 1-DOF joint ``T_parent_child(q) =
A Z(q) B`` as one URDF joint from the parent link to the child link, or, when ``B`` cannot be
moved before ``Z(q)`` (standard D-H with ``a != 0``), as a joint to an intermediate link
``<child>_dh`` followed by a fixed joint ``B`` to the child; named frames hang from their link
on fixed joints. :func:`urdf_frame_tree` returns exactly that tree with the poses of the
configurations ``kin``, so a viewer that draws the URDF from ``/joint_states`` (Foxglove's URDF
layer) and one that reads ``/tf`` show the same picture, and every URDF link has one parent.

The rule and the names here follow ``mechanism_to_urdf``; tests/io/test_robot_description.py
checks that the URDF's forward kinematics at every logged joint state equals the logged ``/tf``.

Imports: model.kinematics, model.mechanism, spatial.transforms.
"""

from __future__ import annotations

import numpy as np

from mechkin.model.kinematics import Kinematics
from mechkin.model.mechanism import Mechanism
from mechkin.spatial.transforms import invert

__all__ = ["dh_intermediate", "urdf_frame_tree"]


def dh_intermediate(mech: Mechanism, k: int) -> bool:
    """Whether joint k needs the intermediate link ``<child>_dh`` in the URDF: a revolute joint
    whose ``B`` translates off its axis (``A Z(q) B`` cannot be written ``(A B) Z'(q)``)."""
    p_B = mech.B[k][:3, 3]
    return not (bool(mech.s[k]) or (abs(p_B[0]) == 0 and abs(p_B[1]) == 0))


def urdf_frame_tree(mech: Mechanism, kin: Kinematics
                    ) -> tuple[str, list[str], list[str], np.ndarray]:
    """(root, names, parents, T_parent_child (m, k, 4, 4)) of every URDF link but the root.

    Order: per joint its child (or ``<child>_dh`` then the child), then the named frames.
    """
    used: set[str] = set(mech.link_names) | set(mech.frame_names) | set(mech.joint_names)

    def fresh(base: str) -> str:  # the names mechanism_to_urdf gives, in its order
        name = base
        while name in used:
            name += "_"
        used.add(name)
        return name

    T_l = kin.T_links  # (m, nl, 4, 4) link poses in the base frame
    names: list[str] = []
    parents: list[str] = []
    blocks: list[np.ndarray] = []
    for k in range(mech.n):
        P, C = int(mech.joint_parent_link[k]), int(mech.joint_child_link[k])
        T_PC = invert(T_l[:, P]) @ T_l[:, C]
        if dh_intermediate(mech, k):
            dh = fresh(f"{mech.link_names[C]}_dh")
            fresh(dh + "_fixed")
            B = mech.B[k]
            names += [dh, mech.link_names[C]]
            parents += [mech.link_names[P], dh]
            blocks += [T_PC @ invert(B), np.broadcast_to(B, T_PC.shape)]
        else:
            names.append(mech.link_names[C])
            parents.append(mech.link_names[P])
            blocks.append(T_PC)
    m = kin.q.shape[0]
    for f in range(mech.n_links, len(mech.frame_names)):
        names.append(mech.frame_names[f])
        parents.append(mech.link_names[int(mech.frame_link[f])])
        blocks.append(np.broadcast_to(mech.frame_offset[f], (m, 4, 4)))
    T = np.stack(blocks, axis=1) if blocks else np.zeros((m, 0, 4, 4))
    return mech.link_names[0], names, parents, np.ascontiguousarray(T)
